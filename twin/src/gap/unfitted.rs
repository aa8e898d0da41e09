//! Stage "labels no fold fits": evidence that only an unsettled label carries. A label still
//! drifting at the end of its recordings is read like with like (the twin over the same
//! window) and never fitted (`RankContext::new`), so leave-one-label-out cannot credit an
//! effect that only such a label shows: a Stribeck friction drop tips the loosest setting into
//! gross slip, still drifting, and leaves the tighter ones as they were. Where the gap lies in
//! those labels alone, each identifiable mechanical candidate is fitted in sample on every
//! ranked label and scored by the Schwarz criterion against "none" (one magnitude, k ln n);
//! the best one's magnitude is searched with full-order runs at those labels (a threshold
//! effect is not linear in its magnitude), and the verdict confirms it on every label
//! (docs/decisions/gap-unfitted-labels.md).

use fom::stats::Z90;
use rayon::prelude::*;
use serde::Serialize;

use super::candidates::linear::{huber, Fit, LinearCandidate};
use super::candidates::mechanical;
use super::confirmation::{confirm, residual_row, row_chi2, Confirmed, Run};
use super::ranking::RankContext;
use super::report::FailedRun;
use super::twin_runs::Variant;
use super::verdict::{a_gap, NOT_IDENTIFIABLE, STRONG_EVIDENCE};
use super::Diagnosis;

/// Magnitudes of the coarse search: the effect's physical bound in this many equal steps.
const COARSE_POINTS: usize = 6;

/// What the labels no fold fits showed (`GapReport::unfitted_labels`).
#[derive(Debug, Clone, Serialize)]
pub struct UnfittedEvidence {
    /// The labels that carry the gap alone.
    pub labels: Vec<String>,
    /// The identifiable mechanical candidates fitted in sample on every ranked label, best
    /// first: their score against "none" (chi-square difference plus ln n) on all cells and
    /// beyond the slip level.
    pub in_sample: Vec<InSampleScore>,
    /// The best candidate's magnitude searched with full-order runs at `labels`: (magnitude,
    /// chi-square of their cells), in the order run; magnitude 0 is the baseline twin. Empty
    /// where no candidate had very strong evidence.
    pub search: Vec<[f64; 2]>,
    /// The magnitude that fits `labels` best and its 90 % interval (from the chi-square's
    /// curvature about it), where searched.
    pub magnitude: Option<f64>,
    pub interval90: Option<[f64; 2]>,
    /// The withheld labels' RMS z that its full-order runs on every ranked label leave.
    pub confirmed_gap_after: Option<f64>,
    /// The trained box's bounds the baseline calibration sits at (`calibrate::bound_parameters`)
    /// where the best candidate would have been named: a drive outside the trained range reads
    /// the same there, so it is not (docs/decisions/gap-unfitted-labels.md, "At the trained
    /// box's edge").
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub outside_trained_box: Vec<String>,
    /// Whether the verdict named it.
    pub named: bool,
}

/// One candidate's in-sample score (`UnfittedEvidence::in_sample`).
#[derive(Debug, Clone, Serialize)]
pub struct InSampleScore {
    pub effect: String,
    pub score: f64,
    pub score_beyond_slip_level: f64,
    /// Index of the mechanical variant.
    #[serde(skip)]
    pub variant: usize,
    /// The in-sample fit's slip offset, pp.
    #[serde(skip)]
    pub slip_offset_pct: f64,
}

/// The labels no fold fits: the unsettled labels among those the folds evaluate, in their
/// order (`RankContext::eval_labels`; under leave-one-label-out, every ranked label).
pub(super) fn no_fold_fits(r: &RankContext) -> Vec<usize> {
    r.eval_labels
        .iter()
        .copied()
        .filter(|&l| r.held_out[l])
        .collect()
}

