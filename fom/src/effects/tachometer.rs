//! `tachometer`: the speed sensors themselves (pulses per revolution, the resolution of the timer
//! that stamps the pulses, the share of pulses that go missing), so that synthetic measurements
//! and the twin compare like with like. Nothing changes in the mechanics: the table is read by
//! the twin's sensor model (`twin/src/sensor.rs`) when a run is written as a measurement.
