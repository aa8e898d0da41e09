//! A third independent simulator of the belt drive, of another model form than both the
//! full-order model (a segmented belt in penalty contact) and the lumped model
//! (`crate::lumped`: a saturating traction curve between two shafts): a continuous belt in two
//! elastic spans that follows creep theory, read by a counter instead of pulse timing. It is
//! one of the three simulators of the model-form confusion matrix
//! (`docs/validation/gap-model-forms.md`). It reads only the drive's numbers from a
//! [`DriveConfig`] and its `[effects]` table, to which it gives physics of its own.
//!
//! - **Belt**: two straight spans of length d cos(beta) (beta = asin((r2 - r1) / d)), each
//!   holding an unstretched length U_i of belt, strain eps_i = L_i / U_i - 1 and tension
//!   T_i = EA eps_i (Hooke); the belt on the arcs is taken as fixed. The unstretched belt
//!   length follows the configuration (`fom::statics::unstretched_length_m`).
//! - **Creep** (Euler-Eytelwein / Grashof creep theory; Johnson, Contact Mechanics, 1985,
//!   sec. 8.7; Kim & Marshek, "Belt forces with pulley flexure", 1987): on each pulley the belt
//!   sticks on the arc where it arrives and creeps on the arc where it leaves, so it arrives at
//!   the pulley's surface speed. The driver draws q1 = r1 w1 / (1 + eps1) of unstretched belt
//!   per second from the tight span, the fan pulley q2 = r2 w2 / (1 + eps2) from the slack span,
//!   and dU1/dt = q2 - q1 = -dU2/dt. In steady running this is the creep slip
//!   1 - r2 w2 / (r1 w1) = (eps1 - eps2) / (1 + eps1).
//! - **Gross slip**: the creep arc covers a whole wrap when (T1 - m v^2) / (T2 - m v^2) reaches
//!   e^{mu theta} (Euler-Eytelwein with centrifugal tension; Shigley's Mechanical Engineering
//!   Design, 10th ed., eq. 17-7); beyond, the belt slides over the pulley at the tension excess
//!   over that limit divided by [`SLIDING_DAMPING_N_S_M`] (a viscous regularisation of
//!   Coulomb's law), on the driver first (the smaller wrap).
//! - **Rotors**: first-order speed dynamics J dw/dt = torque; the motor and the fan load are the
//!   configuration's (`fom::drive::Motor`, `fom::drive::Load`: Kloss's law, fan affinity law).
//!   The spans carry no material damping; the motor's torque-speed slope damps the span mode.
//!
//! Its effects (the names of `rom gap`'s catalogue, the keys of `[effects.<name>]`):
//! - `bearing-drag`: T = T_c (2 / pi) atan(w / 0.1 rad/s) + c w on the fan shaft (a Coulomb drag
//!   smoothed by an arctangent; SKF, Rolling bearings catalogue, 2018, "Friction").
//! - `pulley-eccentricity`: the pulley's centre turns at e (cos(theta + phi), sin(theta + phi))
//!   about its shaft; to first order in e / r that lengthens both spans by the offset along the
//!   line of centres (the spans' tension pumps at 1x) and moves the spans' moment arms about the
//!   shaft by the offset across it, so the torque on the pulley gains e_y (T1 + T2); relative
//!   to its moving tangent points the surface still runs at w r (plane kinematics of the offset
//!   circle; Meriam & Kraige, Engineering Mechanics: Dynamics, sec. 5/6). The full-order model
//!   moves the contact circle of a segmented belt; the lumped model turns the moment arm into
//!   the belt's speed.
//! - `blade-pass-pulsation`: only the aerodynamic part of the fan torque pulsates,
//!   k w^2 (1 + a sin(z theta2 + phi)) (the blades passing the scroll's cut-off modulate the
//!   pressure rise, not the seal friction; Bleier, Fan Handbook, 1998, ch. 16).
//! - `stribeck-friction`: the friction coefficient in the gross-slip limit falls with the
//!   belt's sliding speed over the pulleys, |r1 w1 - r2 w2|, along the exponential Stribeck curve
//!   mu = mu_s (r + (1 - r) exp(-(v / v_s)^2)) (Armstrong-Helouvry, Dupont & Canudas de Wit,
//!   Automatica 30(7), 1994), r the `dynamic_ratio`; it acts at the knee, where the limit binds.
//! - `belt-hysteresis`: each span a standard linear solid, T = EA (eps - g eps_d) with the
//!   dashpot strain eps_d relaxing at d eps_d/dt = (eps - eps_d) / tau and carried in by the
//!   belt from the other span at the rate v / L (Findley, Lai & Onaran, Creep and Relaxation of
//!   Nonlinear Viscoelastic Materials, 1976, sec. 5.2).
//! - `tachometer`: the counter's pulses per revolution, its clock (`timer_resolution_s`) and
//!   the share of pulses it misses (see [`CounterSensor`]).

