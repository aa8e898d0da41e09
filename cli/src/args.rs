//! Every flag of `rom`, in one place (clap derive). The library crates never see a flag name:
//! [`flag_for`] names the flag behind a library parameter when an error is shown.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use crate::values::{at_least_one, effect, non_negative, positive, side_gap, EffectSpec};

/// The flag that sets a library input named in an error (`InvalidArgument`); `None` for an
/// input no flag of `rom` sets.
pub fn flag_for(input: rom::Input) -> Option<&'static str> {
    use fom::params::Variable;
    use rom::Input;
    Some(match input {
        Input::FrictionSamples => "--samples",
        Input::ValidationPoints => "--points",
        Input::SampleRate => "--sample-rate",
        Input::PulsesPerRev => "--pulses-per-rev",
        Input::SpeedNoise => "--speed-noise",
        Input::TimerResolution => "--timer-resolution",
        Input::MissingPulseShare => "--missing-pulse-share",
        Input::ConditionLabel => "--label",
        Input::Variable(Variable::AxialStiffness) => "--stiffness",
        Input::CalibrationTolerance => "--tolerance",
        // Named as they are: the message already speaks the user's terms.
        Input::Variable(_) | Input::HeldOutRuns | Input::Holdout => return None,
    })
}

/// The rules every help line follows, stated once (`rom --help`).
pub const CONVENTIONS: &str =
    "Conventions: every physical quantity's help line ends its name with \
its SI unit after a comma (\"Centre distance, m\"); a value with a unit suffix says so \
(--side-gap 0.25mm). Defaults are shown as [default: VALUE], or [default: from the drive \
configuration] / [default: from the model] where the drive or the model sets them. Usage \
errors exit 2, bad input (a file, a value refused after parsing) exits 1. \
Guides: docs/guide/<command>.md; units: docs/decisions/units-in-help.md.";

#[derive(Parser)]
#[command(
    name = "rom",
    version,
    about = "beltwin: digital twin of belt-pulley drives",
    after_help = CONVENTIONS
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Run the full-order model (finite-segment belt) and write its time series.
    Simulate(SimulateArgs),
    /// Run the training campaign (Latin hypercube through the full-order model) and fit the
    /// surrogate to it.
    Train(TrainArgs),
    /// Predict the steady slip distribution at a centre distance with the surrogate (or a
    /// toothed belt's tooth loads).
    Predict(PredictArgs),
    /// What a model file is: its kind, inputs and trained ranges, provenance and validation.
    Info(InfoArgs),
    /// Compare the surrogate with fresh full-order runs at points it was not trained on.
    Validate(ValidateArgs),
    /// Diagnose belt looseness from measured speeds (format belt-measurements/1).
    Diagnose(DiagnoseArgs),
    /// Calibrate the twin to measured slip (model updating).
    Calibrate(CalibrateArgs),
    /// Sim-to-real gap: where the calibrated twin misses measured runs, which unmodelled
    /// effect explains it, and how far the gap shrinks on withheld labels once it is modelled.
    Gap(GapArgs),
    /// The online twin: watch many drives (a replayed data set or MQTT), diagnose each steady
    /// segment, keep alarms with hysteresis, store in SQLite, serve an HTTP API and dashboard.
    Serve(ServeArgs),
    /// Export the surrogate or the full-order model as an FMI 2.0 co-simulation FMU.
    ExportFmu(ExportFmuArgs),
}

/// What a command prints: a readable report or one JSON object (nothing else on stdout).
/// The cluster schedulers `rom train --submit` knows.
#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum Scheduler {
    // Slurm: `sbatch` array jobs chained with `--dependency=afterok`.
    Slurm,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum ReportFormat {
    Text,
    Json,
}

/// What `rom predict` prints: text, JSON, or CSV rows.
#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum Format {
    Text,
    Json,
    Csv,
}

/// What `rom export-fmu` wraps.
#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
pub enum FmuKindArg {
    /// The slip surrogate: `rom predict` at the FMU's inputs.
    Surrogate,
    /// The full-order model: `rom simulate` stepped inside the FMU.
    Fom,
}

