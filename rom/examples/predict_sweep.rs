//! Time of 10,000 slip-distribution predictions with the shipped surrogate (100 friction
//! samples each, d swept over 0.416-0.424 m), the Rust side of `Surrogate.predict_many`:
//!
//!     cargo build --release --example predict_sweep -p beltwin-rom
//!     taskset -c 0 target/release/examples/predict_sweep

use fom::DesignPoint;
use rom::predict_distribution;

fn main() {
    let file = rom::shipped::slip_model().expect("the shipped surrogate");
    let s = &file.surrogate;
    let cfg = s.config().expect("its configuration");
    let n = 10_000;
    let start = std::time::Instant::now();
    let mut sum = 0.0;
    for i in 0..n {
        let d_m = 0.416 + 0.008 * i as f64 / (n - 1) as f64;
        let q = DesignPoint::nominal_with(&cfg, Some(d_m), None, None);
        sum += predict_distribution(s, &cfg, &q, 100, false)
            .expect("a point in the box")
            .mean_slip_pct;
    }
    println!(
        "{n} predictions in {:.3} s (mean of the mean slips {:.6} %)",
        start.elapsed().as_secs_f64(),
        sum / n as f64
    );
}
