//! Friction laws at a belt-pulley contact and their implicit solution per contact.
//!
//! The baseline is regularised Coulomb friction F = -mu F_n tanh(v / v_th) (seed paper eq. 5;
//! Mostaghel 1975). A new law is a variant of [`FrictionLaw`] with its own solve; the step
//! calls [`FrictionLaw::solve_implicit`] and never names a law.

/// The friction law of the belt-pulley contacts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrictionLaw {
    /// F = -mu F_n tanh(v / v_th) (seed paper eq. 5).
    RegularisedCoulomb {
        /// Effective friction coefficient.
        mu: f64,
        /// Velocity threshold of the regularisation, m/s.
        velocity_threshold_m_s: f64,
    },
}

impl FrictionLaw {
    /// Whether the law transmits any force (a zero coefficient switches friction off).
    pub fn is_active(&self) -> bool {
        match *self {
            FrictionLaw::RegularisedCoulomb { mu, .. } => mu > 0.0,
        }
    }

    /// Backward-Euler solve at one contact: the end-of-step relative tangential velocity v and
    /// its change v - v_pred, for a contact with normal force `normal_n` (N) on a belt point of
    /// mass `mass_kg` (inverse `inv_mass`), predicted velocity `v_pred` (m/s), step `dt` (s)
    /// and a warm start `v_guess` (the contact's last value).
    #[inline]
    pub fn solve_implicit(
        &self,
        v_pred: f64,
        normal_n: f64,
        inv_mass: f64,
        dt: f64,
        v_guess: f64,
    ) -> (f64, f64) {
        match *self {
            FrictionLaw::RegularisedCoulomb {
                mu,
                velocity_threshold_m_s,
            } => {
                let a = dt * mu * normal_n * inv_mass;
                solve_implicit_friction(v_pred, a, velocity_threshold_m_s, v_guess)
            }
        }
    }
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
