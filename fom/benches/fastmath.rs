//! The slice exponential against libm's: `cargo bench -p beltwin-fom --features bench --bench fastmath`.
//! 4,096 values over [-12.3, 0], the range of the surrogate's correlation exponents.
use criterion::{criterion_group, criterion_main, Criterion};

fn exp_slice(c: &mut Criterion) {
    let x: Vec<f64> = (0..4096).map(|i| -(i as f64) * 0.003).collect();
    let mut v = x.clone();
    let mut group = c.benchmark_group("exp_4096");
    group.bench_function("fastmath", |b| {
        b.iter(|| {
            v.copy_from_slice(&x);
            fom::fastmath::exp_in_place(std::hint::black_box(&mut v));
        })
    });
    group.bench_function("libm", |b| {
        b.iter(|| {
            v.copy_from_slice(&x);
            std::hint::black_box(&mut v)
                .iter_mut()
                .for_each(|e| *e = e.exp());
        })
    });
    group.finish();
}

criterion_group!(benches, exp_slice);
criterion_main!(benches);
