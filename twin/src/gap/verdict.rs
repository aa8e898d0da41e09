//! Stage "verdict" and "how far": whether the best candidate is named (very strong evidence,
//! beyond the slip level too, identifiable, removing at least half of the withheld gap in its
//! fit and in its confirmation runs), "none" or "unexplained"; the withheld labels' RMS z
//! before and after with bootstrap intervals over labels; the verdict's text; the report.

use fom::stats::{chi2_quantile, rms, Z90};
use rand::Rng;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rom::snapshots::quantile_function;

use super::candidates::linear::Joint;
use super::candidates::selection::forward_select;
use super::candidates::{fit_bound, mechanical, tachometer, Scored};
use super::cells::{fit_cell, tension_term, where_cells};
use super::confirmation::{magnitude_at_tension, MagnitudeAtTension, Run};
use super::features;
use super::ranking::{chi2, RankContext};
use super::report::{
    BaselineSummary, FailedRun, GapReport, GapSummary, KneeLabel, LabelPlot, NamedEffect, Param,
    PartialEffect, SignatureLine,
};
use super::signature_line::{confirmed_by, line_rule, on_a_harmonic};
use super::twin_runs::Variant;
use super::unfitted::MagnitudeSearch;
use super::Diagnosis;
use crate::error::Result;

mod confirmation_runs;
mod text;
mod unfitted_labels;
use confirmation_runs::confirmation_runs;
use text::{unfitted_note, verdict_notes, verdict_text};
use unfitted_labels::unfitted_decision;

/// Score below which a candidate beats "none": a Schwarz-criterion difference of 10, "very
/// strong" evidence on the scale of Kass & Raftery (1995, J. Am. Stat. Assoc. 90, 773), section
/// 3.2 (there on 2 ln B, which the chi-square difference plus k ln n approximates).
pub(super) const STRONG_EVIDENCE: f64 = -10.0;

/// Probability level of the data-set test for a gap (chi-square of the withheld cells).
const GAP_LEVEL: f64 = 0.999;

/// Share of the withheld gap's excess over noise (RMS z above 1) that a candidate must remove
/// to be named as the gap's cause: more than it leaves (a named effect shrinks the withheld gap's
/// excess by at least half).
pub(super) const EXPLAINED_SHARE: f64 = 0.5;

/// Catalogue effects that are ranked but never named. Belt hysteresis's relaxed stiffness
/// (1 - g) EA raises creep slip by about 0.69 g / (1 - g) pp at every label, which the
/// calibration's slip offset takes as it takes a belt whose creep differs from the twin's.
/// From a recording at standstill what is left, a start-up slip below the twin's, tells it
/// from a softer belt of the twin's own form, but another simulator's healthy run-up shows it
/// too, so it would make hysteresis a candidate there as well
/// (docs/decisions/belt-hysteresis-measurement.md, "A start-up from standstill"). Measured in
/// the confusion matrix (`studies/gap-confusion/gap_confusion.csv` and its second noise
/// realisation): it was named at one of five magnitudes, a different one in each realisation,
/// and on another simulator's healthy belt with a retrained surrogate. Ranked first within the
/// strong-evidence margin of a runner-up that may be named, it gives way to it (`gives_way`).
pub const NOT_IDENTIFIABLE: [&str; 1] = ["belt-hysteresis"];

/// What the verdict rules decided about the best candidate.
struct Decision {
    /// The withheld labels' gap with the best candidate (linearised).
    best_after: GapSummary,
    best_explains: bool,
    beyond_level: bool,
    identifiable: bool,
    /// The confirmation runs' RMS z, and whether one of them failed.
    confirmed: Option<f64>,
    /// The installation tension the confirmation runs were made at where the tension search
    /// moved it, N.
    confirmed_tension_n: Option<f64>,
    /// The magnitude the confirmation runs were made at where the search at the labels no
    /// fold fits moved it from the linearised fit's (`unfitted::over_magnitude`).
    confirmed_magnitude: Option<MagnitudeSearch>,
    /// The magnitude the runs at a re-fitted tension ask for in the named effect's own line
    /// (`confirmation::magnitude_at_tension`); `None` where nothing is named.
    magnitude_at_tension: Option<MagnitudeAtTension>,
    /// The best candidate named by its own line (`line_rule`), not by the whole gap.
    by_line: Option<SignatureLine>,
    confirmation_failed: bool,
    /// Per label, per cell: what the confirmation runs leave (measured - the run with the
    /// effect, sd, usable).
    confirmed_rows: Option<Vec<Vec<(f64, f64, bool)>>>,
    chosen: bool,
    chosen_variant: Option<usize>,
    /// A strong candidate that is not named: (effect, share of the excess it removes, whether
    /// its confirmation runs are what fell short).
    partial: Option<(String, f64, bool)>,
    knee_labels: Vec<KneeLabel>,
    knee_gap: bool,
    top: String,
    /// "none" on withheld cells above noise (RMS z above 1) where the omnibus test finds no
    /// gap and the only very strong evidence lies in the slip level (`GapEvidence`).
    level_only: bool,
    /// Whether a never-named candidate ranked first gave way to the named one (`gives_way`);
    /// it is then second in the ranking.
    gave_way: bool,
}