/// Per-label z in `RankContext::eval_labels` order, split into the fitted labels' and those
/// of the labels no fold fits.
pub(super) fn fitted_and_unfitted(r: &RankContext, z: &[Vec<f64>]) -> [Vec<Vec<f64>>; 2] {
    let of = |unfitted: bool| -> Vec<Vec<f64>> {
        r.eval_labels
            .iter()
            .zip(z)
            .filter(|(l, _)| r.held_out[**l] == unfitted)
            .map(|(_, z)| z.clone())
            .collect()
    };
    [of(false), of(true)]
}

/// The labels that carry the gap alone where no fold fits them: leave-one-label-out
/// (`leave_one_out`), the unsettled labels in the ranking, when their withheld cells fail the
/// data-set test for a gap and the fitted labels' pass it. Empty otherwise.
pub(super) fn gap_labels(r: &RankContext, leave_one_out: bool) -> Vec<usize> {
    if !leave_one_out {
        return Vec::new();
    }
    let unfitted = no_fold_fits(r);
    let [z_fitted, z_unfitted] = fitted_and_unfitted(r, &r.z_before);
    if unfitted.is_empty() || a_gap(&z_fitted) || !a_gap(&z_unfitted) {
        return Vec::new();
    }
    unfitted
}

/// The identifiable mechanical candidates fitted in sample on the fitted labels and `labels`,
/// best first (`InSampleScore`).
pub(super) fn in_sample_scores(
    r: &RankContext,
    vars: &[Variant],
    labels: &[usize],
) -> Vec<InSampleScore> {
    let all: Vec<usize> = r.fitted.iter().chain(labels).copied().collect();
    let none = r.none();
    let f0 = none.fit(&all, false);
    let loss_of = |c: &LinearCandidate, f: &Fit| -> [f64; 2] {
        all.iter().fold([0.0, 0.0], |[a, b], &h| {
            let cells: f64 = c.z(h, f).iter().map(|&z| huber(z)).sum();
            [a + cells, b + r.level_free_loss(c, f, h)]
        })
    };
    let [none_all, none_free] = loss_of(&none, &f0);
    let mut scores: Vec<InSampleScore> = vars
        .iter()
        .enumerate()
        .filter(|(_, var)| !NOT_IDENTIFIABLE.contains(&var.effect))
        .map(|(v, var)| {
            let c = r.variant(v, var);
            let f = c.fit(&all, true);
            let [with_all, with_free] = loss_of(&c, &f);
            InSampleScore {
                effect: mechanical::name(var),
                score: with_all - none_all + r.ln_n,
                score_beyond_slip_level: with_free - none_free + r.ln_n,
                variant: v,
                slip_offset_pct: f.offset,
            }
        })
        .collect();
    scores.sort_by(|a, b| a.score.total_cmp(&b.score));
    scores
}

/// Whether an in-sample score is very strong evidence, on all cells and beyond the slip level
/// (the rule the out-of-sample ranking's first candidate meets to be named).
pub(super) fn very_strong(s: &InSampleScore) -> bool {
    s.score < STRONG_EVIDENCE && s.score_beyond_slip_level < STRONG_EVIDENCE
}

