//! `rom train`: the training campaign, then the surrogate fitted to it.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use training::{CampaignSettings, Event};

use super::{drive_config, set_threads, CommandResult};
use crate::args::TrainArgs;
use crate::{kinds, progress};

pub fn run(a: TrainArgs) -> CommandResult {
    let cfg = drive_config(a.config.as_deref())?;
    // A toothed belt's campaign varies side gap, load torque and shaft load.
    let kind = rom::Kind::for_config(&cfg);
    let mut settings = match &a.settings {
        Some(p) => CampaignSettings::from_toml_str(
            &std::fs::read_to_string(p).map_err(|e| format!("reading {}: {e}", p.display()))?,
            &p.display().to_string(),
        )?,
        None => kind.default_settings(),
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
    if a.refine.is_some() && !kind.refines() {
        return Err(
            "--refine: refinement rounds are for the slip surrogate; a toothed campaign is a \
             Latin hypercube (raise --samples)"
                .into(),
        );
    }
    let mut report = run_round(&a, &cfg, &settings)?;
    if let Some(n) = a.refine.filter(|_| report.complete) {
        // The surrogate of the data set as it stands picks the round's points.
        let ds = training::Dataset::load(&a.data)?;
        let s = rom::kind::fit_slip(&ds, a.knee_aligned)?;
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
            .unwrap_or_else(|| a.data.join(kinds::file_in_data_set(kind)));
        fit_and_save(&a, kind, &model)?;
    }
    Ok(())
}

/// Fits the model of `kind` to the complete data set, writes it and prints its summary.
fn fit_and_save(a: &TrainArgs, kind: rom::Kind, model: &Path) -> CommandResult {
    let t = std::time::Instant::now();
    let ds = training::Dataset::load(&a.data)?;
    let file = rom::ModelFile::fit(kind, &ds, a.knee_aligned)?;
    file.save(model)?;
    println!(
        "{}",
        kinds::fit_summary(&file, model, &ds, t.elapsed().as_secs_f64())
    );
    Ok(())
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
