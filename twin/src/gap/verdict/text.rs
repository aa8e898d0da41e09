//! The verdict's words: its main sentence and the notes after it.

use super::super::baseline::KNEE_ELASTICITY;
use super::super::candidates::{tachometer, Scored};
use super::super::report::{num, CellGap, FailedRun, GapSummary, NamedEffect, SignatureLine};
use super::super::unfitted::{very_strong, UnfittedEvidence};
use super::{Decision, EXPLAINED_SHARE, STRONG_EVIDENCE};

/// The verdict's main sentence: no gap (within noise, or off in the slip level alone:
/// `level_only`), an unexplained gap (where, and the best candidate), or the named effects with
/// the gap before and after them.
pub(super) fn verdict_text(
    top: &str,
    level_only: bool,
    named: &[NamedEffect],
    ranking: &[Scored],
    before: &GapSummary,
    after: &GapSummary,
    cells: &[CellGap],
) -> String {
    let mut worst: Vec<&CellGap> = cells.iter().filter(|c| c.significant).collect();
    worst.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let where_text = worst
        .iter()
        .take(3)
        .map(|c| format!("{} {} (z {:+.1})", c.label, c.cell, c.z))
        .collect::<Vec<_>>()
        .join(", ");
    match top {
        "none" if level_only => format!(
            "no effect's gap: the withheld cells are off by more than noise on average (RMS z \
             {:.2}, {} single cells beyond the threshold) but pass the data-set test for a gap, \
             and the candidates' very strong evidence lies in the slip level alone: a \
             model-form difference in the slip level (a belt whose creep differs from the \
             twin's), not an effect's signature",
            before.rms_z, before.cells_beyond_noise
        ),
        "none" => format!(
            "no gap beyond noise: the withheld cells are within what measurement noise and \
             friction uncertainty explain (RMS z {:.2}, {} single cells beyond the threshold)",
            before.rms_z, before.cells_beyond_noise
        ),
        "unexplained" => format!(
            "the twin misses the measurement (withheld RMS z {:.2}; {} cells beyond noise{}) \
             and no catalogue effect explains it (best: {}, RMS z {:.2} after): a model-form \
             difference or an effect outside the catalogue",
            before.rms_z,
            before.cells_beyond_noise,
            if where_text.is_empty() {
                String::new()
            } else {
                format!(", largest: {where_text}")
            },
            ranking[0].0.effect,
            ranking[0].0.gap_after
        ),
        effect => format!(
            "{} the gap: withheld RMS z {:.2} -> {}; signature {}; where: {}{}",
            if named.len() > 1 {
                format!(
                    "{} explain",
                    named
                        .iter()
                        .map(|e| e.effect.as_str())
                        .collect::<Vec<_>>()
                        .join(" and ")
                )
            } else {
                format!("{effect} explains")
            },
            before.rms_z,
            if named.len() > 1 {
                named
                    .iter()
                    .map(|e| format!("{:.2}", e.gap_after))
                    .collect::<Vec<_>>()
                    .join(" -> ")
            } else {
                format!("{:.2}", after.rms_z)
            },
            ranking[0].0.signature.join(", "),
            where_text,
            if after.cells_beyond_noise > 0 {
                format!(
                    "; {} withheld cells stay beyond noise with it (a second effect or a \
                     model-form difference)",
                    after.cells_beyond_noise
                )
            } else {
                String::new()
            }
        ),
    }
}

