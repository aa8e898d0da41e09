//! `rom predict`: the steady slip distribution at a centre distance, with the friction
//! uncertainty of the seed paper (section 4.2: +-1 % around the nominal coefficient)
//! propagated through the surrogate.

use fom::stats::{mean_and_variance, quantiles_of_map};
use fom::{DesignPoint, DriveConfig};
use serde::Serialize;

use crate::physical::Outside;
use crate::snapshots::{from_z, from_z_in_place};
use crate::surrogate::Surrogate;
use crate::RomError;

/// Relative half-width of the friction uncertainty (seed paper, section 4.2).
pub const FRICTION_UNCERTAINTY: f64 = 0.01;
/// Default number of friction samples.
pub const DEFAULT_SAMPLES: usize = 100;
/// Most friction samples a prediction takes. The strata are centred, so the mixture converges
/// fast: on the shipped surrogate at d 0.42 m the mean agrees with 100,000 samples to 1e-8 pp
/// at 100 samples; 100,000 cost 0.7 s and 100 MB, and 10,000,000 took 8.6 GB
/// (`docs/validation/readers.md`).
pub const MAX_SAMPLES: usize = 100_000;

/// The five reported quantiles, %.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quantiles {
    pub p05: f64,
    pub p25: f64,
    pub p50: f64,
    pub p75: f64,
    pub p95: f64,
}

/// A predicted slip distribution (the JSON object `rom predict` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Distribution {
    pub center_distance_m: f64,
    pub mu: f64,
    pub tension_n: f64,
    pub mean_slip_pct: f64,
    pub std_slip_pct: f64,
    pub quantiles_pct: Quantiles,
    /// The surrogate's own uncertainty (one standard deviation) of the mean slip at nominal mu.
    pub surrogate_std_pct: f64,
    /// The surrogate's 90 % predictive interval of the mean slip at nominal mu, % (the
    /// interval `rom validate` checks the coverage of: `mean_interval90_pct`).
    pub mean_interval90_pct: [f64; 2],
    /// Friction samples propagated.
    pub samples: usize,
    pub friction_uncertainty_pct: f64,
    /// True when a request outside the trained domain was allowed (`--allow-extrapolation`).
    pub extrapolated: bool,
    /// The inputs outside their trained ranges (empty when inside, or when only the belt is
    /// looser than any training run's: `extrapolation_reason` says so).
    pub outside: Vec<Outside>,
    /// Why the answer is an extrapolation, when it is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extrapolation_reason: Option<String>,
    /// Probability levels and pooled quantile function of the distribution, %.
    pub quantile_function_pct: Vec<[f64; 2]>,
}

/// The 90 % predictive interval of a predicted mean slip `mean_pct` whose surrogate standard
/// deviation is `sd_pct` (normal, z = 1.645: `fom::stats::Z90`), %.
pub fn mean_interval90_pct(mean_pct: f64, sd_pct: f64) -> [f64; 2] {
    let half = crate::stats::Z90 * sd_pct;
    [mean_pct - half, mean_pct + half]
}

/// "; the nearest accepted point ..." of a point inside the trained ranges that is refused as
/// looser than any training run (`Surrogate::nearest_accepted`), else empty.
fn nearest_accepted_text(s: &Surrogate, cfg: &DriveConfig, q: &DesignPoint) -> String {
    if s.outside_ranges(q).is_some() {
        return String::new();
    }
    s.nearest_accepted(cfg, q).map_or(String::new(), |p| {
        format!(
            "; the nearest accepted point moving one input: d = {:.5} m, mu = {:.4}, \
             installation tension {:.1} N",
            p.center_distance_m, p.friction, p.installation_tension_n
        )
    })
}

/// Friction samples: stratified over mu (1 +- 1 %), one at the centre of each of `k` equal
/// strata (a one-dimensional centred Latin hypercube: deterministic, and for a smooth response
/// far more accurate than as many random draws).
pub fn friction_samples(mu: f64, k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| mu * (1.0 + FRICTION_UNCERTAINTY * (2.0 * (i as f64 + 0.5) / k as f64 - 1.0)))
        .collect()
}

