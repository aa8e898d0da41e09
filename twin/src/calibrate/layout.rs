//! The search space of a calibration: the free parameters' names and bounds, decoded into a
//! design point per condition plus the slip offset, and the twin's prediction there.

use fom::{DesignPoint, DriveConfig};
use rom::Surrogate;

use super::options::{Distances, FreeSet, Target};
use crate::error::{Result, TwinError};

/// Decodes a parameter vector.
pub(super) struct Layout {
    pub n: usize,
    pub free: FreeSet,
    pub known: Vec<Option<f64>>,
    pub positions: Vec<f64>,
    pub mu0: f64,
    pub t0: f64,
    pub names: Vec<String>,
    pub bounds: Vec<[f64; 2]>,
}

/// A decoded parameter vector: the design point of each condition plus the slip offset.
#[derive(Clone)]
pub(super) struct Point {
    pub d: Vec<f64>,
    pub mu: f64,
    pub t: f64,
    pub offset: f64,
    pub ea: Option<f64>,
}

impl Point {
    /// The design point of each condition.
    pub fn design_points(&self) -> impl Iterator<Item = DesignPoint> + '_ {
        self.d
            .iter()
            .map(|&d| DesignPoint::drive(d, self.mu, self.t, self.ea))
    }
}

impl Layout {
    pub fn new(
        s: &Surrogate,
        cfg: &DriveConfig,
        targets: &[Target],
        free: FreeSet,
    ) -> Result<Self> {
        let st = &s.settings;
        let [dlo, dhi] = st.center_distance_m;
        let mut names = Vec::new();
        let mut bounds = Vec::new();
        match free.distances {
            Distances::Known => {
                if let Some(t) = targets.iter().find(|t| t.known_center_distance_m.is_none()) {
                    return Err(TwinError::Calibration(format!(
                        "condition {} has no known centre distance; free `distances` or \
                         `spaced-distances`",
                        t.label
                    )));
                }
                // A known distance the surrogate was not trained at cannot be calibrated to
                // (every candidate would be refused, and the search would say only that).
                if let Some((t, why)) = targets.iter().find_map(|t| {
                    let d = t.known_center_distance_m?;
                    Some((
                        t,
                        s.outside_range(fom::params::Variable::CenterDistance, d)?,
                    ))
                }) {
                    return Err(TwinError::Calibration(format!(
                        "condition {} lies outside the surrogate's trained range: {why}; leave \
                         it out, or train a surrogate that covers it",
                        t.label
                    )));
                }
            }
            Distances::Free => {
                for t in targets {
                    names.push(format!("center_distance_m[{}]", t.label));
                    bounds.push([dlo, dhi]);
                }
            }
            Distances::EquallySpaced => {
                names.push("center_distance_m[first]".into());
                bounds.push([dlo, dhi]);
                names.push("spacing_m".into());
                let span = targets.iter().map(|t| t.position).fold(1.0, f64::max);
                bounds.push([0.0, (dhi - dlo) / span]);
            }
        }
        if free.friction {
            names.push("friction".into());
            bounds.push(st.friction);
        }
        if free.tension {
            names.push("installation_tension_n".into());
            bounds.push(st.installation_tension_n);
        }
        if free.ratio {
            names.push("slip_offset_pct".into());
            bounds.push([-5.0, 5.0]);
        }
        if free.stiffness {
            let r = st.axial_stiffness_n.ok_or_else(|| {
                TwinError::Calibration(
                    "`stiffness` is free but this surrogate was trained at one belt stiffness; \
                     train one over a range (`axial_stiffness_n = [lo, hi]` in the campaign \
                     settings)"
                        .into(),
                )
            })?;
            names.push("axial_stiffness_n".into());
            bounds.push(r);
        }
        if names.is_empty() {
            return Err(TwinError::Calibration("no free parameters".into()));
        }
        Ok(Self {
            n: targets.len(),
            free,
            known: targets.iter().map(|t| t.known_center_distance_m).collect(),
            positions: targets.iter().map(|t| t.position).collect(),
            mu0: cfg.effective_friction(),
            t0: cfg
                .belt
                .installation_tension_n
                .unwrap_or(0.5 * (st.installation_tension_n[0] + st.installation_tension_n[1])),
            names,
            bounds,
        })
    }

