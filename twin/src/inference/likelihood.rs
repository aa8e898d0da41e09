//! The Gaussian likelihood of a measured mean slip against the twin's prediction, shared by
//! calibration and diagnosis.

/// Model discrepancy between twin and measurement (1 sd, relative): the surrogate's accuracy
/// target (2 %) on top of its own variance.
pub const MODEL_DISCREPANCY: f64 = 0.02;

/// Variance of (measured - twin) mean slip, %^2: the measurement's standard error, the
/// surrogate's own variance and the model discrepancy (relative to `discrepancy_scale_pct`).
pub fn misfit_variance(
    measured_se_pct: f64,
    surrogate_var_pct2: f64,
    discrepancy_scale_pct: f64,
) -> f64 {
    measured_se_pct.powi(2)
        + surrogate_var_pct2
        + (MODEL_DISCREPANCY * discrepancy_scale_pct).powi(2)
}

/// Log-likelihood of a residual with variance `var` (Gaussian, up to a constant).
pub fn log_likelihood(residual: f64, var: f64) -> f64 {
    -0.5 * residual.powi(2) / var - 0.5 * var.ln()
}
