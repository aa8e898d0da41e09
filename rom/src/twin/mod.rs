//! The digital twin's side of measurements: the exchange format (`measured`) and the sensor
//! model that turns full-order runs into synthetic recordings (`sensor`).

pub mod measured;
pub mod sensor;
