//! Running a drive: static equilibrium, the dynamic run, and what is recorded.

use crate::belt_kind::{KindRecord, Recorder};
use crate::config::ValidConfig;
pub use crate::config::RELAXATION_MAX_S;
use crate::effects::Effects;
use crate::error::FomError;
use crate::integrator::{StepMode, StepWorkspace};
use crate::model::{Model, DRIVEN, DRIVER};
use crate::output::{EnergyBalance, OutputRow, RunSummary};
use crate::slip::slip_pct;
use crate::stats::quantile;
use crate::steady::{self, Settling};
use std::sync::Arc;
use std::time::Instant;

/// Everything a run produces.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub rows: Vec<OutputRow>,
    pub summary: RunSummary,
    /// Axial force along the belt at the end time: (arc length from the slack-span start, N).
    pub tension_profile: Vec<(f64, f64)>,
    /// Static span tension after equilibrium, N (mean of both span midpoints).
    pub static_tension_n: f64,
    /// What the belt's kind records beyond the rows (`belt_kind::Recorder`), if anything;
    /// read it with [`RunResult::record`].
    pub kind_record: Option<Arc<dyn KindRecord>>,
    /// The model at the end of the run.
    pub model: Model,
}

impl RunResult {
    /// The belt kind's record of the run as a `T` (e.g. `belt_kind::tooth_record::ToothRecord`
    /// of a toothed belt), if it kept one of that type.
    pub fn record<T: 'static>(&self) -> Option<&T> {
        self.kind_record.as_deref()?.as_any().downcast_ref()
    }
}

/// Options of a run beyond the configuration.
#[derive(Clone, Default)]
pub struct RunOptions<'a> {
    /// Called with (simulated time, duration) about every 1 % of the run.
    pub progress: Option<&'a (dyn Fn(f64, f64) + Sync)>,
    /// Optional physics acting through the step's hooks (none by default).
    pub effects: Effects,
    /// When set, the run stops within `POLL_EVERY_STEPS` steps with `FomError::Interrupted`; a caller's
    /// progress callback may set it (Ctrl-C in Python).
    pub stop: Option<&'a std::sync::atomic::AtomicBool>,
}

/// Steps between two looks at the wall clock and at `RunOptions::stop`.
const POLL_EVERY_STEPS: usize = 1024;

/// Least wall time between two progress reports, s: a run reports at every 1 % of its steps
/// or after this long, whichever comes first (a run with tiny steps reports while it works).
const PROGRESS_EVERY_WALL_S: f64 = 0.5;

/// Result of the static-equilibrium search.
#[derive(Debug, Clone, Copy)]
pub struct Equilibrium {
    pub steps: usize,
    /// Largest node speed at the end, m/s.
    pub residual_speed_m_s: f64,
    /// Span tensions (slack-side span, tight-side span), N.
    pub span_tension_n: (f64, f64),
}

impl Equilibrium {
    /// The static span tension, N: the mean of both spans' at rest.
    pub fn static_tension_n(&self) -> f64 {
        0.5 * (self.span_tension_n.0 + self.span_tension_n.1)
    }
}

/// The static span tension the model's belt settles at with the pulleys held, N
/// (`relax_to_equilibrium`; docs/fom-numerics.md, "Initial state"): with the belt's bending
/// stiffness, above the perfectly flexible belt's (`DesignPoint::static_tension_n`) by up to 7 %
/// at the loosest settings of the default drive.
pub fn settled_static_tension_n(cfg: &ValidConfig) -> Result<f64, FomError> {
    let (_, eq) = prepare_with(cfg, &Effects::default())?;
    Ok(eq.static_tension_n())
}