/// Predicts the slip distribution at `q` with `samples` friction samples around `q.friction`.
/// Refuses points outside the trained ranges unless `allow_extrapolation`.
pub fn predict_distribution(
    s: &Surrogate,
    cfg: &DriveConfig,
    q: &DesignPoint,
    samples: usize,
    allow_extrapolation: bool,
) -> Result<Distribution, RomError> {
    if samples == 0 || samples > MAX_SAMPLES {
        return Err(RomError::InvalidArgument {
            input: crate::Input::FrictionSamples,
            message: format!(
                "must lie in [1, {MAX_SAMPLES}], got {samples} (the prediction has converged \
                 long before: {DEFAULT_SAMPLES} samples agree with {MAX_SAMPLES} to 1e-8 \
                 percentage points on the shipped surrogate)"
            ),
        });
    }
    s.check_inputs(cfg, q)?;
    if let Err(RomError::Impossible { input, reason }) =
        crate::physical::check_physical(cfg, q, &crate::Kind::Slip.inputs())
    {
        return Err(RomError::Impossible {
            input,
            // Outside the trained ranges as well: that range is named too (the physical
            // reason alone names configuration keys).
            reason: match s.outside_ranges(q) {
                Some(outside) => format!("{reason}; {outside}"),
                None => reason + &nearest_accepted_text(s, cfg, q),
            },
        });
    }
    let outside = s.extrapolation(cfg, q);
    if let (Some(why), false) = (&outside, allow_extrapolation) {
        return Err(RomError::Extrapolation {
            reason: format!("{why}{}", nearest_accepted_text(s, cfg, q)),
        });
    }
    // The mixture over friction samples: each sample's quantile function at mid-point levels
    // is an equally weighted sample of its distribution; pool them. The quantiles are order
    // statistics of the pool, selected in the transformed space (`from_z` is increasing, so
    // the order is the same and the per-sample rearrangement is not needed) without sorting
    // it all. With the vectorised exponentials (`fom::fastmath`) and the column-major
    // correlations (`gp::KrigingMean`), 10,000 predictions went from 2.17 s to 0.81-0.85 s
    // on the 216-run model; 0.84-1.02 s over ten runs on the shipped 240-run one
    // (`rom/examples/predict_sweep.rs`, one core).
    let pool_z = s.friction_pool_z(cfg, q, &friction_samples(q.friction, samples))?;
    let mut levels = vec![0.05, 0.25, 0.50, 0.75, 0.95];
    levels.extend_from_slice(&s.probability_levels);
    let qs = quantiles_of_map(&pool_z, &levels, from_z);
    let mut pooled = pool_z;
    from_z_in_place(&mut pooled);
    let (mean, var) = mean_and_variance(&pooled);
    let point = s.predict_point(cfg, q)?;
    if let (Some(why), false) = (s.beyond_trained_slip(mean), allow_extrapolation) {
        return Err(RomError::Extrapolation { reason: why });
    }
    if !(mean.is_finite() && var.is_finite() && point.surrogate_std_pct.is_finite()) {
        let n = fom::readable::readable;
        return Err(RomError::Predict(format!(
            "the surrogate gave a non-finite prediction at d = {} m, mu = {}, T = {} N: an \
             input lies too far outside the trained ranges to extrapolate to",
            n(q.center_distance_m),
            n(q.friction),
            n(q.installation_tension_n)
        )));
    }
    Ok(Distribution {
        center_distance_m: q.center_distance_m,
        mu: q.friction,
        tension_n: q.installation_tension_n,
        mean_slip_pct: mean,
        std_slip_pct: var.sqrt(),
        quantiles_pct: Quantiles {
            p05: qs[0],
            p25: qs[1],
            p50: qs[2],
            p75: qs[3],
            p95: qs[4],
        },
        surrogate_std_pct: point.surrogate_std_pct,
        mean_interval90_pct: mean_interval90_pct(point.mean_slip_pct, point.surrogate_std_pct),
        samples,
        friction_uncertainty_pct: 100.0 * FRICTION_UNCERTAINTY,
        extrapolated: outside.is_some(),
        outside: crate::physical::outside_ranges(&s.settings.ranges(), |v| q.get(v)),
        extrapolation_reason: outside,
        quantile_function_pct: s
            .probability_levels
            .iter()
            .zip(&qs[5..])
            .map(|(&p, &v)| [p, v])
            .collect(),
    })
}

impl Distribution {
    /// Readable table.
    pub fn to_text(&self) -> String {
        let q = &self.quantiles_pct;
        let mut t = String::new();
        for o in &self.outside {
            t += &format!("EXTRAPOLATED: {}\n", o.to_text());
        }
        if let (true, true, Some(why)) = (
            self.extrapolated,
            self.outside.is_empty(),
            &self.extrapolation_reason,
        ) {
            t += &format!("EXTRAPOLATED: {why}\n");
        }
        t += &format!(
            "centre distance {:.4} m, friction {:.3} (+-{:.0} %, {} samples), installation \
             tension {:.1} N\n",
            self.center_distance_m,
            self.mu,
            self.friction_uncertainty_pct,
            self.samples,
            self.tension_n
        );
        t += &format!(
            "steady slip (%)   mean {:.4}  std {:.4}  (surrogate uncertainty of the mean \
             +-{:.4}, 1 sd)\n",
            self.mean_slip_pct, self.std_slip_pct, self.surrogate_std_pct
        );
        let [lo, hi] = self.mean_interval90_pct;
        t += &format!("90 % interval of the mean slip (%)  {lo:.4} to {hi:.4}\n");
        t += "quantile          p05      p25      p50      p75      p95\n";
        t += &format!(
            "slip (%)      {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>8.4}",
            q.p05, q.p25, q.p50, q.p75, q.p95
        );
        t
    }

    /// CSV: one row per probability level.
    pub fn to_csv(&self) -> String {
        let mut t = String::from("probability,slip_pct\n");
        for [p, v] in &self.quantile_function_pct {
            t += &format!("{p:.4},{v:.6}\n");
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn friction_samples_are_centred_strata_within_one_percent() {
        let s = friction_samples(0.7, 4);
        let want = [0.69475, 0.69825, 0.70175, 0.70525];
        for (a, b) in s.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{s:?}");
        }
        let mean = s.iter().sum::<f64>() / 4.0;
        assert!((mean - 0.7).abs() < 1e-12);
        assert!(friction_samples(0.7, 1000)
            .iter()
            .all(|m| (m / 0.7 - 1.0).abs() <= 0.01));
    }
}
