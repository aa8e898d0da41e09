//! `rom train`: the training campaign, then the surrogate fitted to it.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use rom::{Surrogate, SurrogateFile};
use training::{CampaignSettings, Event};

use super::{drive_config, set_threads, CommandResult};
use crate::args::TrainArgs;
use crate::progress;

/// Monte Carlo points of the refused-share estimate (standard error below 0.07 pp at 1 %).
const REFUSED_SHARE_SAMPLES: usize = 20_000;

/// Name of the surrogate file written into the data set when `--model` is not given.
const MODEL_IN_DATA_SET: &str = "surrogate.json";

pub fn run(a: TrainArgs) -> CommandResult {
    let cfg = drive_config(a.config.as_deref())?;
    let toothed = cfg.belt.kind == fom::config::BeltKind::Toothed;
    let mut settings = match &a.settings {
        Some(p) => CampaignSettings::from_toml_str(
            &std::fs::read_to_string(p).map_err(|e| format!("reading {}: {e}", p.display()))?,
            &p.display().to_string(),
        )?,
        // A toothed belt's campaign varies side gap, load torque and shaft load.
        None if toothed => CampaignSettings::toothed_default(),
        None => CampaignSettings::default(),
    };
    if let Some(n) = a.samples {
        settings.samples = n;
    }
    if let Some(s) = a.seed {
        settings.seed = s;
    }
    settings.validate()?;
    set_threads(a.threads)?;
    // `--model` is checked before the campaign (docs/decisions/output-files.md).
    if let Some(m) = &a.model {
        fom::output::check_output_path(m, "--model")?;
    }
    if toothed {
        if a.refine.is_some() {
            return Err(
                "--refine: refinement rounds are for the slip surrogate; a toothed \
                        campaign is a Latin hypercube (raise --samples)"
                    .into(),
            );
        }
        let report = run_round(&a, &cfg, &settings)?;
        if report.complete {
            let model = a
                .model
                .clone()
                .unwrap_or_else(|| a.data.join(TOOTH_MODEL_IN_DATA_SET));
            fit_and_save_tooth(&a.data, &model)?;
        }
        return Ok(());
    }
    let mut report = run_round(&a, &cfg, &settings)?;
    if let Some(n) = a.refine.filter(|_| report.complete) {
        // The surrogate of the data set as it stands picks the round's points.
        let ds = training::Dataset::load(&a.data)?;
        let s = fit(&ds, a.knee_aligned)?;
        let existing: Vec<fom::DesignPoint> = ds.points.iter().map(|p| p.point).collect();
        let seed = settings.seed.wrapping_add(existing.len() as u64);
        let points = rom::refine::refinement_points(&s, &ds.config, &existing, n, seed)?;
        let total = training::add_points(&a.data, &points)?;
        println!(
            "refinement: {} points added where the surrogate is least certain (design now {total})",
            points.len()
        );
        report = run_round(&a, &cfg, &settings)?;
    }
    if report.complete {
        let model = a
            .model
            .clone()
            .unwrap_or_else(|| a.data.join(MODEL_IN_DATA_SET));
        fit_and_save(&a.data, &model, a.knee_aligned)?;
    }
    Ok(())
}

/// The slip surrogate of `ds`, with the knee-aligned input's exponent chosen by likelihood
/// when `knee_aligned`, else on the capacity itself.
fn fit(ds: &training::Dataset, knee_aligned: bool) -> Result<Surrogate, rom::RomError> {
    let exponents: &[f64] = if knee_aligned {
        &rom::surrogate::FRICTION_EXPONENTS
    } else {
        &[0.0]
    };
    Surrogate::fit_with_exponents(ds, rom::surrogate::DEFAULT_ENERGY, exponents)
}