/// Dynamic relaxation to static equilibrium with the pulleys held (docs/fom-numerics.md, "Initial
/// state"): heavy velocity damping; first without friction so that axial waves even out the
/// tension around the pulleys, then with friction, which also stops the free circulation of
/// the belt around the loop (a neutral mode of a frictionless belt), until the belt is at rest.
pub fn relax_to_equilibrium(model: &mut Model) -> Result<Equilibrium, FomError> {
    let mut ws = StepWorkspace::default();
    let dt = model.params.step_s;
    // Damping near critical for the first span mode f1 = sqrt(T/rho_A)/(2 l_span).
    let t0 = model.nominal_static_tension_n().max(1.0);
    let rho_a = model.belt.mass_kg / model.belt.element.l0_m;
    let f1 = (t0 / rho_a).sqrt() / (2.0 * model.path.span_length());
    let damping_1_s = 4.0 * std::f64::consts::PI * f1;
    // Frictionless phase: a few axial wave transits around the loop.
    let wave_speed = (model.belt.element.k_axial * model.belt.element.l0_m / rho_a).sqrt();
    let frictionless_steps = (10.0 * model.pitch_path_length_m / wave_speed / dt) as usize;
    let max_steps = frictionless_steps + ((RELAXATION_MAX_S / dt) as usize).max(1000);
    let min_steps = frictionless_steps + (0.02 / dt) as usize;
    let check_every = 200;
    let mut steps = 0;
    let mut residual = f64::INFINITY;
    while steps < max_steps {
        let mode = StepMode::Relax {
            damping_1_s,
            friction: steps >= frictionless_steps,
        };
        for _ in 0..check_every {
            model.step(mode, &mut ws);
        }
        steps += check_every;
        model.belt.renormalise_directions();
        model.check_health().map_err(|e| match e {
            FomError::Numerical { time_s, message } => FomError::Numerical {
                time_s,
                message: format!(
                    "while finding static equilibrium (pulleys held, t counts relaxation): \
                     {message}"
                ),
            },
            other => other,
        })?;
        let b = &model.belt;
        // Where the belt's circulation around the loop is a neutral mode at rest (a toothed
        // belt floating in its backlash), the residual leaves it out.
        let circulation = if model.belt_contact.circulates_freely() {
            (0..b.n)
                .map(|i| b.vx[i] * b.cth[i] + b.vy[i] * b.sth[i])
                .sum::<f64>()
                / b.n as f64
        } else {
            0.0
        };
        residual = (0..b.n)
            .map(|i| (b.vx[i] - circulation * b.cth[i]).hypot(b.vy[i] - circulation * b.sth[i]))
            .fold(0.0, f64::max);
        if residual < 1e-5 && steps >= min_steps {
            break;
        }
    }
    let b = &mut model.belt;
    b.vx.fill(0.0);
    b.vy.fill(0.0);
    b.w.fill(0.0);
    b.assemble_internal_forces(model.gravity_m_s2);
    model.time_s = 0.0;
    model.ledger = Default::default();
    model.max_penetration_m = 0.0;
    model.belt_contact.reset();
    let (lower, upper) = model.path.span_midpoints();
    let slack = b.axial_n[b.element_nearest(lower)];
    let tight = b.axial_n[b.element_nearest(upper)];
    Ok(Equilibrium {
        steps,
        residual_speed_m_s: residual,
        span_tension_n: (slack, tight),
    })
}

/// Builds the model from a configuration and brings it to static equilibrium.
pub fn prepare(cfg: &ValidConfig) -> Result<(Model, Equilibrium), FomError> {
    prepare_with(cfg, &Effects::default())
}

/// Builds the model with its configuration's effects plus `effects` and brings it to static
/// equilibrium (the effects act during the equilibrium search too: a runout already deforms
/// the belt at rest).
pub fn prepare_with(
    cfg: &ValidConfig,
    effects: &Effects,
) -> Result<(Model, Equilibrium), FomError> {
    let mut model = Model::from_config(cfg)?;
    for e in effects.iter() {
        model.add_effect(e.clone());
    }
    if !effects.is_empty() {
        // An added effect may stiffen the belt (hysteresis): the step is checked again.
        model.resolve_step(&cfg.simulation)?;
    }
    let eq = relax_to_equilibrium(&mut model)?;
    Ok((model, eq))
}

/// Runs a configuration: equilibrium, then `duration_s` of dynamics.
pub fn simulate(cfg: &ValidConfig, opts: RunOptions) -> Result<RunResult, FomError> {
    let (model, eq) = prepare_with(cfg, &opts.effects)?;
    run_prepared(cfg, model, eq, opts)
}