#[derive(clap::Args)]
pub struct ExportFmuArgs {
    /// Which model the FMU wraps.
    #[arg(long, value_enum)]
    pub kind: FmuKindArg,
    /// Slip surrogate file (surrogate kind) [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration (TOML): the full-order model's, or the one the surrogate was
    /// trained on. [default: from the surrogate; for fom, the shipped drive]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The FMU file to write (NAME.fmu).
    #[arg(long)]
    pub out: PathBuf,
    /// The FMU binary (libbeltwin_fmu.so). [default: beside the rom executable]
    #[arg(long)]
    pub fmu_lib: Option<PathBuf>,
}

#[derive(clap::Args)]
pub struct InfoArgs {
    /// Model file. [default: the shipped slip surrogate; with --config of a toothed drive, the
    /// shipped tooth-load surrogate]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration whose shipped model to describe (TOML).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// What to print.
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
}

#[derive(clap::Args)]
pub struct GapArgs {
    /// Measured data set directory (with manifest.toml).
    #[arg(long)]
    pub measured: PathBuf,
    /// Surrogate file [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration the surrogate must have been trained on. [default: from the model]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Labels withheld from calibration and effect fits, on which the gap before and after is
    /// measured (comma list). [default: leave one label out at a time]
    #[arg(long, value_delimiter = ',')]
    pub holdout: Vec<String>,
    /// Write gap.txt, gap.json and gap.html (heat map, distributions) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// What to print.
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Worker threads. [default: all cores]
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// Measured data set directory (with manifest.toml).
    #[arg(long, required_unless_present = "table", conflicts_with = "table")]
    pub measured: Option<PathBuf>,
    /// Instead of recordings: a CSV of mean slips per condition (columns `condition`,
    /// `experiment_mean_slip_pct`; `#` comments), e.g. the HVAC paper's Table 2.
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// Free parameters: friction, tension, ratio, stiffness, distances | spaced-distances
    /// (comma list). [default: friction,tension, plus distances when a condition's distance is
    /// unknown]
    #[arg(long)]
    pub free: Option<twin::calibrate::FreeSet>,
    /// Largest acceptable error per condition, %.
    #[arg(long, default_value_t = 5.0)]
    pub tolerance: f64,
    /// Skip the full-order confirmation of the fitted point.
    #[arg(long)]
    pub no_confirm: bool,
    /// Also calibrate on all conditions but one and predict that one, for each.
    #[arg(long)]
    pub leave_one_out: bool,
    /// With --leave-one-out: at most this many full-order runs per condition stand in for the
    /// posterior predictive's draws where the surrogate is not trusted (past its box, at its
    /// knee), one per stratum of those draws by traction capacity. More runs, a less noisy
    /// median and interval, at a full-order run each (never more runs than draws). Ignored
    /// with --no-confirm.
    #[arg(long, default_value_t = twin::calibrate::PREDICTIVE_FOM_RUNS, value_parser = at_least_one)]
    pub predictive_runs: usize,
    /// Write the calibrated configuration (TOML) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Output: a readable report, or JSON (the calibration and any leave-one-out rows).
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Surrogate file (docs/surrogate.md) [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration the surrogate must have been trained on. [default: from the model]
    #[arg(long)]
    pub config: Option<PathBuf>,
}

#[derive(clap::Args)]
pub struct DiagnoseArgs {
    /// Measured data set directory (with manifest.toml).
    #[arg(long)]
    pub measured: PathBuf,
    /// Write diagnosis.txt, diagnosis.json and slip-boxplots.svg into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// What to print: the readable verdicts, or their JSON (as diagnosis.json).
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Surrogate file (docs/surrogate.md) [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration the surrogate must have been trained on. [default: from the model]
    #[arg(long)]
    pub config: Option<PathBuf>,
}

#[derive(clap::Args)]
pub struct PredictArgs {
    /// Centre distance, m (required by a slip surrogate; a toothed belt's tooth-load surrogate
    /// takes --side-gap, --load-torque and --shaft-load instead).
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub d: Option<f64>,
    /// Side gap of a toothed belt's tooth in its groove, m; or with a unit: 0.25mm, 250um.
    /// [default: from the drive configuration]
    #[arg(long, value_parser = side_gap, conflicts_with = "d")]
    pub side_gap: Option<f64>,
    /// Load torque of a toothed belt's driven shaft, N m. [default: from the drive
    /// configuration]
    #[arg(long, value_parser = non_negative, conflicts_with = "d")]
    pub load_torque: Option<f64>,
    /// Static shaft load of a toothed belt, N. [default: from the drive configuration]
    #[arg(long, value_parser = positive, conflicts_with = "d")]
    pub shaft_load: Option<f64>,
    /// Nominal effective friction coefficient, dimensionless. [default: from the drive
    /// configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub mu: Option<f64>,
    /// Installation tension, N. [default: from the drive configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub tension: Option<f64>,
    /// Effective axial belt stiffness EA, N (surrogates trained over a stiffness range).
    /// [default: from the drive configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub stiffness: Option<f64>,
    /// An effect parameter the surrogate was trained over, NAME:KEY=VALUE[,KEY=VALUE], e.g.
    /// `--effect bearing-drag:coulomb_nm=0.8` (repeatable; keys as in `[effects.<name>]`,
    /// unit in the key's suffix).
    #[arg(long = "effect", alias = "effect-param", value_name = "NAME:KEY=VALUE", value_parser = effect)]
    pub effects: Vec<EffectSpec>,
    /// Friction samples propagated through the surrogate (mu +- 1 %).
    #[arg(long, default_value_t = rom::predict::DEFAULT_SAMPLES, value_parser = at_least_one)]
    pub samples: usize,
    /// What to print: a readable table, JSON, or CSV rows (quantile function).
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Write a box plot (SVG) of the predicted distribution.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write the predicted start-up slip series (CSV time_s,slip_pct).
    #[arg(long)]
    pub startup: Option<PathBuf>,
    /// Surrogate file (docs/surrogate.md) [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Drive configuration the surrogate must have been trained on. [default: from the model]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Predict outside the trained ranges, within physics (docs/decisions/physical-domain.md);
    /// the output is marked EXTRAPOLATED.
    #[arg(long)]
    pub allow_extrapolation: bool,
}

#[derive(clap::Args)]
pub struct ValidateArgs {
    /// Number of fresh Latin-hypercube points.
    #[arg(long, default_value_t = 20)]
    pub points: usize,
    /// Seed of the validation design. [default: from the model, its training seed + 1]
    #[arg(long)]
    pub seed: Option<u64>,
    /// Surrogate file (docs/surrogate.md) [default: the shipped one]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Also write the per-point results as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// What to print: the readable table, or the report's JSON (as --json writes).
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Only points at the looseness knee, chosen by physics: the loosest 5 % (by traction
    /// capacity) of a larger Latin hypercube over the trained box; each point's region is
    /// still decided by its full-order run (knee: settled slip >= 1 %).
    #[arg(long)]
    pub knee: bool,
    /// Only points at the knee's onset outside the knee band: points of a larger Latin
    /// hypercube whose traction capacity lies above the band and whose predicted mean slip is
    /// at least 0.75 % (the interval calibration's onset part).
    #[arg(long, conflicts_with = "knee")]
    pub onset: bool,
    /// Runs nothing: calibrates the surrogate's 90 % intervals on the settled full-order runs
    /// of these earlier `rom validate --json` files (comma-separated; held-out runs, split
    /// conformal, docs/surrogate.md) and writes the surrogate to --out. Their seeds are then
    /// refused by `rom validate` on it.
    #[arg(long, value_name = "FILES", value_delimiter = ',', requires = "out",
          conflicts_with_all = ["knee", "onset", "json", "seed", "format"])]
    pub calibrate_intervals: Vec<PathBuf>,
    /// The surrogate file --calibrate-intervals writes.
    #[arg(long, requires = "calibrate_intervals")]
    pub out: Option<PathBuf>,
    /// Worker threads. [default: all cores]
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(clap::Args)]
pub struct TrainArgs {
    /// Drive configuration (TOML). [default: the shipped HVAC drive, fom/configs/hvac.toml]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Campaign settings (TOML with samples, seed, ranges, duration_s, min_duration_s,
    /// steady_length_s; docs/guide/train.md). [default: the documented defaults]
    #[arg(long)]
    pub settings: Option<PathBuf>,
    /// Number of Latin-hypercube points (overrides the settings file). [default: from the
    /// settings]
    #[arg(long)]
    pub samples: Option<usize>,
    /// Seed of the design (overrides the settings file). [default: from the settings]
    #[arg(long)]
    pub seed: Option<u64>,
    /// Data set directory (created, or resumed if it exists).
    #[arg(long, default_value = "training-data")]
    pub data: PathBuf,
    /// Surrogate file written after the campaign (the shipped model is never overwritten by
    /// default). [default: surrogate.json in --data]
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Compute only share I of N of the design, written I/N (e.g. 3/8: the points whose index
    /// is 2 modulo 8), for cluster job arrays; no surrogate is fitted.
    #[arg(long, value_name = "I/N", conflicts_with_all = ["merge", "plan"])]
    pub shard: Option<training::Shard>,
    /// Join the shards written into --data, then fit the surrogate.
    #[arg(long)]
    pub merge: bool,
    /// After the campaign is complete, add a refinement round of N points where the surrogate
    /// is least certain (docs/surrogate.md, "Adaptive training"), run it and refit. Each call
    /// adds a new round; an interrupted round resumes with a plain `rom train` on the same
    /// --data.
    #[arg(long, value_name = "N", conflicts_with_all = ["merge", "shard", "plan"])]
    pub refine: Option<usize>,
    /// Refinement rounds of --refine N points, one after the other. [default: 1]
    #[arg(long, value_name = "K", requires = "refine")]
    pub rounds: Option<usize>,
    /// Join the shards written into --data, fit, and add a refinement round of N points to the
    /// design without running it: a cluster campaign's fit-and-plan step (the shards then run
    /// the round).
    #[arg(long, value_name = "N", conflicts_with = "merge")]
    pub plan: Option<usize>,
    /// Submit the whole campaign (its runs, any --refine rounds, the fit) to a cluster's
    /// scheduler instead of running it here; the job scripts are written into --data/jobs.
    #[arg(
        long,
        value_enum,
        value_name = "SCHEDULER",
        conflicts_with_all = ["shard", "merge", "plan"]
    )]
    pub submit: Option<Scheduler>,
    /// Shards of each round, one array task each (with --submit).
    #[arg(long, value_name = "N", requires = "submit", default_value_t = 16)]
    pub array_size: usize,
    /// Slurm partition of every job (with --submit). [default: the cluster's default]
    #[arg(long, requires = "submit")]
    pub partition: Option<String>,
    /// Time limit of every job, in Slurm's syntax, e.g. 01:00:00 (with --submit). [default:
    /// the partition's]
    #[arg(long, requires = "submit")]
    pub time: Option<String>,
    /// Say which points of the campaign in --data are done, which failed and which are
    /// pending, and run nothing.
    #[arg(long, conflicts_with_all = ["shard", "merge", "plan", "refine", "submit"])]
    pub status: bool,
    /// Fit with the knee-aligned input: the capacity times friction to a power chosen by
    /// likelihood (docs/surrogate.md, "How it is built"). The shipped model is fitted with it,
    /// after five refinement rounds without it (docs/validation/surrogate.md).
    #[arg(long)]
    pub knee_aligned: bool,
    /// What to print at the end: the readable summary, or its JSON (progress goes to stderr).
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Worker threads. [default: all cores]
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(clap::Args)]
pub struct SimulateArgs {
    /// Drive configuration (TOML). [default: the shipped HVAC drive, fom/configs/hvac.toml]
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Centre distance, m (moves the driven pulley along the line of centres). [default: from
    /// the drive configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub d: Option<f64>,
    /// Effective friction coefficient, dimensionless. [default: from the drive configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub mu: Option<f64>,
    /// Installation tension, N: static span tension at the reference centre distance.
    /// [default: from the drive configuration]
    #[arg(long, value_parser = positive, allow_hyphen_values = true)]
    pub tension: Option<f64>,
    /// Simulated duration, s (with --until-settled: the longest run, 15 s unless given).
    /// [default: from the drive configuration]
    #[arg(long)]
    pub duration: Option<f64>,
    /// End the run once it has settled (the one steady-state definition): at least 3 s and 2 s
    /// of steady running, at most --duration.
    #[arg(long)]
    pub until_settled: bool,
    /// Output CSV of the time series.
    #[arg(long, required_unless_present = "measurement_out")]
    pub out: Option<PathBuf>,
    /// Also write the run as a synthetic measurement (format belt-measurements/1) into this
    /// data set directory, appending to its manifest.
    #[arg(long, requires = "label")]
    pub measurement_out: Option<PathBuf>,
    /// Condition label of the synthetic measurement (e.g. d0); the file is LABEL-runN.csv.
    #[arg(long)]
    pub label: Option<String>,
    /// Sensor read-out rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    pub sample_rate: f64,
    /// Tachometer pulses per revolution. [default: from the drive configuration
    /// ([effects.tachometer]), else 60]
    #[arg(long)]
    pub pulses_per_rev: Option<u32>,
    /// Standard deviation of the speed noise, rpm.
    #[arg(
        long = "speed-noise",
        alias = "speed-noise-rpm",
        value_name = "SPEED_NOISE",
        default_value_t = 1.0
    )]
    pub speed_noise_rpm: f64,
    /// Resolution of the tachometers' pulse timer, s (0: exact pulse times). [default: from
    /// the drive configuration ([effects.tachometer]), else 0]
    #[arg(long)]
    pub timer_resolution: Option<f64>,
    /// Share of tachometer pulses that go missing, in [0, 0.5), dimensionless. [default: from
    /// the drive configuration ([effects.tachometer]), else 0]
    #[arg(long)]
    pub missing_pulse_share: Option<f64>,
    /// Counting gate of a speed counter by the M/T method, s: each reading is the whole pulse
    /// gaps within the gate over their span (0: the speed from the last pulse gap).
    #[arg(long, value_parser = non_negative, default_value_t = 0.0)]
    pub gate: f64,
    /// Standard deviation of each tachometer pulse edge's time, s: a pick-up's jitter, applied
    /// before the timer stamps the pulse.
    #[arg(long, value_parser = non_negative, default_value_t = 0.0)]
    pub edge_jitter: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub noise_seed: u64,
    /// Switch on an unmodelled effect for this run, NAME:KEY=VALUE[,KEY=VALUE], e.g.
    /// `--effect bearing-drag:coulomb_nm=0.5` (repeatable; keys as in `[effects.<name>]`,
    /// unit in the key's suffix).
    #[arg(long = "effect", value_name = "NAME:KEY=VALUE", value_parser = effect)]
    pub effects: Vec<EffectSpec>,
    /// Output CSV of the axial force along the belt at the end time.
    #[arg(long)]
    pub tension_profile: Option<PathBuf>,
    /// Side gap (backlash) of a toothed belt's tooth in its groove, m; or with a unit: 0.2mm,
    /// 200um (sets `contact.tooth.side_gap_m`). [default: from the drive configuration]
    #[arg(long, value_parser = side_gap)]
    pub side_gap: Option<f64>,
    /// Largest load torque of a driven load with a torque profile (`driven.load.profile`),
    /// N m; the profile is scaled to it. [default: from the drive configuration]
    #[arg(long, value_parser = non_negative)]
    pub load_torque: Option<f64>,
    /// Static shaft load, N: the driven pulley moves along the line of centres until the belt
    /// pulls its shaft with this force (in place of --d).
    #[arg(long, value_parser = positive, conflicts_with = "d")]
    pub shaft_load: Option<f64>,
    /// Output CSV of the tooth loads of a toothed belt (`time_s,tooth,flank_a_n,flank_b_n,
    /// tip_n`: mean normal load on each flank and the tip over each output interval, N).
    #[arg(long)]
    pub tooth_loads: Option<PathBuf>,
    /// What to print after the run: the readable summary, or its JSON (the files written are
    /// then named on stderr).
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
}

#[derive(clap::Args)]
pub struct ServeArgs {
    /// serve.toml: the drives' models, retention, the MQTT broker (docs/guide/serve.md).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Replay a measured data set (format belt-measurements/1) as if live, one drive per label.
    #[arg(long)]
    pub replay: Option<PathBuf>,
    /// Replayed seconds per wall second (0: as fast as possible).
    #[arg(long, default_value_t = 1.0, value_parser = non_negative, requires = "replay")]
    pub speed: f64,
    /// Replay each label this long, s on its clock, its runs repeated. [default: once]
    #[arg(long, value_parser = positive, requires = "replay")]
    pub duration: Option<f64>,
    /// Serve the HTTP API and the dashboard at this address (e.g. 127.0.0.1:8080); the
    /// server keeps serving after a replay ends.
    #[arg(long)]
    pub http: Option<String>,
    /// SQLite database (created if missing; a restart resumes from it).
    #[arg(long, default_value = "rom-serve.db")]
    pub db: PathBuf,
}
