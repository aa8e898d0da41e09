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
    /// F = -mu(|v|) F_n tanh(v / v_th) with a Stribeck curve falling from the static coefficient
    /// mu_s at rest to the dynamic mu_d at the Stribeck speed v_s along the cubic step of the
    /// seed paper "arc-tooth-synchronous-belt-recurdyn", eq. 4 (see `stribeck_mu`; the
    /// Stribeck effect: Olsson et al., "Friction models and friction compensation", Eur. J.
    /// Control 4, 1998). Not monotone in v, so the implicit solve brackets its root (see
    /// [`solve_implicit_stribeck`]).
    Stribeck {
        static_mu: f64,
        dynamic_mu: f64,
        stribeck_speed_m_s: f64,
        velocity_threshold_m_s: f64,
    },
}

impl FrictionLaw {
    /// Whether the law transmits any force (a zero coefficient switches friction off).
    pub fn is_active(&self) -> bool {
        match *self {
            FrictionLaw::RegularisedCoulomb { mu, .. } => mu > 0.0,
            FrictionLaw::Stribeck { static_mu, .. } => static_mu > 0.0,
        }
    }

    /// Friction force per unit normal force at relative velocity v: -mu(|v|) tanh(v / v_th).
    pub fn traction_ratio(&self, v: f64) -> f64 {
        match *self {
            FrictionLaw::RegularisedCoulomb {
                mu,
                velocity_threshold_m_s,
            } => -mu * (v / velocity_threshold_m_s).tanh(),
            FrictionLaw::Stribeck {
                static_mu,
                dynamic_mu,
                stribeck_speed_m_s,
                velocity_threshold_m_s,
            } => {
                -stribeck_mu(static_mu, dynamic_mu, stribeck_speed_m_s, v.abs()).0
                    * (v / velocity_threshold_m_s).tanh()
            }
        }
    }

    /// Backward-Euler solve at one contact: the end-of-step relative tangential velocity v and
    /// its change v - v_pred, for a contact with normal force `normal_n` (N) on a belt point of
    /// mass `mass_kg` (inverse `inv_mass`), predicted velocity `v_pred` (m/s), step `dt` (s)
    /// and a warm start `v_guess` (the contact's last value).
    #[inline(always)]
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
            FrictionLaw::Stribeck {
                static_mu,
                dynamic_mu,
                stribeck_speed_m_s,
                velocity_threshold_m_s,
            } => solve_implicit_stribeck(
                v_pred,
                dt * normal_n * inv_mass,
                [static_mu, dynamic_mu, stribeck_speed_m_s],
                velocity_threshold_m_s,
                v_guess,
            ),
        }
    }
}

/// The Stribeck coefficient at sliding speed s >= 0 and its derivative d mu / ds: from mu_s at
/// rest down to mu_d at the Stribeck speed v_s along the cubic (haversine-like) step
/// h(x) = x^2 (3 - 2 x), x = s / v_s, of the seed paper "arc-tooth-synchronous-belt-recurdyn"
/// eq. 4 (RecurDyn's STEP function), constant mu_d beyond: mu = mu_s - (mu_s - mu_d) h(x).
#[inline]
fn stribeck_mu(mu_s: f64, mu_d: f64, v_s: f64, s: f64) -> (f64, f64) {
    if s >= v_s {
        return (mu_d, 0.0);
    }
    let x = s / v_s;
    let drop = mu_s - mu_d;
    (
        mu_s - drop * x * x * (3.0 - 2.0 * x),
        -drop * 6.0 * x * (1.0 - x) / v_s,
    )
}

