//! Bad input (`docs/configuration.md`, "Checks"): one clear error per class, naming the cause and
//! the place.

use beltwin_tests::at_distance;
use fom::config::{DriveConfig, DEFAULT_HVAC_TOML};
use fom::simulation::simulate;
use fom::{FomError, Model, RunOptions};

/// The default file with one line replaced (the line must exist).
fn edited(old: &str, new: &str) -> String {
    assert!(
        DEFAULT_HVAC_TOML.contains(old),
        "test edits a line that exists: {old}"
    );
    DEFAULT_HVAC_TOML.replacen(old, new, 1)
}

fn config_error(text: &str) -> String {
    match DriveConfig::from_toml_str(text, "drive.toml") {
        Err(e @ FomError::Config { .. }) => e.to_string(),
        other => panic!("expected a configuration error, got {other:?}"),
    }
}

#[test]
fn unknown_key_is_named() {
    let msg = config_error(&edited(
        "thickness_m = 0.008",
        "thickness_m = 0.008\nthicknes_m = 1",
    ));
    assert!(
        msg.contains("drive.toml") && msg.contains("thicknes_m"),
        "{msg}"
    );
}

#[test]
fn missing_key_is_named() {
    let msg = config_error(&edited("axial_stiffness_n = 20000.0", ""));
    assert!(
        msg.contains("axial_stiffness_n") && msg.contains("missing"),
        "{msg}"
    );
}

#[test]
fn toml_syntax_error_gives_the_line() {
    let msg = config_error(&edited("segments = 240", "segments = = 240"));
    assert!(msg.contains("line"), "{msg}");
}

#[test]
fn negative_value_is_named_with_its_key() {
    let msg = config_error(&edited(
        "mass_per_length_kg_m = 0.105",
        "mass_per_length_kg_m = -0.1",
    ));
    assert!(msg.contains("belt.mass_per_length_kg_m = -0.1"), "{msg}");
}

#[test]
fn two_belt_length_specifications_are_refused() {
    let msg = config_error(&edited(
        "installation_tension_n = 250.0",
        "installation_tension_n = 250.0\npre_strain = 0.01",
    ));
    assert!(msg.contains("exactly one of"), "{msg}");
}

#[test]
fn motor_and_speed_profile_together_are_refused() {
    let msg = config_error(&format!(
        "{DEFAULT_HVAC_TOML}\n[driver.speed_profile]\ntime_s = [0.0, 1.0]\nrpm = [0.0, 1000.0]\n"
    ));
    assert!(msg.contains("not both"), "{msg}");
}

#[test]
fn overlapping_pulleys_are_refused() {
    let err = at_distance(&DriveConfig::default_hvac(), 0.12).unwrap_err();
    assert!(err.to_string().contains("pulleys overlap"), "{err}");
}

#[test]
fn belt_too_long_to_be_tensioned_is_refused() {
    let mut cfg = DriveConfig::default_hvac();
    cfg.belt.installation_tension_n = None;
    cfg.belt.unstretched_length_m = Some(1.40);
    let err = Model::from_config(&cfg.check().unwrap()).unwrap_err();
    assert!(
        matches!(err, FomError::Geometry(_)) && err.to_string().contains("slack"),
        "{err}"
    );
}

#[test]
fn belt_too_short_to_wrap_is_refused() {
    let mut cfg = DriveConfig::default_hvac();
    cfg.belt.installation_tension_n = None;
    // The open-belt path is 1.317 m: 1.10 m would stretch 19.7 %, beyond the default rated
    // elongation of 10 %.
    cfg.belt.unstretched_length_m = Some(1.10);
    let err = Model::from_config(&cfg.check().unwrap()).unwrap_err();
    assert!(
        err.to_string().contains("too short to wrap") && err.to_string().contains("max_strain"),
        "{err}"
    );
}

