//! Where a surrogate may be asked at all: the physical domain of a design point, checked before
//! any surrogate answers (every kind, with or without extrapolation allowed), and the list of
//! trained ranges an allowed extrapolation leaves. Why: `docs/decisions/physical-domain.md`.

use fom::params::Variable;
use fom::{DesignPoint, DriveConfig};
use serde::Serialize;
use training::DesignRanges;

use crate::RomError;

/// Refuses a point no drive can have: friction or installation tension not positive (where
/// they are among the model's `inputs`; else they are the configuration's, checked with it),
/// or a centre distance at which the pulleys overlap or the belt cannot be installed (slack,
/// or stretched beyond its rated elongation: `fom::statics::installed_strain`, the check model
/// building makes). The error names the input and the reason (`blamed_for_installation`).
pub fn check_physical(
    cfg: &DriveConfig,
    q: &DesignPoint,
    inputs: &[Variable],
) -> Result<(), RomError> {
    let impossible = |input: Variable, reason: String| RomError::Impossible { input, reason };
    let n = fom::readable::readable;
    let asks = |v: Variable| inputs.contains(&v);
    if asks(Variable::Friction) && !(q.friction.is_finite() && q.friction > 0.0) {
        return Err(impossible(
            Variable::Friction,
            format!(
                "friction {} is not a positive number: a friction coefficient is > 0",
                n(q.friction)
            ),
        ));
    }
    if asks(Variable::InstallationTension)
        && !(q.installation_tension_n.is_finite() && q.installation_tension_n > 0.0)
    {
        return Err(impossible(
            Variable::InstallationTension,
            format!(
                "installation tension {} N is not a positive number: an installed belt pulls \
                 its spans",
                n(q.installation_tension_n)
            ),
        ));
    }
    // Where the point moves the driven pulley to (a shaft load places it), the statics of the
    // configuration moved there.
    let moved = q
        .moved(cfg)
        .map_err(|e| impossible(Variable::CenterDistance, e.to_string()))?;
    fom::statics::installed_strain(&moved).map_err(|e| {
        let reason = match e {
            fom::FomError::Geometry(m) => m,
            other => other.to_string(),
        };
        impossible(blamed_for_installation(cfg, q, inputs), reason)
    })?;
    Ok(())
}

/// The input a belt that cannot be installed at `q` is blamed on: the installation tension
/// where it is an input and the belt cannot be installed with it at the configuration's own
/// centre distance either (a tension that stretches any belt past its rated elongation), else
/// the centre distance.
fn blamed_for_installation(cfg: &DriveConfig, q: &DesignPoint, inputs: &[Variable]) -> Variable {
    let mut at_own_distance = *q;
    at_own_distance.center_distance_m = cfg.center_distance_m();
    let tension_alone = inputs.contains(&Variable::InstallationTension)
        && at_own_distance
            .moved(cfg)
            .is_ok_and(|c| fom::statics::installed_strain(&c).is_err());
    if tension_alone {
        Variable::InstallationTension
    } else {
        Variable::CenterDistance
    }
}

/// One input of an extrapolated answer outside its trained range.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outside {
    /// The input's configuration key (`center_distance_m`, `friction`, ...).
    pub input: &'static str,
    pub value: f64,
    /// The trained range, [low, high].
    pub trained: [f64; 2],
}

impl Outside {
    /// The readable line of an extrapolated answer, e.g. `d 0.4300 m outside trained
    /// 0.415-0.424 m` (the variable's name and unit from `Variable::describe`).
    pub fn to_text(&self) -> String {
        let n = fom::readable::readable;
        format!(
            "{} {} outside trained {}-{}",
            self.input,
            n(self.value),
            n(self.trained[0]),
            n(self.trained[1])
        )
    }
}

/// Every input of `ranges` whose value (`value_of`; `None`: not set, not checked) lies outside
/// its trained range, in input order.
pub fn outside_ranges(
    ranges: &DesignRanges,
    value_of: impl Fn(Variable) -> Option<f64>,
) -> Vec<Outside> {
    ranges
        .variables()
        .into_iter()
        .filter_map(|v| {
            let [lo, hi] = ranges.get(v)?;
            let x = value_of(v)?;
            (!(x >= lo && x <= hi)).then_some(Outside {
                input: v.key(),
                value: x,
                trained: [lo, hi],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(cfg: &DriveConfig, q: &DesignPoint) -> (Variable, String) {
        match check_physical(cfg, q, &crate::Kind::Slip.inputs()) {
            Err(RomError::Impossible { input, reason }) => (input, reason),
            other => panic!("{q:?} not refused: {other:?}"),
        }
    }

    /// The five points that once returned a slip under `--allow-extrapolation`: friction -1
    /// and 0, tension -5 N, d 5 m (beyond the belt's elongation) and d 0.40 m (slack).
    #[test]
    fn impossible_points_are_refused_with_their_reason() {
        let cfg = fom::ValidConfig::default_hvac();
        let at = |d: f64, mu: f64, t: f64| {
            let mut q = DesignPoint::nominal(&cfg);
            q.center_distance_m = d;
            q.friction = mu;
            q.installation_tension_n = t;
            q
        };
        let n = DesignPoint::nominal(&cfg);
        let (d0, mu0, t0) = (n.center_distance_m, n.friction, n.installation_tension_n);
        let slip = crate::Kind::Slip.inputs();
        assert!(check_physical(&cfg, &n, &slip).is_ok());
        // A model that does not take friction leaves it to the configuration.
        assert!(check_physical(&cfg, &at(d0, 0.0, t0), &[Variable::SideGap]).is_ok());
        for mu in [-1.0, 0.0, f64::NAN] {
            assert_eq!(refused(&cfg, &at(d0, mu, t0)).0, Variable::Friction);
        }
        assert_eq!(
            refused(&cfg, &at(d0, mu0, -5.0)).0,
            Variable::InstallationTension
        );
        let (v, why) = refused(&cfg, &at(0.40, mu0, t0));
        assert_eq!(v, Variable::CenterDistance);
        assert!(why.contains("slack"), "{why}");
        let (_, why) = refused(&cfg, &at(5.0, mu0, t0));
        assert!(why.contains("too short to wrap"), "{why}");
        let (_, why) = refused(&cfg, &at(0.05, mu0, t0));
        assert!(why.contains("overlap"), "{why}");
        // A tension that stretches the belt past its rated elongation at any distance is
        // blamed on the tension, not on the distance it is asked at.
        let (v, why) = refused(&cfg, &at(0.42, mu0, 5000.0));
        assert_eq!(v, Variable::InstallationTension);
        assert!(why.contains("too short to wrap"), "{why}");
        // Outside the trained box but physical: d 0.43 m is tighter and installable.
        assert!(check_physical(&cfg, &at(0.43, mu0, t0), &slip).is_ok());
    }

    #[test]
    fn every_input_outside_its_range_is_listed() {
        let mut r = DesignRanges::default();
        r.insert(Variable::CenterDistance, [0.415, 0.424]);
        r.insert(Variable::Friction, [0.6, 0.8]);
        r.insert(Variable::InstallationTension, [200.0, 300.0]);
        let q = DesignPoint::drive(0.43, 0.5, 250.0, None);
        let o = outside_ranges(&r, |v| q.get(v));
        assert_eq!(o.len(), 2);
        assert_eq!(o[0].input, "center_distance_m");
        assert_eq!(o[0].trained, [0.415, 0.424]);
        assert_eq!(o[1].input, "friction");
        assert_eq!(
            o[0].to_text(),
            "center_distance_m 0.43 outside trained 0.415-0.424"
        );
    }
}