/// The data-set test for a gap on cells' z (per label): their chi-square above its
/// `GAP_LEVEL` quantile under noise alone.
pub(super) fn a_gap(z: &[Vec<f64>]) -> bool {
    chi2(z) > chi2_quantile(GAP_LEVEL, z.iter().map(Vec::len).sum())
}

/// Share of the withheld gap's excess over noise removed when the RMS z goes from `before`
/// to `after`.
pub(super) fn reduction_of(before: f64, after: f64) -> f64 {
    (before - after) / (before - 1.0).max(1e-9)
}

/// The verdict on the ranked candidates, and the report.
pub(super) fn report(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    ranking: Vec<Scored>,
    mut failed_runs: Vec<FailedRun>,
) -> Result<GapReport> {
    let before = summarise(&r.z_before, r.eval_names.clone(), r.threshold);
    let where_cells = where_cells(r.twins, &r.base_cells, r.threshold);
    let (ranking, dec) = decide_in_order(d, r, vars, ranking, &before, &mut failed_runs);
    let (ranking, dec, unfitted) =
        unfitted_decision(d, r, vars, ranking, dec, &before, &mut failed_runs);
    // The variants on the first effect's harmonics, kept out of the selection.
    let on_harmonic = dec.chosen_variant.map_or(Vec::new(), |v0| {
        on_a_harmonic(vars, v0, d.ratio, d.ctx.blades)
    });
    let (named, z_named, held_back) = named_effects(r, vars, &ranking, &dec, &on_harmonic);
    let after = match (&z_named, dec.chosen) {
        (Some(z), _) => summarise(z, r.eval_names.clone(), r.threshold),
        (None, true) => dec.best_after.clone(),
        (None, false) => before.clone(),
    };
    let za = match (&z_named, dec.chosen) {
        (Some(z), _) => z,
        (None, true) => &ranking[0].1,
        (None, false) => &r.z_before,
    };
    let reduction_interval = reduction_interval(&r.z_before, za);
    // Capped at 100 %: an after-gap below the noise level removed all of the excess.
    let reduction = if dec.chosen {
        reduction_of(before.rms_z, after.rms_z).min(1.0)
    } else {
        0.0
    };
    // The named effect must also beat the runner-up by the strong-evidence margin to be told
    // apart from it (the same scale as against "none").
    let close_second = match unfitted.as_ref().filter(|e| e.named) {
        // Named in sample: told apart from the other candidates on the same footing.
        Some(e) => e
            .in_sample
            .get(1)
            .filter(|x| x.score - e.in_sample[0].score < -STRONG_EVIDENCE)
            .map(|x| x.effect.clone()),
        None => ranking
            .get(1)
            .filter(|x| dec.chosen && x.0.score - ranking[0].0.score < -STRONG_EVIDENCE)
            .map(|x| x.0.effect.clone()),
    };
    let confirmed_reduction = dec
        .confirmed
        .map(|c| reduction_of(before.rms_z, c).clamp(0.0, 1.0));
    let absorbed = r.absorbed(&d.labels);
    let mut verdict = verdict_text(
        &dec.top,
        dec.level_only,
        &named,
        &ranking,
        &before,
        &after,
        &where_cells,
    );
    if dec.by_line.is_some() {
        // Named by its line, not by explaining the whole gap (the note below says how much).
        verdict = verdict
            .replacen(
                " explains the gap: withheld",
                " is named by its own line: whole withheld",
                1,
            )
            .replacen(
                " explain the gap: withheld",
                " are named, the first by its own line: whole withheld",
                1,
            );
    }
    verdict += &verdict_notes(&dec, &ranking, &failed_runs, close_second.as_deref());
    if let Some(e) = &unfitted {
        verdict += &unfitted_note(e);
    }
    verdict += &at_bound_note(d);
    verdict += &text::tension_reading_note(&d.cal.misfit);
    if let (Some(v0), false) = (dec.chosen_variant, held_back.is_empty()) {
        verdict += &format!(
            "; not added beside it: {}, whose line is a harmonic of {}'s at this drive's speed \
             ratio {:.2}: what the first effect's runs leave on that line can be the harmonic, \
             which the speed amplitudes cannot tell from a second effect",
            held_back
                .iter()
                .map(|&v| mechanical::name(&vars[v]))
                .collect::<Vec<_>>()
                .join(", "),
            mechanical::name(&vars[v0]),
            d.ratio
        );
    }
    if let Some(a) = absorbed.as_ref().filter(|a| a.model_form_difference) {
        verdict += &format!(
            "; absorbed: a model-form difference in the slip level across labels ({}), which \
             the twin's creep curve does not have and the calibration's offset alone cannot take",
            a.slip_level_pp
                .iter()
                .map(|(l, v)| format!("{l} {v:+.3} pp"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let plots = plots(r, vars, &ranking, dec.chosen_variant);
    Ok(GapReport {
        top_effect: dec.top,
        named,
        absorbed,
        not_told_apart_from: close_second,
        partial_effect: dec.partial.map(|(effect, share, by_runs)| PartialEffect {
            effect,
            reduction: share,
            by_runs,
        }),
        named_by_line: dec.by_line,
        verdict,
        ranking: ranking.into_iter().map(|x| x.0).collect(),
        gap_before: before,
        gap_after: after,
        reduction,
        reduction_interval90: reduction_interval,
        confirmed_gap_after: dec.confirmed,
        confirmation_tension_n: dec.confirmed_tension_n,
        confirmation_magnitude: dec.confirmed_magnitude.clone(),
        magnitude_at_confirmation_tension: dec.magnitude_at_tension.clone(),
        confirmed_reduction,
        where_cells,
        calibration: baseline_summary(d, r),
        blades: d.ctx.blades,
        z_threshold: r.threshold,
        unusable: d.unusable.clone(),
        unsettled_labels: d.unsettled.clone(),
        failed_runs,
        second_pass: Vec::new(),
        elapsed_s: d.started.elapsed().as_secs_f64(),
        knee_labels: dec.knee_labels,
        unfitted_labels: unfitted,
        load_levels: None,
        sensor: d.sensor.clone().with_correlated_noise(r.twins),
        plots,
    })
}

/// The verdict's note where the baseline calibration sits at a bound of the trained box (empty
/// otherwise).
fn at_bound_note(d: &Diagnosis) -> String {
    let at_bound = crate::calibrate::bound_parameters(&d.cal.misfit);
    if at_bound.is_empty() {
        return String::new();
    }
    format!(
        "; the baseline calibration sits at the trained box's edge ({}; its misfit is listed \
         under it): no healthy twin in the trained range reproduces every label, so part of \
         the gap lies in the baseline itself (an effect that makes the belt slide at the \
         loosest labels, or a drive outside the trained range)",
        at_bound.join(", ")
    )
}

/// Every named effect: the one the verdict rules named, then those the forward selection adds
/// over the identifiable mechanical variants (`candidates::selection`; not after the
/// tachometer, whose grid has no columns to join), and the withheld labels' z after the last
/// step, or after the first effect's confirmation runs where none was added (`None` without
/// runs: the tachometer). The selection starts from what the first effect's confirmation
/// runs leave (the twin run with it at its fitted magnitude), not from its linearisation, so
/// that a response the linearisation misses is not taken for a second effect: an eccentric
/// pulley's second harmonic grows with the square of its runout and, at a 2:1 speed ratio,
/// lands on the other pulley's 1x line. The effects added are fitted jointly on those
/// residuals; the first keeps its fitted, confirmed magnitude
/// (docs/decisions/gap-forward-selection.md). Variants `on_harmonic` are kept out of the
/// selection; the third value is those of them it would have added.
fn named_effects(
    r: &RankContext,
    vars: &[Variant],
    ranking: &[Scored],
    dec: &Decision,
    on_harmonic: &[usize],
) -> (Vec<NamedEffect>, Option<Vec<Vec<f64>>>, Vec<usize>) {
    if !dec.chosen {
        return (Vec::new(), None, Vec::new());
    }
    let best = &ranking[0].0;
    // Run at the searched magnitude, the effect is named at it; run at a re-fitted tension,
    // at the magnitude those runs ask for.
    let at = |value, interval90| {
        vec![Param {
            value,
            interval90,
            ..best.params[0].clone()
        }]
    };
    let params = match (&dec.confirmed_magnitude, &dec.magnitude_at_tension) {
        (Some(s), _) => at(s.magnitude, s.interval90),
        (None, Some(a)) => at(a.magnitude, a.interval90),
        (None, None) => best.params.clone(),
    };
    let first = NamedEffect {
        effect: best.effect.clone(),
        params,
        gap_after: best.gap_after,
        score_gain: -best.score,
    };
    let (Some(v0), Some(rows)) = (dec.chosen_variant, dec.confirmed_rows.as_ref()) else {
        return (vec![first], None, Vec::new());
    };
    let joint = Joint {
        rows: rows.clone(),
        ..r.joint(vars)
    };
    let identifiable: Vec<bool> = vars
        .iter()
        .enumerate()
        .map(|(v, var)| v != v0 && !NOT_IDENTIFIABLE.contains(&var.effect))
        .collect();
    // Those on the first effect's harmonics that the selection would add are reported.
    let held_back: Vec<usize> = if on_harmonic.is_empty() {
        Vec::new()
    } else {
        forward_select(&joint, &[], &identifiable, &r.folds_view())
            .steps
            .iter()
            .map(|s| s.effect)
            .filter(|v| on_harmonic.contains(v))
            .collect()
    };
    let allowed: Vec<bool> = (0..vars.len())
        .map(|v| identifiable[v] && !on_harmonic.contains(&v))
        .collect();
    let selection = forward_select(&joint, &[], &allowed, &r.folds_view());
    let steps = &selection.steps;
    // The first effect's figure is the withheld gap its runs leave, not its linearised fit's,
    // and the steps after it are measured from there (docs/decisions/gap-forward-selection.md,
    // "Consequences").
    let mut first = first;
    first.gap_after = rms(&selection.start_z.concat());
    let Some(last) = steps.last() else {
        return (vec![first], Some(selection.start_z), held_back);
    };
    let set: Vec<usize> = steps.iter().map(|s| s.effect).collect();
    let f = joint.fit(&r.fitted, &set);
    let mut named = vec![first];
    for (k, s) in steps.iter().enumerate() {
        let var = &vars[s.effect];
        named.push(NamedEffect {
            effect: mechanical::name(var),
            params: vec![Param {
                name: var.parameter.to_string(),
                value: f.m[k],
                interval90: [
                    (f.m[k] - Z90 * f.sd[k]).max(0.0),
                    (f.m[k] + Z90 * f.sd[k]).min(fit_bound(var.max)),
                ],
            }],
            gap_after: rms(&s.z.concat()),
            score_gain: s.gain,
        });
    }
    (named, Some(last.z.clone()), held_back)
}

/// The verdict rules. Without a named effect, a gap is there when the withheld cells'
/// chi-square exceeds its 99.9 % quantile under noise alone (single cells beyond the threshold
/// are still marked in the where-table). An effect with very strong evidence is a gap even
/// when the omnibus test, diluted over all cells, misses it (its signature lives in a few
/// cells), but only where the withheld cells are not within noise as a whole (RMS z above 1):
/// below it there is nothing to explain. It is named only when it explains the gap: it removes
/// at least half of the withheld gap's excess over noise, or what it leaves is within noise. A
/// candidate that only nibbles at a gap (a model-form difference, such as a looseness knee of
/// another shape, moves the slip levels that several effects also move) is reported as part of
/// an unexplained gap, never as its cause.
fn decide(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    ranking: &[Scored],
    before: &GapSummary,
    failed_runs: &mut Vec<FailedRun>,
) -> Decision {
    let significant_before = a_gap(&r.z_before);
    // A gap to explain: the omnibus test, or withheld cells off by more than noise on average
    // (RMS z above 1, the noise level). Within noise nothing is named, however strong a
    // candidate's evidence (a sensor model fitting one cell's scatter on the twin's own data).
    let gap_there = significant_before || before.rms_z > 1.0;
    let best = &ranking[0];
    let strong = best.0.score < STRONG_EVIDENCE;
    let best_after = summarise(&best.1, r.eval_names.clone(), r.threshold);
    let best_explains =
        reduction_of(before.rms_z, best_after.rms_z) >= EXPLAINED_SHARE || !a_gap(&best.1);
    // Strong beyond the slip level too (see `RankContext::level_free_loss`).
    let beyond_level = best.0.score_beyond_slip_level < STRONG_EVIDENCE;
    // The sensor first (docs/decisions/sensor-first.md): a tachometer model is named only where
    // the sensor stage read a sensor's structure in the recordings. Fitted to the readings'
    // shape alone (their kurtosis, their scatter), it is what any sensor noise that is not
    // white gives too.
    let identifiable = !NOT_IDENTIFIABLE.contains(&best.0.effect.as_str())
        && !tachometer::shape_alone(&best.0.effect, d.sensor.read_structure());
    let qualified = strong && beyond_level && identifiable;
    // Named by its own line where the whole gap is not explained (model-form tolerance): by
    // the fit, or by the confirmation runs where the fit promised it
    // (docs/decisions/gap-signature-line.md).
    let own_line = best
        .0
        .variant
        .filter(|_| qualified)
        .and_then(|v| line_rule(r, vars, v));
    let fit_by_line = !best_explains && own_line.is_some();
    let candidate = qualified && gap_there && (best_explains || fit_by_line);
    let line_cells = own_line.as_ref().map_or(Vec::new(), |l| l.0.clone());
    // Whether confirmation runs leaving `c` (RMS z over all cells, over the line's) explain
    // the gap, or the effect's own line as its fit does.
    let explains_line = |c: [f64; 2]| {
        own_line.as_ref().is_some_and(|(_, line_before, _)| {
            reduction_of(*line_before, c[1]) >= EXPLAINED_SHARE || c[1] <= 1.0
        })
    };
    let explains_whole =
        |c: [f64; 2]| reduction_of(before.rms_z, c[0]) >= EXPLAINED_SHARE || c[0] <= 1.0;
    // What the fit promised: the line where it is named by its line, else the whole gap.
    let explains_promised = |c: [f64; 2]| match fit_by_line {
        true => explains_line(c),
        false => explains_whole(c),
    };
    let (confirmation, confirmation_failed, searched, magnitude_at_tension) =
        match best.0.variant.filter(|_| candidate) {
            Some(v) => {
                let run = Run {
                    vars,
                    v,
                    m: best.0.params[0].value,
                    tension_n: None,
                    form_sd: r.form_sd(v),
                    reuse: true,
                };
                let (c, failed, searched) =
                    confirmation_runs(d, r, run, &line_cells, explains_promised, failed_runs);
                let at_tension = c
                    .as_ref()
                    .and_then(|c| magnitude_at_tension(r, &run, c, &d.labels));
                (c, failed, searched, at_tension)
            }
            None => (None, false, None, None),
        };
    let confirmed_both = confirmation.as_ref().map(|c| c.rms_z);
    let confirmed = confirmed_both.map(|c| c[0]);
    // A candidate whose confirmation runs failed is not confirmed (the failure is reported).
    // Runs that fall short of the whole gap the fit promised may still explain the effect's
    // own line: then it is named by that line.
    // The runs' word, where there are runs: explained (by the line or not) or not explained.
    let by_runs =
        confirmed_both.map(|c| confirmed_by(fit_by_line, explains_whole(c), explains_line(c)));
    let confirmed_explains = !confirmation_failed && by_runs.is_none_or(|b| b.is_some());
    let chosen = candidate && confirmed_explains;
    // By its line: where the fit, or the runs, explain the line and not the whole gap.
    let named_by_line = by_runs.map_or(fit_by_line, |b| b == Some(true));
    let whole_after = match (fit_by_line, confirmed) {
        (false, Some(c)) => c,
        _ => best_after.rms_z,
    };
    let by_line = own_line.filter(|_| chosen && named_by_line).map(|line| {
        signature_line(
            line,
            confirmed_both,
            [before.rms_z, whole_after],
            fit_by_line,
        )
    });
    let partial = (strong && gap_there && !chosen && !confirmation_failed).then(|| {
        let (after, by_runs) = match confirmed {
            Some(c) if !confirmed_explains => (c, true),
            _ => (best_after.rms_z, false),
        };
        (
            best.0.effect.clone(),
            reduction_of(before.rms_z, after).clamp(0.0, 1.0),
            by_runs,
        )
    });
    let (knee_labels, knee_gap) = knee_labels(d, r);
    let evidence = strong_gap(
        ranking.iter().map(|s| {
            (
                s.0.effect.as_str(),
                [s.0.score, s.0.score_beyond_slip_level],
            )
        }),
        d.sensor.read_structure(),
    );
    let top = if chosen {
        best.0.effect.clone()
    } else if !knee_gap && (!gap_there || (!significant_before && evidence != GapEvidence::Strong))
    {
        "none".to_string()
    } else {
        "unexplained".to_string()
    };
    // "none" on a gap above noise whose only strong evidence lies in the slip level.
    let level_only = top == "none" && gap_there && evidence == GapEvidence::SlipLevelOnly;
    Decision {
        best_after,
        best_explains,
        beyond_level,
        identifiable,
        confirmed,
        confirmed_tension_n: confirmation.as_ref().and_then(|c| c.tension_n),
        confirmed_magnitude: searched,
        magnitude_at_tension: magnitude_at_tension.filter(|_| chosen),
        by_line,
        confirmation_failed,
        confirmed_rows: confirmation.map(|c| c.rows),
        chosen,
        chosen_variant: best.0.variant.filter(|_| chosen),
        partial,
        knee_labels,
        knee_gap,
        top,
        level_only,
        gave_way: false,
    }
}

/// The report of an effect named by its own line: the line's cells and withheld RMS z before
/// and after (`line`), in the confirmation runs (`confirmed`: all cells, the line's), and the
/// whole gap's RMS z before and after it (in the runs where they, not the fit, named it).
fn signature_line(
    (cells, before, after): (Vec<usize>, f64, f64),
    confirmed: Option<[f64; 2]>,
    [whole_before, whole_after]: [f64; 2],
    fit_by_line: bool,
) -> SignatureLine {
    SignatureLine {
        cells: cells.iter().map(|&i| features::CELLS[i].name()).collect(),
        rms_z_before: before,
        rms_z_after: after,
        confirmed_rms_z_after: confirmed.map(|c| c[1]),
        whole_gap_reduction: reduction_of(whole_before, whole_after).clamp(0.0, 1.0),
        whole_gap_by_runs: !fit_by_line,
        whole_gap_grows: whole_after > whole_before,
    }
}

/// Whether the first candidate, never named (`NOT_IDENTIFIABLE`), gives way to the runner-up
/// in the verdict: the runner-up may be named and the two scores are less than the
/// strong-evidence margin apart, so the data do not tell them apart (as a named effect's close
/// second is reported). The first's lead is then no reason to leave the gap unexplained.
fn gives_way(ranking: &[Scored]) -> bool {
    match ranking {
        [first, second, ..] => {
            NOT_IDENTIFIABLE.contains(&first.0.effect.as_str())
                && !NOT_IDENTIFIABLE.contains(&second.0.effect.as_str())
                && second.0.score - first.0.score < -STRONG_EVIDENCE
        }
        _ => false,
    }
}

/// The verdict's decision on the ranking, and the ranking it reads (best first). Where the
/// first candidate gives way (`gives_way`), the runner-up is decided on first and, if it is
/// named, leads the ranking with the never-named one second; otherwise the ranking stands
/// (docs/decisions/never-named-gives-way.md).
fn decide_in_order(
    d: &Diagnosis,
    r: &RankContext,
    vars: &[Variant],
    ranking: Vec<Scored>,
    before: &GapSummary,
    failed_runs: &mut Vec<FailedRun>,
) -> (Vec<Scored>, Decision) {
    if gives_way(&ranking) {
        let mut swapped = ranking.clone();
        swapped.swap(0, 1);
        let mut dec = decide(d, r, vars, &swapped, before, failed_runs);
        if dec.chosen {
            dec.gave_way = true;
            return (swapped, dec);
        }
    }
    let dec = decide(d, r, vars, &ranking, before, failed_runs);
    (ranking, dec)
}

/// How strong the ranking's evidence of a gap that the omnibus test misses is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum GapEvidence {
    /// No candidate has very strong evidence.
    Weak,
    /// Very strong on all cells, not beyond the slip level: what a belt whose creep differs
    /// from the twin's does too (docs/decisions/gap-model-form.md).
    SlipLevelOnly,
    /// Very strong on all cells and beyond the slip level.
    Strong,
}

/// The evidence of a gap that the omnibus test misses in the ranking (effect, [score, score
/// beyond the slip level]; best first): that of its best candidate that is not a tachometer
/// fitted to the readings' shape alone (`tachometer::shape_alone`), since a sensor difference
/// is never an unexplained gap (docs/decisions/sensor-first.md). Only evidence beyond the slip
/// level makes a gap: a slip level the calibration and the slip level's discrepancy do not
/// reach is the model-form difference any plant may have (docs/decisions/gap-model-form.md).
fn strong_gap<'a>(
    ranking: impl IntoIterator<Item = (&'a str, [f64; 2])>,
    sensor_read: bool,
) -> GapEvidence {
    match ranking
        .into_iter()
        .find(|&(effect, _)| !tachometer::shape_alone(effect, sensor_read))
    {
        Some((_, [all, beyond])) if all < STRONG_EVIDENCE && beyond < STRONG_EVIDENCE => {
            GapEvidence::Strong
        }
        Some((_, [all, _])) if all < STRONG_EVIDENCE => GapEvidence::SlipLevelOnly,
        _ => GapEvidence::Weak,
    }
}

/// Knee labels left out of the ranking (`RankContext::active`): their own gap against the
/// baseline twin (chi-square of their cells against its 99.9 % quantile, as for the withheld
/// labels, with the tension's spread through the twin's runs in their cells' sd), whether any
/// of them shows one, and per label the tension interval run and the share of its cells'
/// variance that spread is (mean over the cells that enter fits).
fn knee_labels(d: &Diagnosis, r: &RankContext) -> (Vec<KneeLabel>, bool) {
    let mut knee_gap = false;
    let knee_labels: Vec<KneeLabel> = (0..r.n)
        .filter(|j| !r.active.contains(j))
        .map(|j| {
            let lt = &r.twins[j];
            let cells: Vec<(f64, f64)> = r.base_cells[j]
                .iter()
                .enumerate()
                .filter(|(i, c)| fit_cell(*i, **c))
                .map(|(i, &(m, t, sd))| ((m - t) / sd, (tension_term(i, lt) / sd).powi(2)))
                .collect();
            let z: Vec<f64> = cells.iter().map(|c| c.0).collect();
            knee_gap |= a_gap(std::slice::from_ref(&z));
            let t0 = lt.q.installation_tension_n;
            KneeLabel {
                label: d.labels[j].clone(),
                tension_elasticity: lt.tension_elasticity,
                tension_interval_n: lt.tension_ends_n.unwrap_or([t0, t0]),
                tension_variance_share: cells.iter().map(|c| c.1).sum::<f64>()
                    / cells.len().max(1) as f64,
                rms_z: rms(&z),
            }
        })
        .collect();
    (knee_labels, knee_gap)
}

/// Bootstrap interval (90 %) of the reduction over labels, from the withheld z before and
/// after (fixed seed: 2000 resamples).
fn reduction_interval(z_before: &[Vec<f64>], za: &[Vec<f64>]) -> [f64; 2] {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x51);
    // Resamples without an excess over noise (RMS z below 1.05) have nothing to reduce and
    // are left out.
    let mut r: Vec<f64> = (0..2000)
        .filter_map(|_| {
            let pick: Vec<usize> = (0..z_before.len())
                .map(|_| rng.gen_range(0..z_before.len()))
                .collect();
            let b = rms(&pick
                .iter()
                .flat_map(|&k| z_before[k].clone())
                .collect::<Vec<_>>());
            let a = rms(&pick.iter().flat_map(|&k| za[k].clone()).collect::<Vec<_>>());
            (b > 1.05).then(|| ((b - a) / (b - 1.0)).min(1.0))
        })
        .collect();
    r.sort_by(f64::total_cmp);
    [
        fom::stats::quantile(&r, 0.05),
        fom::stats::quantile(&r, 0.95),
    ]
}

/// The slip distributions per label: measured, the baseline twin, and the twin with the named
/// effect (linearised: the reference run's distribution scaled to the fitted magnitude's share
/// of the shift, plus the offset refitted with it).
fn plots(
    r: &RankContext,
    vars: &[Variant],
    ranking: &[Scored],
    chosen_variant: Option<usize>,
) -> Vec<LabelPlot> {
    r.twins
        .iter()
        .enumerate()
        .map(|(l, lt)| LabelPlot {
            label: lt.label.clone(),
            measured: lt.measured.slip_sorted.clone(),
            before: lt.baseline.slip_sorted.clone(),
            after: match chosen_variant {
                Some(v) => lt.variant[v].as_ref().map(|f| {
                    let share = ranking[0].0.params[0].value / vars[v].reference;
                    let q = interpolate(&lt.baseline.slip_sorted, &f.slip_sorted, share);
                    q.iter().map(|x| x + ranking[0].0.slip_offset_pct).collect()
                }),
                None => None,
            }
            .unwrap_or_else(|| lt.baseline.slip_sorted.clone()),
            index: l,
        })
        .collect()
}

/// The baseline calibration as reported.
fn baseline_summary(d: &Diagnosis, r: &RankContext) -> BaselineSummary {
    BaselineSummary {
        fitted_on: (0..r.n)
            .filter(|&l| !r.held_out[l])
            .map(|l| d.labels[l].clone())
            .collect(),
        friction: d.cal.friction,
        installation_tension_n: d.cal.installation_tension_n,
        slip_offset_pct: d.cal.slip_offset_pct,
        center_distances_m: r
            .twins
            .iter()
            .map(|lt| (lt.label.clone(), lt.q.center_distance_m))
            .collect(),
        misfit: d.cal.misfit.clone(),
        startup_fit: d.startup_fit.clone(),
        tension_prior: d.cal.tension_prior,
    }
}

/// RMS z over labels with a 90 % bootstrap interval over labels (fixed seed: 2000 resamples).
pub(super) fn summarise(per_label: &[Vec<f64>], names: Vec<String>, threshold: f64) -> GapSummary {
    let all: Vec<f64> = per_label.iter().flatten().copied().collect();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x6a9);
    let mut boots: Vec<f64> = (0..2000)
        .map(|_| {
            let pick: Vec<f64> = (0..per_label.len())
                .flat_map(|_| per_label[rng.gen_range(0..per_label.len())].clone())
                .collect();
            rms(&pick)
        })
        .collect();
    boots.sort_by(f64::total_cmp);
    GapSummary {
        labels: names,
        rms_z: rms(&all),
        interval90: [
            fom::stats::quantile(&boots, 0.05),
            fom::stats::quantile(&boots, 0.95),
        ],
        cells_beyond_noise: all.iter().filter(|z| z.abs() > threshold).count(),
    }
}

/// Quantile functions a + share (b - a) on [`features::levels`].
fn interpolate(a: &[f64], b: &[f64], share: f64) -> Vec<f64> {
    let p = features::levels();
    let (qa, qb) = (quantile_function(a, &p), quantile_function(b, &p));
    qa.iter()
        .zip(&qb)
        .map(|(x, y)| x + share * (y - x))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::report::{CellGap, Ranked};

    /// A tachometer fitted to the readings' shape alone, with no sensor structure read, does
    /// not make a gap the omnibus test misses: the next candidate's evidence decides.
    #[test]
    fn an_unread_sensors_shape_is_not_strong_evidence_of_a_gap() {
        let ranking = [(tachometer::NAME, -10.7), ("belt-hysteresis", -2.2)];
        let strong = |r: &[(&'static str, f64)], read| {
            strong_gap(r.iter().map(|&(e, s)| (e, [s, s])), read) == GapEvidence::Strong
        };
        assert!(!strong(&ranking, false));
        assert!(strong(&ranking, true));
        let ranking = [(tachometer::NAME, -10.7), ("belt-hysteresis", -11.5)];
        assert!(strong(&ranking, false));
        assert!(strong(&[("bearing-drag", -11.5)], false));
        assert!(!strong(&[("bearing-drag", -2.0)], true));
    }

    /// Very strong evidence in the slip level alone (a healthy drive whose creep differs from
    /// the twin's: Stribeck friction fitting -16.6 on all cells, -2.9 beyond the slip level)
    /// is not a gap the omnibus test misses; evidence beyond the slip level is.
    #[test]
    fn evidence_in_the_slip_level_alone_is_not_a_gap_the_omnibus_test_misses() {
        let level_only = [
            ("stribeck-friction", [-16.6, -2.9]),
            ("bearing-drag", [-4.0, -4.0]),
        ];
        assert_eq!(strong_gap(level_only, true), GapEvidence::SlipLevelOnly);
        let beyond = [("stribeck-friction", [-16.6, -10.5])];
        assert_eq!(strong_gap(beyond, true), GapEvidence::Strong);
        let weak = [("stribeck-friction", [-9.9, -20.0])];
        assert_eq!(strong_gap(weak, true), GapEvidence::Weak);
        // The first candidate that is not a sensor's shape alone decides.
        let shape_first = [
            (tachometer::NAME, [-30.0, -30.0]),
            ("belt-hysteresis", [-63.8, -3.0]),
        ];
        assert_eq!(strong_gap(shape_first, false), GapEvidence::SlipLevelOnly);
    }

    fn scored(effect: &str, score: f64) -> Scored {
        let ranked = Ranked {
            effect: effect.into(),
            score,
            params: Vec::new(),
            gap_after: 1.0,
            slip_offset_pct: 0.0,
            signature: Vec::new(),
            score_beyond_slip_level: score,
            line_only: false,
            variant: None,
        };
        (ranked, Vec::new())
    }

    /// Belt hysteresis ranked first, never named, does not block a runner-up within the
    /// strong-evidence margin of it; beyond the margin, or behind a candidate that can be
    /// named, nothing gives way.
    #[test]
    fn a_never_named_first_gives_way_only_to_a_runner_up_it_is_not_told_apart_from() {
        let ranking = |a: (&str, f64), b: (&str, f64)| [scored(a.0, a.1), scored(b.0, b.1)];
        assert!(gives_way(&ranking(
            ("belt-hysteresis", -30.5),
            ("bearing-drag", -20.6)
        )));
        assert!(!gives_way(&ranking(
            ("belt-hysteresis", -30.5),
            ("bearing-drag", -20.4)
        )));
        assert!(!gives_way(&ranking(
            ("bearing-drag", -30.5),
            ("belt-hysteresis", -25.0)
        )));
        assert!(!gives_way(&ranking(
            ("pulley-eccentricity (pulley=driven)", -30.5),
            ("bearing-drag", -25.0)
        )));
        assert!(!gives_way(&[scored("belt-hysteresis", -30.5)]));
    }

    /// An unexplained gap names its largest cells beyond noise, and says nothing of them when
    /// there are none (a gap carried by the withheld cells as a whole and a strong candidate).
    #[test]
    fn an_unexplained_verdict_lists_the_cells_beyond_noise_only_where_there_are_some() {
        let summary = |cells_beyond_noise| GapSummary {
            labels: vec!["d1".into()],
            rms_z: 1.02,
            interval90: [0.9, 1.1],
            cells_beyond_noise,
        };
        let cell = |z: f64, significant| CellGap {
            label: "d1".into(),
            cell: format!("steady/slip/mean/level z{z}"),
            measured: 0.7,
            twin: 0.69,
            sd: 0.01,
            z,
            significant,
        };
        let ranking = [scored("stribeck-friction", -12.0)];
        let text = |top, level_only, n, cells: &[CellGap]| {
            verdict_text(
                top,
                level_only,
                &[],
                &ranking,
                &summary(n),
                &summary(n),
                cells,
            )
        };
        let none = [cell(2.1, false)];
        let t = text("unexplained", false, 0, &none);
        assert!(t.contains("0 cells beyond noise) and no catalogue"), "{t}");
        assert!(!t.contains("largest"), "{t}");
        let some = [cell(2.1, false), cell(-4.0, true), cell(3.5, true)];
        let t = text("unexplained", false, 2, &some);
        assert!(
            t.contains("2 cells beyond noise, largest: d1 steady/slip/mean/level z-4 (z -4.0), d1 steady/slip/mean/level z3.5 (z +3.5))"),
            "{t}"
        );
        // "none" above noise in the slip level alone says so; within noise it does not.
        let t = text("none", true, 0, &none);
        assert!(
            t.starts_with("no effect's gap: the withheld cells are off by more than noise on average (RMS z 1.02, 0 single cells")
                && t.contains("a model-form difference in the slip level"),
            "{t}"
        );
        let text = text("none", false, 0, &none);
        assert!(text.starts_with("no gap beyond noise"), "{text}");
    }
}