/// The installation strain limit is the belt's rated elongation (`belt.max_strain`), compared
/// with a tolerance: a belt installed at exactly its limit builds (5 % was refused by a
/// floating-point comparison), one above it is refused naming the key, and an elastomer belt
/// at 8 % builds under the default limit with a warning above the typical working strain.
#[test]
fn installation_strain_is_limited_by_the_rated_elongation() {
    let with = |pre: f64, max: Option<f64>| {
        let mut cfg = DriveConfig::default_hvac();
        cfg.belt.installation_tension_n = None;
        cfg.belt.reference_center_distance_m = None;
        cfg.belt.pre_strain = Some(pre);
        cfg.belt.max_strain = max;
        // A shorter belt has stiffer segments: the step follows.
        cfg.simulation.step_s = fom::config::StepSize::Auto;
        cfg
    };
    let m = Model::from_config(&(with(0.05, Some(0.05))).check().unwrap()).unwrap();
    assert!((m.static_strain() - 0.05).abs() < 1e-12);
    assert!(m.strain_warning().unwrap().contains("5.00 %"));
    let err = with(0.06, Some(0.05)).check().unwrap_err().to_string();
    assert!(
        err.contains("belt.pre_strain = 0.06") && err.contains("max_strain = 0.05"),
        "{err}"
    );
    let m = Model::from_config(&(with(0.08, None)).check().unwrap()).unwrap();
    assert!(m.strain_warning().is_some());
    // The default drive (1.25 %) gives no warning.
    let m = Model::from_config(&fom::ValidConfig::default_hvac()).unwrap();
    assert!(m.strain_warning().is_none(), "{:?}", m.strain_warning());
    let err = with(0.01, Some(0.0)).check().unwrap_err().to_string();
    assert!(err.contains("belt.max_strain = 0"), "{err}");
}

/// `step_s = "auto"` picks the largest step within the stability estimate that divides the
/// output interval, and a fixed step above the limit is refused naming the step that would run.
#[test]
fn auto_step_picks_a_stable_step_and_a_refusal_names_it() {
    let text = edited("step_s = 1.0e-5", "step_s = \"auto\"");
    let cfg = DriveConfig::from_toml_str(&text, "drive.toml").unwrap();
    let m = Model::from_config(&cfg).unwrap();
    let (dt, limit) = (m.params.step_s, m.stable_step_estimate_s());
    let per_row = cfg.simulation.output_interval_s / dt;
    assert!(dt <= limit && dt > 0.95 * limit, "{dt} vs {limit}");
    assert!((per_row - per_row.round()).abs() < 1e-9, "{per_row}");
    assert_eq!(cfg.resolved_step_s().unwrap(), dt);
    // It survives the round trip through the file format.
    let again = DriveConfig::from_toml_str(&cfg.to_toml_string(), "again").unwrap();
    assert_eq!(again.simulation.step_s, fom::config::StepSize::Auto);
    let mut fixed = DriveConfig::default_hvac();
    fixed.simulation.step_s = fom::config::StepSize::Seconds(5e-5);
    let err = Model::from_config(&fixed.check().unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(&format!("a step of {dt:.4e} s would run")) && err.contains("\"auto\""),
        "{err}"
    );
    let err = config_error(&edited("step_s = 1.0e-5", "step_s = \"fast\""));
    assert!(err.contains("step_s") && err.contains("auto"), "{err}");
}

#[test]
fn step_above_stability_limit_is_refused_before_running() {
    let mut cfg = DriveConfig::default_hvac();
    cfg.simulation.step_s = fom::config::StepSize::Seconds(5e-5);
    let err = Model::from_config(&cfg.check().unwrap()).unwrap_err();
    assert!(err.to_string().contains("stability limit"), "{err}");
}

#[test]
fn runaway_penetration_stops_the_run_with_its_time() {
    // A contact far too soft for the belt tension: the belt sinks into the pulleys.
    let mut cfg = DriveConfig::default_hvac();
    cfg.contact.stiffness_n_m = 100.0;
    cfg.simulation.duration_s = 0.2;
    let err = simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, FomError::Numerical { .. })
            && msg.contains("penetration")
            && msg.contains("t = "),
        "{msg}"
    );
}

#[test]
fn failure_during_the_run_stops_it_at_the_next_check_with_run_time() {
    // A corrupted state (as after an overflow) must not produce rows: the run stops at its
    // first health check, at the end of the first 1 ms output interval.
    let mut cfg = DriveConfig::default_hvac();
    cfg.simulation.duration_s = 0.05;
    let (mut model, eq) = fom::simulation::prepare(&cfg.check().unwrap()).unwrap();
    model.belt.vy[40] = f64::INFINITY;
    let msg = match fom::simulation::run_prepared(
        &cfg.check().unwrap(),
        model,
        eq,
        RunOptions::default(),
    ) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a non-finite state ran through"),
    };
    assert!(
        msg.contains("t = 0.001000 s") && msg.contains("NaN or infinite"),
        "{msg}"
    );
}