/// Dynamic run of a model already at equilibrium.
pub fn run_prepared(
    cfg: &ValidConfig,
    mut model: Model,
    eq: Equilibrium,
    opts: RunOptions,
) -> Result<RunResult, FomError> {
    let wall = Instant::now();
    let sim = &cfg.simulation;
    let dt = model.params.step_s;
    let n_steps = (sim.duration_s / dt).round() as usize;
    let steps_per_row = ((sim.output_interval_s / dt).round() as usize).max(1);
    let mut ws = StepWorkspace::default();
    let mut row = RowState::new(&model);
    let mut rows = Vec::with_capacity(n_steps / steps_per_row + 2);
    rows.push(row.first_row(&model));
    let mut recorder = model.belt_contact.recorder(cfg);
    let progress_every = (n_steps / 100).max(1);
    let mut last_report = Instant::now();
    // Energy ledger snapshots every `SNAPSHOT_S`, so the balance can be taken over the steady
    // window found after the run (from the snapshot nearest its start).
    const SNAPSHOT_S: f64 = 0.05;
    let snapshot_every = ((SNAPSHOT_S / dt).round() as usize).max(1);
    let mut snapshots = vec![(0.0, model.ledger, model.mechanical_energy_j())];
    // Running until settled: checked every `CHECK_EVERY_S` after the least duration.
    const CHECK_EVERY_S: f64 = 0.5;
    let check_every = ((CHECK_EVERY_S / dt).round() as usize).max(1);
    let mut settled_early = false;
    for k in 1..=n_steps {
        model.step(StepMode::Dynamic, &mut ws);
        if k % snapshot_every == 0 {
            snapshots.push((model.time_s, model.ledger, model.mechanical_energy_j()));
        }
        row.accumulate(&model);
        if let Some(rec) = &mut recorder {
            rec.step(model.belt_contact.as_ref(), model.time_s);
        }
        if k % steps_per_row == 0 || k == n_steps {
            model.belt.renormalise_directions();
            model.check_health()?;
            rows.push(row.finish(&model, &mut recorder));
        }
        if let Some(cb) = opts.progress {
            if k % progress_every == 0
                || (k % POLL_EVERY_STEPS == 0
                    && last_report.elapsed().as_secs_f64() >= PROGRESS_EVERY_WALL_S)
            {
                cb(model.time_s, sim.duration_s);
                last_report = Instant::now();
            }
        }
        if k % POLL_EVERY_STEPS == 0
            && opts
                .stop
                .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
        {
            return Err(FomError::Interrupted {
                time_s: model.time_s,
            });
        }
        if let Some(u) = sim.until_settled {
            if k % check_every == 0
                && model.time_s >= u.min_duration_s - 0.5 * dt
                && k < n_steps
                && settling(&rows, sim.steady_start_s, u.judging_window_s())
                    .start_s()
                    .is_some_and(|start| model.time_s - start >= u.steady_length_s - 0.5 * dt)
            {
                settled_early = true;
                break;
            }
        }
    }
    if settled_early {
        // The remaining output interval's partial row is not written; the run ends on a row.
        if let Some(cb) = opts.progress {
            cb(sim.duration_s, sim.duration_s);
        }
    }
    let wall_s = wall.elapsed().as_secs_f64();
    let kind_record = recorder.map(|r| r.finish());
    Ok(finish_run(
        sim,
        model,
        rows,
        &snapshots,
        eq,
        wall_s,
        kind_record,
    ))
}

/// Energy ledger and mechanical energy at one time of the run.
type Snapshot = (f64, crate::model::EnergyLedger, f64);

