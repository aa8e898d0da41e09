//! The mechanical candidates: each catalogue variant (`twin_runs::variants`) through its
//! sensitivity runs, fitted as a linear candidate with the slip offset as nuisance.

use super::linear::Fit;
use super::{fit_bound, Scored};
use crate::gap::features::CELLS;
use crate::gap::ranking::{loss, RankContext};
use crate::gap::report::{Param, Ranked};
use crate::gap::twin_runs::Variant;
use fom::stats::rms;
use fom::stats::Z90;

/// Every mechanical variant scored, in catalogue order.
pub(in crate::gap) fn score(r: &RankContext, vars: &[Variant]) -> Vec<Scored> {
    vars.iter()
        .enumerate()
        .map(|(v, var)| score_variant(r, v, var))
        .collect()
}

/// A variant's name in the report: the effect, and its discrete choice in brackets.
pub(in crate::gap) fn name(var: &Variant) -> String {
    if var.choice.is_empty() {
        var.effect.to_string()
    } else {
        format!("{} ({})", var.effect, var.choice)
    }
}

/// One variant: its out-of-sample score, in-sample magnitude, offset and signature.
fn score_variant(r: &RankContext, v: usize, var: &Variant) -> Scored {
    let c = r.variant(v, var);
    let z = r.oos(&c, true);
    let Fit {
        m,
        sd,
        offset: offset_pct,
        ..
    } = c.fit(&r.fitted, true);
    // The signature: the cells that moved most towards the measurement.
    let mut moved: Vec<(f64, String)> = (0..CELLS.len())
        .map(|i| {
            let shift: f64 = r
                .fitted
                .iter()
                .filter(|&&l| c.rows[l][i].3)
                .map(|&l| (m * c.rows[l][i].1 / c.rows[l][i].2).abs())
                .sum();
            (shift, CELLS[i].name())
        })
        .collect();
    moved.sort_by(|a, b| b.0.total_cmp(&a.0));
    let name = name(var);
    (
        Ranked {
            effect: name,
            score: loss(&z) - r.loss_none + r.ln_n,
            params: vec![Param {
                name: var.parameter.to_string(),
                value: m,
                interval90: [
                    (m - Z90 * sd).max(0.0),
                    (m + Z90 * sd).min(fit_bound(var.max)),
                ],
            }],
            gap_after: rms(&z.concat()),
            slip_offset_pct: offset_pct,
            signature: moved
                .into_iter()
                .take(3)
                .filter(|x| x.0 > 0.0)
                .map(|x| x.1)
                .collect(),
            score_beyond_slip_level: r.oos_level_free(&c, true) - r.level_free_none + r.ln_n,
            line_only: r.line_only.get(v).copied().unwrap_or(false),
            variant: Some(v),
        },
        z,
    )
}
