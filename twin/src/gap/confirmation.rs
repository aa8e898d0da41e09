//! Stage "confirmation": full-order (reduced-resolution) runs with the candidate mechanical
//! effect at its fitted magnitude on the labels of the ranking (no new run where one within
//! 10 % exists). They have the last word: the linearised fit may promise more than the effect
//! delivers when it is run (an effect that pushes the twin into its looseness knee), and a
//! second effect is looked for in what the runs leave, not in what the linearisation leaves
//! (`verdict::named_effects`). Where the runs at the calibrated installation tension fall
//! short, they are repeated at the tension within its posterior that fits best
//! (`over_tension`).

use fom::stats::{rms, slope_through_origin, Z90};
use rayon::prelude::*;
use serde::Serialize;

use super::baseline::effect_features_at;
use super::candidates::linear::LinearCandidate;
use super::cells::{fit_cell, label_cells, CellRow};
use super::features::CELLS;
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
    /// Per evaluated label (`RankContext::eval_labels`), (cell index, withheld z) of its
    /// usable cells.
    pub z_cells: Vec<Vec<(usize, f64)>>,
    /// The installation tension the runs were made at, N, where the tension search
    /// (`over_tension`) moved it from the calibrated one.
    pub tension_n: Option<f64>,
}

/// Points of the tension search across the installation tension's 90 % posterior interval
/// (`over_tension`): its ends and seven between, about 10 N apart on the shipped drive.
const TENSION_POINTS: usize = 9;

/// One confirmation: variant `v` at magnitude `m`, the installation tension at `tension_n`
/// (`None`: the calibrated one).
#[derive(Clone, Copy)]
pub(super) struct Run<'v> {
    pub vars: &'v [Variant],
    pub v: usize,
    pub m: f64,
    pub tension_n: Option<f64>,
    /// The relative sd of the magnitude mapping from label to label in the variant's own
    /// line (`LinearCandidate::form_sd`): `LINE_FORM_SD` where it is mapped by its line.
    pub form_sd: f64,
    /// Whether a run within 10 % of the magnitude at the calibrated tension (the reference
    /// run or the second pass's) may stand for it: a confirmation's shortcut. A magnitude
    /// search runs every point, since a threshold effect's answer changes steeply within
    /// 10 %.
    pub reuse: bool,
}

impl Run<'_> {
    /// The run's specification, and the factor by which a twin-equivalent magnitude beyond the
    /// effect's physical bound (`MODEL_FORM_SCALE`) scales the run's shift of every cell (it is
    /// run at the bound).
    fn spec(&self) -> (String, f64) {
        let m_run = self.m_run().max(1e-12);
        (self.vars[self.v].spec(m_run), self.m / m_run)
    }

    /// The magnitude run: `m`, at most the effect's physical bound.
    fn m_run(&self) -> f64 {
        self.m.min(self.vars[self.v].max)
    }

    /// Label `l`'s cells with the effect: (measured, twin, sd) per cell.
    pub(super) fn cells(
        &self,
        d: &Diagnosis,
        r: &RankContext,
        l: usize,
    ) -> Result<Vec<CellRow>, TwinError> {
        let lt = &r.twins[l];
        let var = &self.vars[self.v];
        let (spec, scale) = self.spec();
        // A run within 10 % of the fitted magnitude at the calibrated tension is already
        // there (the reference or the second pass's).
        let f = match (&lt.variant[self.v], self.tension_n) {
            (Some(f), None) if self.reuse && (self.m_run() / var.reference - 1.0).abs() < 0.1 => {
                f.clone()
            }
            _ => effect_features_at(d, lt, self.tension_n, var, &spec)?,
        };
        let cells = label_cells(lt, &f);
        let line = var.line_cells();
        Ok(cells
            .iter()
            .enumerate()
            .map(|(i, &(m, t, sd))| {
                let t0 = r.base_cells[l][i].1;
                let t = if scale > 1.0 {
                    t0 + scale * (t - t0)
                } else {
                    t
                };
                // The line's answer may differ from the run's by the mapping's sd, as in the fit.
                let form = if line.contains(&i) { self.form_sd } else { 0.0 };
                (m, t, sd.hypot(form * (t - t0)))
            })
            .collect())
    }
}

