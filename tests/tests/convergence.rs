//! Convergence of the steady mean slip in step size and segment count
//! (`docs/validation/convergence.md`): halving the step and doubling the segments each change it by
//! less than 1 % relative. The short variants run on a quick prescribed-speed drive; the full
//! default drive (motor start, 3 s) is in the `#[ignore]`d long variants
//! (`cargo test --release -- --ignored`).

use beltwin_tests::{default_drive, quick_steady_drive, rel};
use fom::config::DriveConfig;
use fom::simulation::{simulate, RunOptions};

fn mean_slip(mut cfg: DriveConfig, segments: usize, step_s: f64) -> f64 {
    cfg.belt.segments = segments;
    cfg.simulation.step_s = fom::config::StepSize::Seconds(step_s);
    let s = simulate(&cfg.check().unwrap(), RunOptions::default())
        .unwrap()
        .summary;
    assert!(s.steady_rows > 100 && s.mean_slip_pct > 0.3, "{s:?}");
    s.mean_slip_pct
}

/// Step halving at 240 segments, (240, dt) -> (240, dt/2); segment doubling at a step both
/// resolutions allow (480 segments need dt <= 4.8e-6 s): (240, dt/4) -> (480, dt/4).
fn assert_converged(cfg: DriveConfig) {
    let dt = cfg.check().unwrap().resolved_step_s().unwrap();
    let base = mean_slip(cfg.clone(), 240, dt);
    let half_step = mean_slip(cfg.clone(), 240, 0.5 * dt);
    // 1 %: the target's bound.
    assert!(
        rel(half_step, base) < 0.01,
        "halving the step: {base:.4} % -> {half_step:.4} %"
    );
    let fine_240 = mean_slip(cfg.clone(), 240, 0.25 * dt);
    let fine_480 = mean_slip(cfg, 480, 0.25 * dt);
    assert!(
        rel(fine_480, fine_240) < 0.01,
        "doubling the segments: {fine_240:.4} % -> {fine_480:.4} %"
    );
}

#[test]
fn steady_slip_converges_in_step_and_segments_short() {
    assert_converged(quick_steady_drive());
}

#[test]
#[ignore = "about a minute: the full default drive four times"]
fn steady_slip_converges_in_step_and_segments_default_drive() {
    assert_converged(default_drive());
}