/// Variant `v`'s magnitude that fits `labels` best, searched with full-order runs over
/// [0, its physical bound]: a coarse grid, a finer one about its best, and the vertex of the
/// parabola through the least point and its neighbours; the least point run, with the
/// parabola's 90 % interval. The points run, the magnitude and its interval; `None` where a
/// run failed (recorded in `failed_runs`).
pub(super) fn search(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    v: usize,
    labels: &[usize],
    failed_runs: &mut Vec<FailedRun>,
) -> Option<(Vec<[f64; 2]>, f64, [f64; 2])> {
    let max = vars[v].max;
    let at = |ms: &[f64], failed_runs: &mut Vec<FailedRun>| -> Option<Vec<[f64; 2]>> {
        let rows: Result<Vec<[f64; 2]>, FailedRun> = ms
            .par_iter()
            .map(|&m| {
                let run = Run {
                    vars,
                    v,
                    m,
                    tension_n: None,
                    form_sd: 0.0,
                    reuse: false,
                };
                let mut chi2 = 0.0;
                for &l in labels {
                    let cells = run.cells(d, r, l).map_err(|e| FailedRun {
                        label: r.twins[l].label.clone(),
                        effect: vars[v].spec(m),
                        purpose: "magnitude search",
                        reason: e.to_string(),
                    })?;
                    chi2 += row_chi2(&residual_row(&cells));
                }
                Ok([m, chi2])
            })
            .collect();
        rows.map_err(|f| failed_runs.push(f)).ok()
    };
    let step = max / COARSE_POINTS as f64;
    let coarse: Vec<f64> = (1..=COARSE_POINTS).map(|k| step * k as f64).collect();
    let baseline: f64 = labels
        .iter()
        .map(|&l| {
            let cells = &r.base_cells[l];
            row_chi2(&residual_row(cells))
        })
        .sum();
    let mut points = vec![[0.0, baseline]];
    points.extend(at(&coarse, failed_runs)?);
    let best = least(&points)[0];
    // The fine search about the coarse search's best: a third and two thirds of a coarse step
    // on either side, within [0, max].
    let fine: Vec<f64> = [-2.0, -1.0, 1.0, 2.0]
        .iter()
        .map(|k| best + k * step / 3.0)
        .filter(|&m| m > 0.0 && m <= max)
        .collect();
    points.extend(at(&fine, failed_runs)?);
    // The parabola's vertex is run too: about a threshold the chi-square is steep and
    // lopsided, and the vertex of three points may miss its least point.
    let (m_vertex, _) = vertex(&points);
    let m_vertex = m_vertex.clamp(0.0, max);
    if points.iter().all(|p| (p[0] - m_vertex).abs() > 1e-9) {
        points.extend(at(&[m_vertex], failed_runs)?);
    }
    let m = least(&points)[0];
    let (_, sd) = vertex(&points);
    Some((
        points,
        m,
        [(m - Z90 * sd).max(0.0), (m + Z90 * sd).min(max)],
    ))
}

/// A named effect's magnitude searched at the labels no fold fits, where its runs at the
/// linearised fit's magnitude fell short (`GapReport::confirmation_magnitude`).
#[derive(Debug, Clone, Serialize)]
pub struct MagnitudeSearch {
    /// The labels searched at: drifting labels in the ranking.
    pub labels: Vec<String>,
    /// (magnitude, chi-square of their cells), in the order run; 0 is the baseline twin.
    pub search: Vec<[f64; 2]>,
    pub magnitude: f64,
    pub interval90: [f64; 2],
    /// The linearised fit's magnitude the runs fell short at.
    pub fitted: f64,
}

/// The confirmation `run` of a candidate whose runs at the linearised fit's magnitude fall
/// short, repeated at the magnitude that fits the labels no fold fits (`search`): the fit
/// sets a threshold effect's magnitude from the labels that do not cross its threshold, and
/// a label still drifting at its recordings' end, where the effect shows most, takes no part
/// in it (docs/decisions/gap-unfitted-labels.md, "A named effect's magnitude"). `None`
/// without such labels in the ranking, under `--holdout`, or where a run failed.
pub(super) fn over_magnitude(
    d: &Diagnosis,
    r: &RankContext,
    run: Run,
    line: &[usize],
    failed_runs: &mut Vec<FailedRun>,
) -> Option<(Confirmed, MagnitudeSearch)> {
    let labels = no_fold_fits(r);
    if labels.is_empty() || !d.opts.holdout.is_empty() {
        return None;
    }
    let (search, m, interval90) = search(d, r, run.vars, run.v, &labels, failed_runs)?;
    let again = Run {
        m,
        tension_n: None,
        reuse: false,
        ..run
    };
    let (Some(c), false) = confirm(d, r, again, line, failed_runs) else {
        return None;
    };
    Some((
        c,
        MagnitudeSearch {
            labels: labels.iter().map(|&l| d.labels[l].clone()).collect(),
            search,
            magnitude: m,
            interval90,
            fitted: run.m,
        },
    ))
}