/// The confirmation `run` on every label of the ranking: the withheld labels' RMS z (each
/// label's slip offset refitted on the other labels' confirmed cells, as in the fit) and the
/// residuals left, and whether a run failed (then recorded in `failed_runs` and `None`).
pub(super) fn confirm(
    d: &Diagnosis,
    r: &RankContext,
    run: Run,
    line: &[usize],
    failed_runs: &mut Vec<FailedRun>,
) -> (Option<Confirmed>, bool) {
    confirm_reusing(d, r, run, line, failed_runs, None)
}

/// `confirm`, with one label's cells already run (`done`: the label and its cells from the
/// same run) taken instead of running it again.
fn confirm_reusing(
    d: &Diagnosis,
    r: &RankContext,
    run: Run,
    line: &[usize],
    failed_runs: &mut Vec<FailedRun>,
    done: Option<(usize, &[CellRow])>,
) -> (Option<Confirmed>, bool) {
    // Per label its cells, or the first failed run's label and error.
    type LabelCells = Vec<(usize, Vec<CellRow>)>;
    let rows: std::result::Result<LabelCells, (usize, TwinError)> = r
        .active
        .par_iter()
        .map(|&l| match done {
            Some((k, cells)) if k == l => Ok((l, cells.to_vec())),
            _ => run.cells(d, r, l).map(|c| (l, c)).map_err(|e| (l, e)),
        })
        .collect();
    let rows = match rows {
        Ok(rows) => rows,
        Err((l, e)) => {
            failed_runs.push(FailedRun {
                label: r.twins[l].label.clone(),
                effect: run.spec().0,
                purpose: "confirmation",
                reason: e.to_string(),
            });
            return (None, true);
        }
    };
    let mut all = vec![Vec::new(); r.n];
    for (l, cells) in rows {
        all[l] = residual_row(&cells)
            .into_iter()
            .map(|(g, sd, ok)| (g, 0.0, sd, ok))
            .collect();
    }
    let c = LinearCandidate {
        rows: all,
        max: 0.0,
        nuis: r.nuis.clone(),
        form_sd: 0.0,
    };
    // Withheld as the gap before the effect is (`RankContext::oos`): each label's slip offset
    // from the other labels, so that before and after are one quantity.
    let z_cells = r.oos_z_cells(&c, false);
    let cells: Vec<(usize, f64)> = z_cells.concat();
    let z: Vec<f64> = cells.iter().map(|&(_, z)| z).collect();
    let z_line: Vec<f64> = cells
        .iter()
        .filter(|(i, _)| line.contains(i))
        .map(|&(_, z)| z)
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
            z_cells,
            tension_n: run.tension_n,
        }),
        false,
    )
}

