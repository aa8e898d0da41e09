//! Sim-to-real gap diagnosis (`rom gap`): where a calibrated twin misses measured runs, which
//! unmodelled effect of the catalogue explains it, and how far the gap shrinks on withheld
//! labels once that effect is modelled.
//!
//! 0. **The sensor** (`sensor_id`): the tachometer identified from the recordings (pulses per
//!    revolution, timer, white noise, missing pulses) before any mechanics is judged; the
//!    twin's runs are read through it.
//! 1. **Where**: the baseline twin (surrogate calibrated to the fitted labels: friction,
//!    installation tension, slip offset, and distances where unknown) is run as a
//!    reduced-resolution full-order model at each label's point and read like the measurement
//!    (`twin_runs`); every cell of `features::CELLS` gets z = (measured - twin) / sd, with sd
//!    from the measurement's standard error, the twin's, the friction uncertainty (+-1 %, seed
//!    paper section 4.2) and, for the slip level, the surrogate's variance and the model
//!    discrepancy of the calibration's likelihood.
//! 2. **Which**: each candidate (the mechanical effects through one sensitivity run each per
//!    label, the tachometer through a grid of sensor models) is fitted to the fitted labels'
//!    cells by weighted least squares, with the calibration's slip offset as a nuisance
//!    parameter (what calibration absorbs is not credited to an effect), robustly (Huber).
//!    Candidates are ranked by the out-of-sample Huber loss (leave-one-label-out, or the
//!    holdout) plus the Schwarz penalty k ln n against "none". The best is named only with very
//!    strong evidence and when it removes at least half of the withheld gap, in its fit and in
//!    full-order runs at its fitted magnitude (at the calibrated installation tension, or, where
//!    those fall short, at the tension within its posterior that fits best); otherwise the gap
//!    is unexplained.
//! 3. **How far**: the RMS z of the withheld labels' cells before and after, with a bootstrap
//!    interval over labels, and the confirmation runs' RMS z.
//!
//! 4. **Load levels** (`load_levels`): where labels were recorded at a second load, the slip's
//!    rise with the load against the twin's, the belt's stiffness under load.
//!
//! One file per stage: `baseline` (the label twins), `cells` (where), `candidates` (linear
//! effects and the tachometer grid), `ranking` (folds and scores), `confirmation`, `verdict`,
//! `report` (types and rendering); `features` reads a recording (`sensor_noise` its sensor's
//! noise), `twin_runs` runs the twin.
//! How to add a stage or a candidate: docs/extending/gap-stage.md.

pub mod baseline;
pub mod calibration;
pub mod candidates;
pub mod cells;
pub mod confirmation;
pub mod features;
pub mod load_levels;
pub mod ranking;
pub mod reading;
pub mod report;
pub mod sensor_counter;
pub mod sensor_id;
pub mod sensor_noise;
pub mod signature_line;
pub mod twin_runs;
pub mod unfitted;
pub mod verdict;

use fom::stats::Z90;
use std::time::Instant;

use fom::DriveConfig;
use rayon::prelude::*;
use rom::Surrogate;

use crate::calibrate::{Calibration, Target};
use crate::error::{Result, TwinError};
use crate::measured::DataSet;
use baseline::{
    blade_count, effect_features_at, label_twins, measured_features, record_failure,
    unsettled_label, usable_targets, LabelTwin,
};
use calibration::{calibrate_baseline, startup_targets};
use features::{BandContext, Features};
use twin_runs::{variants, Resolution, Variant};

pub use report::{
    BaselineSummary, CellGap, FailedRun, GapReport, GapSummary, KneeLabel, NamedEffect, Param,
    PartialEffect, Ranked, SecondPassRun, SignatureLine, StartupFit, UnsettledLabel,
};
pub use verdict::NOT_IDENTIFIABLE;

/// Options of a gap diagnosis.
#[derive(Debug, Clone, Default)]
pub struct GapOptions {
    /// Labels withheld from calibration and effect fits; empty: leave-one-label-out.
    pub holdout: Vec<String>,
    pub resolution: Resolution,
}

