//! Running a campaign: every design point through the full-order model, in parallel (rayon),
//! resumable, shardable over the nodes of a cluster.

use std::path::Path;
use std::time::Instant;

use fom::belt_kind::tooth_record::ToothRecord;
use fom::output::write_run_csv;
use fom::{DesignPoint, DriveConfig, RunOptions, ValidConfig};
use rayon::prelude::*;

use crate::dataset::{
    config_hash, read_design, read_header, read_status, run_csv_path, status_path,
    tooth_peaks_path, write_design, write_points, write_status, write_text, write_tooth_peaks,
    CampaignHeader, PointRecord, PointStatus, CAMPAIGN_FILE, CAMPAIGN_FORMAT, DESIGN_FILE,
    DRIVE_FILE, POINTS_FILE, RUNS_DIR,
};
use crate::design::latin_hypercube_about;
use crate::settings::CampaignSettings;
use crate::TrainingError;

/// Share `index` (1-based) of `count` equal shares: points with `i % count == index - 1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// Parses `I/N` with 1 <= I <= N.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || format!("shard `{s}` is not I/N with 1 <= I <= N (e.g. 3/8)");
        let (i, n) = s.split_once('/').ok_or_else(err)?;
        let index: usize = i.trim().parse().map_err(|_| err())?;
        let count: usize = n.trim().parse().map_err(|_| err())?;
        if index == 0 || count == 0 || index > count {
            return Err(err());
        }
        Ok(Self { index, count })
    }
}

impl Shard {
    pub fn owns(&self, point: usize) -> bool {
        point % self.count == self.index - 1
    }
}

/// What the campaign reports while it runs.
#[derive(Debug, Clone)]
pub enum Event {
    /// `pending` points of this share still to run, `done` finished earlier (resumed).
    Started { pending: usize, done: usize },
    /// A point finished; `error` is set for a failed run.
    Finished { index: usize, error: Option<String> },
}

/// Counts at the end of a campaign call.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignReport {
    pub total: usize,
    /// Points of this share run in this call.
    pub ran: usize,
    /// Points of this share that were already finished (resume).
    pub skipped: usize,
    /// Failed points among all finished ones.
    pub failed: usize,
    /// Points that ran to the longest duration without settling.
    pub unsettled: usize,
    /// Settled points whose energy balance did not close (a numerical artefact; not used).
    pub unbalanced: usize,
    /// Whether `points.csv` was written (every point finished).
    pub complete: bool,
}

/// The configuration of one design point: the base drive moved to the point, running until
/// settled within the campaign's shortest and longest run.
pub fn point_config(
    base: &DriveConfig,
    settings: &CampaignSettings,
    p: &DesignPoint,
) -> fom::Result<ValidConfig> {
    if settings.tooth.is_some() {
        // A toothed run is the configuration's start-up, as long as the configuration says.
        return p.apply(base);
    }
    // The run's settings first (the design point moves none of them), then the point: the
    // moved configuration is checked once, by `apply`.
    let mut run = base.clone();
    run.simulation.duration_s = settings.duration_s;
    run.simulation.steady_start_s = None;
    run.simulation.until_settled = Some(settings.until_settled());
    p.apply(&run)
}

/// Creates the data set directory, or checks that an existing one was made with the same
/// settings and configuration (so a resumed or sharded campaign cannot mix two designs).
fn open_or_create(
    dir: &Path,
    base: &DriveConfig,
    settings: &CampaignSettings,
) -> Result<Vec<DesignPoint>, TrainingError> {
    settings.validate()?;
    let header = CampaignHeader {
        format: CAMPAIGN_FORMAT.into(),
        crate_version: env!("CARGO_PKG_VERSION").into(),
        config_sha256: config_hash(base),
        settings: settings.clone(),
    };
    if dir.join(CAMPAIGN_FILE).exists() {
        let old = read_header(dir)?;
        if old.config_sha256 != header.config_sha256 {
            return Err(TrainingError::Mismatch(format!(
                "{} holds a campaign on another drive configuration (sha256 {} vs {}); use a \
                 new data-set directory",
                dir.display(),
                &old.config_sha256[..12],
                &header.config_sha256[..12]
            )));
        }
        if old.settings != header.settings {
            return Err(TrainingError::Mismatch(format!(
                "{} holds a campaign with other settings ({:?}); use a new data-set directory or \
                 the same settings",
                dir.display(),
                old.settings
            )));
        }
        return read_design(&dir.join(DESIGN_FILE));
    }
    check_some_corner_runs(base, settings)?;
    std::fs::create_dir_all(dir.join(RUNS_DIR)).map_err(|source| TrainingError::Io {
        context: format!("creating {}", dir.join(RUNS_DIR).display()),
        source,
    })?;
    let design = latin_hypercube_about(
        &DesignPoint::nominal(base),
        &settings.ranges(),
        settings.samples,
        settings.seed,
    );
    write_text(&dir.join(DRIVE_FILE), &base.to_toml_string())?;
    write_design(&dir.join(DESIGN_FILE), &design)?;
    // The header last: it marks a fully initialised data set.
    write_text(
        &dir.join(CAMPAIGN_FILE),
        &toml::to_string(&header).expect("header serialises"),
    )?;
    Ok(design)
}

