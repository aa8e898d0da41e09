//! Shared set-ups for the system tests in `tests/tests/`.

use fom::config::{DriveConfig, SpeedProfileConfig};
use fom::simulation::{simulate, RunOptions, RunResult};
use std::sync::OnceLock;

pub mod example_args;

/// The shipped surrogate (`rom::shipped::SLIP`).
pub fn shipped_surrogate() -> rom::SurrogateFile {
    rom::shipped::slip_model().unwrap()
}

/// The shipped default drive.
pub fn default_drive() -> DriveConfig {
    DriveConfig::default_hvac()
}

/// Replaces the motor by a prescribed driver speed: linear ramp to `rpm` over `ramp_s`.
pub fn with_prescribed_driver(mut cfg: DriveConfig, rpm: f64, ramp_s: f64) -> DriveConfig {
    cfg.driver.motor = None;
    cfg.driver.speed_profile = Some(SpeedProfileConfig {
        time_s: vec![0.0, ramp_s],
        rpm: vec![0.0, rpm],
    });
    cfg
}

/// A short steady-running case for step/segment studies: prescribed driver ramped to the
/// motor's loaded speed, a light fan impeller so the drive settles within ~0.5 s.
pub fn quick_steady_drive() -> DriveConfig {
    let mut cfg = with_prescribed_driver(default_drive(), 1750.0, 0.2);
    cfg.driven.inertia_kg_m2 = 0.02;
    cfg.simulation.duration_s = 0.9;
    cfg.simulation.steady_start_s = Some(0.5);
    cfg
}

/// The default drive (motor start from standstill) run to steady state once per test binary:
/// 2.6 s, steady window from 1.6 s.
pub fn default_steady_run() -> &'static RunResult {
    static RUN: OnceLock<RunResult> = OnceLock::new();
    RUN.get_or_init(|| {
        let mut cfg = default_drive();
        cfg.simulation.duration_s = 2.6;
        cfg.simulation.steady_start_s = Some(1.6);
        simulate(&cfg.check().expect("valid"), RunOptions::default()).expect("default drive runs")
    })
}

/// `cfg` moved to centre distance `d` (the driven pulley along the line of centres).
pub fn at_distance(cfg: &DriveConfig, d: f64) -> fom::Result<fom::ValidConfig> {
    fom::DesignPoint {
        center_distance_m: d,
        ..fom::DesignPoint::nominal(cfg)
    }
    .apply(cfg)
}

/// Relative difference |a - b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A cheap drive for surrogate tests: 100 segments at 2.2e-5 s, the default motor, a light fan
/// impeller (0.02 kg m^2) so the start-up ends within ~0.4 s. At 80 segments this drive
/// carries a growing speed oscillation (slip std 0.03 % -> 0.11 % over the first second at
/// d 0.4225 m), as large as the effects the tests look for; at 100 segments the std stays near
/// 0.01 % and bearing drag of 0.3 vs 3.7 N m moves slip 0.675 % -> 0.800 % (the default
/// 240-segment drive: 0.695 % -> 0.846 %).
pub fn cheap_drive() -> DriveConfig {
    let mut cfg = default_drive();
    cfg.belt.segments = 100;
    cfg.simulation.step_s = fom::config::StepSize::Seconds(2.2e-5);
    cfg.driven.inertia_kg_m2 = 0.02;
    cfg
}

/// The default drive (240 segments) with a light fan impeller (0.02 kg m^2): steady within
/// ~0.5 s of motor start, so surrogate tests can train on 1 s runs. ~1.3 s of CPU per run.
pub fn light_fan_drive() -> DriveConfig {
    let mut cfg = default_drive();
    cfg.driven.inertia_kg_m2 = 0.02;
    cfg
}

/// Campaign settings for `cheap_drive` and `light_fan_drive`: healthy to strongly loose (d
/// 0.416-0.424 m), runs of 0.6-3 s that end once 0.4 s of steady running are in.
pub fn cheap_settings(samples: usize, seed: u64) -> training::CampaignSettings {
    training::CampaignSettings {
        samples,
        seed,
        center_distance_m: [0.416, 0.424],
        friction: [0.6, 0.8],
        installation_tension_n: [200.0, 300.0],
        axial_stiffness_n: None,
        effect_parameters: Default::default(),
        tooth: None,
        duration_s: 3.0,
        min_duration_s: 0.6,
        steady_length_s: 0.4,
    }
}

pub mod creep;
pub mod lumped;