use fom::config::effects::ShaftSelector;
use fom::config::DriveConfig;
use fom::drive::{Load, Motor};
use fom::OutputRow;
use rand::Rng;
use rand_distr::StandardNormal;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::f64::consts::PI;

/// Regularisation of gross slip, N s/m: a tension excess of 1 N over the Euler-Eytelwein limit
/// slides the belt at 1 cm/s. The spans relax such an excess in about
/// c L / (EA (1 + e^{mu theta})) = 0.25 ms on the default drive.
pub const SLIDING_DAMPING_N_S_M: f64 = 100.0;

/// The speed sensor: a counter by the M/T method (Ohmae et al., "A microprocessor-controlled
/// high-accuracy wide-range speed regulator for motor drives", IEEE Trans. Ind. Electron.
/// 29(3), 1982): at each read-out it counts the whole pulse gaps m within the last `gate_s`
/// (at least the last one) and divides by their span T stamped on its clock, n = 60 m / (P T).
/// Its noise is the pick-up's edge jitter, not an additive speed noise; it averages over the
/// gate, and a missed pulse lowers its count (it does not bridge gaps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CounterSensor {
    /// Read-out rate, Hz.
    pub sample_rate_hz: f64,
    /// Counting gate, s.
    pub gate_s: f64,
    /// Standard deviation of each pulse edge's time, s.
    pub edge_jitter_s: f64,
    /// Seed of the jitter and of the missed pulses.
    pub seed: u64,
}

impl Default for CounterSensor {
    /// 1 kHz read-out, a 4 ms gate, 1.5 us edge jitter: about 1 rpm of scatter at the motor's
    /// speed (sqrt(2) x jitter / gate of the reading), like the default tachometer's noise.
    fn default() -> Self {
        Self {
            sample_rate_hz: 1000.0,
            gate_s: 4e-3,
            edge_jitter_s: 1.5e-6,
            seed: 1,
        }
    }
}

/// What the creep simulator runs.
#[derive(Debug, Clone)]
pub struct CreepRun {
    pub center_distance_m: f64,
    pub duration_s: f64,
    /// Recordings written by [`write_dataset`] start this long after the motor start, s.
    pub from_s: f64,
    pub step_s: f64,
    pub output_interval_s: f64,
    pub sensor: CounterSensor,
    /// Where set, [`write_dataset`] gives each run the belt's static span tension as a
    /// tension meter reads it: the simulator's own static tension times (1 + share z), z a
    /// standard normal draw of the label's seed, with `share` of the reading as its standard
    /// deviation (`static_tension_n`, `static_tension_sd_n`; `docs/measured-data.md`).
    pub tension_reading_sd_share: Option<f64>,
}

impl CreepRun {
    pub fn at(center_distance_m: f64, duration_s: f64) -> Self {
        Self {
            center_distance_m,
            duration_s,
            from_s: 0.0,
            step_s: 5e-5,
            output_interval_s: 1e-3,
            sensor: CounterSensor::default(),
            tension_reading_sd_share: None,
        }
    }
}

/// The creep simulator's static span tension at centre distance `d_m` on `cfg`, N: the
/// configuration's unstretched belt on the open-belt path, T0 = EA (L - L0) / L0
/// (`fom::statics`), the tension [`simulate`] starts from.
pub fn static_tension_n(cfg: &DriveConfig, d_m: f64) -> fom::Result<f64> {
    let cfg = crate::at_distance(cfg, d_m)?;
    let (r1, r2) = fom::statics::pitch_radii_m(&cfg);
    let l0 = fom::statics::unstretched_length_m(&cfg)?;
    let path = fom::statics::open_belt_length_m(d_m, r1, r2);
    Ok(fom::statics::static_tension_n(
        cfg.belt.axial_stiffness_n,
        path,
        l0,
    ))
}

