//! Normal contact: the penalty law of seed paper eq. 4 (Hunt & Crossley 1975), solved linearly
//! implicitly per contact inside the step.

/// Linearly implicit penalty contact at one node (backward Euler on the contact spring, the
/// law of paper eq. 4 linearised about the current penetration): with the predicted outward
/// normal velocity `vn_pred` (m/s) the end-of-step force is
/// F = K delta^n + C d(delta)/dt_new, C = n K delta^(n-1) dt + K D delta^n,
/// d(delta)/dt_new = -(vn_pred + dt F / m). Unconditionally stable for the node's own contact
/// oscillator, so the penalty stiffness does not limit the step. Returns (F >= 0, C) in N and
/// N s/m; F = 0 when the contact would pull.
#[inline]
pub fn implicit_normal_force_n(
    k: f64,
    damping_s_m: f64,
    exponent: f64,
    delta: f64,
    vn_pred: f64,
    dt_over_m: f64,
    dt: f64,
) -> (f64, f64) {
    let (elastic, k_tangent) = if exponent == 1.0 {
        (k * delta, k)
    } else {
        let e = k * delta.powf(exponent);
        (e, exponent * e / delta)
    };
    let c = k_tangent * dt + damping_s_m * elastic;
    // delta_rate = -(vn_pred + dt/m F), F = elastic + c delta_rate.
    let f = (elastic - c * vn_pred) / (1.0 + c * dt_over_m);
    (f.max(0.0), c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn implicit_normal_force_solves_its_equation() {
        let (k, d, m, dt) = (1e8, 0.3, 1e-3, 1e-5);
        let (delta, vn) = (2e-5, -0.05);
        let (f, c) = implicit_normal_force_n(k, d, 1.0, delta, vn, dt / m, dt);
        let rate = -(vn + dt / m * f);
        assert!((f - (k * delta + c * rate)).abs() < 1e-9 * f);
        // A node leaving fast gets no pull.
        let (f_out, _) = implicit_normal_force_n(k, d, 1.0, 1e-7, 5.0, dt / m, dt);
        assert_eq!(f_out, 0.0);
    }
}