/// What every stage of one diagnosis reads: the inputs, the usable labels, the band context
/// and the baseline calibration.
pub(crate) struct Diagnosis<'a> {
    pub s: &'a Surrogate,
    pub cfg: &'a DriveConfig,
    pub set: &'a DataSet,
    pub opts: &'a GapOptions,
    /// Usable labels, in the data set's order.
    pub labels: Vec<String>,
    /// Labels left out, with the reason.
    pub unusable: Vec<[String; 2]>,
    /// Usable labels still drifting at their end: compared, never fitted.
    pub unsettled: Vec<UnsettledLabel>,
    pub ctx: BandContext,
    /// R_t of the model's slip formula and of the data's.
    pub model_ratio: f64,
    pub ratio: f64,
    pub cal: Calibration,
    /// What the steady slips alone gave, where the start-up slips decided `cal`.
    pub startup_fit: Option<StartupFit>,
    /// The sensor identified from the recordings (`sensor_id`), through which the twin is read.
    pub sensor: sensor_id::IdentifiedSensor,
    pub started: Instant,
}

/// Runs the gap diagnosis: the baseline twins, the ranking and verdict, and a second pass at
/// the fitted magnitudes of the two best mechanical candidates.
pub fn gap(
    s: &Surrogate,
    cfg: &DriveConfig,
    set: &DataSet,
    opts: &GapOptions,
) -> Result<GapReport> {
    let started = Instant::now();
    let ratio = set.speed_ratio(cfg);
    check_holdout(set, opts)?;
    // Labels at another load than the reference one are compared through the load levels.
    let full = set;
    let split = full.split_by_load();
    let set = split.as_ref().map_or(full, |(main, _)| main);
    check_load_holdout(split.as_ref().map(|(_, o)| o.as_slice()), opts)?;
    let mut ctx = band_context(cfg, set);
    let (labels, unusable, unsettled) = usable_labels(s, set, ratio, &ctx)?;
    let sensor = sensor_id::identify_data_set(set, &labels, ratio, cfg);
    ctx.blades = blade_count(set, &labels, ratio);
    let fitted: Vec<String> = labels
        .iter()
        .filter(|l| !opts.holdout.contains(l) && !unsettled.iter().any(|u| &u.label == *l))
        .cloned()
        .collect();
    if labels.iter().all(|l| opts.holdout.contains(l)) {
        return Err(TwinError::InvalidArgument {
            input: rom::Input::Holdout,
            message: "withholds every label; keep at least one to calibrate on".into(),
        });
    }
    if fitted.is_empty() {
        return Err(TwinError::Gap(format!(
            "nothing to calibrate on: every label not withheld still drifts at the end of its \
             recordings ({}); record until the slip has settled, at least {} s of steady \
             running at one label",
            unsettled
                .iter()
                .map(|u| u.label.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            fom::steady::MIN_WINDOW_S
        )));
    }
    let all_targets = usable_targets(set, &labels, ratio, &unsettled)?;
    let fit_targets: Vec<Target> = all_targets
        .iter()
        .filter(|t| fitted.contains(&t.label))
        .cloned()
        .collect();
    let startup = startup_targets(set, &fit_targets, ratio, &ctx)?;
    let (cal, startup_fit) = calibrate_baseline(s, cfg, &fit_targets, &startup)?;
    let d = Diagnosis {
        s,
        cfg,
        set,
        opts,
        labels,
        unusable,
        unsettled,
        ctx,
        model_ratio: cfg.transmission_ratio(),
        ratio,
        cal,
        startup_fit,
        sensor,
        started,
    };
    let vars = variants(d.ctx.blades);
    let (twins, failed) = label_twins(&d, &all_targets, &fit_targets, &vars)?;
    let levels = split.as_ref().map(|(_, others)| {
        let h = vars
            .iter()
            .find(|v| v.effect == "belt-hysteresis")
            .expect("the catalogue has belt hysteresis");
        load_levels::compare(&d, full, others, &twins, h)
    });
    let mut report = ranked(&d, twins, vars, failed)?;
    if let Some(note) = load_levels::reference_note(cfg, set, ratio) {
        report.verdict += &note;
    }
    if let Some(ll) = levels {
        report.verdict += &format!(" {}", ll.finding);
        if let Some(note) = load_levels::ranking_note(&ll, &report.ranking) {
            report.verdict += &note;
        }
        report.load_levels = Some(ll);
    }
    Ok(report)
}

/// The ranking and verdict on the label twins, with the second pass where it applies; the
/// verdict (and its confirmation runs) only on the ranking that stands.
fn ranked(
    d: &Diagnosis,
    mut twins: Vec<LabelTwin>,
    vars: Vec<Variant>,
    failed: Vec<FailedRun>,
) -> Result<GapReport> {
    let (again, first_scores) = {
        let (r, first) = ranking::scored(d, &twins, &vars)?;
        let again = second_pass_candidates(&first, &vars);
        if again.is_empty() {
            return verdict::report(d, &r, &vars, first, failed);
        }
        let scores: Vec<[f64; 2]> = again.iter().map(|&(v, _)| score_of(&first, v)).collect();
        (again, scores)
    };
    second_pass(d, &again, &first_scores, &mut twins, vars, failed)
}

/// A mechanical variant's score in a ranking, on all cells and beyond the slip level (+inf
/// where it is not ranked).
fn score_of(ranking: &[candidates::Scored], v: usize) -> [f64; 2] {
    ranking
        .iter()
        .find(|x| x.0.variant == Some(v))
        .map_or([f64::INFINITY; 2], |x| {
            [x.0.score, x.0.score_beyond_slip_level]
        })
}

/// The band context before the blade count is known (8 blades until `blade_count`).
pub fn band_context(cfg: &DriveConfig, set: &DataSet) -> BandContext {
    BandContext {
        blades: 8,
        belt_length_m: fom::statics::open_belt_length_m(
            cfg.center_distance_m(),
            0.5 * cfg.driver.pitch_diameter_m,
            0.5 * cfg.driven.pitch_diameter_m,
        ),
        driver_diameter_m: set
            .manifest
            .driver_pulley_diameter_m
            .unwrap_or(cfg.driver.pitch_diameter_m),
    }
}

/// The labels `gap` would diagnose in `set`, and the others with the reason; refused as `gap`
/// refuses a data set with fewer than two usable labels. Runs no twin (cheap): for callers
/// that build data sets (the online twin's gap sample).
pub fn usable_labels_of(
    s: &Surrogate,
    cfg: &DriveConfig,
    set: &DataSet,
) -> Result<(Vec<String>, Vec<[String; 2]>)> {
    usable_labels(s, set, set.speed_ratio(cfg), &band_context(cfg, set))
        .map(|(labels, unusable, _)| (labels, unusable))
}

/// Every `--holdout` label must be one of the data set's.
fn check_holdout(set: &DataSet, opts: &GapOptions) -> Result<()> {
    for h in &opts.holdout {
        if !set.labels().contains(h) {
            return Err(TwinError::InvalidArgument {
                input: rom::Input::Holdout,
                message: format!(
                    "names label `{h}`, which the data set does not have (labels: {})",
                    set.labels().join(", ")
                ),
            });
        }
    }
    Ok(())
}

/// A `--holdout` label at another load than the reference one is compared through the load
/// levels, never withheld from the ranking.
fn check_load_holdout(others: Option<&[String]>, opts: &GapOptions) -> Result<()> {
    let Some(h) = opts
        .holdout
        .iter()
        .find(|h| others.is_some_and(|o| o.contains(h)))
    else {
        return Ok(());
    };
    Err(TwinError::InvalidArgument {
        input: rom::Input::Holdout,
        message: format!(
            "names label `{h}`, which is at another load than the data set's reference load: \
             it is compared through the load levels (docs/decisions/gap-load-levels.md), not \
             withheld; withhold a label at the reference load"
        ),
    })
}

/// Usable labels, the others with the reason, and the usable ones still drifting.
type UsableLabels = (Vec<String>, Vec<[String; 2]>, Vec<UnsettledLabel>);

/// Usable labels (readable, and at a known distance, if any, the surrogate was trained at),
/// the others with the reason, and the usable ones still drifting; at least two usable.
fn usable_labels(
    s: &Surrogate,
    set: &DataSet,
    ratio: f64,
    ctx: &BandContext,
) -> Result<UsableLabels> {
    let mut unusable = Vec::new();
    let mut unsettled = Vec::new();
    let mut labels = Vec::new();
    for l in set.labels() {
        let outside = set
            .known_center_distance_m(&l)
            .and_then(|d| s.outside_range(fom::params::Variable::CenterDistance, d));
        if let Some(why) = outside {
            unusable.push([l, why]);
            continue;
        }
        match measured_features(set, &l, ratio, ctx) {
            Ok((f, _)) => {
                if f.unsettled {
                    unsettled.push(unsettled_label(&l, &f));
                }
                labels.push(l)
            }
            Err(e) => unusable.push([l, e.to_string()]),
        }
    }
    if labels.len() < 2 {
        return Err(TwinError::Gap(format!(
            "a gap diagnosis needs at least two usable labels, the data set has {} ({})",
            labels.len(),
            unusable
                .iter()
                .map(|[l, e]| format!("{l}: {e}"))
                .collect::<Vec<_>>()
                .join("; ")
        )));
    }
    Ok((labels, unusable, unsettled))
}

/// Second pass: each of the two best variants, if fitted clearly above its reference
/// magnitude, is run again at the fitted magnitude, so that its sensitivities are taken where
/// they are used (the effects are not linear over their range: slip spread at the knee,
/// stick-slip onset). Not below it: there the rerun's signature would sink into the run's own
/// scatter and be dropped as insignificant (`candidates::SENSITIVITY_SD`). The variants and
/// magnitudes to run again, from the first ranking (best first); empty: none.
fn second_pass_candidates(first: &[candidates::Scored], vars: &[Variant]) -> Vec<(usize, f64)> {
    // Only the two best candidates that beat "none" (the ranking is sorted by score).
    first
        .iter()
        .map(|x| &x.0)
        .filter(|r| r.score < 0.0)
        .take(2)
        .filter_map(|r| {
            let v = r.variant?;
            let p = &r.params[0];
            let sd = (p.interval90[1] - p.interval90[0]) / (2.0 * Z90);
            let share = p.value / vars[v].reference;
            // Not beyond the physical bound (a twin-equivalent magnitude may be).
            (p.value > 2.0 * sd && share > 1.4).then_some((v, p.value.min(vars[v].max)))
        })
        .collect()
}

/// Whether a second-pass run is kept: not where it costs its candidate the very strong
/// evidence (`verdict::STRONG_EVIDENCE`) the reference run gave it, on all cells and on those
/// beyond the slip level (what naming an effect asks, `verdict`). A run at the first fit's
/// magnitude that turns very strong evidence for the effect into none has left the plant's
/// regime (a friction drop run past the onset of sliding, say), and the reference run is the
/// better-founded sensitivity (docs/decisions/gap-second-pass.md).
fn rerun_kept([score_first, beyond_first]: [f64; 2], score_rerun: f64) -> bool {
    let strong = verdict::STRONG_EVIDENCE;
    !(score_first < strong && beyond_first < strong && score_rerun >= strong)
}

/// The second pass's runs (`second_pass_candidates`) at every label, and the ranking and
/// verdict with those kept (`rerun_kept`); `first_scores`: each candidate's first-pass scores
/// (`score_of`).
fn second_pass(
    d: &Diagnosis,
    again: &[(usize, f64)],
    first_scores: &[[f64; 2]],
    twins: &mut [LabelTwin],
    mut vars: Vec<Variant>,
    mut failed: Vec<FailedRun>,
) -> Result<GapReport> {
    let jobs: Vec<(usize, usize, f64)> = (0..twins.len())
        .flat_map(|l| again.iter().map(move |&(v, m)| (l, v, m)))
        .collect();
    let rerun: Vec<Result<Features>> = jobs
        .par_iter()
        .map(|&(l, v, m)| effect_features_at(d, &twins[l], None, &vars[v], &vars[v].spec(m)))
        .collect();
    // The reference runs and magnitudes they replace, put back for a run set aside.
    let mut reference_runs = Vec::with_capacity(jobs.len());
    for (&(l, v, m), f) in jobs.iter().zip(rerun) {
        let (label, spec) = (twins[l].label.clone(), vars[v].spec(m));
        let f = record_failure(f, &mut failed, &label, &spec, "second pass");
        reference_runs.push(std::mem::replace(&mut twins[l].variant[v], f));
    }
    let references: Vec<f64> = again
        .iter()
        .map(|&(v, m)| std::mem::replace(&mut vars[v].reference, m))
        .collect();
    let (r, ranking) = ranking::scored(d, twins, &vars)?;
    let runs: Vec<SecondPassRun> = again
        .iter()
        .zip(first_scores)
        .map(|(&(v, m), &first)| {
            let score_rerun = score_of(&ranking, v)[0];
            SecondPassRun {
                effect: vars[v].spec(m),
                score_first: first[0],
                score_first_beyond_slip_level: first[1],
                score_rerun,
                kept: rerun_kept(first, score_rerun),
            }
        })
        .collect();
    let mut report = if runs.iter().all(|run| run.kept) {
        // The ranking with the reruns stands: not scored again.
        verdict::report(d, &r, &vars, ranking, failed)?
    } else {
        let aside = |v: usize| {
            again
                .iter()
                .zip(&runs)
                .any(|(&(w, _), run)| w == v && !run.kept)
        };
        for (&(v, _), reference) in again.iter().zip(references) {
            if aside(v) {
                vars[v].reference = reference;
            }
        }
        for (&(l, v, _), before) in jobs.iter().zip(reference_runs) {
            if aside(v) {
                twins[l].variant[v] = before;
            }
        }
        ranking::rank(d, twins, &vars, &failed)?
    };
    report.second_pass = runs;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use baseline::run_spread;
    use features::CELLS;
    use fom::DesignPoint;

    #[test]
    fn a_second_pass_run_is_set_aside_only_where_it_costs_the_very_strong_evidence() {
        let strong = verdict::STRONG_EVIDENCE;
        // Better, or weaker but still very strong: kept.
        assert!(rerun_kept([-40.0, -30.0], -300.0));
        assert!(rerun_kept([-300.0, -30.0], -40.0));
        assert!(rerun_kept([-40.0, -30.0], strong - 0.1));
        // Without very strong evidence before, nothing to lose: kept.
        assert!(rerun_kept([strong + 0.1, -30.0], 500.0));
        // Very strong only in the slip level, which calibration moves: could not name the
        // effect, kept.
        assert!(rerun_kept([-71.4, -2.4], 147.8));
        // A friction drop whose rerun turned very strong evidence into evidence against.
        assert!(!rerun_kept([-40.0, -30.0], 2889.7));
        assert!(!rerun_kept([-40.0, -30.0], strong));
        // A candidate the rerun left unranked (every run failed) is set aside.
        assert!(!rerun_kept([-40.0, -30.0], f64::INFINITY));
    }

    #[test]
    fn run_spread_is_the_sample_sd_per_cell_and_zero_where_a_run_has_no_value() {
        let with = |v: f64| Features {
            cells: vec![features::Measure { value: v, se: 0.1 }; CELLS.len()],
            ..Features::default()
        };
        let spread = run_spread(&with(2.0), &[with(3.0), with(1.0)]);
        assert!(
            spread.iter().all(|&s| (s - 1.0).abs() < 1e-12),
            "{spread:?}"
        );
        let spread = run_spread(&with(2.0), &[with(f64::NAN), with(1.0)]);
        assert!(spread.iter().all(|&s| s == 0.0), "{spread:?}");
    }

    #[test]
    fn a_failed_effect_run_is_recorded_with_its_reason_not_dropped() {
        // A run the model refuses: a fan-pulley runout of 1 m.
        let cfg = DriveConfig::default_hvac();
        let q = DesignPoint::nominal(&cfg);
        let spec = "pulley-eccentricity:pulley=driven,runout_m=1.0";
        let r = twin_runs::run_config(&cfg, &q, &Resolution::default(), 1e-3, 3.0, Some(spec))
            .and_then(|c| twin_runs::run(&c))
            .map(|_| panic!("a 1 m runout must not run"));
        let mut failed = Vec::new();
        assert!(record_failure(r, &mut failed, "d1", spec, "confirmation").is_none());
        assert_eq!(failed.len(), 1);
        let f = &failed[0];
        assert_eq!((f.label.as_str(), f.effect.as_str()), ("d1", spec));
        assert_eq!(f.purpose, "confirmation");
        assert!(f.reason.contains("runout"), "{}", f.reason);
    }
}