/// A run: rows at the output interval (means over each interval) and each shaft's true pulse
/// times.
pub struct CreepResult {
    pub rows: Vec<OutputRow>,
    pub pulses_s: [Vec<f64>; 2],
    pub pulses_per_rev: u32,
}

/// The drive's numbers and effects, read once.
struct Plant {
    r: [f64; 2],
    inertia: [f64; 2],
    damping: [f64; 2],
    ea: f64,
    span_m: f64,
    wrap: [f64; 2],
    mu_s: f64,
    mass_kg_m: f64,
    motor: Motor,
    load: Load,
    fan_nm_s2: f64,
    drag: Option<(f64, f64)>,
    runout: Option<(usize, f64, f64)>,
    blades: Option<(f64, f64, f64)>,
    stribeck: Option<(f64, f64)>,
    hysteresis: Option<(f64, f64)>,
}

/// State: shaft speeds w1, w2 (rad/s), angles (rad), unstretched span lengths U1, U2 (m) and
/// the spans' dashpot strains.
type State = [f64; 8];

/// Span tensions and the shaft torques at a state.
struct Forces {
    tension: [f64; 2],
    torque: [f64; 2],
}

impl Plant {
    fn new(cfg: &DriveConfig) -> fom::Result<Self> {
        let (r1, r2) = fom::statics::pitch_radii_m(cfg);
        let d = cfg.center_distance_m();
        let motor = cfg.driver.motor.as_ref().ok_or_else(|| {
            fom::FomError::Geometry("the creep simulator needs a motor-driven drive".into())
        })?;
        let load = cfg.driven.load.as_ref().ok_or_else(|| {
            fom::FomError::Geometry("the creep simulator needs a loaded fan shaft".into())
        })?;
        let fx = &cfg.effects;
        let shaft = |s: ShaftSelector| match s {
            ShaftSelector::Driver => 0,
            ShaftSelector::Driven => 1,
        };
        Ok(Self {
            r: [r1, r2],
            inertia: [cfg.driver.inertia_kg_m2, cfg.driven.inertia_kg_m2],
            damping: [
                cfg.driver.bearing_damping_n_m_s,
                cfg.driven.bearing_damping_n_m_s,
            ],
            ea: cfg.belt.axial_stiffness_n,
            span_m: d * ((r2 - r1) / d).asin().cos(),
            wrap: {
                let (a, b) = fom::statics::wrap_angles_rad(d, r1, r2);
                [a, b]
            },
            mu_s: cfg.effective_friction(),
            mass_kg_m: cfg.belt.mass_per_length_kg_m,
            motor: Motor::new(motor),
            load: Load::new(load),
            fan_nm_s2: load.fan_nm_s2,
            drag: fx.bearing_drag.map(|b| (b.coulomb_nm, b.viscous_nm_s)),
            runout: fx
                .pulley_eccentricity
                .map(|e| (shaft(e.pulley), e.runout_m, e.phase_deg.to_radians())),
            blades: fx
                .blade_pass_pulsation
                .map(|b| (b.blades as f64, b.amplitude, b.phase_deg.to_radians())),
            stribeck: fx
                .stribeck_friction
                .map(|s| (s.dynamic_ratio, s.stribeck_speed_m_s)),
            hysteresis: fx
                .belt_hysteresis
                .map(|h| (h.stiffness_ratio, h.relaxation_s)),
        })
    }

    /// The pulleys' centre offsets from their shafts, [x, y] each, m.
    fn offsets(&self, x: &State) -> [[f64; 2]; 2] {
        let mut off = [[0.0; 2]; 2];
        if let Some((k, e, phi)) = self.runout {
            let a = x[2 + k] + phi;
            off[k] = [e * a.cos(), e * a.sin()];
        }
        off
    }

    fn g(&self) -> f64 {
        self.hysteresis.map_or(0.0, |h| h.0)
    }

    /// Span strains and tensions (a span cannot push).
    fn spans(&self, x: &State, off: &[[f64; 2]; 2]) -> ([f64; 2], [f64; 2]) {
        let len = self.span_m + off[1][0] - off[0][0];
        let eps = [len / x[4] - 1.0, len / x[5] - 1.0];
        let g = self.g();
        let t = [
            (self.ea * (eps[0] - g * x[6])).max(0.0),
            (self.ea * (eps[1] - g * x[7])).max(0.0),
        ];
        (eps, t)
    }

