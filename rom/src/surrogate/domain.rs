//! Where the slip surrogate may answer: its trained ranges, a belt looser than any training
//! run, a predicted slip beyond the trained one, and inputs it was not trained over.

use fom::params::Variable;
use fom::{DesignPoint, DriveConfig};

use super::{Surrogate, OUTPUT_MARGIN};
use crate::features::capacity_n;
use crate::RomError;

impl Surrogate {
    /// The drive configuration the surrogate was trained on.
    pub fn config(&self) -> Result<fom::ValidConfig, RomError> {
        Ok(DriveConfig::from_toml_str(
            &self.config_toml,
            "surrogate file (embedded configuration)",
        )?)
    }

    /// Names the first input outside the training ranges, if any.
    pub fn outside_ranges(&self, q: &DesignPoint) -> Option<String> {
        self.settings
            .ranges()
            .first_outside(|v| q.get(v))
            .map(|(var, x, range)| out_of_range(var, x, range))
    }

    /// Names `v` if it lies outside the trained range of `var` (`None` also when the surrogate
    /// does not vary `var`).
    pub fn outside_range(&self, var: fom::params::Variable, v: f64) -> Option<String> {
        let range = self.settings.ranges().get(var)?;
        (!(v >= range[0] && v <= range[1])).then(|| out_of_range(var, v, range))
    }

    /// Names a query whose traction capacity lies below every training run's: the belt is
    /// looser (or slack) beyond what the surrogate has seen, even with d, mu and the tension
    /// each inside their ranges.
    pub fn looser_than_trained(&self, cfg: &DriveConfig, q: &DesignPoint) -> Option<String> {
        let t0 = q.static_tension_n(cfg);
        let u = capacity_n(t0, q.smaller_wrap_angle_rad(cfg), q.friction);
        let lo = self.capacity_range_n[0];
        (u < lo - 1e-9 * lo.abs()).then(|| {
            format!(
                "the belt is looser than in any training run: static span tension {t0:.1} N \
                 gives a traction capacity of {u:.1} N, below the trained minimum {lo:.1} N"
            )
        })
    }

    /// The accepted point nearest to `q` (refused as looser than trained) reached by moving one
    /// input towards a tighter belt, d, installation tension or friction up to where the
    /// traction capacity reaches the trained minimum, measured in units of each input's trained
    /// range; `None` if no single move inside the ranges gets there.
    pub fn nearest_accepted(&self, cfg: &DriveConfig, q: &DesignPoint) -> Option<DesignPoint> {
        let accepted = |p: &DesignPoint| self.looser_than_trained(cfg, p).is_none();
        let mut best: Option<(f64, DesignPoint)> = None;
        for (var, [lo, hi]) in self.settings.ranges() {
            if !matches!(
                var,
                Variable::CenterDistance | Variable::InstallationTension | Variable::Friction
            ) {
                continue;
            }
            let at = |x: f64| {
                let mut p = *q;
                p.set(var, x);
                p
            };
            let x0 = q.get(var).unwrap_or(lo);
            if !accepted(&at(hi)) {
                continue;
            }
            // Bisection on the monotone capacity: a refused, b accepted.
            let (mut a, mut b) = (x0.max(lo), hi);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if accepted(&at(m)) {
                    b = m;
                } else {
                    a = m;
                }
            }
            let dist = (b - x0) / (hi - lo);
            if best.as_ref().is_none_or(|(d, _)| dist < *d) {
                best = Some((dist, at(b)));
            }
        }
        best.map(|(_, p)| p)
    }

    /// Share of the trained box that `looser_than_trained` or `beyond_trained_slip` refuses,
    /// Monte Carlo over `samples`
    /// uniform points (fixed seed: the figure is reproducible; standard error
    /// sqrt(p (1 - p) / samples)).
    pub fn refused_share(&self, cfg: &DriveConfig, samples: usize) -> f64 {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256Plus::seed_from_u64(1);
        let ranges = self.settings.ranges();
        let mut refused = 0usize;
        for _ in 0..samples {
            let mut p = DesignPoint::from_columns(&[], &[]);
            for (var, [lo, hi]) in &ranges {
                p.set(*var, lo + (hi - lo) * rng.gen::<f64>());
            }
            let beyond = || {
                self.predict_point(cfg, &p).map_or(true, |pp| {
                    self.beyond_trained_slip(pp.mean_slip_pct).is_some()
                })
            };
            if self.looser_than_trained(cfg, &p).is_some() || beyond() {
                refused += 1;
            }
        }
        refused as f64 / samples as f64
    }

    /// Refuses a point that sets a variable this surrogate was not trained over (to another
    /// value than the configuration's): the surrogate has no input for it, so the answer would
    /// silently ignore it.
    pub fn check_inputs(&self, cfg: &DriveConfig, q: &DesignPoint) -> Result<(), RomError> {
        let trained = self.settings.ranges().variables();
        let nominal = DesignPoint::nominal(cfg);
        for v in Variable::ALL {
            let Some(x) = q.get(v) else { continue };
            if !trained.contains(&v) && x != nominal.value_or_config(v, cfg) {
                let keys: Vec<&str> = trained.iter().map(|t| t.key()).collect();
                return Err(RomError::InvalidArgument {
                    input: crate::Input::Variable(v),
                    message: format!(
                        "= {x}: this surrogate was not trained over it (its inputs: {}); train \
                         one with a range for it",
                        keys.join(", ")
                    ),
                });
            }
        }
        Ok(())
    }

    /// Why a predicted mean slip cannot be trusted: more than `OUTPUT_MARGIN` above the largest
    /// steady mean slip of any training run (the processes overshooting between sparse runs in
    /// the loosest corner, a validation once found 345 % where the full-order model
    /// settled at 6 %); None when within, or for files without the training maximum.
    pub fn beyond_trained_slip(&self, mean_slip_pct: f64) -> Option<String> {
        let max = self.max_trained_slip_pct?;
        (mean_slip_pct.is_nan() || mean_slip_pct > OUTPUT_MARGIN * max).then(|| {
            format!(
                "the surrogate's mean slip {mean_slip_pct:.3} % lies beyond the largest of its \
                 training runs ({max:.3} %) by more than {:.0} %: it is extrapolating in slip",
                100.0 * (OUTPUT_MARGIN - 1.0)
            )
        })
    }

    /// Why the surrogate cannot answer at `q` without extrapolating, if it cannot: an input
    /// outside its trained range, or a belt looser than any training run's.
    pub fn extrapolation(&self, cfg: &DriveConfig, q: &DesignPoint) -> Option<String> {
        self.outside_ranges(q)
            .or_else(|| self.looser_than_trained(cfg, q))
    }
}

/// The refusal of `v` for `var`, outside its trained range `[lo, hi]`.
fn out_of_range(var: fom::params::Variable, v: f64, [lo, hi]: [f64; 2]) -> String {
    let name = var.describe();
    let n = fom::readable::readable;
    format!(
        "{name} {} is outside the trained range [{}, {}]",
        n(v),
        n(lo),
        n(hi)
    )
}
