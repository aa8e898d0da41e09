//! Progress bars (indicatif) for the long-running commands.

use fom::DriveConfig;
use indicatif::{ProgressBar, ProgressStyle};

fn bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
    bar
}

/// A bar for one full-order run expected to take more than about a second, else none.
pub fn simulation(cfg: &DriveConfig) -> Option<ProgressBar> {
    let steps = cfg.simulation.duration_s / cfg.simulation.step_s;
    let segment_steps = steps * cfg.belt.segments as f64;
    // ~50 ns per segment-step on one core (README figure); below ~1 s, no bar.
    (segment_steps * 5e-8 >= 1.0).then(|| {
        bar(
            1000,
            "simulating {bar:40} {msg} [{elapsed_precise} < {eta}]",
        )
    })
}

/// The callback a run reports its simulated time to.
pub fn simulation_callback(bar: &ProgressBar) -> impl Fn(f64, f64) + Sync + '_ {
    move |t, total| {
        bar.set_position((1000.0 * t / total) as u64);
        bar.set_message(format!("{t:.2}/{total:.2} s"));
    }
}

/// A bar over the runs of a training campaign (length set when the campaign starts).
pub fn campaign() -> ProgressBar {
    bar(
        0,
        "training {bar:40} {pos}/{len} runs, {msg} [{elapsed_precise} < {eta}]",
    )
}

/// A bar over the full-order runs of a validation.
pub fn validation(points: usize) -> ProgressBar {
    bar(
        points as u64,
        "validating {bar:40} {pos}/{len} full-order runs [{elapsed_precise} < {eta}]",
    )
}
