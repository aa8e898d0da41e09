//! Wall time of the default drive (issue 2 speed target): `cargo bench -p beltwin-fom`.
//! One sample simulates 3 s from static equilibrium at the default resolution on one core.
use criterion::{criterion_group, criterion_main, Criterion};
use fom::simulation::{prepare, run_prepared, RunOptions};
use fom::DriveConfig;

fn default_drive_3s(c: &mut Criterion) {
    let cfg = DriveConfig::default_hvac();
    let (model, eq) = prepare(&cfg).unwrap();
    let mut group = c.benchmark_group("fom");
    group.sample_size(10);
    group.bench_function("default_drive_3s", |b| {
        b.iter(|| run_prepared(&cfg, model.clone(), eq, RunOptions::default()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, default_drive_3s);
criterion_main!(benches);
