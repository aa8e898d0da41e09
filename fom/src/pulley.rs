//! Rigid pulleys on revolute joints at fixed shaft centres (an effect may move the contact
//! circle, see `effects`). Any number of pulleys can take part in
//! contact; each carries what drives or brakes it.

use crate::config::PulleyConfig;
use crate::drive::{Load, Motor, SpeedProfile};

/// What acts on a pulley's shaft.
#[derive(Debug, Clone)]
pub enum ShaftDrive {
    /// Induction motor torque (Kloss curve).
    Motor(Motor),
    /// Speed follows a profile; the torque needed is reported.
    Prescribed(SpeedProfile),
    /// Braked by a load torque.
    Load(Load),
    /// Free (an idler): only bearing damping.
    Free,
    /// Held at standstill (used for static equilibrium and for tests).
    Locked,
}

#[derive(Debug, Clone)]
pub struct Pulley {
    /// Shaft centre, m.
    pub center_m: [f64; 2],
    /// Centre of the contact circle, m: the shaft centre unless an effect moves it (runout);
    /// set by the step.
    pub contact_center_m: [f64; 2],
    /// Pitch radius r, m (used for the speed ratio, paper eq. 1).
    pub pitch_radius_m: f64,
    /// Radius of the circle on which the segment centres (pitch-line nodes) rest, m:
    /// the pitch radius corrected for the polygonal effect of the finite segments.
    pub node_radius_m: f64,
    pub inertia_kg_m2: f64,
    pub bearing_damping_n_m_s: f64,
    pub drive: ShaftDrive,
    /// Rotation angle, rad (counter-clockwise positive).
    pub angle_rad: f64,
    pub omega_rad_s: f64,
}

impl Pulley {
    pub fn new(cfg: &PulleyConfig, node_radius_m: f64) -> Self {
        let drive = if let Some(m) = &cfg.motor {
            ShaftDrive::Motor(Motor::new(m))
        } else if let Some(p) = &cfg.speed_profile {
            ShaftDrive::Prescribed(SpeedProfile::new(p))
        } else if let Some(l) = &cfg.load {
            ShaftDrive::Load(Load::new(l))
        } else {
            ShaftDrive::Free
        };
        Self {
            center_m: cfg.center_m,
            contact_center_m: cfg.center_m,
            pitch_radius_m: 0.5 * cfg.pitch_diameter_m,
            node_radius_m,
            inertia_kg_m2: cfg.inertia_kg_m2,
            bearing_damping_n_m_s: cfg.bearing_damping_n_m_s,
            drive,
            angle_rad: 0.0,
            omega_rad_s: 0.0,
        }
    }

    /// External shaft torque (motor or load, not the belt, not the bearing), N m, positive
    /// counter-clockwise. Prescribed and locked shafts return 0 (their torque is a reaction).
    pub fn shaft_torque_nm(&self, t: f64, omega: f64) -> f64 {
        match &self.drive {
            ShaftDrive::Motor(m) => m.torque_nm(t, omega),
            ShaftDrive::Load(l) => -l.brake_torque_nm(t, omega),
            ShaftDrive::Prescribed(_) | ShaftDrive::Free | ShaftDrive::Locked => 0.0,
        }
    }

    /// The prescribed speed at t, if the shaft's speed is kinematically driven.
    pub fn prescribed_omega(&self, t: f64) -> Option<f64> {
        match &self.drive {
            ShaftDrive::Prescribed(p) => Some(p.omega(t)),
            ShaftDrive::Locked => Some(0.0),
            _ => None,
        }
    }
}