/// The confirmation repeated with the installation tension re-fitted, for an effect whose
/// runs at the calibrated tension fall short. The effect's answer can depend steeply on where
/// in its posterior the twin sits where the baseline's does not: creep slip hardly moves with
/// the installation tension (Johnson, Contact Mechanics, 1985, sec. 8.7), so calibration leaves
/// it wide, while the driver pulley's 0.29 mm runout at the loosest label of a drive near its
/// knee gave a 1x line of 0.64, 0.76, 4.19, 2.84 and 1.26 rpm at 240, 245, 250, 255 and 270 N
/// (a resonance the runout excites). The fitted label that `first` leaves furthest off is run
/// at `TENSION_POINTS` tensions across the interval; the tension with the least misfit there,
/// the posterior's penalty included, is run on every other label, and kept if it fits the
/// fitted labels better than the calibrated tension
/// (docs/decisions/gap-confirmation-tension.md). `None` when no point beats the calibrated
/// tension or a run failed (a failed search run is not recorded: the calibrated tension's
/// confirmation stands).
pub(super) fn over_tension(
    d: &Diagnosis,
    r: &RankContext,
    run: Run,
    line: &[usize],
    first: &Confirmed,
) -> Option<Confirmed> {
    let t0 = r.twins[*r.fitted.first()?].q.installation_tension_n;
    let [lo, hi] = d.cal.interval90("installation_tension_n", t0);
    if hi <= lo {
        return None;
    }
    let worst = *r
        .fitted
        .iter()
        .max_by(|&&a, &&b| misfit(&first.rows, &[a]).total_cmp(&misfit(&first.rows, &[b])))?;
    let grid: Vec<f64> = (0..TENSION_POINTS)
        .map(|k| lo + (hi - lo) * k as f64 / (TENSION_POINTS - 1) as f64)
        .collect();
    let at_worst: Vec<(f64, Vec<CellRow>)> = grid
        .par_iter()
        .filter_map(|&t| {
            let cells = Run {
                tension_n: Some(t),
                ..run
            }
            .cells(d, r, worst)
            .ok()?;
            Some((t, cells))
        })
        .collect();
    let chi2: Vec<(f64, f64)> = at_worst
        .iter()
        .map(|(t, cells)| (*t, row_chi2(&residual_row(cells))))
        .collect();
    let t_best = best_tension(&chi2, t0, [lo, hi], misfit(&first.rows, &[worst]))?;
    let again = Run {
        tension_n: Some(t_best),
        ..run
    };
    // The worst label's run at that tension is the search's own, its cells' sds widened by
    // how far the answer moves within half a grid step of it.
    let k_best = at_worst.iter().position(|(t, _)| *t == t_best)?;
    let searched = &at_worst[k_best].1;
    let spread = grid_resolution_sd(&at_worst, k_best);
    let widened: Vec<CellRow> = searched
        .iter()
        .zip(&spread)
        .map(|(&(m, t, sd), &s)| (m, t, sd.hypot(s)))
        .collect();
    let (c, _) = confirm_reusing(d, r, again, line, &mut Vec::new(), Some((worst, &widened)));
    // Kept on the runs' own misfit, the worst label's the search's chi-square there, without
    // the widening: the grid's resolution is what the figure is uncertain by, not evidence
    // for the tension.
    c.filter(|c| {
        let others: Vec<usize> = r.fitted.iter().copied().filter(|&l| l != worst).collect();
        misfit(&c.rows, &others) + chi2[k_best].1 + tension_prior(t_best, t0, [lo, hi])
            < misfit(&first.rows, &r.fitted)
    })
}

/// A named effect's magnitude re-fitted on its confirmation runs at a re-fitted installation
/// tension (`over_tension`), where the linearised fit set it at the calibrated tension.
#[derive(Debug, Clone, Serialize)]
pub struct MagnitudeAtTension {
    /// The installation tension of the runs, N.
    pub tension_n: f64,
    /// The effect's own line cells and the fitted labels the magnitude is read on.
    pub cells: Vec<String>,
    pub labels: Vec<String>,
    pub magnitude: f64,
    pub interval90: [f64; 2],
    /// The linearised fit's magnitude, at which the runs (and the gap after) are made.
    pub fitted: f64,
}

