//! Adaptive training: where the next full-order runs should go. After the Latin hypercube, the
//! surrogate's own uncertainty of the mean slip relative to the accuracy it must reach there
//! (`validate::mean_slip_tolerance_pct`: max(0.05 pp, 2 %) in creep, max(0.1 pp, 5 %) at the
//! knee) points at the knee's onset and at sparsely sampled corners; candidates are spread by a
//! distance penalty so that one round does not pile its points onto one spot (maximum-variance
//! sequential design: Sacks, Welch, Mitchell & Wynn, Statistical Science 4(4), 1989, sec. 4).
//! A third of each round goes instead where the surrogate is least sure on which side of the
//! knee threshold (`validate::KNEE_SLIP_PCT`) the slip lies: the smallest
//! U = |mean - threshold| / std, the learning function of AK-MCS (Echard, Gayton & Lemaire,
//! Structural Safety 33(2), 2011, eq. 13), which puts runs on the knee's onset. The variance
//! alone spent half of a round on the tight corners of the box, where creep slip is flat.
//! The last third fills the region predicted past the threshold: the candidate there farthest
//! from every run (maximin distance, Johnson, Moore & Ylvisaker, J. Stat. Plan. Inference
//! 26, 1990). The first two rules left the knee between its 1 % contour and the loosest
//! corner bare (five rounds on the default drive: no run at 1.4-2.4 % slip near mu 0.7), and
//! the surrogate's means there were biased by +0.1-0.2 pp (`docs/surrogate.md`, "Adaptive
//! training").

use fom::{DesignPoint, DriveConfig};
use training::latin_hypercube;

use crate::surrogate::Surrogate;
use crate::validate::{mean_slip_tolerance_pct, KNEE_SLIP_PCT};
use crate::RomError;

/// Candidates scored per point of a round.
pub const CANDIDATES_PER_POINT: usize = 64;

/// `n` new design points for the surrogate `s` trained on `existing` points: greedily, in
/// turn, the candidate (from a Latin hypercube over the trained box, seed `seed`) with the
/// smallest U at the knee threshold and the one with the largest surrogate standard deviation
/// of the mean slip over the accuracy target at the predicted slip, each score times
/// min(1, distance to the nearest chosen or existing point / r), r = half the spacing of a
/// regular grid with as many points, and the candidate predicted at the knee farthest from
/// the chosen and existing points (the variance rule when none is left), all in the box
/// scaled to the unit cube.
pub fn refinement_points(
    s: &Surrogate,
    cfg: &DriveConfig,
    existing: &[DesignPoint],
    n: usize,
    seed: u64,
) -> Result<Vec<DesignPoint>, RomError> {
    let ranges = s.settings.ranges();
    let dim = ranges.len() as f64;
    let unit = |p: &DesignPoint| -> Vec<f64> {
        ranges
            .iter()
            .map(|(v, [lo, hi])| (p.get(*v).unwrap_or(*lo) - lo) / (hi - lo))
            .collect()
    };
    let candidates = latin_hypercube(&ranges, CANDIDATES_PER_POINT * n.max(1), seed);
    // (unit position, std / accuracy target, 1 / U at the knee threshold, predicted at the knee)
    let mut scored = Vec::with_capacity(candidates.len());
    for c in &candidates {
        let p = s.predict_point(cfg, c)?;
        let sd = p.surrogate_std_pct;
        let need = mean_slip_tolerance_pct(p.mean_slip_pct);
        let inv_u = sd / (p.mean_slip_pct - KNEE_SLIP_PCT).abs().max(1e-12);
        scored.push((unit(c), sd / need, inv_u, p.mean_slip_pct >= KNEE_SLIP_PCT));
    }
    let mut taken: Vec<Vec<f64>> = existing.iter().map(unit).collect();
    let r = 0.5 * ((taken.len() + n) as f64).powf(-1.0 / dim);
    let mut out = Vec::with_capacity(n);
    let mut used = vec![false; candidates.len()];
    for round in 0..n {
        // In turn: the knee's onset, the largest relative uncertainty, and the emptiest spot
        // where the knee is predicted (space filling there).
        let rule = if (round % 3 == 2) && scored.iter().zip(&used).any(|(c, u)| c.3 && !u) {
            Rule::FillKnee
        } else if round % 3 == 0 {
            Rule::Onset
        } else {
            Rule::Variance
        };
        let mut best: Option<(f64, usize)> = None;
        for (k, (x, rel_sd, inv_u, at_knee)) in scored.iter().enumerate() {
            if used[k] || (rule == Rule::FillKnee && !at_knee) {
                continue;
            }
            let d = taken
                .iter()
                .map(|t| t.iter().zip(x).map(|(a, b)| (a - b).powi(2)).sum::<f64>())
                .fold(f64::INFINITY, f64::min)
                .sqrt();
            let score = match rule {
                Rule::Onset => *inv_u * (d / r).min(1.0),
                Rule::Variance => *rel_sd * (d / r).min(1.0),
                Rule::FillKnee => d,
            };
            if best.is_none_or(|(b, _)| score > b) {
                best = Some((score, k));
            }
        }
        let Some((_, k)) = best else { break };
        used[k] = true;
        taken.push(scored[k].0.clone());
        out.push(candidates[k]);
    }
    Ok(out)
}

/// The three scores a round takes in turn.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Rule {
    /// Smallest U at the knee threshold.
    Onset,
    /// Largest surrogate sd over the accuracy target.
    Variance,
    /// Farthest from every run among the candidates predicted at the knee.
    FillKnee,
}
