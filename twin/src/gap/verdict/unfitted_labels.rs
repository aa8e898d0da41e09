//! The verdict where the gap lies in drifting labels alone, which no fold fits
//! (`crate::gap::unfitted`): the in-sample candidate, its magnitude search and its runs on
//! every label, and the decision and ranking that name it.

use super::super::candidates::Scored;
use super::super::confirmation::{confirm, Run};
use super::super::features;
use super::super::ranking::RankContext;
use super::super::report::{FailedRun, GapSummary, Param, Ranked};
use super::super::twin_runs::Variant;
use super::super::unfitted::{self, UnfittedEvidence};
use super::super::Diagnosis;
use super::{a_gap, reduction_of, summarise, Decision, EXPLAINED_SHARE};

/// The labels no fold fits, where the verdict on the ranking is "unexplained" and the gap lies
/// in them alone (`unfitted::gap_labels`): the identifiable candidates fitted in sample, the
/// best one with very strong evidence searched with full-order runs at those labels and run
/// at that magnitude on every ranked label. It is named where those runs remove at least half
/// of the withheld gap's excess over noise (or leave it within noise), leave both the fitted
/// labels and those labels passing the data-set test, and the baseline calibration lies
/// inside the trained box; it then leads the ranking with its in-sample score
/// (docs/decisions/gap-unfitted-labels.md). The ranking and decision as
/// they were otherwise.
pub(super) fn unfitted_decision(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    mut ranking: Vec<Scored>,
    dec: Decision,
    before: &GapSummary,
    failed_runs: &mut Vec<FailedRun>,
) -> (Vec<Scored>, Decision, Option<UnfittedEvidence>) {
    if dec.top != "unexplained" {
        return (ranking, dec, None);
    }
    let labels = unfitted::gap_labels(r, d.opts.holdout.is_empty());
    if labels.is_empty() {
        return (ranking, dec, None);
    }
    let scores = unfitted::in_sample_scores(r, vars, &labels);
    let mut ev = UnfittedEvidence {
        labels: labels.iter().map(|&l| d.labels[l].clone()).collect(),
        in_sample: scores.clone(),
        search: Vec::new(),
        magnitude: None,
        interval90: None,
        confirmed_gap_after: None,
        outside_trained_box: Vec::new(),
        named: false,
    };
    let Some(best) = scores.first().filter(|s| unfitted::very_strong(s)) else {
        return (ranking, dec, Some(ev));
    };
    let v = best.variant;
    let Some((points, m, interval)) = unfitted::search(d, r, vars, v, &labels, failed_runs) else {
        return (ranking, dec, Some(ev));
    };
    (ev.search, ev.magnitude, ev.interval90) = (points, Some(m), Some(interval));
    let run = Run {
        vars,
        v,
        m,
        tension_n: None,
        form_sd: 0.0,
        reuse: false,
    };
    let (Some(c), false) = confirm(d, r, run, &[], failed_runs) else {
        return (ranking, dec, Some(ev));
    };
    ev.confirmed_gap_after = Some(c.rms_z[0]);
    let z: Vec<Vec<f64>> = c
        .z_cells
        .iter()
        .map(|cells| cells.iter().map(|&(_, z)| z).collect())
        .collect();
    let explains = reduction_of(before.rms_z, c.rms_z[0]) >= EXPLAINED_SHARE || c.rms_z[0] <= 1.0;
    // The evidence is the labels' own, fitted in sample: the runs must reproduce them too, not
    // only shrink their gap.
    let [z_fitted, z_unfitted] = unfitted::fitted_and_unfitted(r, &z);
    if !explains || a_gap(&z_fitted) || a_gap(&z_unfitted) {
        return (ranking, dec, Some(ev));
    }
    // A calibration at the trained box's edge says no healthy twin in the trained range
    // reproduces every label: a drive beyond it (a belt looser than stated) slides at the
    // labels no fold fits as the effect does, and the twin cannot run it to compare.
    ev.outside_trained_box = crate::calibrate::bound_parameters(&d.cal.misfit)
        .into_iter()
        .map(String::from)
        .collect();
    if !ev.outside_trained_box.is_empty() {
        return (ranking, dec, Some(ev));
    }
    ev.named = true;
    let var = &vars[v];
    let entry = Ranked {
        effect: best.effect.clone(),
        score: best.score,
        params: vec![Param {
            name: var.parameter.to_string(),
            value: m,
            interval90: interval,
        }],
        gap_after: c.rms_z[0],
        slip_offset_pct: best.slip_offset_pct,
        signature: runs_signature(r, &c.z_cells, &labels),
        score_beyond_slip_level: best.score_beyond_slip_level,
        line_only: r.line_only.get(v).copied().unwrap_or(false),
        variant: Some(v),
    };
    ranking.retain(|s| s.0.variant != Some(v));
    ranking.insert(0, (entry, z.clone()));
    let dec = Decision {
        best_after: summarise(&z, r.eval_names.clone(), r.threshold),
        best_explains: true,
        beyond_level: true,
        identifiable: true,
        confirmed: Some(c.rms_z[0]),
        confirmed_tension_n: None,
        confirmed_magnitude: None,
        magnitude_at_tension: None,
        by_line: None,
        confirmation_failed: false,
        confirmed_rows: Some(c.rows),
        chosen: true,
        chosen_variant: Some(v),
        partial: None,
        top: best.effect.clone(),
        level_only: false,
        gave_way: false,
        ..dec
    };
    (ranking, dec, Some(ev))
}

/// The three cells of `labels` whose withheld |z| the confirmation runs (`z_cells`, per
/// evaluated label) lower most from the baseline's: the signature the runs show.
fn runs_signature(r: &RankContext, z_cells: &[Vec<(usize, f64)>], labels: &[usize]) -> Vec<String> {
    let before = r.oos_z_cells(&r.none(), false);
    let mut gain = vec![0.0; features::CELLS.len()];
    for (k, l) in r.eval_labels.iter().enumerate() {
        if !labels.contains(l) {
            continue;
        }
        for (&(i, zb), &(j, za)) in before[k].iter().zip(&z_cells[k]) {
            if i == j {
                gain[i] += zb.abs() - za.abs();
            }
        }
    }
    let mut order: Vec<usize> = (0..gain.len()).filter(|&i| gain[i] > 0.0).collect();
    order.sort_by(|&a, &b| gain[b].total_cmp(&gain[a]));
    order
        .into_iter()
        .take(3)
        .map(|i| features::CELLS[i].name())
        .collect()
}