/// The magnitude that the runs at a re-fitted tension `c` ask for in the effect's own line
/// (`Variant::line_cells`) on the fitted labels, no run added. At a fixed tension a runout
/// or a pulsation forces its line, and a forced response is linear in its forcing
/// (Meirovitch, Fundamentals of Vibrations, 2001, ch. 3), so the runs' shift of each line
/// cell from the baseline, delta, scales with the magnitude: the measured shift over the
/// run's, weighted by the runs' own sds (the mapping's spread and the searched label's grid
/// step included; `fom::stats::slope_through_origin`), times the run's magnitude. `None`
/// without a re-fitted tension, a line, or a shift in it
/// (docs/decisions/gap-confirmation-tension.md).
pub(super) fn magnitude_at_tension(
    r: &RankContext,
    run: &Run,
    c: &Confirmed,
    names: &[String],
) -> Option<MagnitudeAtTension> {
    let tension_n = c.tension_n?;
    let line = run.vars[run.v].line_cells();
    // Per usable line cell of a fitted label: the measured shift from the baseline, the
    // run's (measured - baseline less what the run leaves), and the run's sd.
    let shifts: Vec<[f64; 3]> = r
        .fitted
        .iter()
        .filter_map(|&l| {
            c.rows
                .get(l)
                .filter(|row| !row.is_empty())
                .map(|row| (l, row))
        })
        .flat_map(|(l, row)| {
            line.iter().filter_map(move |&i| {
                let (residual, sd, usable) = row[i];
                let g = r.base_cells[l][i].0 - r.base_cells[l][i].1;
                usable.then_some([g, g - residual, sd])
            })
        })
        .collect();
    let (factor, sd) = slope_through_origin(shifts)?;
    let m = run.m;
    Some(MagnitudeAtTension {
        tension_n,
        cells: line.iter().map(|&i| CELLS[i].name()).collect(),
        labels: r.fitted.iter().map(|&l| names[l].clone()).collect(),
        magnitude: (factor * m).max(0.0),
        interval90: [((factor - Z90 * sd) * m).max(0.0), (factor + Z90 * sd) * m],
        fitted: m,
    })
}

/// Per cell, the RMS by which the twin's answer at the searched label moves within half a
/// grid step either side of the chosen tension `points[k]` (the grid's resolution: the best
/// tension is known to that step, and a resonance narrower than the step moves the answer
/// within it). On each side the answer is taken as linear towards the neighbouring tension,
/// so it changes by c = (x_neighbour - x_chosen) / 2 at the half step, and with the tension
/// uniform over the half steps E[(x - x_chosen)^2] = (c_below^2 + c_above^2) / 6 (c^2 / 3 at
/// an end of the grid, one side only). `points`: (tension, cells) in tension order.
fn grid_resolution_sd(points: &[(f64, Vec<CellRow>)], k: usize) -> Vec<f64> {
    let chosen = &points[k].1;
    let sides: Vec<&Vec<CellRow>> = [k.checked_sub(1), Some(k + 1)]
        .into_iter()
        .flatten()
        .filter_map(|j| points.get(j).map(|p| &p.1))
        .collect();
    if sides.is_empty() {
        return vec![0.0; chosen.len()];
    }
    (0..chosen.len())
        .map(|i| {
            let sum: f64 = sides
                .iter()
                .map(|s| ((s[i].1 - chosen[i].1) / 2.0).powi(2))
                .sum();
            (sum / (3.0 * sides.len() as f64)).sqrt()
        })
        .collect()
}

/// The posterior's penalty on tension `t`: ((t - t0) / sd)^2, with sd the 90 % interval's
/// half on t's side over z_0.95 (the interval is not symmetric).
fn tension_prior(t: f64, t0: f64, [lo, hi]: [f64; 2]) -> f64 {
    let sd = if t > t0 { hi - t0 } else { t0 - lo } / Z90;
    ((t - t0) / sd.max(1e-9)).powi(2)
}