/// What the verdict adds after its main sentence: why a strong candidate is not named, a
/// failed confirmation, the knee labels, a runner-up not told apart.
pub(super) fn verdict_notes(
    dec: &Decision,
    ranking: &[Scored],
    failed_runs: &[FailedRun],
    close_second: Option<&str>,
) -> String {
    let mut verdict = String::new();
    if let Some(l) = &dec.by_line {
        verdict += &format!(
            "; named by its own line ({}: withheld RMS z {:.2} -> {:.2}{}), though {}: the \
             plant answers it with another magnitude or shape than the twin (its magnitude is \
             the twin's equivalent), and the rest of the gap is that model-form difference",
            l.cells.join(", "),
            l.rms_z_before,
            l.rms_z_after,
            l.confirmed_rms_z_after.map_or(String::new(), |c| format!(
                ", {c:.2} in its full-order runs"
            )),
            whole_share(l)
        );
    }
    if let (Some((effect, share, _)), false, true) = (
        &dec.partial,
        dec.identifiable,
        ranking[0].0.effect == tachometer::NAME,
    ) {
        verdict += &format!(
            "; the best candidate, {effect} (score {:.1}, {:.0} % of the excess over noise \
             removed), is not named: the recordings show no structure of a sensor (no timer \
             lattice, pulse count or missing pulses read), and the readings' shape alone is \
             what sensor noise that is not white gives too: no gap by itself \
             (docs/decisions/sensor-first.md)",
            ranking[0].0.score,
            100.0 * share
        );
    } else if let (Some((effect, share, _)), false) = (&dec.partial, dec.identifiable) {
        verdict += &format!(
            "; the best candidate, {effect} (score {:.1}, {:.0} % of the excess over noise \
             removed), is never named: {NOT_TOLD_FROM_CREEP} (docs/twin.md, \"The gap \
             diagnosis\")",
            ranking[0].0.score,
            100.0 * share
        );
    } else if let (Some((effect, share, _)), true) =
        (&dec.partial, dec.best_explains && !dec.beyond_level)
    {
        verdict += &format!(
            "; the best candidate, {effect} (score {:.1}, {:.0} % of the excess over noise \
             removed), is not named: its evidence lies in the slip level alone (score {:.1} on \
             the other cells), which the calibration and a belt whose creep differs from the \
             twin's move as well",
            ranking[0].0.score,
            100.0 * share,
            ranking[0].0.score_beyond_slip_level
        );
    } else if let Some((effect, share, by_runs)) = &dec.partial {
        verdict += &format!(
            "; the best candidate, {effect} (score {:.1}), removes only {:.0} % of the excess \
             over noise{} (a named effect must remove at least {:.0} %): at most part of the gap",
            ranking[0].0.score,
            100.0 * share,
            if *by_runs {
                " when run at its fitted magnitude (the linearised fit promised more)"
            } else {
                ""
            },
            100.0 * EXPLAINED_SHARE
        );
    }
    verdict += &confirmation_notes(dec);
    if let Some(f) = failed_runs
        .iter()
        .find(|f| dec.confirmation_failed && f.purpose == "confirmation")
    {
        verdict += &format!(
            "; the best candidate, {} (score {:.1}), is not named: its full-order run at the \
             fitted magnitude ({}) failed at label {}: {}",
            ranking[0].0.effect, ranking[0].0.score, f.effect, f.label, f.reason
        );
    }
    if !dec.knee_labels.is_empty() {
        verdict += &format!(
            "; left out of the ranking, the twin there in its looseness knee (slip elasticity to \
             the installation tension above {KNEE_ELASTICITY}, where another drive's knee answers \
             an effect differently; the tension's 90 % interval run through the twin): {}{}",
            dec.knee_labels
                .iter()
                .map(|k| format!(
                    "{} (elasticity {:.1}, {:.0}-{:.0} N, {:.0} % of its cells' variance, RMS z \
                     {:.2})",
                    k.label,
                    k.tension_elasticity,
                    k.tension_interval_n[0],
                    k.tension_interval_n[1],
                    100.0 * k.tension_variance_share,
                    k.rms_z
                ))
                .collect::<Vec<_>>()
                .join(", "),
            if dec.knee_gap {
                "; the gap there stays unexplained (a model-form difference at the knee)"
            } else {
                ""
            }
        );
    }
    if dec.gave_way {
        verdict += &format!(
            "; {} scores better ({:.1} against {:.1}, less than {} apart) but is never named: \
             {NOT_TOLD_FROM_CREEP}; not told apart from it, {} is named by what it does beyond \
             that (docs/decisions/never-named-gives-way.md)",
            ranking[1].0.effect,
            ranking[1].0.score,
            ranking[0].0.score,
            -STRONG_EVIDENCE,
            ranking[0].0.effect
        );
    } else if let Some(second) = close_second {
        verdict += &format!(
            "; not told apart from {second} (scores {:.1} and {:.1}, less than {} apart): \
             either fits these data",
            ranking[0].0.score, ranking[1].0.score, -STRONG_EVIDENCE
        );
    }
    verdict
}

