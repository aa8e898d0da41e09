//! Numerical settings of the time integration, in one place.

/// Numerical settings of the integrator.
#[derive(Debug, Clone, Copy)]
pub struct IntegrationParameters {
    /// Time step, s. Checked against `Model::stable_step_estimate_s` before a run.
    pub step_s: f64,
}