/// The point of least chi-square.
fn least(points: &[[f64; 2]]) -> [f64; 2] {
    points
        .iter()
        .copied()
        .min_by(|a, b| a[1].total_cmp(&b[1]))
        .unwrap_or([0.0, f64::INFINITY])
}

/// The chi-square's minimum over the magnitude and its sd: the vertex of the parabola through
/// the least point and its neighbours (its two inner ones at the grid's edge; Press et al.,
/// Numerical Recipes, 3rd ed., 2007, eq. 10.3.1), kept within those three points, and the sd
/// where the parabola rises by 1 (a chi-square's 1-sigma contour, ibid. sec. 15.6.5). Where
/// the three points do not curve upwards, or there are fewer than three, the least point and
/// the distance to its nearest neighbour.
pub(super) fn vertex(points: &[[f64; 2]]) -> (f64, f64) {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let k = (0..p.len())
        .min_by(|&a, &b| p[a][1].total_cmp(&p[b][1]))
        .unwrap_or(0);
    let nearest = {
        let l = if k > 0 {
            p[k][0] - p[k - 1][0]
        } else {
            f64::INFINITY
        };
        let u = p.get(k + 1).map_or(f64::INFINITY, |q| q[0] - p[k][0]);
        l.min(u)
    };
    if p.len() < 3 {
        return (p.get(k).map_or(0.0, |q| q[0]), nearest);
    }
    let mid = k.clamp(1, p.len() - 2);
    let ([a, fa], [b, fb], [c, fc]) = (p[mid - 1], p[mid], p[mid + 1]);
    // f(x) = fb + s1 (x - b) + curv (x - b)^2 through the three points.
    let s_ab = (fb - fa) / (b - a);
    let s_bc = (fc - fb) / (c - b);
    let curv = (s_bc - s_ab) / (c - a);
    if curv <= 0.0 || !curv.is_finite() {
        return (p[k][0], nearest);
    }
    let s1 = s_ab + curv * (b - a);
    let x = (b - s1 / (2.0 * curv)).clamp(a, c);
    (x, curv.recip().sqrt())
}

#[cfg(test)]
mod tests {
    use super::super::baseline::tests::label_twin_of;
    use super::super::baseline::LabelTwin;
    use super::super::features::{cell_index, Band, Cell, Signal, Statistic, Window, CELLS};
    use super::super::ranking::tests::features;
    use super::super::twin_runs::variants;
    use super::*;