/// The verdict's notes on how the confirmation runs were made where the first ones fell
/// short: at a searched magnitude, or at a re-fitted tension with the magnitude its runs ask
/// for.
fn confirmation_notes(dec: &Decision) -> String {
    let mut notes = String::new();
    if let Some(s) = &dec.confirmed_magnitude {
        notes += &format!(
            "; its full-order runs are made at the magnitude that fits {}, which no fold fits \
             ({} [{}, {}], searched with full-order runs there): at the linearised fit's {} \
             they fell short (docs/decisions/gap-unfitted-labels.md)",
            s.labels.join(", "),
            num(s.magnitude),
            num(s.interval90[0]),
            num(s.interval90[1]),
            num(s.fitted)
        );
    }
    if let Some(t) = dec.confirmed_tension_n {
        notes += &format!(
            "; its full-order runs are made with the installation tension re-fitted to {t:.1} N \
             within its 90 % interval: at the calibrated tension they fell short, and the \
             effect's answer depends on the tension more steeply than the slip does; the label \
             the tension was searched at allows for how far that answer moves within half the \
             search's step (docs/decisions/gap-confirmation-tension.md)"
        );
        if let Some(a) = &dec.magnitude_at_tension {
            notes += &format!(
                "; at that tension its own line ({}) asks for a magnitude of {} [{}, {}], the \
                 one named (the runs' answer there scaled to the measured line on {}; the runs, \
                 and the gap after, are at the linearised fit's {})",
                a.cells.join(", "),
                num(a.magnitude),
                num(a.interval90[0]),
                num(a.interval90[1]),
                a.labels.join(", "),
                num(a.fitted)
            );
        }
    }
    notes
}

/// What an effect named by its own line does to the whole gap, in the verdict's words.
fn whole_share(l: &SignatureLine) -> String {
    let runs = if l.whole_gap_by_runs {
        " in its full-order runs (its linearised fit promised more)"
    } else {
        ""
    };
    if l.whole_gap_grows {
        format!(
            "the whole gap grows with it{runs}, the twin's effect moving cells the plant's leaves"
        )
    } else {
        format!(
            "it removes only {:.0} % of the whole gap's excess over noise{runs}",
            100.0 * l.whole_gap_reduction
        )
    }
}

/// Why a never-named candidate (`NOT_IDENTIFIABLE`) is not named, in the verdict's words.
const NOT_TOLD_FROM_CREEP: &str = "from two speed signals at one load it cannot be told from a \
                                   belt whose creep differs from the twin's";

