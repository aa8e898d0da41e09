//! An independent lumped-parameter belt-drive simulator: the "other simulator" against which
//! `rom gap`, `rom calibrate` and `rom diagnose` are checked on data sets made by other
//! simulators, whose healthy slip differs by a few percent and whose looseness knee has another
//! shape (`docs/validation/gap.md`, "Another simulator's data").
//!
//! It shares no physics code with the full-order model: two rigid shafts coupled by a belt whose
//! traction is a saturating function of the slip (the creep-plus-gross-slip traction curve of a
//! brush-type model) instead of a finite-segment chain in penalty contact. It reads only the
//! drive's numbers from a [`DriveConfig`] (pulleys, inertias, motor, fan, belt EA, mass,
//! installation tension and friction).
//!
//! - Static tension at centre distance d: T0 = EA (L(d) / L0 - 1), L0 from the installation
//!   tension at the reference distance (Hooke's law on the open-belt length, Shigley's
//!   Mechanical Engineering Design, 10th ed., eq. 17-1 for L).
//! - Traction capacity: F_max = 2 (T0 - m v^2) (e^{mu theta} - 1) / (e^{mu theta} + 1)
//!   (Euler-Eytelwein with T1 + T2 = 2 T0, centrifugal tension m v^2; Shigley eq. 17-7/17-9).
//! - Traction curve: F = F_max (1 - exp(-EA s / F_max)): slope EA at small slip (elastic creep,
//!   s = (T1 - T2) / EA, Johnson, Contact Mechanics, 1985, sec. 8.7) and saturation at F_max
//!   (gross slip).
//! - Motor: Kloss's law T = 2 T_b / (s / s_b + s_b / s) (Fitzgerald & Kingsley, Electric
//!   Machinery, 6th ed., sec. 6.7); fan: T = c0 + k w^2 (fan affinity law) plus extra Coulomb
//!   drag `extra_drag_nm`, signed with the speed.
//! - Driven-pulley eccentricity `driven_runout_m` (e): the moment arm of the belt about the
//!   shaft, and so the radius that converts shaft speed to belt speed, is r2 + e cos(theta2)
//!   (the rotation axis e off the pulley's centre; first order in e / r2, Shigley eq. 17-1's
//!   pitch radius measured from the shaft). Span length changes are left out.
//! - Integration: classical fourth-order Runge-Kutta at `step_s`; rows are means over each
//!   output interval, as the full-order model writes them.

use fom::config::DriveConfig;
use fom::OutputRow;

/// What the lumped simulator runs.
#[derive(Debug, Clone)]
pub struct LumpedRun {
    pub center_distance_m: f64,
    pub duration_s: f64,
    /// Extra Coulomb torque on the fan shaft, N m (the catalogue's bearing drag).
    pub extra_drag_nm: f64,
    /// Multiplies the traction curve's creep stiffness (EA s): a belt whose creep differs from
    /// the configuration's (another simulator's healthy slip).
    pub creep_stiffness_factor: f64,
    pub step_s: f64,
    pub output_interval_s: f64,
    /// Recordings written by [`write_dataset`] start this long after the motor start, s (0:
    /// from standstill).
    pub from_s: f64,
    /// Runout of the driven (fan) pulley: its rotation axis this far off its centre, m.
    pub driven_runout_m: f64,
    /// The recordings' tachometer timer resolution, s (0: exact pulse times; `SensorModel`).
    pub timer_resolution_s: f64,
}

impl LumpedRun {
    pub fn at(center_distance_m: f64, duration_s: f64) -> Self {
        Self {
            center_distance_m,
            duration_s,
            extra_drag_nm: 0.0,
            creep_stiffness_factor: 1.0,
            step_s: 1e-4,
            output_interval_s: 1e-3,
            from_s: 0.0,
            driven_runout_m: 0.0,
            timer_resolution_s: 0.0,
        }
    }
}

/// Open-belt pitch length, m (Shigley eq. 17-1).
fn open_length_m(d: f64, r1: f64, r2: f64) -> f64 {
    let phi = ((r2 - r1) / d).asin();
    2.0 * d * phi.cos() + std::f64::consts::PI * (r1 + r2) + 2.0 * phi * (r2 - r1)
}

