//! `rom predict` and `rom train` as a user runs them, on the shipped surrogate.

use std::process::Command;

use crate::support::{run_rom as rom, stderr, stdout};

#[test]
fn predict_at_the_default_distance_prints_a_table() {
    let o = rom(&["predict", "--d", "0.42"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("centre distance 0.4200 m"), "{out}");
    assert!(out.contains("p05") && out.contains("p95"), "{out}");
}

#[test]
fn predict_json_has_the_documented_keys_and_sane_values() {
    let o = rom(&["predict", "--d", "0.418", "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    for key in [
        "center_distance_m",
        "mu",
        "tension_n",
        "mean_slip_pct",
        "std_slip_pct",
        "quantiles_pct",
        "surrogate_std_pct",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    let q = &v["quantiles_pct"];
    let qs: Vec<f64> = ["p05", "p25", "p50", "p75", "p95"]
        .iter()
        .map(|k| q[k].as_f64().unwrap())
        .collect();
    assert!(qs.windows(2).all(|w| w[0] <= w[1]), "{qs:?}");
    let mean = v["mean_slip_pct"].as_f64().unwrap();
    // Creep slip of a healthy V-belt drive: positive and a few percent at most.
    assert!(mean > 0.1 && mean < 5.0, "{mean}");
    assert_eq!(v["center_distance_m"].as_f64().unwrap(), 0.418);
}

#[test]
fn predict_outside_the_trained_range_fails_unless_allowed() {
    let o = rom(&["predict", "--d", "0.43"]);
    assert!(!o.status.success());
    assert!(stdout(&o).is_empty());
    let err = stderr(&o);
    assert!(
        err.contains("0.43") && err.contains("outside the trained range"),
        "{err}"
    );
    assert!(err.contains("--allow-extrapolation"), "{err}");
    let o = rom(&["predict", "--d", "0.426", "--allow-extrapolation"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("EXTRAPOLATED: center_distance_m 0.426 outside trained"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn predict_plot_and_startup_files_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("box.svg");
    let csv = dir.path().join("startup.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(["predict", "--d", "0.42", "--plot"])
        .arg(&svg)
        .arg("--startup")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("slip (%)"));
    let startup = std::fs::read_to_string(&csv).unwrap();
    assert!(startup.starts_with("time_s,slip_pct\n"));
    assert!(startup.lines().count() > 100);
}

#[test]
fn missing_or_damaged_model_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.json");
    let o = rom(&[
        "predict",
        "--d",
        "0.42",
        "--model",
        missing.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("nope.json"), "{}", stderr(&o));
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"format\":\"beltwin-surrogate/9\"}\n{}").unwrap();
    let o = rom(&["predict", "--d", "0.42", "--model", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("bad.json") && err.contains("beltwin-surrogate/9"),
        "{err}"
    );
}

#[test]
fn predict_with_another_configuration_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("other.toml");
    std::fs::write(
        &cfg,
        fom::config::DEFAULT_HVAC_TOML.replacen("friction = 0.7", "friction = 0.6", 1),
    )
    .unwrap();
    let o = rom(&["predict", "--d", "0.42", "--config", cfg.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("another drive configuration than") && err.contains("other.toml"),
        "{err}"
    );
}

#[test]
fn bad_flags_get_one_clear_error() {
    let o = rom(&["predict", "--d", "0.42", "--samples", "0"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--samples"), "{}", stderr(&o));
    let o = rom(&["train", "--shard", "3/2", "--data", "/nonexistent/x"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("shard `3/2`"), "{}", stderr(&o));
    let o = rom(&["predict", "--d", "abc"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("abc"), "{}", stderr(&o));
}

#[test]
fn a_variable_the_surrogate_was_not_trained_over_is_refused_not_ignored() {
    // The shipped surrogate has inputs d, mu and T only; the effect syntax of `simulate`, and
    // the older dotted one.
    for (flag, spec) in [
        ("--effect", "bearing-drag:coulomb_nm=1"),
        ("--effect-param", "bearing-drag.coulomb_nm=1"),
    ] {
        let o = rom(&["predict", "--d", "0.42", flag, spec]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("bearing-drag.coulomb_nm"),
            "{}",
            stderr(&o)
        );
    }
    let o = rom(&["predict", "--d", "0.417", "--stiffness", "30000"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--stiffness") && stderr(&o).contains("not trained over"),
        "{}",
        stderr(&o)
    );
}

fn synchronous_config() -> String {
    format!(
        "{}/../fom/configs/synchronous-arc.toml",
        env!("CARGO_MANIFEST_DIR")
    )
}

/// The documented command (`docs/guide/predict.md`, "Toothed belts: tooth loads"): the shipped
/// tooth-load surrogate of the seed paper's drive, the side gap with its unit
/// (`--side-gap 0.25mm`), and the same point in metres.
#[test]
fn predict_tooth_loads_on_the_toothed_drive() {
    let cfg = synchronous_config();
    let o = rom(&["predict", "--config", &cfg, "--side-gap", "0.25mm"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("side gap 0.2500 mm"), "{out}");
    assert!(out.contains("largest tooth load of the run"), "{out}");
    let o = rom(&[
        "predict",
        "--config",
        &cfg,
        "--side-gap",
        "2.5e-4",
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let mean = v["mean_peak_n"].as_f64().unwrap();
    let max = v["max_n"].as_f64().unwrap();
    let [lo, hi] = [0, 1].map(|i| v["mean_peak_interval_n"][i].as_f64().unwrap());
    // The shipped drive's pass peaks are 40-45 N and its largest load 53-61 N
    // (`docs/validation/toothed-belt.md`, "The tooth-load surrogate").
    assert!((30.0..60.0).contains(&mean), "{mean}");
    assert!(lo < mean && mean < hi && max > mean, "{v}");
    // Outside the trained box (0.05-0.35 mm): refused with the range.
    let o = rom(&["predict", "--config", &cfg, "--side-gap", "0.5mm"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("outside the trained range"),
        "{}",
        stderr(&o)
    );
    // Slip-surrogate flags are not tooth-surrogate inputs.
    let o = rom(&["predict", "--config", &cfg, "--mu", "0.7"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--side-gap"), "{}", stderr(&o));
}

/// An installed `rom` (`cargo install --path cli`) has no source tree beside it: the binary,
/// copied to a directory outside the workspace and run from `/`, still answers with the
/// shipped models (embedded, `rom::shipped`), the same bytes as in the workspace.
#[test]
fn an_installed_binary_answers_from_any_directory() {
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("rom");
    std::fs::copy(env!("CARGO_BIN_EXE_rom"), &exe).unwrap();
    let run = |args: &[&str]| {
        let o = Command::new(&exe)
            .args(args)
            .current_dir("/")
            .output()
            .unwrap();
        assert!(o.status.success(), "rom {}: {}", args.join(" "), stderr(&o));
        stdout(&o)
    };
    let here = rom(&["predict", "--d", "0.42"]);
    assert_eq!(run(&["predict", "--d", "0.42"]), stdout(&here));
    let toothed = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fom/configs/synchronous-arc.toml"
    );
    let out = run(&["predict", "--config", toothed]);
    assert!(out.contains("largest tooth load of the run"), "{out}");
}