/// What the labels no fold fits showed (`unfitted`): the named effect's in-sample evidence and
/// its magnitude search, or why none was named there.
pub(super) fn unfitted_note(e: &UnfittedEvidence) -> String {
    let labels = e.labels.join(", ");
    let Some(best) = e.in_sample.first() else {
        return String::new();
    };
    let runs = match (e.magnitude, e.interval90) {
        (Some(m), Some([lo, hi])) => format!(
            "its magnitude searched with {} full-order runs there ({m:.3} [{lo:.3}, {hi:.3}])",
            e.search.len().saturating_sub(1)
        ),
        _ => String::new(),
    };
    if e.named {
        return format!(
            "; named from the labels no fold fits ({labels}: still drifting, read like with like \
             and never fitted, so leave-one-label-out cannot credit what only they show): fitted \
             in sample on every ranked label, score {:.1} ({:.1} beyond the slip level), {runs}, \
             and run at it on every label, the fitted labels within noise with it \
             (docs/decisions/gap-unfitted-labels.md); the calibration does not see those labels, \
             so a belt looser than calibrated whose slide there is smooth reads the same: a \
             tension meter's reading of the belt (`static_tension_n`) tells them apart (ibid., \
             \"A looser belt\")",
            best.score, best.score_beyond_slip_level
        );
    }
    let gap_there = format!(
        "; the gap lies in the labels no fold fits alone ({labels}): the best candidate fitted in \
         sample there, {} (score {:.1}, {:.1} beyond the slip level)",
        best.effect, best.score, best.score_beyond_slip_level
    );
    match (e.magnitude, e.confirmed_gap_after) {
        (Some(_), Some(after)) if !e.outside_trained_box.is_empty() => format!(
            "{gap_there}, {runs}, leaves withheld RMS z {after:.2} when run at it on every label \
             and would explain them, but is not named: the baseline calibration sits at the \
             trained box's edge ({}), so a drive outside the trained range, such as a belt \
             looser than stated, slides there the same way (docs/decisions/gap-unfitted-labels.md, \
             \"At the trained box's edge\")",
            e.outside_trained_box.join(", ")
        ),
        (Some(_), Some(after)) => format!(
            "{gap_there}, {runs}, leaves withheld RMS z {after:.2} when run at it on every label; \
             a named effect must remove at least {:.0} % of the excess over noise and leave the \
             fitted labels and those it was fitted on within noise: not named",
            100.0 * EXPLAINED_SHARE
        ),
        (Some(_), None) => format!(
            "{gap_there}, {runs}, is not named: its run at that magnitude failed on a label \
             (failed_runs)"
        ),
        (None, _) if very_strong(best) => {
            format!("{gap_there}, is not named: a run of its magnitude search failed (failed_runs)")
        }
        (None, _) => format!(
            "{gap_there}, has no very strong evidence on all cells and beyond the slip level: \
             no catalogue effect explains them"
        ),
    }
}