    /// Speed at which the belt slides over pulley k beyond its creep (positive: the pulley's
    /// surface runs ahead of the belt), m/s.
    fn sliding(&self, k: usize, t: [f64; 2], x: &State) -> f64 {
        let v = self.r[0] * x[0];
        let c = self.mass_kg_m * v * v;
        let mu = match self.stribeck {
            Some((ratio, vs)) => {
                let v_slide = (self.r[0] * x[0] - self.r[1] * x[1]).abs();
                self.mu_s * (ratio + (1.0 - ratio) * (-(v_slide / vs).powi(2)).exp())
            }
            None => self.mu_s,
        };
        let e = (mu * self.wrap[k]).exp();
        let (a, b) = (t[0] - c, t[1] - c);
        let (ahead, behind) = (a - b * e, b - a * e);
        let excess = if ahead > 0.0 {
            ahead
        } else if behind > 0.0 {
            -behind
        } else {
            0.0
        };
        // On the driver the pulley runs ahead of the belt when the tight span pulls back; on
        // the fan pulley the belt runs ahead of the pulley.
        if k == 0 {
            excess / SLIDING_DAMPING_N_S_M
        } else {
            -excess / SLIDING_DAMPING_N_S_M
        }
    }

    fn fan_torque_nm(&self, t: f64, x: &State) -> f64 {
        let w = x[1];
        let mut tq = self.load.brake_torque_nm(t, w);
        if let Some((z, a, phi)) = self.blades {
            tq += a * self.fan_nm_s2 * w * w.abs() * (z * x[3] + phi).sin();
        }
        if let Some((tc, cv)) = self.drag {
            tq += tc * 2.0 / PI * (w / 0.1).atan() + cv * w;
        }
        tq
    }

    fn forces(&self, t: f64, x: &State) -> Forces {
        let off = self.offsets(x);
        let (_, ten) = self.spans(x, &off);
        let (dt, st) = (ten[0] - ten[1], ten[0] + ten[1]);
        Forces {
            tension: ten,
            torque: [
                self.motor.torque_nm(t, x[0]) - self.r[0] * dt - off[0][1] * st,
                self.r[1] * dt + off[1][1] * st - self.fan_torque_nm(t, x),
            ],
        }
    }

    fn rhs(&self, t: f64, x: &State) -> State {
        let off = self.offsets(x);
        let (eps, _) = self.spans(x, &off);
        let f = self.forces(t, x);
        // Relative to its moving tangent point an eccentric pulley's surface runs at w r.
        let q1 = (x[0] * self.r[0] - self.sliding(0, f.tension, x)) / (1.0 + eps[0]);
        let q2 = (x[1] * self.r[1] - self.sliding(1, f.tension, x)) / (1.0 + eps[1]);
        let mut dx = [0.0; 8];
        for k in 0..2 {
            dx[k] = (f.torque[k] - self.damping[k] * x[k]) / self.inertia[k];
            dx[2 + k] = x[k];
        }
        dx[4] = q2 - q1;
        dx[5] = q1 - q2;
        if let Some((_, tau)) = self.hysteresis {
            let renew = (self.r[0] * x[0]).abs() / self.span_m;
            dx[6] = (eps[0] - x[6]) / tau + renew * (x[7] - x[6]);
            dx[7] = (eps[1] - x[7]) / tau + renew * (x[6] - x[7]);
        }
        dx
    }
}