/// Backward-Euler friction with the Stribeck law: finds v with
/// g(v) = v - v_pred + b mu(|v|) tanh(v / v_th) = 0, b = dt F_n / m_eff. The law is not
/// monotone, so g may have several roots; g(0) = -v_pred and g(v_pred) has the sign of v_pred,
/// so [0, v_pred] always brackets one. Newton from the warm start `v_guess` (the contact's
/// last value: a sticking contact stays stuck, a sliding one keeps sliding, which is what
/// stick-slip hysteresis is), kept inside a bracket that shrinks on the sign of g, with
/// bisection whenever Newton would leave it or g' <= 0. Returns (v, v - v_pred).
pub fn solve_implicit_stribeck(
    v_pred: f64,
    b: f64,
    [mu_s, mu_d, v_s]: [f64; 3],
    v_th: f64,
    v_guess: f64,
) -> (f64, f64) {
    if b <= 0.0 || v_pred == 0.0 {
        return (v_pred, 0.0);
    }
    let sign = v_pred.signum();
    // Work with u = sign * v >= 0 on [0, |v_pred|].
    let up = v_pred.abs();
    let g = |u: f64| {
        let (mu, dmu) = stribeck_mu(mu_s, mu_d, v_s, u);
        // Past 18 v_th, tanh = 1 to within 1e-15 (as in `solve_implicit_friction`).
        let (th, dth) = if u > 18.0 * v_th {
            (1.0, 0.0)
        } else {
            let th = fast_tanh(u / v_th);
            (th, (1.0 - th * th) / v_th)
        };
        (u - up + b * mu * th, 1.0 + b * (dmu * th + mu * dth))
    };
    // Every root satisfies u = up - b mu(u) tanh(u / v_th) >= up - b mu_s. When that bound is
    // past both v_s (mu = mu_d) and 18 v_th (tanh = 1 to within 1e-15), the root is unique and
    // explicit: u = up - b mu_d.
    if up - b * mu_s >= v_s.max(18.0 * v_th) {
        let v = sign * (up - b * mu_d);
        return (v, v - v_pred);
    }
    let (mut lo, mut hi) = (0.0_f64, up);
    // Sliding even under the largest (static) friction: the root lies past 18 v_th, where
    // tanh = 1, and one fixed-point step from v_pred starts Newton next to it.
    let mut u = if up - b * mu_s > 18.0 * v_th {
        lo = up - b * mu_s;
        up - b * stribeck_mu(mu_s, mu_d, v_s, up).0
    } else {
        (sign * v_guess).clamp(lo, hi)
    };
    let tol = 1e-6 * v_th;
    for _ in 0..60 {
        let (gu, dg) = g(u);
        if gu > 0.0 {
            hi = u;
        } else {
            lo = u;
        }
        let newton = u - gu / dg;
        let next = if dg > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        // Unlike `solve_implicit_friction`, no Newton step is taken on a residual bound here:
        // tried, it moved the toothed belt's quasi-static torque balance by 1 % (test
        // `load_sharing_over_the_wrap_follows_the_tooth_spring_distribution`).
        let done = (next - u).abs() <= tol || hi - lo <= tol;
        u = next;
        if done {
            break;
        }
    }
    let v = sign * u;
    (v, v - v_pred)
}

/// Backward-Euler friction at one contact: finds v with
/// v = v_pred + (dt / m_eff) F(v), F(v) = -mu F_n tanh(v / v_th),
/// where v is the relative tangential velocity at the end of the step and m_eff the effective
/// mass of the belt point. The function is monotone, so the root is unique; Newton steps start
/// from `v_guess` (the last step's value) and are kept inside the bracket between v_pred and
/// the sticking velocity. Returns (v, v - v_pred): the end velocity and the change friction made.
#[inline(always)]
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
        let step = (v_new - v).abs();
        // The residual after this Newton step is at most max|g''| step^2 / 2 (Taylor's
        // remainder), with g'' = -2 a th sech^2 / v_th^2 and max |th sech^2| = 2 / (3 sqrt 3)
        // (at th^2 = 1/3): when that bound is already within the tolerance the step is taken
        // without another evaluation (70 % of the solves on the default drive took two, the
        // second only to confirm the first).
        const MAX_TH_SECH2: f64 = 0.384_900_179_459_750_5; // 2 / (3 sqrt 3)
        let residual_after = a_impulse * MAX_TH_SECH2 / (v_th * v_th) * step * step;
        let bisected = !(v_new > lo && v_new < hi);
        if bisected {
            v_new = 0.5 * (lo + hi);
        }
        let done = step <= tol || (!bisected && residual_after <= tol);
        v = v_new;
        if done {
            break;
        }
    }
    (v, v - v_pred)
}

