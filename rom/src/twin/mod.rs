//! The digital twin's side of measurements: the exchange format (`measured`) and the sensor
//! model that turns full-order runs into synthetic recordings (`sensor`), and the looseness
//! diagnosis (`diagnose`), and calibration (`calibrate`).

pub mod calibrate;
pub mod diagnose;
pub mod measured;
pub mod sensor;
