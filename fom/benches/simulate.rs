//! Wall time of the default drive: `cargo bench -p beltwin-fom --features bench`.
//! - `default_drive_3s`: 3 s from static equilibrium at the default resolution on one core
//!   (target: 4x real time, `docs/validation/speed.md`);
//! - `effects/<name>`: 1 s of the default drive with one catalogue effect switched on, against
//!   `effects/none` (target: an effect costs at most 10 % of the run time,
//!   `docs/validation/effects.md`, "Cost").
use criterion::{criterion_group, criterion_main, Criterion};
use fom::simulation::{prepare, run_prepared, RunOptions};
use fom::DriveConfig;

fn default_drive_3s(c: &mut Criterion) {
    let cfg = fom::ValidConfig::default_hvac();
    let (model, eq) = prepare(&cfg).unwrap();
    let mut group = c.benchmark_group("fom");
    group.sample_size(10);
    group.bench_function("default_drive_3s", |b| {
        b.iter(|| run_prepared(&cfg, model.clone(), eq, RunOptions::default()).unwrap())
    });
    group.finish();
}

fn effects(c: &mut Criterion) {
    let cases: [(&str, Option<&str>); 6] = [
        ("none", None),
        (
            "pulley-eccentricity",
            Some("pulley-eccentricity:pulley=driven,runout_m=2e-4"),
        ),
        (
            "blade-pass-pulsation",
            Some("blade-pass-pulsation:blades=8,amplitude=0.05"),
        ),
        (
            "stribeck-friction",
            Some("stribeck-friction:dynamic_ratio=0.6,stribeck_speed_m_s=0.05"),
        ),
        ("bearing-drag", Some("bearing-drag:coulomb_nm=1")),
        (
            "belt-hysteresis",
            Some("belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01"),
        ),
    ];
    let mut group = c.benchmark_group("effects");
    group.sample_size(10);
    for (name, spec) in cases {
        let mut cfg = DriveConfig::default_hvac();
        cfg.simulation.duration_s = 1.0;
        if let Some(s) = spec {
            cfg.effects.set_from_spec(s).unwrap();
        }
        let cfg = cfg.check().unwrap();
        let (model, eq) = prepare(&cfg).unwrap();
        group.bench_function(name, |b| {
            b.iter(|| run_prepared(&cfg, model.clone(), eq, RunOptions::default()).unwrap())
        });
    }
    group.finish();
}

fn synchronous_arc(c: &mut Criterion) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/synchronous-arc.toml");
    let cfg = DriveConfig::from_file(&path).unwrap();
    let mut group = c.benchmark_group("fom");
    group.sample_size(10);
    group.bench_function("synchronous_arc_0_3s", |b| {
        b.iter(|| fom::simulate(&cfg, RunOptions::default()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, default_drive_3s, effects, synchronous_arc);
criterion_main!(benches);