fn rk4(p: &Plant, t: f64, x: &State, h: f64) -> State {
    let add = |a: &State, b: &State, s: f64| -> State { std::array::from_fn(|i| a[i] + s * b[i]) };
    let k1 = p.rhs(t, x);
    let k2 = p.rhs(t + 0.5 * h, &add(x, &k1, 0.5 * h));
    let k3 = p.rhs(t + 0.5 * h, &add(x, &k2, 0.5 * h));
    let k4 = p.rhs(t + h, &add(x, &k3, h));
    std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// Runs the creep model of `cfg` (its effects switched on) at `run`'s centre distance from
/// standstill at static tension.
pub fn simulate(cfg: &DriveConfig, run: &CreepRun) -> fom::Result<CreepResult> {
    let cfg = crate::at_distance(cfg, run.center_distance_m)?;
    let p = Plant::new(&cfg)?;
    let l0 = fom::statics::unstretched_length_m(&cfg)?;
    let (r1, r2) = (p.r[0], p.r[1]);
    let path = fom::statics::open_belt_length_m(cfg.center_distance_m(), r1, r2);
    // Static strain everywhere; the spans hold their share of the unstretched belt.
    let eps0 = fom::statics::static_strain(path, l0);
    let u0 = p.span_m / (1.0 + eps0);
    let mut x: State = [0.0, 0.0, 0.0, 0.0, u0, u0, eps0, eps0];
    let ppr = cfg.effects.tachometer.map_or(60, |t| t.pulses_per_rev);
    let pulse_angle = 2.0 * PI / ppr as f64;
    let mut next_pulse = [pulse_angle; 2];
    let mut pulses_s: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let dt = run.step_s;
    let per_row = (run.output_interval_s / dt).round().max(1.0) as usize;
    let steps = (run.duration_s / dt).round() as usize;
    let ratio = cfg.transmission_ratio();
    let rpm = 30.0 / PI;
    let mut rows = vec![OutputRow {
        time_s: 0.0,
        slip_pct: f64::NAN,
        ..Default::default()
    }];
    let mut acc = [0.0f64; 6];
    for k in 0..steps {
        let t = k as f64 * dt;
        let next = rk4(&p, t, &x, dt);
        for s in 0..2 {
            while next[2 + s] >= next_pulse[s] {
                let share = (next_pulse[s] - x[2 + s]) / (next[2 + s] - x[2 + s]);
                pulses_s[s].push(t + share.clamp(0.0, 1.0) * dt);
                next_pulse[s] += pulse_angle;
            }
        }
        x = next;
        let f = p.forces(t + dt, &x);
        for (a, v) in acc.iter_mut().zip([
            x[0],
            x[1],
            f.tension[0],
            f.tension[1],
            p.motor.torque_nm(t + dt, x[0]),
            p.fan_torque_nm(t + dt, &x),
        ]) {
            *a += v;
        }
        if (k + 1) % per_row == 0 {
            let m: Vec<f64> = acc.iter().map(|a| a / per_row as f64).collect();
            let (n1, n2) = (m[0] * rpm, m[1] * rpm);
            rows.push(OutputRow {
                time_s: (k + 1) as f64 * dt,
                driver_rpm: n1,
                driven_rpm: n2,
                slip_pct: fom::slip::slip_pct(ratio, n1, n2),
                tight_span_tension_n: m[2],
                slack_span_tension_n: m[3],
                driver_torque_nm: m[4],
                driven_torque_nm: m[5],
            });
            acc = [0.0; 6];
        }
    }
    Ok(CreepResult {
        rows,
        pulses_s,
        pulses_per_rev: ppr,
    })
}

/// The pulses the counter sees: each edge jittered, stamped on its clock (rounded down to a
/// tick), some missed.
fn sensed_pulses(
    true_s: &[f64],
    sensor: &CounterSensor,
    cfg: &DriveConfig,
    stream: u64,
) -> Vec<f64> {
    let tach = cfg.effects.tachometer;
    let tick = tach.map_or(0.0, |t| t.timer_resolution_s);
    let miss = tach.map_or(0.0, |t| t.missing_pulse_share);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed.wrapping_mul(7919) ^ stream);
    let mut out = Vec::with_capacity(true_s.len());
    for &p in true_s {
        let jitter: f64 = rng.sample(StandardNormal);
        let dropped = rng.gen::<f64>() < miss;
        let mut t = p + sensor.edge_jitter_s * jitter;
        if tick > 0.0 {
            t = (t / tick).floor() * tick;
        }
        if !dropped && out.last().is_none_or(|&l| t > l) {
            out.push(t);
        }
    }
    out
}

/// The counter's reading at `t`, rpm: the whole pulse gaps in the gate before `t` (at least
/// the last one) over their span; zero before two pulses or after a pause of four gaps.
fn counter_rpm(pulses: &[f64], t: f64, gate_s: f64, ppr: u32, cursor: &mut usize) -> f64 {
    while *cursor < pulses.len() && pulses[*cursor] <= t {
        *cursor += 1;
    }
    let n = *cursor;
    if n < 2 {
        return 0.0;
    }
    let last = pulses[n - 1];
    let mut first = n - 2;
    while first > 0 && pulses[first - 1] > t - gate_s {
        first -= 1;
    }
    let gaps = (n - 1 - first) as f64;
    let span = last - pulses[first];
    if span <= 0.0 || t - last > 4.0 * span / gaps {
        return 0.0;
    }
    60.0 * gaps / (ppr as f64 * span)
}