/// Runs (or merges) the campaign's pending points and prints its counts.
fn run_round(
    a: &TrainArgs,
    cfg: &fom::DriveConfig,
    settings: &CampaignSettings,
) -> Result<training::CampaignReport, Box<dyn std::error::Error>> {
    let wall = std::time::Instant::now();
    let report = if a.merge {
        training::merge(&a.data)?
    } else {
        let bar = progress::campaign();
        let failures = AtomicUsize::new(0);
        let on_event = |e: Event| match e {
            Event::Started { pending, done } => {
                bar.set_length(pending as u64);
                bar.set_message(format!("0 not usable ({done} done earlier)"));
            }
            Event::Finished { index, error } => {
                if let Some(err) = error {
                    let n = failures.fetch_add(1, Ordering::Relaxed) + 1;
                    bar.println(format!("point {index} not usable: {err}"));
                    bar.set_message(format!("{n} not usable"));
                }
                bar.inc(1);
            }
        };
        let r = training::run_campaign(&a.data, cfg, settings, a.shard, &on_event)?;
        bar.finish_and_clear();
        r
    };
    println!(
        "campaign {}: {} points, {} run now in {:.1} s, {} done earlier, {} failed, {} \
         unsettled within the longest run, {} with an energy balance off by more than {} % \
         (all three left out of the fit){}",
        a.data.display(),
        report.total,
        report.ran,
        wall.elapsed().as_secs_f64(),
        report.skipped,
        report.failed,
        report.unsettled,
        report.unbalanced,
        fom::output::ENERGY_RESIDUAL_FLAG_PCT,
        if report.complete {
            ""
        } else {
            " (shard finished; join with --merge when all shards are done)"
        }
    );
    Ok(report)
}

/// Name of the tooth-load surrogate written into a toothed data set without `--model`.
const TOOTH_MODEL_IN_DATA_SET: &str = "tooth-surrogate.json";

fn fit_and_save_tooth(data: &Path, model: &Path) -> CommandResult {
    let t = std::time::Instant::now();
    let ds = training::Dataset::load(data)?;
    let hash = training::config_hash(&ds.config);
    let s = rom::tooth::ToothSurrogate::fit(&ds)?;
    let file = rom::tooth::ToothSurrogateFile::new(s, hash);
    file.save(model)?;
    let s = &file.surrogate;
    println!(
        "tooth-load surrogate {}: {} runs ({} failed or unbalanced), {} modes ({:.3} % energy), \
         leave-one-out error (rms) {:.1} % in the mean pass peak and {:.1} % in the run's largest \
         tooth load, sd factor {:.2}, fitted in {:.1} s",
        model.display(),
        s.training_runs,
        s.failed_runs,
        s.model.means.len(),
        100.0 * s.model.basis.energy_kept,
        100.0 * s.loo_rms_rel[0],
        100.0 * s.loo_rms_rel[1],
        s.std_calibration,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

fn fit_and_save(data: &Path, model: &Path, knee_aligned: bool) -> CommandResult {
    let t = std::time::Instant::now();
    let ds = training::Dataset::load(data)?;
    let hash = training::config_hash(&ds.config);
    let s = fit(&ds, knee_aligned)?;
    let file = SurrogateFile::new(s, hash);
    file.save(model)?;
    let s = &file.surrogate;
    println!(
        "surrogate {}: {} runs ({} failed, unsettled or unbalanced; {} on the gross-slip branch, above {} %, left out), start-up {} modes ({:.3} % energy), steady {} modes \
         ({:.3} % energy), leave-one-out sd factor {:.2} ({} at the knee), fitted in {:.1} s",
        model.display(),
        s.training_runs,
        s.failed_runs,
        s.gross_slip_runs,
        rom::surrogate::GROSS_SLIP_PCT,
        s.startup.means.len(),
        100.0 * s.startup.basis.energy_kept,
        s.steady.means.len(),
        100.0 * s.steady.basis.energy_kept,
        s.std_calibration,
        s.std_calibration_knee.map_or_else(
            || "the same".to_string(),
            |k| format!("{k:.2}")
        ),
        t.elapsed().as_secs_f64()
    );
    if s.friction_exponent_likelihoods.len() > 1 {
        let tried: Vec<String> = s
            .friction_exponent_likelihoods
            .iter()
            .map(|(c, ll)| format!("{c} ({ll:.1})"))
            .collect();
        println!(
            "knee-aligned input u mu^c: c = {} by likelihood; tried (log likelihood): {}",
            s.aligned_capacity.map_or(0.0, |a| a.friction_exponent),
            tried.join(", ")
        );
    }
    println!(
        "domain: {:.2} % of the trained box is refused, as looser than any training run (rom \
         predict names the nearest accepted point) or predicted beyond the trained slip",
        100.0 * s.refused_share(&ds.config, REFUSED_SHARE_SAMPLES)
    );
    println!(
        "90 % intervals: leave-one-out, which overstates them after refinement rounds; to \
         calibrate them on held-out runs, `rom validate --model {m} --json V.json` (uniform and \
         --knee, seeds other than {seed}) then `rom validate --model {m} --calibrate-intervals \
         V.json,... --out FILE`",
        m = model.display(),
        seed = s.settings.seed
    );
    Ok(())
}