/// The run's result from its rows: settling, summary over the steady window, energy balance
/// over the same window (from the snapshot nearest its start), the tension profile.
fn finish_run(
    sim: &crate::config::SimulationConfig,
    model: Model,
    rows: Vec<OutputRow>,
    snapshots: &[Snapshot],
    eq: Equilibrium,
    wall_s: f64,
    kind_record: Option<Arc<dyn KindRecord>>,
) -> RunResult {
    let min_window_s = sim
        .until_settled
        .map_or(steady::MIN_WINDOW_S, |u| u.judging_window_s());
    let settle = settling(&rows, sim.steady_start_s, min_window_s);
    let end_s = rows.last().map_or(0.0, |r| r.time_s);
    // An unsettled run's statistics are over the fixed window, else the last minimum window
    // (flagged in the summary, never taken as steady).
    let steady_start = settle
        .start_s()
        .or(sim.steady_start_s)
        .unwrap_or((end_s - min_window_s).max(0.0));
    let (_, l0, e0) = *snapshots
        .iter()
        .min_by(|a, b| {
            (a.0 - steady_start)
                .abs()
                .total_cmp(&(b.0 - steady_start).abs())
        })
        .expect("the first snapshot is taken before the run");
    let energy = EnergyBalance {
        input_j: model.ledger.input_j - l0.input_j,
        load_j: model.ledger.load_j - l0.load_j,
        dissipated_j: model.ledger.dissipated_j - l0.dissipated_j,
        stored_change_j: model.mechanical_energy_j() - e0,
    };
    let mut summary = summarise(
        &rows,
        settle,
        steady_start,
        model.max_penetration_m,
        wall_s,
        end_s,
    );
    summary.energy = energy;
    let start = model.belt.element_nearest(model.path.tangent_points()[0]);
    let tension_profile = model.belt.tension_profile(start);
    RunResult {
        rows,
        summary,
        tension_profile,
        static_tension_n: eq.static_tension_n(),
        kind_record,
        model,
    }
}

/// The run's settling by the one steady-state definition (`fom::steady`) on its slip rows, with
/// a steady window of at least `min_window_s`, from `fixed_start_s` if the user fixed it.
pub fn settling(rows: &[OutputRow], fixed_start_s: Option<f64>, min_window_s: f64) -> Settling {
    let (t, v): (Vec<f64>, Vec<f64>) = rows.iter().map(|r| (r.time_s, r.slip_pct)).unzip();
    steady::settle(&t, &v, min_window_s, fixed_start_s)
}

/// What the output rows are accumulated from between two rows: span tensions at the span
/// midpoints' elements, drive torques, and the shaft angles at the row's start. Public so that
/// a caller stepping the model itself (the co-simulation FMU, `fmu/`) makes the same rows.
#[derive(Debug, Clone)]
pub struct RowState {
    mids: ([f64; 2], [f64; 2]),
    slack_e: usize,
    tight_e: usize,
    acc: [f64; 4],
    acc_n: usize,
    angle0: [f64; 2],
    t_row0: f64,
}

impl RowState {
    pub fn new(model: &Model) -> Self {
        let (lower_mid, upper_mid) = model.path.span_midpoints();
        Self {
            mids: (lower_mid, upper_mid),
            slack_e: model.belt.element_nearest(lower_mid),
            tight_e: model.belt.element_nearest(upper_mid),
            acc: [0.0; 4],
            acc_n: 0,
            angle0: [
                model.pulleys[DRIVER].angle_rad,
                model.pulleys[DRIVEN].angle_rad,
            ],
            t_row0: 0.0,
        }
    }

    /// The row at time zero: the static span tensions, no speeds yet.
    pub fn first_row(&self, model: &Model) -> OutputRow {
        OutputRow {
            time_s: 0.0,
            driver_rpm: 0.0,
            driven_rpm: 0.0,
            slip_pct: f64::NAN,
            tight_span_tension_n: model.belt.axial_n[self.tight_e],
            slack_span_tension_n: model.belt.axial_n[self.slack_e],
            driver_torque_nm: 0.0,
            driven_torque_nm: 0.0,
        }
    }

    /// Adds the step just taken.
    pub fn accumulate(&mut self, model: &Model) {
        // Keep the span elements current: the belt moves less than one element per step.
        self.slack_e = nearest_neighbour(model, self.slack_e, self.mids.0);
        self.tight_e = nearest_neighbour(model, self.tight_e, self.mids.1);
        let acc = &mut self.acc;
        acc[0] += model.belt.axial_n[self.tight_e];
        acc[1] += model.belt.axial_n[self.slack_e];
        acc[2] += model.drive_torque_nm[DRIVER];
        acc[3] += -model.drive_torque_nm[DRIVEN];
        self.acc_n += 1;
    }