/// Runs the lumped model of `cfg` at `run`'s distance from standstill; rows at the output
/// interval (means over each interval), in the full-order model's row type.
pub fn simulate(cfg: &DriveConfig, run: &LumpedRun) -> Vec<OutputRow> {
    let (r1, r2) = (
        0.5 * cfg.driver.pitch_diameter_m,
        0.5 * cfg.driven.pitch_diameter_m,
    );
    let ea = cfg.belt.axial_stiffness_n;
    let d = run.center_distance_m;
    let d_ref = cfg
        .belt
        .reference_center_distance_m
        .unwrap_or_else(|| cfg.center_distance_m());
    let t_inst = cfg.belt.installation_tension_n.unwrap_or(250.0);
    let l0 = open_length_m(d_ref, r1, r2) / (1.0 + t_inst / ea);
    let t0 = ea * (open_length_m(d, r1, r2) / l0 - 1.0);
    // Wrap angle on the smaller (driver) pulley.
    let theta = std::f64::consts::PI - 2.0 * ((r2 - r1) / d).asin();
    let e = (cfg.effective_friction() * theta).exp();
    let m = cfg.belt.mass_per_length_kg_m;
    let motor = cfg.driver.motor.as_ref().expect("a motor-driven drive");
    let w_sync = motor.synchronous_rpm * std::f64::consts::PI / 30.0;
    let load = cfg.driven.load.as_ref().expect("a loaded drive");
    let creep_ea = ea * run.creep_stiffness_factor;
    let runout = run.driven_runout_m;
    // The driven pulley's radius about its shaft at angle theta2 (module docs).
    let r2_at = |theta2: f64| r2 + runout * theta2.cos();
    // Belt force on the shafts at driver speed w1, fan speed w2 and fan angle theta2.
    let traction = |w1: f64, w2: f64, theta2: f64| -> f64 {
        let v1 = r1 * w1;
        let capacity = (2.0 * (t0 - m * v1 * v1) * (e - 1.0) / (e + 1.0)).max(0.0);
        // Slip regularised at rest (speeds below 0.05 m/s carry no slip).
        let s = (v1 - r2_at(theta2) * w2) / v1.abs().max(0.05);
        if capacity <= 0.0 {
            return 0.0;
        }
        capacity * (1.0 - (-creep_ea * s.abs() / capacity).exp()) * s.signum()
    };
    // State: driver speed, fan speed, fan angle.
    let rhs = |t: f64, w: [f64; 3]| -> [f64; 3] {
        let on = t >= motor.start_time_s;
        let s = 1.0 - w[0] / w_sync;
        let tm = if on && s.abs() > 1e-12 {
            2.0 * motor.breakdown_torque_nm / (s / motor.breakdown_slip + motor.breakdown_slip / s)
        } else {
            0.0
        };
        let f = traction(w[0], w[1], w[2]);
        // Coulomb terms regularised over 0.1 rad/s so the shaft can rest.
        let coulomb = |c: f64, w: f64| c * (w / 0.1).clamp(-1.0, 1.0);
        let tl = coulomb(load.constant_nm + run.extra_drag_nm, w[1])
            + load.viscous_nm_s * w[1]
            + load.fan_nm_s2 * w[1] * w[1].abs();
        [
            (tm - r1 * f - cfg.driver.bearing_damping_n_m_s * w[0]) / cfg.driver.inertia_kg_m2,
            (r2_at(w[2]) * f - tl - cfg.driven.bearing_damping_n_m_s * w[1])
                / cfg.driven.inertia_kg_m2,
            w[1],
        ]
    };
    let dt = run.step_s;
    let per_row = (run.output_interval_s / dt).round().max(1.0) as usize;
    let steps = (run.duration_s / dt).round() as usize;
    let rpm = 30.0 / std::f64::consts::PI;
    let mut w = [0.0f64; 3];
    let mut rows = Vec::with_capacity(steps / per_row + 1);
    let mut acc = [0.0f64; 2];
    let ratio = cfg.transmission_ratio();
    let row = |t: f64, n1: f64, n2: f64| OutputRow {
        time_s: t,
        driver_rpm: n1,
        driven_rpm: n2,
        slip_pct: fom::slip::slip_pct(ratio, n1, n2),
        ..Default::default()
    };
    rows.push(row(0.0, 0.0, 0.0));
    for k in 0..steps {
        let t = k as f64 * dt;
        let add =
            |a: [f64; 3], b: [f64; 3], h: f64| [a[0] + h * b[0], a[1] + h * b[1], a[2] + h * b[2]];
        let k1 = rhs(t, w);
        let k2 = rhs(t + 0.5 * dt, add(w, k1, 0.5 * dt));
        let k3 = rhs(t + 0.5 * dt, add(w, k2, 0.5 * dt));
        let k4 = rhs(t + dt, add(w, k3, dt));
        for i in 0..3 {
            w[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        acc[0] += w[0];
        acc[1] += w[1];
        if (k + 1) % per_row == 0 {
            let n = per_row as f64;
            rows.push(row((k + 1) as f64 * dt, acc[0] / n * rpm, acc[1] / n * rpm));
            acc = [0.0; 2];
        }
    }
    rows
}

/// Writes a measured-data set (`belt-measurements/1`) of the lumped model of `cfg` into `dir`:
/// one recording per (label, centre distance), `run` at that distance, read by the default
/// sensor with seed `seed + k` for the k-th label; the manifest carries each label's distance.
/// Returns each recording's file name and settled slip (last 0.5 s, %).
pub fn write_dataset(
    dir: &std::path::Path,
    cfg: &DriveConfig,
    labels: &[(&str, f64)],
    run: &LumpedRun,
    seed: u64,
) -> twin::Result<Vec<(String, f64)>> {
    labels
        .iter()
        .enumerate()
        .map(|(k, &(label, d))| {
            let mut rows = simulate(
                cfg,
                &LumpedRun {
                    center_distance_m: d,
                    ..run.clone()
                },
            );
            let tail_slip = final_slip_pct(&rows, 0.5);
            // `from_s`: a recording that starts in steady running (times restart at 0).
            rows.retain(|r| r.time_s >= run.from_s - 1e-9);
            for r in &mut rows {
                r.time_s -= run.from_s;
            }
            let sensor = twin::sensor::SensorModel {
                seed: seed + k as u64,
                timer_resolution_s: run.timer_resolution_s,
                ..twin::sensor::SensorModel::default()
            };
            let at = crate::at_distance(cfg, d)?;
            let file = twin::sensor::append_synthetic_run(dir, label, &at, &rows, &sensor)?;
            Ok((file, tail_slip))
        })
        .collect()
}

/// The lumped model's settled mean slip over the last `window_s` of a run, %.
pub fn final_slip_pct(rows: &[OutputRow], window_s: f64) -> f64 {
    let t_end = rows.last().map_or(0.0, |r| r.time_s);
    let tail: Vec<f64> = rows
        .iter()
        .filter(|r| r.time_s >= t_end - window_s)
        .map(|r| r.slip_pct)
        .collect();
    tail.iter().sum::<f64>() / tail.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn healthy_creep_slip_is_the_transmitted_force_over_ea() {
        // Default drive at 0.424 m: far from the knee, slip = F / EA with F = fan torque / r2.
        let cfg = crate::default_drive();
        let rows = simulate(&cfg, &LumpedRun::at(0.424, 4.0));
        let last = rows.last().unwrap();
        let w2 = last.driven_rpm * std::f64::consts::PI / 30.0;
        let load = cfg.driven.load.as_ref().unwrap();
        let f = (load.constant_nm + load.fan_nm_s2 * w2 * w2 + 1e-4 * w2)
            / (0.5 * cfg.driven.pitch_diameter_m);
        let creep = 100.0 * f / cfg.belt.axial_stiffness_n;
        // The saturating curve slips more than pure creep by -ln(1 - x) / x with x = F / F_max
        // (about 0.26 here: a factor 1.15); 20 % bounds that factor for x below 0.33.
        let s = final_slip_pct(&rows, 0.5);
        assert!((s / creep - 1.0).abs() < 0.2, "slip {s} %, creep {creep} %");
        assert!(s > creep, "the saturating curve slips more than pure creep");
    }

    #[test]
    fn slip_grows_steeply_as_the_belt_loosens() {
        let cfg = crate::default_drive();
        let s = |d: f64| final_slip_pct(&simulate(&cfg, &LumpedRun::at(d, 4.0)), 0.5);
        let (tight, loose) = (s(0.424), s(0.4155));
        assert!(loose > 1.5 * tight, "tight {tight} %, loose {loose} %");
    }
}