/// A recording of a run through the counter of `cfg`'s tachometer table (60 pulses, an exact
/// clock and no missed pulses without one): read-outs from `from_s` on, times restarting at 0.
pub fn measure(
    result: &CreepResult,
    cfg: &DriveConfig,
    sensor: &CounterSensor,
    from_s: f64,
) -> twin::measured::Recording {
    let p: Vec<Vec<f64>> = (0..2)
        .map(|s| sensed_pulses(&result.pulses_s[s], sensor, cfg, s as u64 + 1))
        .collect();
    let end = result.rows.last().map_or(0.0, |r| r.time_s);
    let n = (end * sensor.sample_rate_hz).floor() as usize;
    let mut rec = twin::measured::Recording::default();
    let mut cursor = [0usize; 2];
    for k in 0..=n {
        let t = k as f64 / sensor.sample_rate_hz;
        let speed: Vec<f64> = (0..2)
            .map(|s| {
                counter_rpm(
                    &p[s],
                    t,
                    sensor.gate_s,
                    result.pulses_per_rev,
                    &mut cursor[s],
                )
            })
            .collect();
        if t < from_s - 1e-9 {
            continue;
        }
        rec.time_s.push(t - from_s);
        rec.driver_rpm.push(speed[0]);
        rec.driven_rpm.push(speed[1]);
    }
    rec
}

/// Writes a measured-data set (`belt-measurements/1`) of the creep model of `cfg` (its effects
/// on) into `dir`: one recording per (label, centre distance), read by `run.sensor` with seed
/// `seed + k` for the k-th label, through the exchange format's writer
/// (`twin::measured::append_run`). The manifest carries each label's distance and no effect.
/// Returns each recording's file name and settled slip (last 0.5 s of the true speeds, %).
pub fn write_dataset(
    dir: &std::path::Path,
    cfg: &DriveConfig,
    labels: &[(&str, f64)],
    run: &CreepRun,
    seed: u64,
) -> twin::Result<Vec<(String, f64)>> {
    let (d1, d2) = (cfg.driver.pitch_diameter_m, cfg.driven.pitch_diameter_m);
    labels
        .iter()
        .enumerate()
        .map(|(k, &(label, d))| {
            twin::sensor::check_label(label)?;
            let result = simulate(
                cfg,
                &CreepRun {
                    center_distance_m: d,
                    ..run.clone()
                },
            )?;
            let tail_slip = crate::lumped::final_slip_pct(&result.rows, 0.5);
            let sensor = CounterSensor {
                seed: seed + k as u64,
                ..run.sensor
            };
            let rec = measure(&result, cfg, &sensor, run.from_s);
            let file = (1..)
                .map(|n| format!("{label}-run{n}.csv"))
                .find(|f| !dir.join(f).exists())
                .expect("a free run number");
            let mut metadata = std::collections::BTreeMap::new();
            metadata.insert("synthetic".to_string(), toml::Value::Boolean(true));
            if let Some(share) = run.tension_reading_sd_share {
                let mut rng = Xoshiro256PlusPlus::seed_from_u64(sensor.seed ^ 0x7e57_0000);
                let z: f64 = rng.sample(StandardNormal);
                let reading = static_tension_n(cfg, d)? * (1.0 + share * z);
                for (key, v) in [
                    (twin::measured::STATIC_TENSION_KEY, reading),
                    (twin::measured::STATIC_TENSION_SD_KEY, share * reading),
                ] {
                    metadata.insert(
                        key.to_string(),
                        toml::Value::Float((v * 10.0).round() / 10.0),
                    );
                }
            }
            let comment = format!(
                "synthetic measurement by the creep simulator (tests/src/creep.rs): counter \
                 gate {} s, {} pulses/rev, clock {} s, edge jitter {} s, seed {}",
                sensor.gate_s,
                result.pulses_per_rev,
                cfg.effects.tachometer.map_or(0.0, |t| t.timer_resolution_s),
                sensor.edge_jitter_s,
                sensor.seed
            );
            twin::measured::append_run(
                dir,
                twin::measured::RunEntry {
                    file: file.clone(),
                    label: label.to_string(),
                    center_distance_m: Some(d),
                    metadata,
                },
                &rec,
                &comment,
                (d1, d2),
            )?;
            Ok((file, tail_slip))
        })
        .collect()
}