/// Of (tension, chi-square) `points`, the tension whose chi-square plus the posterior's
/// penalty is least, if that is below `at_t0`, the chi-square at the calibrated tension `t0`.
fn best_tension(points: &[(f64, f64)], t0: f64, interval: [f64; 2], at_t0: f64) -> Option<f64> {
    points
        .iter()
        .map(|&(t, chi2)| (t, chi2 + tension_prior(t, t0, interval)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|&(_, score)| score < at_t0)
        .map(|(t, _)| t)
}

/// A label's cells as residuals: (measured - twin, sd, usable) per cell.
pub(super) fn residual_row(cells: &[CellRow]) -> Vec<(f64, f64, bool)> {
    cells
        .iter()
        .enumerate()
        .map(|(i, &(m, t, sd))| (m - t, sd, fit_cell(i, (m, t, sd))))
        .collect()
}

/// Chi-square of the usable cells of one label's residuals.
pub(super) fn row_chi2(row: &[(f64, f64, bool)]) -> f64 {
    row.iter()
        .filter(|c| c.2)
        .map(|&(g, sd, _)| (g / sd).powi(2))
        .sum()
}

/// Chi-square of the usable residual cells of `labels` in `rows`.
fn misfit(rows: &[Vec<(f64, f64, bool)>], labels: &[usize]) -> f64 {
    labels.iter().map(|&l| row_chi2(&rows[l])).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Chi-square of one cell whose twin answer peaks sharply at 250 N (a resonance).
    fn peaked(t: f64) -> f64 {
        let answer = 0.7 + 3.5 / (1.0 + ((t - 251.0) / 3.0).powi(2));
        ((3.8 - answer) / 0.08).powi(2)
    }

    /// The grid's resolution: a flat answer adds nothing; a peak between grid points adds
    /// the RMS of the linear answer towards each neighbour over half a step, one-sided at an
    /// end of the grid.
    #[test]
    fn the_answer_at_the_searched_label_carries_the_grid_step_it_is_known_to() {
        let at = |x: f64| vec![(3.8, x, 0.07), (1.0, 1.0, 0.1)];
        let points: Vec<(f64, Vec<CellRow>)> = [0.8, 3.0, 1.6]
            .iter()
            .enumerate()
            .map(|(k, &x)| (244.0 + 10.0 * k as f64, at(x)))
            .collect();
        let sd = grid_resolution_sd(&points, 1);
        // c = -1.1 and -0.7: sqrt((1.21 + 0.49) / 6).
        assert!((sd[0] - (1.7f64 / 6.0).sqrt()).abs() < 1e-12, "{sd:?}");
        assert_eq!(sd[1], 0.0);
        // At the grid's end, the one neighbour: c = 1.1, sqrt(1.21 / 3).
        let end = grid_resolution_sd(&points, 0);
        assert!((end[0] - (1.21f64 / 3.0).sqrt()).abs() < 1e-12, "{end:?}");
        // The measured 3.8 rpm against the chosen 3.0: 11 sd by the run's own error, within
        // 1.5 once the step is counted.
        assert!((3.8 - 3.0) / 0.07f64.hypot(sd[0]) < 1.5);
        // A lone point knows no step.
        assert_eq!(grid_resolution_sd(&points[..1], 0), vec![0.0, 0.0]);
    }

    #[test]
    fn a_resonance_inside_the_tension_interval_is_found_and_the_prior_weighs_the_distance() {
        let (t0, interval) = (244.7, [212.9, 293.5]);
        let grid: Vec<(f64, f64)> = (0..TENSION_POINTS)
            .map(|k| {
                let t = 212.9 + 80.6 * k as f64 / (TENSION_POINTS - 1) as f64;
                (t, peaked(t))
            })
            .collect();
        let t = best_tension(&grid, t0, interval, peaked(t0)).expect("a better tension");
        assert!((t - 253.0).abs() < 5.0, "{t}");
        // A flat answer: nothing beats the calibrated tension, whose penalty is zero.
        let flat: Vec<(f64, f64)> = grid.iter().map(|&(t, _)| (t, 40.0)).collect();
        assert_eq!(best_tension(&flat, t0, interval, 40.0), None);
        // A small gain far out in the posterior is not worth its penalty.
        let far = [(212.9, 39.0), (293.5, 39.0)];
        assert_eq!(best_tension(&far, t0, interval, 40.0), None);
        // Nor is a marginal gain past the interval's narrow side (sd 31.8 / 1.645 = 19.3 N).
        assert!(tension_prior(212.9, t0, interval) > 2.5);
        assert!((tension_prior(293.5, t0, interval) - Z90 * Z90).abs() < 1e-9);
    }
}
