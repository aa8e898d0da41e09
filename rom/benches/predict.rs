//! Prediction latency of the shipped surrogate: a full slip distribution with the friction
//! uncertainty propagated by 100 samples (the `rom predict` default) and by 200, one point, and
//! the parts.

use criterion::{criterion_group, criterion_main, Criterion};
use fom::DesignPoint;
use rom::predict_distribution;

fn bench(c: &mut Criterion) {
    let file = rom::shipped::slip_model().expect("shipped surrogate");
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let q = DesignPoint {
        center_distance_m: 0.42,
        friction: 0.7,
        installation_tension_n: 250.0,
        axial_stiffness_n: None,
        effects: Default::default(),
        side_gap_m: None,
        load_torque_nm: None,
        shaft_load_n: None,
    };
    for k in [100, 200] {
        c.bench_function(&format!("predict_distribution_{k}_samples"), |b| {
            b.iter(|| predict_distribution(s, &cfg, &q, k, false).unwrap())
        });
    }
    let qs: Vec<DesignPoint> = rom::predict::friction_samples(0.7, 200)
        .into_iter()
        .map(|mu| DesignPoint { friction: mu, ..q })
        .collect();
    c.bench_function("quantile_functions_200", |b| {
        b.iter(|| s.quantile_functions(&cfg, &qs).unwrap())
    });
    c.bench_function("predict_point", |b| {
        b.iter(|| s.predict_point(&cfg, &q).unwrap())
    });
    c.bench_function("load_surrogate_file", |b| {
        b.iter(|| rom::shipped::slip_model().unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