    #[test]
    fn a_parabolas_vertex_and_its_one_sigma_width_are_read_from_three_points() {
        // chi2 = 40 + 400 (m - 0.57)^2: vertex 0.57, sd 1 / sqrt(400) = 0.05.
        let f = |m: f64| 40.0 + 400.0 * (m - 0.57f64).powi(2);
        // The least point inside the grid, and at its edge (0.6: the vertex lies between it
        // and its inner neighbour).
        for grid in [
            vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.55, 0.6, 0.65],
            vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
        ] {
            let points: Vec<[f64; 2]> = grid.iter().map(|&m| [m, f(m)]).collect();
            let (m, sd) = vertex(&points);
            assert!((m - 0.57).abs() < 1e-9, "{m}");
            assert!((sd - 0.05).abs() < 1e-9, "{sd}");
        }
        // A minimum beyond the grid: its edge, with the parabola's width.
        let edge: Vec<[f64; 2]> = [0.0, 0.1, 0.2].iter().map(|&m| [m, f(m)]).collect();
        let (m, sd) = vertex(&edge);
        assert_eq!(m, 0.2);
        assert!((sd - 0.05).abs() < 1e-9, "{sd}");
        // A chi-square that does not curve upwards: the least point and its spacing.
        let (m, sd) = vertex(&[[0.0, 5.0], [0.1, 4.5], [0.2, 2.0]]);
        assert_eq!(m, 0.2);
        assert!((sd - 0.1).abs() < 1e-12, "{sd}");
    }

    /// Four labels d0-d3 whose last is unsettled (never fitted). Variant `v` moves the slip's
    /// level and the speeds at d3 only (as a Stribeck friction drop tips the loosest label into
    /// gross slip); the bearing drag moves every label's slip level a little. The measurement
    /// is the twin plus `shift` times the variant's answer at d3.
    fn four_labels(shift: f64) -> (Vec<LabelTwin>, Vec<Variant>, usize, usize) {
        let vars = variants(8);
        let v = vars
            .iter()
            .position(|x| x.effect == "stribeck-friction")
            .expect("Stribeck friction");
        let drag = vars
            .iter()
            .position(|x| x.effect == "bearing-drag")
            .expect("bearing drag");
        let slip_cells: Vec<usize> = [Statistic::Mean, Statistic::P50]
            .iter()
            .map(|&s| cell_index(Cell::new(Window::Steady, Signal::Slip, s, Band::Level)))
            .collect();
        let driver = cell_index(Cell::new(
            Window::Steady,
            Signal::DriverSpeed,
            Statistic::Mean,
            Band::Level,
        ));
        let base = vec![1.0; CELLS.len()];
        let with = |cells: &[usize], by: f64| {
            let mut c = base.clone();
            for &i in cells {
                c[i] += by;
            }
            c
        };
        let answer = |l: usize| if l == 3 { 2.0 } else { 0.0 };
        let mut stribeck_cells = slip_cells.clone();
        stribeck_cells.push(driver);
        let twins = (0..4)
            .map(|l| {
                let mut measured = features(&with(&stribeck_cells, shift * answer(l)));
                measured.unsettled = l == 3;
                let mut lt = label_twin_of(measured, false);
                lt.label = format!("d{l}");
                lt.baseline = features(&base);
                lt.variant = (0..vars.len())
                    .map(|k| {
                        if k == v {
                            Some(features(&with(&stribeck_cells, answer(l))))
                        } else if k == drag {
                            Some(features(&with(&slip_cells, 0.5)))
                        } else {
                            None
                        }
                    })
                    .collect();
                lt
            })
            .collect();
        (twins, vars, v, drag)
    }

    #[test]
    fn an_effect_only_an_unsettled_label_shows_is_credited_in_sample_only() {
        let (twins, vars, v, drag) = four_labels(1.0);
        let labels: Vec<String> = (0..4).map(|l| format!("d{l}")).collect();
        let r = RankContext::new(&twins, &labels, &[]);
        assert_eq!(r.fitted, vec![0, 1, 2]);
        assert_eq!(gap_labels(&r, true), vec![3]);
        // With a holdout the folds are the user's: no such evidence is looked for.
        assert!(gap_labels(&r, false).is_empty());
        // Out of sample no fold fits d3, so the effect cannot earn its score there.
        let oos = mechanical::score(&r, &vars);
        let stribeck = oos.iter().find(|s| s.0.variant == Some(v)).expect("ranked");
        assert!(stribeck.0.score > STRONG_EVIDENCE, "{}", stribeck.0.score);
        // In sample it is first with very strong evidence beyond the slip level too; the
        // drag, which would move every label, is not.
        let scores = in_sample_scores(&r, &vars, &[3]);
        assert_eq!(scores[0].variant, v, "{:?}", scores[0]);
        assert!(very_strong(&scores[0]), "{:?}", scores[0]);
        let d = scores.iter().find(|s| s.variant == drag).expect("drag");
        assert!(!very_strong(d), "{d:?}");
        // A measurement the twin reproduces at d3 carries no such gap.
        let (twins, ..) = four_labels(0.0);
        let r = RankContext::new(&twins, &labels, &[]);
        assert!(gap_labels(&r, true).is_empty());
    }
}
