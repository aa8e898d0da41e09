//! Belt-pulley contact: penalty normal force (paper eq. 4) and regularised Coulomb friction
//! F = -mu F_n tanh(v / v_th) (paper eq. 5; Mostaghel 1975), both solved implicitly per contact
//! inside the step.

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

/// Backward-Euler friction at one contact: finds v with
/// v = v_pred + (dt / m_eff) F(v), F(v) = -mu F_n tanh(v / v_th),
/// where v is the relative tangential velocity at the end of the step and m_eff the effective
/// mass of the belt point. The function is monotone, so the root is unique; Newton steps start
/// from `v_guess` (the last step's value) and are kept inside the bracket between v_pred and
/// the sticking velocity. Returns (v, v - v_pred): the end velocity and the change friction made.
#[inline]
pub fn solve_implicit_friction(v_pred: f64, a_impulse: f64, v_th: f64, v_guess: f64) -> (f64, f64) {
    // a_impulse = dt * mu * F_n / m_eff (m/s): the largest velocity change friction can make.
    if a_impulse <= 0.0 {
        return (v_pred, 0.0);
    }
    // Saturated sliding: if the full Coulomb impulse leaves |v| / v_th > 18, tanh = +-1 to
    // within 1e-15 and the root is v_pred -+ a.
    let slide = v_pred.abs() - a_impulse;
    if slide > 18.0 * v_th {
        let v = v_pred - a_impulse.copysign(v_pred);
        return (v, v - v_pred);
    }
    let (mut lo, mut hi) = if v_pred >= 0.0 {
        ((v_pred - a_impulse).max(0.0), v_pred)
    } else {
        (v_pred, (v_pred + a_impulse).min(0.0))
    };
    let mut v = v_guess.max(lo).min(hi);
    // 1e-6 v_th: the friction force is then exact to ~1e-6 of mu F_n.
    let tol = 1e-6 * v_th;
    for _ in 0..40 {
        // g(v) = v - v_pred - (dt / m_eff) F(v), F = -mu F_n tanh(v / v_th) (paper eq. 5).
        let th = fast_tanh(v / v_th);
        let g = v - v_pred + a_impulse * th;
        if g > 0.0 {
            hi = v;
        } else {
            lo = v;
        }
        let dg = 1.0 + a_impulse / v_th * (1.0 - th * th);
        let mut v_new = v - g / dg;
        if !(v_new > lo && v_new < hi) {
            v_new = 0.5 * (lo + hi);
        }
        let done = (v_new - v).abs() <= tol;
        v = v_new;
        if done {
            break;
        }
    }
    (v, v - v_pred)
}

/// tanh through one exp: (1 - e^(-2|x|)) / (1 + e^(-2|x|)), exact to rounding; about twice
/// as fast as libm's tanh here (measured in the step profile).
#[inline]
fn fast_tanh(x: f64) -> f64 {
    let e = (-2.0 * x.abs()).exp();
    ((1.0 - e) / (1.0 + e)).copysign(x)
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

    #[test]
    fn fast_tanh_matches_libm() {
        for k in -400..=400 {
            let x = k as f64 * 0.05;
            assert!((fast_tanh(x) - x.tanh()).abs() < 1e-15, "x = {x}");
        }
    }

    #[test]
    fn implicit_friction_satisfies_its_equation() {
        for &(vp, a, vth) in &[
            (0.3, 1.1, 0.005),
            (-0.3, 1.1, 0.005),
            (2.0, 0.5, 0.005),
            (1e-4, 5.0, 0.001),
            (1.1001, 1.1, 0.005),
        ] {
            let (v, dv) = solve_implicit_friction(vp, a, vth, 0.0);
            let residual = v - vp + a * (v / vth).tanh();
            // Newton stops at |dv| < 1e-7 v_th; the residual is then below ~1e-6 v_th.
            assert!(
                residual.abs() < 1e-6 * vth,
                "vp={vp} a={a}: residual {residual}"
            );
            assert!((dv - (v - vp)).abs() < 1e-12);
            // Friction never reverses the sliding direction.
            assert!(v * vp >= 0.0);
        }
    }
}