#[test]
fn non_finite_state_is_reported_not_returned() {
    let mut model = Model::from_config(&fom::ValidConfig::default_hvac()).unwrap();
    model.belt.vx[17] = f64::NAN;
    let err = model.check_health().unwrap_err();
    assert!(err.to_string().contains("NaN"), "{err}");
}

/// A point in the drive plane has two coordinates: a third (or a stray value) is refused, not
/// dropped.
#[test]
fn a_fixed_size_array_with_extra_elements_is_refused() {
    let msg = config_error(&edited(
        "center_m = [0.42, 0.0]",
        "center_m = [0.42, 0.0, 0.0]",
    ));
    assert!(
        msg.contains("invalid length 3") && msg.contains("exactly 2"),
        "{msg}"
    );
    let msg = config_error(&edited(
        "gravity_m_s2 = [0.0, -9.81]",
        "gravity_m_s2 = [0.0, -9.81, 5.0]",
    ));
    assert!(msg.contains("gravity_m_s2"), "{msg}");
    let short = config_error(&edited("center_m = [0.42, 0.0]", "center_m = [0.42]"));
    assert!(short.contains("invalid length 1"), "{short}");
}

/// The campaign settings' ranges are pairs: three numbers are refused.
#[test]
fn a_campaign_range_with_three_numbers_is_refused() {
    let e =
        training::CampaignSettings::from_toml_str("friction = [0.6, 0.7, 0.8]\n", "campaign.toml")
            .unwrap_err()
            .to_string();
    assert!(e.contains("invalid length 3"), "{e}");
    let e = training::CampaignSettings::from_toml_str(
        "axial_stiffness_n = [1.0e4, 2.0e4, 3.0e4]\n",
        "campaign.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("invalid length 3"), "{e}");
}

/// A run whose rows would not fit in memory is refused with the sizes, not aborted on the
/// allocation; one shorter than two output intervals (nothing to summarise) is refused too.
#[test]
fn a_run_too_long_for_memory_or_too_short_to_summarise_is_refused() {
    for duration in ["1.0e9", "1.0e300"] {
        let msg = config_error(&edited(
            "duration_s = 3.0 ",
            &format!("duration_s = {duration} "),
        ));
        assert!(msg.contains("output rows") && msg.contains("GB"), "{msg}");
    }
    let msg = config_error(&edited("duration_s = 3.0 ", "duration_s = 1.0e-9 "));
    assert!(msg.contains("shorter than two output intervals"), "{msg}");
}

/// A step so small that the run would take weeks (`step_s = 1e-12` ran for days with no
/// word) is refused with the step count and what to change.
#[test]
fn a_run_of_too_many_steps_is_refused() {
    let msg = config_error(&edited("step_s = 1.0e-5", "step_s = 1.0e-12"));
    assert!(
        msg.contains("simulation.step_s") && msg.contains("3.500e12 steps"),
        "{msg}"
    );
    // The longest step count allowed is far beyond any real study: 1e-9 s over 3 s passes.
    let text = edited("step_s = 1.0e-5", "step_s = 1.0e-9");
    assert!(DriveConfig::from_toml_str(&text, "drive.toml").is_ok());
}

/// An absurd but finite parameter (a motor of 1e30 N m) stops the run with the time and the
/// reason, as NaN does, instead of writing speeds of 1e27 rpm.
#[test]
fn a_run_that_leaves_physical_plausibility_stops_with_a_message() {
    let text = edited("breakdown_torque_nm = 22.0", "breakdown_torque_nm = 1.0e30");
    let cfg = DriveConfig::from_toml_str(&text, "drive.toml")
        .unwrap()
        .with_duration(0.05)
        .unwrap();
    match simulate(&cfg, RunOptions::default()) {
        Err(e @ FomError::Numerical { .. }) => {
            let m = e.to_string();
            assert!(m.contains("axial wave speed"), "{m}");
        }
        other => panic!(
            "expected a numerical stop, got {:?}",
            other.map(|r| r.summary)
        ),
    }
}
