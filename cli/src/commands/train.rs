//! `rom train`: the training campaign, then the surrogate fitted to it.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use training::{CampaignSettings, Event};

use super::{drive_config, print_report, set_threads, CommandResult};
use crate::args::{ReportFormat, TrainArgs};
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
    let mut out = TrainReport::default();
    let mut report = run_round(&a, &cfg, &settings, &mut out)?;
    if let Some(n) = a.refine.filter(|_| report.complete) {
        // The surrogate of the data set as it stands picks the round's points.
        let ds = training::Dataset::load(&a.data)?;
        let s = rom::kind::fit_slip(&ds, a.knee_aligned)?;
        let existing: Vec<fom::DesignPoint> = ds.points.iter().map(|p| p.point).collect();
        let seed = settings.seed.wrapping_add(existing.len() as u64);
        let points = rom::refine::refinement_points(&s, &ds.config, &existing, n, seed)?;
        let total = training::add_points(&a.data, &points)?;
        say(
            &a,
            &format!(
                "refinement: {} points added where the surrogate is least certain (design now \
                 {total})",
                points.len()
            ),
        );
        out.refinement_points = Some(points.len());
        report = run_round(&a, &cfg, &settings, &mut out)?;
    }
    if report.complete {
        let model = a
            .model
            .clone()
            .unwrap_or_else(|| a.data.join(kinds::file_in_data_set(kind)));
        fit_and_save(&a, kind, &model, &mut out)?;
    }
    match a.format {
        ReportFormat::Text => Ok(()),
        ReportFormat::Json => print_report(a.format, "", &out),
    }
}

/// What `rom train --format json` prints at the end: the campaign's counts, any refinement
/// round, and the model written.
#[derive(Default, serde::Serialize)]
struct TrainReport {
    data: String,
    total_points: usize,
    ran: usize,
    done_earlier: usize,
    failed: usize,
    unsettled: usize,
    unbalanced: usize,
    complete: bool,
    wall_s: f64,
    refinement_points: Option<usize>,
    model: Option<String>,
    model_id: Option<String>,
    fit_s: Option<f64>,
    summary: Option<String>,
}

/// A line of the readable summary: stdout, or stderr when stdout carries JSON.
fn say(a: &TrainArgs, line: &str) {
    match a.format {
        ReportFormat::Text => println!("{line}"),
        ReportFormat::Json => eprintln!("{line}"),
    }
}

/// Fits the model of `kind` to the complete data set, writes it and prints its summary.
fn fit_and_save(
    a: &TrainArgs,
    kind: rom::Kind,
    model: &Path,
    out: &mut TrainReport,
) -> CommandResult {
    let t = std::time::Instant::now();
    let ds = training::Dataset::load(&a.data)?;
    let file = rom::ModelFile::fit(kind, &ds, a.knee_aligned)?;
    file.save(model)?;
    let fit_s = t.elapsed().as_secs_f64();
    let summary = kinds::fit_summary(&file, model, &ds, fit_s);
    say(a, &summary);
    // The id is the sealed file's: read back what was written.
    out.model_id = rom::ModelFile::load(model)
        .ok()
        .map(|m| m.model_id().to_string());
    out.model = Some(model.display().to_string());
    out.fit_s = Some(fit_s);
    out.summary = Some(summary);
    Ok(())
}

/// Runs (or merges) the campaign's pending points and prints its counts.
fn run_round(
    a: &TrainArgs,
    cfg: &fom::DriveConfig,
    settings: &CampaignSettings,
    out: &mut TrainReport,
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
    let wall_s = wall.elapsed().as_secs_f64();
    let line = format!(
        "campaign {}: {} points, {} run now in {:.1} s, {} done earlier, {} failed, {} \
         unsettled within the longest run, {} with an energy balance off by more than {} % \
         (all three left out of the fit){}",
        a.data.display(),
        report.total,
        report.ran,
        wall_s,
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
    say(a, &line);
    *out = TrainReport {
        data: a.data.display().to_string(),
        total_points: report.total,
        ran: out.ran + report.ran,
        done_earlier: report.skipped,
        failed: report.failed,
        unsettled: report.unsettled,
        unbalanced: report.unbalanced,
        complete: report.complete,
        wall_s: out.wall_s + wall_s,
        refinement_points: out.refinement_points,
        ..TrainReport::default()
    };
    Ok(report)
}
