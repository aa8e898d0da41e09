//! `rom train`: the training campaign, then the surrogate fitted to it.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use training::{CampaignSettings, Event};

use super::{drive_config, print_report, set_threads, CommandResult};
use crate::args::{ReportFormat, TrainArgs};
use crate::{kinds, progress};

pub fn run(a: TrainArgs) -> CommandResult {
    if a.status {
        return status(&a);
    }
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
    if (a.refine.is_some() || a.plan.is_some()) && !kind.refines() {
        return Err(
            "--refine: refinement rounds are for the slip surrogate; a toothed campaign is a \
             Latin hypercube (raise --samples)"
                .into(),
        );
    }
    if a.rounds == Some(0) || a.refine == Some(0) || a.plan == Some(0) {
        return Err("--refine, --rounds and --plan take at least 1".into());
    }
    if a.submit.is_some() {
        return submit(&a, &cfg, &settings);
    }
    let mut out = TrainReport::default();
    let mut report = run_round(&a, &cfg, &settings, &mut out)?;
    if let Some(n) = a.plan {
        // The fit-and-plan step of a cluster campaign: the round is run by the shards.
        plan_round(&a, &settings, n, &mut out)?;
        return finish(&a, &out);
    }
    for _ in 0..a.refine.map_or(0, |_| a.rounds.unwrap_or(1)) {
        let Some(n) = a.refine.filter(|_| report.complete) else {
            break;
        };
        plan_round(&a, &settings, n, &mut out)?;
        report = run_round(&a, &cfg, &settings, &mut out)?;
    }
    if report.complete {
        let model = a
            .model
            .clone()
            .unwrap_or_else(|| a.data.join(kinds::file_in_data_set(kind)));
        fit_and_save(&a, kind, &model, &mut out)?;
    }
    finish(&a, &out)
}

/// Prints the JSON report when asked for.
fn finish(a: &TrainArgs, out: &TrainReport) -> CommandResult {
    match a.format {
        ReportFormat::Text => Ok(()),
        ReportFormat::Json => print_report(a.format, "", out),
    }
}

/// Adds a refinement round of `n` points to the complete data set: the surrogate of the data
/// set as it stands picks them (`rom::refine`). The one place a round is planned, whether the
/// round then runs here or on a cluster's shards.
fn plan_round(
    a: &TrainArgs,
    settings: &CampaignSettings,
    n: usize,
    out: &mut TrainReport,
) -> CommandResult {
    let ds = training::Dataset::load(&a.data)?;
    let s = rom::kind::fit_slip(&ds, a.knee_aligned)?;
    let existing: Vec<fom::DesignPoint> = ds.points.iter().map(|p| p.point).collect();
    let seed = settings.seed.wrapping_add(existing.len() as u64);
    let points = rom::refine::refinement_points(&s, &ds.config, &existing, n, seed)?;
    let total = training::add_points(&a.data, &points)?;
    say(
        a,
        &format!(
            "refinement: {} points added where the surrogate is least certain (design now \
             {total})",
            points.len()
        ),
    );
    out.refinement_points = Some(out.refinement_points.unwrap_or(0) + points.len());
    Ok(())
}

/// `rom train --status`: the campaign's points by outcome, from the data set alone.
fn status(a: &TrainArgs) -> CommandResult {
    let p = training::progress(&a.data)?;
    if a.format == ReportFormat::Json {
        return print_report(a.format, "", &p);
    }
    println!(
        "campaign {}: {} points, {} done, {} failed, {} pending{}",
        a.data.display(),
        p.total,
        p.done.len(),
        p.failed.len(),
        p.pending.len(),
        if p.joined {
            " (joined: points.csv written)"
        } else {
            ""
        }
    );
    for (index, status, error) in &p.failed {
        println!(
            "failed: point {index} ({status}{})",
            error.as_deref().map_or(String::new(), |e| format!(": {e}"))
        );
    }
    if !p.pending.is_empty() {
        let shown: Vec<String> = p.pending.iter().map(|i| i.to_string()).collect();
        println!("pending: points {}", shown.join(", "));
    }
    Ok(())
}

/// `rom train --submit slurm`: prepares the data set (so bad settings are refused before any
/// job is queued), writes the job scripts into it and submits the whole campaign.
fn submit(a: &TrainArgs, cfg: &fom::DriveConfig, settings: &CampaignSettings) -> CommandResult {
    if a.array_size == 0 {
        return Err("--array-size must be at least 1".into());
    }
    training::cluster::check_slurm()?;
    let total = training::prepare(&a.data, cfg, settings)?;
    let absolute = |p: &Path, flag: &str| {
        std::path::absolute(p).map_err(|e| format!("{flag} {}: {e}", p.display()))
    };
    let mut flags: Vec<String> = Vec::new();
    if let Some(c) = &a.config {
        flags.extend([
            "--config".into(),
            absolute(c, "--config")?.display().to_string(),
        ]);
    }
    if let Some(s) = &a.settings {
        flags.extend([
            "--settings".into(),
            absolute(s, "--settings")?.display().to_string(),
        ]);
    }
    if let Some(n) = a.samples {
        flags.extend(["--samples".into(), n.to_string()]);
    }
    if let Some(s) = a.seed {
        flags.extend(["--seed".into(), s.to_string()]);
    }
    if a.knee_aligned {
        flags.push("--knee-aligned".into());
    }
    let campaign = training::cluster::ClusterCampaign {
        rom: std::env::current_exe().map_err(|e| format!("locating the rom binary: {e}"))?,
        data: absolute(&a.data, "--data")?,
        flags,
        shards: a.array_size,
        rounds: a.refine.map_or(vec![], |n| vec![n; a.rounds.unwrap_or(1)]),
        model: a
            .model
            .as_deref()
            .map(|m| absolute(m, "--model"))
            .transpose()?,
    };
    let opts = training::cluster::SlurmOptions {
        partition: a.partition.clone(),
        time: a.time.clone(),
    };
    let jobs = training::cluster::submit_slurm(&campaign, &opts)?;
    let mut report = SubmitReport {
        data: campaign.data.display().to_string(),
        design_points: total,
        jobs: Vec::new(),
    };
    for j in &jobs {
        let line = format!(
            "submitted {} as Slurm job {}{} ({})",
            j.step.name(),
            j.id,
            if j.step.is_array() {
                format!(", array 1-{}", campaign.shards)
            } else {
                String::new()
            },
            j.script.display()
        );
        say(a, &line);
        report.jobs.push((j.step.name(), j.id.clone()));
    }
    say(
        a,
        &format!(
            "campaign {}: {total} design points; follow it with `rom train --data {} --status`",
            campaign.data.display(),
            campaign.data.display()
        ),
    );
    match a.format {
        ReportFormat::Text => Ok(()),
        ReportFormat::Json => print_report(a.format, "", &report),
    }
}

/// What `rom train --submit --format json` prints: the data set and each job's name and id.
#[derive(serde::Serialize)]
struct SubmitReport {
    data: String,
    design_points: usize,
    jobs: Vec<(String, String)>,
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
    let report = if a.merge || a.plan.is_some() {
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