/// The verdict's note where a tension meter's readings contradict the baseline calibration's
/// installation tension, from its misfit flags `misfit` (`calibrate::misfit::tension_reading_flag`;
/// empty otherwise): a belt
/// the slips make looser than the meter reads slides at its loosest labels for another reason
/// than its tension (docs/decisions/tension-reading.md).
pub(super) fn tension_reading_note(misfit: &[String]) -> String {
    let Some((side, flag)) = crate::calibrate::tension_reading_side(misfit) else {
        return String::new();
    };
    let why = if side == "looser" {
        "the belt is tighter than the slips make it, so what makes the loosest labels slide \
         is not its tension: an effect (one the catalogue holds at another size or shape, or \
         one it lacks), or a drive whose looseness knee lies elsewhere than the twin's"
    } else {
        "the belt is looser than the slips make it: the twin's slip at that tension is \
         higher than the drive's, a model-form difference in the slip level"
    };
    format!("; a tension meter contradicts the baseline calibration ({flag}): {why}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::unfitted::InSampleScore;

    /// An effect named by its line whose runs leave the whole gap larger says so, rather than
    /// that it removes 0 % of it.
    #[test]
    fn a_line_named_effect_that_grows_the_whole_gap_says_so() {
        let mut l = SignatureLine {
            cells: vec!["steady/driven-speed/amplitude/driven1x".into()],
            rms_z_before: 18.33,
            rms_z_after: 1.02,
            confirmed_rms_z_after: Some(0.54),
            whole_gap_reduction: 0.0,
            whole_gap_by_runs: true,
            whole_gap_grows: true,
        };
        assert!(
            whole_share(&l).starts_with("the whole gap grows with it in its full-order runs"),
            "{}",
            whole_share(&l)
        );
        l.whole_gap_grows = false;
        l.whole_gap_by_runs = false;
        l.whole_gap_reduction = 0.27;
        assert_eq!(
            whole_share(&l),
            "it removes only 27 % of the whole gap's excess over noise"
        );
    }

    /// Each way the labels no fold fits can end says what happened: named, short of the gap,
    /// a failed run, or no very strong candidate.
    #[test]
    fn the_labels_no_fold_fits_say_why_their_best_candidate_is_or_is_not_named() {
        let best = |score: f64| InSampleScore {
            effect: "stribeck-friction".into(),
            score,
            score_beyond_slip_level: score,
            variant: 0,
            slip_offset_pct: 0.0,
        };
        let ev = |score, magnitude: Option<f64>, after: Option<f64>, named| UnfittedEvidence {
            labels: vec!["d3".into()],
            in_sample: vec![best(score)],
            search: vec![[0.0, 10.0], [0.5, 1.0]],
            magnitude,
            interval90: magnitude.map(|m| [m - 0.01, m + 0.01]),
            confirmed_gap_after: after,
            outside_trained_box: Vec::new(),
            named,
        };
        let named = unfitted_note(&ev(-500.0, Some(0.5), Some(0.8), true));
        assert!(
            named.contains("named from the labels no fold fits (d3"),
            "{named}"
        );
        assert!(named.contains("0.500 [0.490, 0.510]"), "{named}");
        // What it is not told apart from is said with it.
        assert!(named.contains("a belt looser than calibrated"), "{named}");
        let short = unfitted_note(&ev(-500.0, Some(0.5), Some(4.0), false));
        assert!(short.contains("leaves withheld RMS z 4.00"), "{short}");
        assert!(short.ends_with("not named"), "{short}");
        let edge = unfitted_note(&UnfittedEvidence {
            outside_trained_box: vec!["friction".into()],
            ..ev(-500.0, Some(0.5), Some(0.8), false)
        });
        assert!(
            edge.contains("would explain them, but is not named"),
            "{edge}"
        );
        assert!(edge.contains("trained box's edge (friction)"), "{edge}");
        let failed = unfitted_note(&ev(-500.0, Some(0.5), None, false));
        assert!(
            failed.contains("its run at that magnitude failed"),
            "{failed}"
        );
        let search_failed = unfitted_note(&ev(-500.0, None, None, false));
        assert!(
            search_failed.contains("magnitude search failed"),
            "{search_failed}"
        );
        let weak = unfitted_note(&ev(-5.0, None, None, false));
        assert!(weak.contains("no very strong evidence"), "{weak}");
    }

    /// The meter's note quotes the flag and reads its side; no flag, no note.
    #[test]
    fn a_tension_meter_that_contradicts_the_calibration_is_said_in_the_verdict() {
        let flag = "installation_tension_n = 159.7 N against 246.6 +- 4.8 N from the tension \
                    readings (z -17.7): the slips ask for a looser belt than the meter reads, \
                    so ...";
        let flags = vec![
            "friction = 0.6 sits at its lower bound".to_string(),
            flag.into(),
        ];
        let note = tension_reading_note(&flags);
        assert!(
            note.starts_with(
                "; a tension meter contradicts the baseline calibration (installation_tension_n \
                 = 159.7 N against 246.6 +- 4.8 N from the tension readings (z -17.7)): the \
                 belt is tighter than the slips make it"
            ),
            "{note}"
        );
        let tighter = tension_reading_note(&[flag.replace("a looser belt", "a tighter belt")]);
        assert!(
            tighter.contains("the belt is looser than the slips make it"),
            "{tighter}"
        );
        assert_eq!(tension_reading_note(&flags[..1]), "");
    }
}