/// Refuses a toothed campaign ([tooth] ranges) on a belt that is not toothed, and the other
/// way round.
fn check_kind(base: &DriveConfig, settings: &CampaignSettings) -> Result<(), TrainingError> {
    let toothed = base.belt.kind == fom::config::BeltKind::Toothed;
    match (toothed, settings.tooth.is_some()) {
        (true, false) => Err(TrainingError::Settings(
            "the drive has a toothed belt: its campaign varies side gap, load torque and shaft \
             load (settings table [tooth]), not centre distance, friction and tension"
                .into(),
        )),
        (false, true) => Err(TrainingError::Settings(format!(
            "settings table [tooth] applies to a toothed belt (belt.kind = \"toothed\"); this \
             belt is \"{}\"",
            base.belt.kind.name()
        ))),
        _ => Ok(()),
    }
}

/// Refuses a design box none of whose corners can even be built (belt slack or overstretched,
/// step above the stability limit, ...): every point would fail after running.
/// Building a model is cheap (no dynamics). Slack and overstretch are monotone in distance,
/// tension and stiffness, so a box whose every corner fails holds no buildable point along
/// those variables; a box with some buildable corners runs, and its failed points are recorded.
fn check_some_corner_runs(
    base: &DriveConfig,
    settings: &CampaignSettings,
) -> Result<(), TrainingError> {
    let ranges = settings.ranges();
    let vars: Vec<_> = ranges.iter().map(|(v, _)| *v).collect();
    let mut reasons: Vec<String> = Vec::new();
    for mask in 0..1usize << ranges.len() {
        let x: Vec<f64> = (0..ranges.len())
            .map(|i| ranges[i].1[(mask >> i) & 1])
            .collect();
        let p = DesignPoint::nominal(base).with_columns(&vars, &x);
        match point_config(base, settings, &p).and_then(|cfg| fom::Model::from_config(&cfg)) {
            Ok(_) => return Ok(()),
            Err(e) => {
                if reasons.len() < 3 {
                    let at: Vec<String> = vars
                        .iter()
                        .zip(&x)
                        .map(|(v, x)| format!("{} = {x}", v.key()))
                        .collect();
                    reasons.push(format!("at {}: {e}", at.join(", ")));
                }
            }
        }
    }
    Err(TrainingError::Settings(format!(
        "no corner of the design box can run, so no point would; e.g. {}",
        reasons.join("; ")
    )))
}

/// Runs one point; a failure (error or panic) becomes a `failed` status, never an abort.
fn run_point(
    dir: &Path,
    base: &DriveConfig,
    settings: &CampaignSettings,
    index: usize,
    p: &DesignPoint,
) -> Result<PointStatus, TrainingError> {
    let wall = Instant::now();
    let outcome = point_config(base, settings, p).and_then(|cfg| {
        std::panic::catch_unwind(|| fom::simulate(&cfg, RunOptions::default())).unwrap_or_else(
            |panic| {
                let what = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                Err(fom::FomError::Step(format!(
                    "panic in the full-order model: {what}"
                )))
            },
        )
    });
    let status = match outcome {
        Ok(run) if settings.tooth.is_some() => {
            write_run_csv(&run_csv_path(dir, index), &run.rows)?;
            tooth_status(dir, index, &run, wall)?
        }
        Ok(run) => {
            write_run_csv(&run_csv_path(dir, index), &run.rows)?;
            let sm = &run.summary;
            // Only a settled run whose energy balance closes is a data point.
            let (status, error) = match sm.steady_data() {
                Ok(_) => ("ok", None),
                Err(why) => (why.status(), Some(why.to_string())),
            };
            PointStatus {
                status: status.into(),
                wall_time_s: wall.elapsed().as_secs_f64(),
                simulated_s: Some(sm.simulated_s),
                steady_start_s: sm.settling.start_s(),
                mean_slip_pct: sm.settling.is_settled().then_some(sm.mean_slip_pct),
                energy_residual_pct: Some(sm.energy.residual_pct()),
                error,
                max_tooth_load_n: None,
            }
        }
        Err(e) => PointStatus {
            status: "failed".into(),
            wall_time_s: wall.elapsed().as_secs_f64(),
            simulated_s: None,
            steady_start_s: None,
            mean_slip_pct: None,
            energy_residual_pct: None,
            error: Some(e.to_string()),
            max_tooth_load_n: None,
        },
    };
    write_status(&status_path(dir, index), &status)?;
    Ok(status)
}