/// tanh for the friction solves. For |x| < 0.5 (about 60 % of the calls on the default drive)
/// x (135135 + 17325 x^2 + 378 x^4 + x^6) / (135135 + 62370 x^2 + 3150 x^4 + 28 x^6), the
/// [7/6] Pade approximant that is Lambert's continued fraction
/// tanh x = x / (1 + x^2 / (3 + x^2 / (5 + ...))) cut after the term 13 (J. H. Lambert,
/// Mémoire sur quelques propriétés remarquables des quantités transcendantes circulaires et
/// logarithmiques, 1768), within 6e-16 relative there (test
/// `fast_tanh_matches_libm`): one division instead of a call to libm's `exp`. Beyond, through
/// one exp: (1 - e^(-2|x|)) / (1 + e^(-2|x|)), exact to rounding and about twice as fast as
/// libm's tanh. Together 6 % less wall time for `rom simulate --duration 3` than the exp form
/// alone (`docs/validation/speed.md`, "Speed, whole process").
#[inline(always)]
fn fast_tanh(x: f64) -> f64 {
    let a = x.abs();
    if a < 0.5 {
        let x2 = x * x;
        return x * (135_135.0 + x2 * (17_325.0 + x2 * (378.0 + x2)))
            / (135_135.0 + x2 * (62_370.0 + x2 * (3_150.0 + 28.0 * x2)));
    }
    let e = (-2.0 * a).exp();
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
        // The rational branch, finely, relative: within 4 ulp of libm.
        for k in 1..5000 {
            let x = k as f64 * 1e-4;
            let rel = (fast_tanh(x) / x.tanh() - 1.0).abs();
            assert!(rel < 9e-16, "x = {x}: {rel:e}");
            assert_eq!(fast_tanh(-x), -fast_tanh(x));
        }
    }

    #[test]
    fn stribeck_solve_satisfies_its_equation_and_never_reverses_sliding() {
        let law = [0.7, 0.4, 0.05];
        for &(vp, b, vth, guess) in &[
            (0.3, 1.1, 0.005, 0.0),
            (-0.3, 1.1, 0.005, -0.3),
            (2.0, 0.5, 0.005, 2.0),
            (0.06, 0.2, 0.001, 0.0),
            (0.06, 0.2, 0.001, 0.06),
            (1e-4, 5.0, 0.001, 0.0),
        ] {
            let (v, dv) = solve_implicit_stribeck(vp, b, law, vth, guess);
            let (mu, _) = stribeck_mu(law[0], law[1], law[2], v.abs());
            let residual = v - vp + b * mu * (v / vth).tanh();
            assert!(
                residual.abs() < 1e-5 * vth,
                "vp={vp} b={b}: residual {residual}"
            );
            assert!((dv - (v - vp)).abs() < 1e-12);
            assert!(v * vp >= 0.0);
            // From warm starts next to that root: within the solve's tolerance, 1e-6 v_th.
            for near in [v * (1.0 + 1e-3), v + 1e-3 * vth, v - 1e-2 * vth] {
                let (w, _) = solve_implicit_stribeck(vp, b, law, vth, near);
                let (mu, _) = stribeck_mu(law[0], law[1], law[2], w.abs());
                let r = w - vp + b * mu * (w / vth).tanh();
                assert!(r.abs() < 1e-6 * vth, "vp={vp} b={b} from {near}: {r}");
            }
        }
    }

    #[test]
    fn stribeck_curve_runs_from_static_to_dynamic() {
        let law = FrictionLaw::Stribeck {
            static_mu: 0.7,
            dynamic_mu: 0.4,
            stribeck_speed_m_s: 0.05,
            velocity_threshold_m_s: 1e-4,
        };
        // Point by point against the cubic step mu_s - (mu_s - mu_d) x^2 (3 - 2 x), x = v / v_s:
        // near rest the static value, half-way the mean, from v_s on the dynamic value.
        for (v, want) in [
            (0.002, 0.7 - 0.3 * 0.04 * 0.04 * (3.0 - 0.08)),
            (0.025, 0.55),
            (0.05, 0.4),
            (0.5, 0.4),
        ] {
            assert!((-law.traction_ratio(v) - want).abs() < 1e-12, "v = {v}");
            assert!((law.traction_ratio(-v) - want).abs() < 1e-12, "v = -{v}");
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
            // Warm starts near the root (the step's usual case) take the first Newton step
            // without a confirming evaluation when its residual bound allows: still within it.
            for guess in [v * (1.0 + 1e-3), v + 1e-3 * vth, v - 0.3 * vth] {
                let (w, _) = solve_implicit_friction(vp, a, vth, guess);
                let r = w - vp + a * (w / vth).tanh();
                assert!(r.abs() < 1e-6 * vth, "vp={vp} a={a} guess {guess}: {r}");
            }
        }
    }
}
