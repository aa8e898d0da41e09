//! Whether belt hysteresis shows through a torque channel: the phase by which the slip lags a
//! shaft torque at the blade-pass frequency on the default drive with the fan's load pulsating
//! (`blade-pass-pulsation:blades=8,amplitude=0.45`), for no hysteresis, g = 0.2 and 0.4
//! (tau = 10 ms), g = 0.2 at the relaxation time of the largest loss angle, and the healthy
//! belt with EA 15 % stiffer (a wrong datasheet EA). Figures: docs/validation/gap.md.
//!
//! `nice cargo run --release -p beltwin-twin --example hysteresis_torque_phase`
//! (five full-order runs of 6 s at the resolution of `rom gap`'s twin runs, two at a time;
//! about 15 s on two cores). The window: the steady speeds of the recording as `rom gap` reads
//! them (`gap::features::steady_speeds`) up to 6 s. The lag is read from the model's rows and
//! from the default 60-pulse tachometer with 1 rpm noise (two seeds; the torque itself exact,
//! as a strain-gauge channel sampled with the speeds); its scatter is the standard deviation
//! of the lag over eight 0.5 s batches divided by sqrt 8, and the two seeds' difference.

use rayon::prelude::*;

use fom::stats::{mean, rms, sample_std};
use fom::{DriveConfig, OutputRow, RunOptions};
use twin::gap::features::{steady_speeds, Read};
use twin::gap::twin_runs::{run_config, Resolution};
use twin::sensor::{measure, SensorModel};
use twin::signal::{lag_deg, line};

const PULSATION: &str = "blade-pass-pulsation:blades=8,amplitude=0.45";
const BLADES: f64 = 8.0;
const DURATION_S: f64 = 6.0;
const BATCHES: usize = 8;

/// One series: time, slip (%), driver and driven torque (N m), tight minus slack span
/// tension (N), driven speed (rpm).
struct Series {
    t: Vec<f64>,
    slip: Vec<f64>,
    tq1: Vec<f64>,
    tq2: Vec<f64>,
    tension: Vec<f64>,
    n2: Vec<f64>,
    dt: f64,
}

impl Series {
    fn from_rows(rows: &[OutputRow], from_s: f64) -> Self {
        let r: Vec<&OutputRow> = rows.iter().filter(|r| r.time_s > from_s).collect();
        let t: Vec<f64> = r.iter().map(|r| r.time_s).collect();
        Series {
            dt: t[1] - t[0],
            slip: r.iter().map(|r| r.slip_pct).collect(),
            tq1: r.iter().map(|r| r.driver_torque_nm).collect(),
            tq2: r.iter().map(|r| r.driven_torque_nm).collect(),
            tension: r
                .iter()
                .map(|r| r.tight_span_tension_n - r.slack_span_tension_n)
                .collect(),
            n2: r.iter().map(|r| r.driven_rpm).collect(),
            t,
        }
    }

    /// The tachometer's speeds and slip, the torques of the rows at the sample times (the rows
    /// are 1 ms interval means ending at the same instants as the 1 kHz samples).
    fn from_tachometer(
        rows: &[OutputRow],
        ratio: f64,
        from_s: f64,
        seed: u64,
        noise_rpm: f64,
    ) -> Self {
        let sensor = SensorModel {
            seed,
            speed_noise_rpm: [noise_rpm; 2],
            ..SensorModel::default()
        };
        let rec = measure(rows, &sensor);
        let dt_row = rows[1].time_s - rows[0].time_s;
        let row_at = |t: f64| &rows[((t - rows[0].time_s) / dt_row).round() as usize];
        let s: Vec<(f64, f64)> = rec
            .slip_samples(ratio)
            .into_iter()
            .filter(|&(t, _)| t > from_s && t <= rows[rows.len() - 1].time_s)
            .collect();
        let t: Vec<f64> = s.iter().map(|p| p.0).collect();
        let n2 = t
            .iter()
            .map(|&ti| rec.driven_rpm[(ti * sensor.sample_rate_hz).round() as usize])
            .collect();
        Series {
            dt: 1.0 / sensor.sample_rate_hz,
            slip: s.iter().map(|p| p.1).collect(),
            tq1: t.iter().map(|&ti| row_at(ti).driver_torque_nm).collect(),
            tq2: t.iter().map(|&ti| row_at(ti).driven_torque_nm).collect(),
            tension: t
                .iter()
                .map(|&ti| row_at(ti).tight_span_tension_n - row_at(ti).slack_span_tension_n)
                .collect(),
            n2,
            t,
        }
    }

