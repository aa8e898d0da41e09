//! Belt-pulley contact: the contact law as a type ([`ContactLaw`]: the penalty normal law of
//! seed paper eq. 4 and a [`FrictionLaw`]), both solved implicitly per contact inside the step
//! (`integrator.rs`).

pub mod friction;
pub mod normal;
pub mod tooth;

pub use friction::FrictionLaw;
pub use normal::{contact_energy_j, implicit_normal_force_n};

/// The contact law between belt and pulleys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactLaw {
    /// Penalty stiffness K per contact point, N/m^n (paper eq. 4).
    pub stiffness_n_m: f64,
    /// Damping factor D, s/m (paper eq. 4).
    pub damping_s_m: f64,
    /// Hertz exponent n (paper eq. 4).
    pub exponent: f64,
    pub friction: FrictionLaw,
}

impl ContactLaw {
    /// The contact law of a configuration: the penalty normal law and the regularised Coulomb
    /// friction of paper eq. 5 with the belt kind's effective coefficient
    /// (`statics::effective_friction`: the wedge of a V-belt raises it).
    pub fn from_config(cfg: &crate::config::DriveConfig) -> Self {
        let c = &cfg.contact;
        ContactLaw {
            stiffness_n_m: c.stiffness_n_m,
            damping_s_m: c.damping_s_m,
            exponent: c.exponent,
            friction: FrictionLaw::RegularisedCoulomb {
                mu: cfg.effective_friction(),
                velocity_threshold_m_s: c.velocity_threshold_m_s,
            },
        }
    }
}
