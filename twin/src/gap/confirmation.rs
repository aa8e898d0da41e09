//! Stage "confirmation": full-order (reduced-resolution) runs with the candidate mechanical
//! effect at its fitted magnitude on the labels of the ranking (no new run where one within
//! 10 % exists). They have the last word: the linearised fit may promise more than the effect
//! delivers when it is run (an effect that pushes the twin into its looseness knee), and a
//! second effect is looked for in what the runs leave, not in what the linearisation leaves
//! (`verdict::named_effects`).

use fom::stats::rms;
use rayon::prelude::*;

use super::baseline::effect_features;
use super::candidates::linear::LinearCandidate;
use super::cells::{fit_cell, label_cells, CellRow};
use super::ranking::RankContext;
use super::report::FailedRun;
use super::twin_runs::Variant;
use super::Diagnosis;
use crate::error::TwinError;

/// What the confirmation runs leave.
pub(super) struct Confirmed {
    /// The withheld labels' RMS z over all their cells and over the line's cells alone (NaN
    /// where no line was given).
    pub rms_z: [f64; 2],
    /// Per label (empty for a label outside the ranking), per cell: (measured - the run with
    /// the effect, sd, usable).
    pub rows: Vec<Vec<(f64, f64, bool)>>,
}

/// Variant `v` run at magnitude `m` on every label of the ranking: the withheld labels' RMS z
/// (the slip offset refitted on the confirmed cells, as in the fit) and the residuals left,
/// and whether a run failed (then recorded in `failed_runs` and `None`).
pub(super) fn confirm(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    v: usize,
    m: f64,
    line: &[usize],
    failed_runs: &mut Vec<FailedRun>,
) -> (Option<Confirmed>, bool) {
    // A twin-equivalent magnitude beyond the effect's physical bound (`MODEL_FORM_SCALE`) is
    // run at the bound, and the run's shift of every cell scaled by m / bound.
    let m_run = m.min(vars[v].max);
    let scale = m / m_run.max(1e-12);
    let spec = vars[v].spec(m_run.max(1e-12));
    // Per label its cells, or the first failed run's label and error.
    type LabelCells = Vec<(usize, Vec<CellRow>)>;
    let rows: std::result::Result<LabelCells, (usize, TwinError)> = r
        .active
        .par_iter()
        .map(|&l| {
            let lt = &r.twins[l];
            // A run within 10 % of the fitted magnitude is already there (the
            // reference or the second pass's).
            let f = match &lt.variant[v] {
                Some(f) if (m_run / vars[v].reference - 1.0).abs() < 0.1 => f.clone(),
                _ => effect_features(d, lt, &spec).map_err(|e| (l, e))?,
            };
            Ok((l, label_cells(lt, &f)))
        })
        .collect();
    let rows = match rows {
        Ok(rows) => rows,
        Err((l, e)) => {
            failed_runs.push(FailedRun {
                label: r.twins[l].label.clone(),
                effect: spec.clone(),
                purpose: "confirmation",
                reason: e.to_string(),
            });
            return (None, true);
        }
    };
    let mut all = vec![Vec::new(); r.n];
    for (l, cells) in rows {
        all[l] = cells
            .iter()
            .enumerate()
            .map(|(i, &(m, t, sd))| {
                let t = if scale > 1.0 {
                    let t0 = r.base_cells[l][i].1;
                    t0 + scale * (t - t0)
                } else {
                    t
                };
                (m - t, 0.0, sd, fit_cell(i, (m, t, sd)))
            })
            .collect();
    }
    let c = LinearCandidate {
        rows: all,
        max: 0.0,
        nuis: r.nuis.clone(),
    };
    let f = c.fit(&r.eval_labels, false);
    let z: Vec<f64> = r.eval_labels.iter().flat_map(|&l| c.z(l, &f)).collect();
    let z_line: Vec<f64> = r
        .eval_labels
        .iter()
        .flat_map(|&l| c.z_cells(l, &f).filter(|(i, _)| line.contains(i)))
        .map(|(_, z)| z)
        .collect();
    let line_rms = if z_line.is_empty() {
        f64::NAN
    } else {
        rms(&z_line)
    };
    (
        Some(Confirmed {
            rms_z: [rms(&z), line_rms],
            rows: c.residuals(),
        }),
        false,
    )
}