    fn blade_pass_hz(&self) -> f64 {
        BLADES * mean(&self.n2) / 60.0
    }

    /// Lag (deg) of the slip behind `x` over the whole window, and its batch standard error.
    fn lag(&self, x: &[f64]) -> (f64, f64) {
        let f = self.blade_pass_hz();
        let whole = lag_deg(&self.t, x, &self.slip, f, self.dt);
        let n = self.t.len() / BATCHES;
        let batches: Vec<f64> = (0..BATCHES)
            .map(|b| {
                let r = b * n..(b + 1) * n;
                let l = lag_deg(&self.t[r.clone()], &x[r.clone()], &self.slip[r], f, self.dt);
                // Unwrapped about the whole window's lag.
                whole + (l - whole + 540.0).rem_euclid(360.0) - 180.0
            })
            .collect();
        (whole, sample_std(&batches) / (BATCHES as f64).sqrt())
    }
}

/// Loss angle (deg) of the standard linear solid at `w_rad_s` (Lakes, Viscoelastic Materials,
/// 2009, sec. 3.4): tan(delta) = g w tau / (1 - g + (w tau)^2).
fn loss_angle_deg(g: f64, tau_s: f64, w_rad_s: f64) -> f64 {
    let wt = w_rad_s * tau_s;
    (g * wt / (1.0 - g + wt * wt)).atan().to_degrees()
}

/// A case: its name, the belt's hysteresis (g, tau s) if any, the factor on EA.
type Case = (String, Option<(f64, f64)>, f64);