    /// The row ending now (and the belt kind's record of it); starts the next.
    pub fn finish(&mut self, model: &Model, recorder: &mut Option<Box<dyn Recorder>>) -> OutputRow {
        let (acc, angle0) = (self.acc, self.angle0);
        let t = model.time_s;
        let span = t - self.t_row0;
        let w1 = (model.pulleys[DRIVER].angle_rad - angle0[0]) / span;
        let w2 = (model.pulleys[DRIVEN].angle_rad - angle0[1]) / span;
        let rpm = 60.0 / (2.0 * std::f64::consts::PI);
        let slip = if crate::steady::turns(w1 * rpm) {
            slip_pct(model.transmission_ratio(), w1, w2)
        } else {
            f64::NAN
        };
        let inv = 1.0 / self.acc_n as f64;
        if let Some(rec) = recorder {
            let (belt, pulleys) = (&model.belt, &model.pulleys);
            rec.row(model.belt_contact.as_ref(), belt, pulleys, t, inv);
        }
        self.acc = [0.0; 4];
        self.acc_n = 0;
        self.angle0 = [
            model.pulleys[DRIVER].angle_rad,
            model.pulleys[DRIVEN].angle_rad,
        ];
        self.t_row0 = t;
        OutputRow {
            time_s: t,
            driver_rpm: w1 * rpm,
            driven_rpm: w2 * rpm,
            slip_pct: slip,
            tight_span_tension_n: acc[0] * inv,
            slack_span_tension_n: acc[1] * inv,
            driver_torque_nm: acc[2] * inv,
            driven_torque_nm: acc[3] * inv,
        }
    }
}

fn nearest_neighbour(model: &Model, e: usize, p: [f64; 2]) -> usize {
    let n = model.belt.n;
    let b = &model.belt;
    let dist2 = |k: usize| {
        let j = (k + 1) % n;
        let mx = 0.5 * (b.x[k] + b.x[j]) - p[0];
        let my = 0.5 * (b.y[k] + b.y[j]) - p[1];
        mx * mx + my * my
    };
    let mut best = e;
    for k in [(e + n - 1) % n, (e + 1) % n] {
        if dist2(k) < dist2(best) {
            best = k;
        }
    }
    best
}

fn summarise(
    rows: &[OutputRow],
    settling: Settling,
    steady_start_s: f64,
    max_penetration_m: f64,
    wall_s: f64,
    simulated_s: f64,
) -> RunSummary {
    let steady: Vec<&OutputRow> = rows
        .iter()
        .filter(|r| r.time_s > steady_start_s && r.slip_pct.is_finite())
        .collect();
    let mut slip: Vec<f64> = steady.iter().map(|r| r.slip_pct).collect();
    slip.sort_by(|a, b| a.total_cmp(b));
    let n = slip.len().max(1) as f64;
    let mean = slip.iter().sum::<f64>() / n;
    let var = slip.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let mean_of = |f: fn(&OutputRow) -> f64| steady.iter().map(|r| f(r)).sum::<f64>() / n;
    RunSummary {
        simulated_s,
        settling,
        steady_start_s,
        steady_rows: slip.len(),
        mean_slip_pct: mean,
        std_slip_pct: var.sqrt(),
        p05_slip_pct: quantile(&slip, 0.05),
        p50_slip_pct: quantile(&slip, 0.50),
        p95_slip_pct: quantile(&slip, 0.95),
        mean_driver_rpm: mean_of(|r| r.driver_rpm),
        mean_driven_rpm: mean_of(|r| r.driven_rpm),
        mean_tight_tension_n: mean_of(|r| r.tight_span_tension_n),
        mean_slack_tension_n: mean_of(|r| r.slack_span_tension_n),
        mean_driver_torque_nm: mean_of(|r| r.driver_torque_nm),
        mean_driven_torque_nm: mean_of(|r| r.driven_torque_nm),
        max_penetration_m,
        wall_time_s: wall_s,
        real_time_factor: simulated_s / wall_s,
        energy: EnergyBalance::default(),
    }
}