/// The outcome of a toothed run: its tooth-root load peaks in the tooth-load window
/// (`fom::belt_kind::tooth_record::tooth_load_window_start_s`) written beside its series; `ok` when
/// its energy balance closes and the window holds passes, `unbalanced` or `failed` otherwise. A
/// toothed run is a start-up of fixed length, so it is not asked to settle.
fn tooth_status(
    dir: &Path,
    index: usize,
    run: &fom::RunResult,
    wall: Instant,
) -> Result<PointStatus, TrainingError> {
    let sm = &run.summary;
    let Some(teeth) = run.record::<ToothRecord>() else {
        return Err(TrainingError::Settings(
            "a toothed campaign's run recorded no tooth loads".into(),
        ));
    };
    let peaks = teeth.window_pass_peaks_n();
    write_tooth_peaks(&tooth_peaks_path(dir, index), &peaks)?;
    let (status, error) = match sm.energy_warning() {
        Some(w) => ("unbalanced", Some(w)),
        None if peaks.is_empty() => (
            "failed",
            Some("no complete tooth pass in the tooth-load window (run too short)".to_string()),
        ),
        None => ("ok", None),
    };
    Ok(PointStatus {
        status: status.into(),
        wall_time_s: wall.elapsed().as_secs_f64(),
        simulated_s: Some(sm.simulated_s),
        steady_start_s: None,
        mean_slip_pct: None,
        energy_residual_pct: Some(sm.energy.residual_pct()),
        error,
        max_tooth_load_n: Some(teeth.max_flank_load_n()),
    })
}

/// The campaign directory's advisory locks (std's `File::lock`, `flock(2)` on Unix): the run
/// lock is held exclusively by an unsharded run, a refinement round and a merge, and shared by
/// the shards, so that two processes never run the same points or mix two designs; the
/// creation lock serialises creating the data set, so that a second process started at the
/// same moment reads the first one's header and is refused if its settings differ. Advisory
/// locks may not reach across the nodes of a network file system: there the shards rely on
/// owning disjoint points, and the merge on all of them having ended.
const RUN_LOCK: &str = ".campaign.lock";
const CREATE_LOCK: &str = ".create.lock";

/// How a process holds the run lock.
#[derive(Clone, Copy, PartialEq)]
enum Hold {
    Exclusive,
    Shared,
}

/// Takes the run lock of `dir` (created if need be) without waiting; the open file holds it
/// until dropped. Taken exclusively, it also removes the temporary files of writers killed
/// mid-write (`remove_stale_temporaries`).
fn lock_run(dir: &Path, hold: Hold) -> Result<std::fs::File, TrainingError> {
    std::fs::create_dir_all(dir).map_err(|source| TrainingError::Io {
        context: format!("creating {}", dir.display()),
        source,
    })?;
    let path = dir.join(RUN_LOCK);
    let file = open_lock_file(&path)?;
    let taken = match hold {
        Hold::Exclusive => file.try_lock(),
        Hold::Shared => file.try_lock_shared(),
    };
    match taken {
        Ok(()) => {
            // With the directory to itself, a process clears what killed writers left.
            if hold == Hold::Exclusive {
                remove_stale_temporaries(dir)?;
            }
            Ok(file)
        }
        Err(std::fs::TryLockError::WouldBlock) => Err(TrainingError::Busy(format!(
            "{} is in use by another `rom train` ({}); wait for it to end{}",
            dir.display(),
            path.display(),
            if hold == Hold::Shared {
                " (shards of one campaign may run together, an unsharded run or a merge may not)"
            } else {
                ""
            }
        ))),
        Err(std::fs::TryLockError::Error(source)) => Err(TrainingError::Io {
            context: format!("locking {}", path.display()),
            source,
        }),
    }
}

