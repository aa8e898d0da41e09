//! Normal contact: the penalty law of seed paper eq. 4 (Hunt & Crossley 1975), solved linearly
//! implicitly per contact inside the step, with the contact detected on the predicted
//! end-of-step penetration.

/// Linearly implicit penalty contact at one node: backward Euler on the law of paper eq. 4,
/// F = K delta^n (1 + D d(delta)/dt), linearised about the predicted end-of-step penetration
/// `delta_pred` = delta_0 - dt vn_pred (m, > 0), where `vn_pred` (m/s) is the outward normal
/// velocity after the explicit forces. With the end-of-step penetration
/// delta_1 = delta_pred - dt^2 F / m and rate -(vn_pred + dt F / m):
/// F = K delta_pred^n (1 - D vn_pred) / (1 + (n K delta_pred^(n-1) dt + D K delta_pred^n) dt / m).
/// Unconditionally stable for the node's own contact oscillator, so the penalty stiffness does
/// not limit the step. Returns F >= 0 in N (0 when the contact would pull).
///
/// Why the predicted penetration (docs/fom-numerics.md, "Contact on the predicted
/// penetration"): a node detected only once it has penetrated falls freely for a whole step
/// first, by up to dt^2 F / m, which at dt = 1e-5 s is ten times the static penetration of the
/// default drive; the contact then chatters, and on a sliding belt the transmitted traction and
/// the energy balance go wrong (a knee point slipped 6.1 % at 1e-5 s against 2.13 % at 5e-6 s).
#[inline]
pub fn implicit_normal_force_n(
    k: f64,
    damping_s_m: f64,
    exponent: f64,
    delta_pred: f64,
    vn_pred: f64,
    dt_over_m: f64,
    dt: f64,
) -> f64 {
    if delta_pred <= 0.0 {
        return 0.0;
    }
    let (elastic, k_tangent) = if exponent == 1.0 {
        (k * delta_pred, k)
    } else {
        let e = k * delta_pred.powf(exponent);
        (e, exponent * e / delta_pred)
    };
    let c = k_tangent * dt + damping_s_m * elastic;
    let f = elastic * (1.0 - damping_s_m * vn_pred) / (1.0 + c * dt_over_m);
    f.max(0.0)
}

/// Elastic energy of the penalty law at penetration `delta` (m): K delta^(n+1) / (n+1), paper
/// eq. 4 integrated; zero without penetration. J.
#[inline]
pub fn contact_energy_j(k: f64, exponent: f64, delta: f64) -> f64 {
    if delta <= 0.0 {
        0.0
    } else if exponent == 1.0 {
        0.5 * k * delta * delta
    } else {
        k * delta.powf(exponent + 1.0) / (exponent + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn implicit_normal_force_solves_its_equation() {
        let (k, d, m, dt) = (1e8, 0.3, 1e-3, 1e-5);
        for n in [1.0, 1.5] {
            let (delta_pred, vn) = (2e-5, -0.05);
            let f = implicit_normal_force_n(k, d, n, delta_pred, vn, dt / m, dt);
            // The linearised law at the end of the step.
            let delta_1 = delta_pred - dt * dt * f / m;
            let rate = -(vn + dt / m * f);
            let e = k * delta_pred.powf(n);
            let linear = e + n * e / delta_pred * (delta_1 - delta_pred) + d * e * rate;
            assert!((f - linear).abs() < 1e-9 * f, "n = {n}: {f} vs {linear}");
        }
        // A node leaving fast gets no pull, and one predicted outside gets no force.
        assert_eq!(
            implicit_normal_force_n(k, d, 1.0, 1e-7, 5.0, dt / m, dt),
            0.0
        );
        assert_eq!(
            implicit_normal_force_n(k, d, 1.0, -1e-7, -0.1, dt / m, dt),
            0.0
        );
    }

    #[test]
    fn resting_node_converges_to_the_static_penetration() {
        // A node pressed by a constant force P settles at K delta = P, for any step, however
        // stiff the contact (backward Euler is L-stable), and never leaves the surface.
        let (k, d, m, p) = (1e8, 0.3, 5.8e-4, 11.0);
        for dt in [1e-6, 1e-5, 4e-5] {
            let (mut delta, mut vn) = (0.0_f64, 0.0_f64);
            for step in 0..2000 {
                let vn_pred = vn + dt * (-p) / m;
                let f =
                    implicit_normal_force_n(k, d, 1.0, delta - dt * vn_pred, vn_pred, dt / m, dt);
                assert!(step == 0 || f > 0.0, "dt {dt}: contact lost at step {step}");
                vn = vn_pred + dt * f / m;
                delta -= dt * vn;
            }
            assert!((k * delta / p - 1.0).abs() < 1e-6, "dt {dt}: {delta}");
        }
    }

    #[test]
    fn contact_energy_is_the_integral_of_the_elastic_force() {
        let (k, n, delta) = (3e7, 1.5, 4e-6);
        let steps = 10_000;
        let h = delta / steps as f64;
        let integral: f64 = (0..steps)
            .map(|i| k * ((i as f64 + 0.5) * h).powf(n) * h)
            .sum();
        assert!((contact_energy_j(k, n, delta) / integral - 1.0).abs() < 1e-6);
        assert_eq!(contact_energy_j(k, n, -1e-6), 0.0);
    }
}