fn main() {
    // (name, hysteresis (g, tau), EA factor); the last case is the relaxation time at which
    // the loss angle at the blade-pass frequency peaks, w tau = sqrt(1 - g).
    let tau_peak = (0.8f64).sqrt() / (2.0 * std::f64::consts::PI * 116.0);
    let cases: [Case; 5] = [
        ("no hysteresis".into(), None, 1.0),
        ("g 0.2".into(), Some((0.2, 0.01)), 1.0),
        ("g 0.4".into(), Some((0.4, 0.01)), 1.0),
        ("EA +15 %".into(), None, 1.15),
        (
            format!("g 0.2, tau {:.2} ms", tau_peak * 1e3),
            Some((0.2, tau_peak)),
            1.0,
        ),
    ];
    let base = DriveConfig::default_hvac();
    let ratio = base.transmission_ratio();
    let runs: Vec<Vec<OutputRow>> = cases
        .par_iter()
        .map(|(_, hyst, ea)| {
            let mut cfg = base.clone();
            cfg.belt.axial_stiffness_n *= ea;
            cfg.effects.set_from_spec(PULSATION).unwrap();
            let spec = hyst
                .map(|(g, tau)| format!("belt-hysteresis:stiffness_ratio={g},relaxation_s={tau}"));
            let q = fom::DesignPoint::nominal(&cfg);
            let c = run_config(
                &cfg,
                &q,
                &Resolution::default(),
                1e-3,
                DURATION_S,
                spec.as_deref(),
            )
            .unwrap();
            fom::simulate(&c, RunOptions::default()).unwrap().rows
        })
        .collect();
    let show = |(l, se): (f64, f64)| format!("{l:.2} ± {se:.2}");
    let mut lines = String::from(
        "| case | steady from s | f_bp Hz | loss angle deg | slip pp | driven speed rpm | \
         driven torque N m | driver torque N m | tension difference N |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut table = String::from(
        "| case | driven torque, rows | driver torque, rows | driver torque, rows from 2 s | \
         tension difference, rows | driven torque, tachometer seed 1 | seed 2 | \
         driver torque, seed 1 | seed 2 | tachometer without noise: driven torque | \
         driver torque |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    // Per torque channel (driven, driver): the rows' lag and the tachometer's (seed 1, 2).
    let mut lags: Vec<[(f64, [f64; 2]); 2]> = Vec::new();
    let mut batch_se = Vec::new();
    for ((name, hyst, _), rows) in cases.iter().zip(&runs) {
        // The steady window of the speeds as `rom gap` reads the recording.
        let rec = measure(rows, &SensorModel::default());
        let from_s = steady_speeds(&rec, ratio, Read::Own)
            .expect("steady")
            .time_s[0];
        let truth = Series::from_rows(rows, from_s);
        let f = truth.blade_pass_hz();
        let loss = hyst.map_or(0.0, |(g, tau)| {
            loss_angle_deg(g, tau, 2.0 * std::f64::consts::PI * f)
        });
        let amp = |v: &[f64]| line(&truth.t, v, f, truth.dt).0;
        lines += &format!(
            "| {name} | {from_s:.2} | {f:.2} | {loss:.2} | {:.4} | {:.3} | {:.3} | {:.4} | {:.3} |\n",
            amp(&truth.slip),
            amp(&truth.n2),
            amp(&truth.tq2),
            amp(&truth.tq1),
            amp(&truth.tension),
        );
        let tach: Vec<Series> = [1, 2]
            .iter()
            .map(|&s| Series::from_tachometer(rows, ratio, from_s, s, 1.0))
            .collect();
        let clean = Series::from_tachometer(rows, ratio, from_s, 1, 0.0);
        let late = Series::from_rows(rows, 2.0);
        let t2 = [tach[0].lag(&tach[0].tq2), tach[1].lag(&tach[1].tq2)];
        let t1 = [tach[0].lag(&tach[0].tq1), tach[1].lag(&tach[1].tq1)];
        let (r2, r1) = (truth.lag(&truth.tq2), truth.lag(&truth.tq1));
        table += &format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} |\n",
            show(r2),
            show(r1),
            show(late.lag(&late.tq1)),
            show(truth.lag(&truth.tension)),
            show(t2[0]),
            show(t2[1]),
            show(t1[0]),
            show(t1[1]),
            clean.lag(&clean.tq2).0,
            clean.lag(&clean.tq1).0,
        );
        lags.push([(r2.0, [t2[0].0, t2[1].0]), (r1.0, [t1[0].0, t1[1].0])]);
        batch_se.extend([t2[0].1, t2[1].1, t1[0].1, t1[1].1]);
    }
    println!("Lines at the blade-pass frequency (rows):\n\n{lines}");
    println!("Lag of the slip behind each signal at the blade-pass frequency, deg:\n\n{table}");
    // Scatter of one recording's lag through the tachometer: the RMS batch standard error, and
    // the RMS of the two seeds' difference over sqrt 2 (each pooled over cases and channels).
    let seed_sd: Vec<f64> = lags
        .iter()
        .flat_map(|c| c.iter().map(|(_, s)| (s[0] - s[1]) / 2f64.sqrt()))
        .collect();
    let (se_batch, se_seed) = (rms(&batch_se), rms(&seed_sd));
    println!(
        "\nscatter of one recording's lag through the tachometer: {se_batch:.2} deg (batches), \
         {se_seed:.2} deg (seeds)"
    );
    println!("| case | channel | lag change from no hysteresis, rows deg | tachometer seed 1 | seed 2 | rows' change / larger scatter |");
    println!("|---|---|---:|---:|---:|---:|");
    for (k, (name, _, _)) in cases.iter().enumerate().skip(1) {
        for (j, ch) in ["driven torque", "driver torque"].iter().enumerate() {
            let (r, s) = lags[k][j];
            let (r0, s0) = lags[0][j];
            println!(
                "| {name} | {ch} | {:.2} | {:.2} | {:.2} | {:.2} |",
                r - r0,
                s[0] - s0[0],
                s[1] - s0[1],
                (r - r0).abs() / se_batch.max(se_seed)
            );
        }
    }
}
