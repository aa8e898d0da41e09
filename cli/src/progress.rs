//! Progress bars (indicatif) for the long-running commands.

use fom::ValidConfig;
use indicatif::{ProgressBar, ProgressFinish, ProgressStyle};

fn bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
    bar
}

/// Steps of one full-order run.
fn simulation_steps(cfg: &ValidConfig) -> Option<f64> {
    Some(cfg.simulation.duration_s / cfg.resolved_step_s().ok()?)
}

/// A bar for one full-order run expected to take more than about a second, else none. It
/// ticks on its own while the static equilibrium is found (before the run reports); a run
/// expected to take over ten minutes is announced with its estimate first.
pub fn simulation(cfg: &ValidConfig) -> Option<ProgressBar> {
    // A configuration that cannot build a model gets no bar: the run reports why at once.
    let steps = simulation_steps(cfg)?;
    // ~50 ns per segment and step on one core (`docs/validation/speed.md`, "Full-order model").
    let estimate_s = steps * cfg.belt.segments as f64 * 5e-8;
    if estimate_s > 600.0 {
        eprintln!(
            "note: this run takes about {:.1} h on one core ({:.2e} steps of {} segments); \
             Ctrl-C stops it",
            estimate_s / 3600.0,
            steps,
            cfg.belt.segments
        );
    }
    (estimate_s >= 1.0).then(|| {
        let b = bar(
            1000,
            "simulating {bar:40} {msg} [{elapsed_precise} < {eta}]",
        );
        b.set_message("finding the static equilibrium");
        b.enable_steady_tick(std::time::Duration::from_millis(500));
        b
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

/// A spinner with the elapsed time for a command that reports nothing until it is done
/// (`rom gap`); cleared when dropped, so that an error message stands alone. Like every bar
/// here it draws on stderr only when stderr is a terminal.
pub fn working(what: &str) -> ProgressBar {
    let b = ProgressBar::new_spinner()
        .with_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed_precise}]")
                .expect("valid template"),
        )
        .with_message(what.to_string())
        .with_finish(ProgressFinish::AndClear);
    b.enable_steady_tick(std::time::Duration::from_millis(250));
    b
}