/// Takes the lock of one shard of `dir` without waiting: held by the process running that
/// shard, so that a second process given the same shard is refused instead of running the
/// same points (`flock(2)`, released when the holder dies, so a requeued task takes it over).
fn lock_shard(dir: &Path, shard: Shard) -> Result<std::fs::File, TrainingError> {
    let path = dir.join(format!(".shard-{}-of-{}.lock", shard.index, shard.count));
    let file = open_lock_file(&path)?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(TrainingError::Busy(format!(
            "shard {}/{} of {} is already running in another process ({})",
            shard.index,
            shard.count,
            dir.display(),
            path.display()
        ))),
        Err(std::fs::TryLockError::Error(source)) => Err(TrainingError::Io {
            context: format!("locking {}", path.display()),
            source,
        }),
    }
}

/// Runs `f` holding the creation lock of `dir` (waiting for it).
fn while_creating<T>(
    dir: &Path,
    f: impl FnOnce() -> Result<T, TrainingError>,
) -> Result<T, TrainingError> {
    let path = dir.join(CREATE_LOCK);
    // Bound to a name: the lock lasts as long as the open file, through `f`.
    let file = open_lock_file(&path)?;
    file.lock().map_err(|source| TrainingError::Io {
        context: format!("locking {}", path.display()),
        source,
    })?;
    f()
}

/// Removes what writers killed mid-write left in the data set (`.NAME.PID-....tmp`).
/// Only under the exclusive run lock: a shard's write in progress is never touched.
fn remove_stale_temporaries(dir: &Path) -> Result<(), TrainingError> {
    for d in [dir.to_path_buf(), dir.join(RUNS_DIR)] {
        if d.is_dir() {
            fom::output::remove_stale_temporaries(&d).map_err(|source| TrainingError::Io {
                context: format!("removing stale temporary files in {}", d.display()),
                source,
            })?;
        }
    }
    Ok(())
}

/// Opens (creating, never truncating) a lock file.
fn open_lock_file(path: &Path) -> Result<std::fs::File, TrainingError> {
    std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .map_err(|source| TrainingError::Io {
            context: format!("opening {}", path.display()),
            source,
        })
}

/// Runs the campaign's share of points that have not finished yet. An unsharded call that
/// leaves every point finished also writes `points.csv`; sharded calls leave that to [`merge`].
pub fn run_campaign(
    dir: &Path,
    base: &DriveConfig,
    settings: &CampaignSettings,
    shard: Option<Shard>,
    on_event: &(dyn Fn(Event) + Sync),
) -> Result<CampaignReport, TrainingError> {
    // Bad settings are refused before anything (the lock file, the directory) is written.
    settings.validate()?;
    check_kind(base, settings)?;
    let _run = lock_run(
        dir,
        if shard.is_some() {
            Hold::Shared
        } else {
            Hold::Exclusive
        },
    )?;
    // Two tasks of one shard (a requeued task and its killed predecessor's leftovers, or a
    // task submitted twice) never run the same points together.
    let _share = shard.map(|s| lock_shard(dir, s)).transpose()?;
    let design = while_creating(dir, || open_or_create(dir, base, settings))?;
    let mine: Vec<usize> = (0..design.len())
        .filter(|&i| shard.is_none_or(|s| s.owns(i)))
        .collect();
    let pending: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|&i| read_status(&status_path(dir, i)).is_err())
        .collect();
    let skipped = mine.len() - pending.len();
    on_event(Event::Started {
        pending: pending.len(),
        done: skipped,
    });
    let results: Vec<Result<PointStatus, TrainingError>> = pending
        .par_iter()
        .map(|&i| {
            let r = run_point(dir, base, settings, i, &design[i]);
            on_event(Event::Finished {
                index: i,
                error: match &r {
                    Ok(s) => s.error.clone(),
                    Err(e) => Some(e.to_string()),
                },
            });
            r
        })
        .collect();
    // An I/O error writing the data set is an error of the campaign, not of a point.
    for r in &results {
        if let Err(e) = r {
            return Err(TrainingError::Data {
                path: dir.display().to_string(),
                message: format!("writing results: {e}"),
            });
        }
    }
    let ran = results.len();
    let (records, missing) = collect(dir, &design)?;
    let complete = shard.is_none() && missing.is_empty();
    if complete {
        write_points(&dir.join(POINTS_FILE), &records)?;
    }
    Ok(CampaignReport {
        total: design.len(),
        ran,
        skipped,
        failed: count_status(&records, "failed"),
        unsettled: count_status(&records, "unsettled"),
        unbalanced: count_status(&records, "unbalanced"),
        complete,
    })
}