    pub fn decode(&self, x: &[f64]) -> Point {
        let mut k = 0;
        let d = match self.free.distances {
            Distances::Known => self.known.iter().map(|d| d.unwrap_or(0.0)).collect(),
            Distances::Free => {
                k = self.n;
                x[..self.n].to_vec()
            }
            Distances::EquallySpaced => {
                k = 2;
                self.positions.iter().map(|i| x[0] - i * x[1]).collect()
            }
        };
        let mut next = |on: bool, default: f64| {
            if on {
                k += 1;
                x[k - 1]
            } else {
                default
            }
        };
        let mu = next(self.free.friction, self.mu0);
        let t = next(self.free.tension, self.t0);
        let offset = next(self.free.ratio, 0.0);
        let ea = self.free.stiffness.then(|| next(true, 0.0));
        Point {
            d,
            mu,
            t,
            offset,
            ea,
        }
    }
}

/// The installation tension the tension readings of the conditions of known distance give
/// together on a belt of axial stiffness `ea_n` (`None`: the configuration's), with its
/// standard deviation, N; `None` where none was read. A perfectly flexible belt's static
/// tension at a distance is linear in the installation tension, T(d) = a T_inst + b
/// (`DesignPoint::static_tension_n`; docs/fom-numerics.md, "Static span tension"); the twin's
/// belt, with its bending stiffness, settles above it by an offset c
/// (`fom::simulation::settled_static_tension_n`; docs/fom-numerics.md, "Initial state"), taken
/// where the flexible belt's map puts the reading. So each reading maps back to the twin's
/// installation tension T_inst = (T_read - c - b) / a, the one at which the twin's belt is as
/// taut as the one read, with sd sd_read / a; the readings are then weighted by their inverse
/// variances (`fom::stats::inverse_variance_mean`).
pub(super) fn tension_from_readings(
    cfg: &DriveConfig,
    targets: &[Target],
    ea_n: Option<f64>,
) -> Result<Option<(f64, f64)>> {
    let (t1, t2) = (100.0, 300.0);
    let mut mapped = Vec::new();
    for t in targets {
        let (Some(r), Some(d)) = (t.tension_reading, t.known_center_distance_m) else {
            continue;
        };
        let at = |t_inst: f64| DesignPoint::drive(d, cfg.effective_friction(), t_inst, ea_n);
        let (f1, f2) = (at(t1).static_tension_n(cfg), at(t2).static_tension_n(cfg));
        let a = (f2 - f1) / (t2 - t1);
        let b = f1 - a * t1;
        let flexible = at((r.tension_n - b) / a);
        let settled_n = flexible
            .apply(cfg)
            .and_then(|c| fom::simulation::settled_static_tension_n(&c))
            .map_err(|e| {
                TwinError::Calibration(format!(
                    "{}: the tension reading {:.1} N at {d} m: the twin's belt at rest there: {e}",
                    t.label, r.tension_n
                ))
            })?;
        let offset_n = settled_n - flexible.static_tension_n(cfg);
        mapped.push([(r.tension_n - offset_n - b) / a, r.sd_n / a]);
    }
    Ok(fom::stats::inverse_variance_mean(mapped))
}

/// Twin mean slip (with the offset) per condition and its variance; None if outside the
/// surrogate's range.
pub(super) fn predict(
    s: &Surrogate,
    cfg: &DriveConfig,
    p: &Point,
) -> Result<Option<Vec<(f64, f64)>>> {
    let qs: Vec<DesignPoint> = p.design_points().collect();
    if qs.iter().any(|q| s.extrapolation(cfg, q).is_some()) {
        return Ok(None);
    }
    // All conditions at once: the same numbers as one at a time (`predict_points`).
    let mut out = Vec::with_capacity(qs.len());
    for pp in s.predict_points(cfg, &qs)? {
        if s.beyond_trained_slip(pp.mean_slip_pct).is_some() {
            return Ok(None);
        }
        out.push((pp.mean_slip_pct + p.offset, pp.likelihood_std_pct.powi(2)));
    }
    Ok(Some(out))
}

pub(super) fn misfit(pred: &[(f64, f64)], targets: &[Target]) -> f64 {
    pred.iter()
        .zip(targets)
        .map(|((m, _), t)| ((m - t.mean_slip_pct) / t.mean_slip_pct).powi(2))
        .sum()
}