/// Creates the data set of a campaign without running anything (or checks an existing one
/// made with the same settings and configuration), so that a cluster submission is refused
/// before any job is queued. Returns the number of points in the design.
pub fn prepare(
    dir: &Path,
    base: &DriveConfig,
    settings: &CampaignSettings,
) -> Result<usize, TrainingError> {
    settings.validate()?;
    check_kind(base, settings)?;
    let _run = lock_run(dir, Hold::Shared)?;
    Ok(while_creating(dir, || open_or_create(dir, base, settings))?.len())
}

/// Where a campaign stands: its points by outcome, from the data set alone.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Progress {
    pub total: usize,
    /// Points whose run finished and is a data point (`ok`).
    pub done: Vec<usize>,
    /// Points whose run finished without a data point, with their status (`failed`,
    /// `unsettled`, `unbalanced`) and error.
    pub failed: Vec<(usize, String, Option<String>)>,
    /// Points not finished yet (queued, or running now).
    pub pending: Vec<usize>,
    /// Whether `points.csv` is there (every point finished and joined).
    pub joined: bool,
}

/// Reads where the campaign in `dir` stands. Takes no lock: it may be read while shards run
/// (a point is finished once its status file is in place, `dataset`).
pub fn progress(dir: &Path) -> Result<Progress, TrainingError> {
    read_header(dir)?;
    let design = read_design(&dir.join(DESIGN_FILE))?;
    let (records, pending) = collect(dir, &design)?;
    let mut out = Progress {
        total: design.len(),
        pending,
        joined: dir.join(POINTS_FILE).exists(),
        ..Progress::default()
    };
    for r in records {
        if r.status.is_ok() {
            out.done.push(r.index);
        } else {
            out.failed.push((r.index, r.status.status, r.status.error));
        }
    }
    Ok(out)
}

fn count_status(records: &[PointRecord], status: &str) -> usize {
    records.iter().filter(|r| r.status.status == status).count()
}

fn collect(
    dir: &Path,
    design: &[DesignPoint],
) -> Result<(Vec<PointRecord>, Vec<usize>), TrainingError> {
    let mut records = Vec::new();
    let mut missing = Vec::new();
    for (index, p) in design.iter().enumerate() {
        let path = status_path(dir, index);
        if path.exists() {
            records.push(PointRecord {
                index,
                point: *p,
                status: read_status(&path)?,
            });
        } else {
            missing.push(index);
        }
    }
    Ok((records, missing))
}

/// Appends a refinement round of `points` to the design of the campaign in `dir`: they get the
/// next indices and run with the next `run_campaign` call (any shard layout; resumable like the
/// first round). `points.csv` is removed until they have all finished. Returns the new size.
pub fn add_points(dir: &Path, points: &[DesignPoint]) -> Result<usize, TrainingError> {
    read_header(dir)?;
    let _run = lock_run(dir, Hold::Exclusive)?;
    let path = dir.join(DESIGN_FILE);
    let mut design = read_design(&path)?;
    design.extend_from_slice(points);
    write_design(&path, &design)?;
    let summary = dir.join(POINTS_FILE);
    if summary.exists() {
        std::fs::remove_file(&summary).map_err(|source| TrainingError::Io {
            context: format!("removing {}", summary.display()),
            source,
        })?;
    }
    Ok(design.len())
}

/// Joins the shards of a campaign (all written into `dir`): checks every point has finished
/// and writes `points.csv`. Names the missing points otherwise.
pub fn merge(dir: &Path) -> Result<CampaignReport, TrainingError> {
    read_header(dir)?;
    let _run = lock_run(dir, Hold::Exclusive)?;
    let design = read_design(&dir.join(DESIGN_FILE))?;
    let (records, missing) = collect(dir, &design)?;
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
        return Err(TrainingError::Incomplete(format!(
            "{} of {} points in {} have not finished (e.g. {}); run the missing shards first",
            missing.len(),
            design.len(),
            dir.display(),
            shown.join(", ")
        )));
    }
    write_points(&dir.join(POINTS_FILE), &records)?;
    Ok(CampaignReport {
        total: design.len(),
        ran: 0,
        skipped: 0,
        failed: count_status(&records, "failed"),
        unsettled: count_status(&records, "unsettled"),
        unbalanced: count_status(&records, "unbalanced"),
        complete: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_parses_and_partitions() {
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!(s, Shard { index: 2, count: 3 });
        assert!(s.owns(1) && s.owns(4) && !s.owns(0) && !s.owns(2));
        for bad in ["0/3", "4/3", "1/0", "x/2", "2", "1/2/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad} accepted");
        }
        let shards: Vec<Shard> = (1..=3).map(|i| Shard { index: i, count: 3 }).collect();
        for p in 0..20 {
            assert_eq!(shards.iter().filter(|s| s.owns(p)).count(), 1);
        }
    }
}
