//! `rom simulate` as a user runs it: exit codes, messages, files.

use std::process::Command;

fn rom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rom"))
}

#[test]
fn bad_centre_distance_fails_with_message_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let o = rom()
        .args(["simulate", "--d", "0.1", "--duration", "0.05", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("pulleys overlap"), "{err}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no partial files"
    );
}

#[test]
fn unknown_config_key_names_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("drive.toml");
    let text = fom::config::DEFAULT_HVAC_TOML.replacen("[belt]", "[belt]\ncolour = 3", 1);
    std::fs::write(&cfg, text).unwrap();
    let o = rom()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(dir.path().join("run.csv"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("drive.toml") && err.contains("colour"),
        "{err}"
    );
}

#[test]
fn short_run_writes_the_documented_columns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let prof = dir.path().join("profile.csv");
    let o = rom()
        .args(["simulate", "--duration", "0.05", "--out"])
        .arg(&out)
        .arg("--tension-profile")
        .arg(&prof)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,driver_rpm,driven_rpm,slip_pct,tight_span_tension_n,slack_span_tension_n,driver_torque_nm,driven_torque_nm"
    );
    // 0.05 s at 1 ms rows plus the initial row.
    assert_eq!(lines.count(), 51);
    let profile = std::fs::read_to_string(&prof).unwrap();
    assert!(profile.starts_with("arc_length_m,axial_force_n\n"));
    assert_eq!(profile.lines().count(), 241, "one row per element");
    let summary = String::from_utf8_lossy(&o.stdout);
    assert!(summary.contains("real-time factor"), "{summary}");
}

/// A cheap drive for CLI runs: 80 segments, light fan.
fn cheap_config(dir: &std::path::Path) -> std::path::PathBuf {
    let text = fom::config::DEFAULT_HVAC_TOML
        .replacen("segments = 240", "segments = 80", 1)
        .replacen("step_s = 1.0e-5", "step_s = 2.5e-5", 1)
        .replacen("inertia_kg_m2 = 0.25", "inertia_kg_m2 = 0.02", 1);
    let p = dir.join("cheap.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn synthetic_measurements_append_to_a_readable_data_set() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = cheap_config(dir.path());
    let set = dir.path().join("set");
    for (label, d) in [("d0", "0.42"), ("d0", "0.42"), ("d3", "0.417")] {
        let o = rom()
            .args(["simulate", "--config"])
            .arg(&cfg)
            .args([
                "--d",
                d,
                "--duration",
                "0.6",
                "--label",
                label,
                "--measurement-out",
            ])
            .arg(&set)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let data = twin::measured::read_dataset(&set, 100).unwrap();
    let files: Vec<&str> = data.manifest.runs.iter().map(|r| r.file.as_str()).collect();
    assert_eq!(files, ["d0-run1.csv", "d0-run2.csv", "d3-run1.csv"]);
    assert_eq!(data.manifest.runs[2].center_distance_m, Some(0.417));
    assert_eq!(data.manifest.driven_pulley_diameter_m, Some(0.2));
    // 1 kHz read-out over 0.6 s; the tachometers read a running drive by the end.
    let r = &data.recordings[0];
    assert_eq!(r.len(), 601);
    assert!(*r.driver_rpm.last().unwrap() > 1000.0);
    let o = rom()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--duration", "0.1", "--label", "a/b", "--measurement-out"])
        .arg(&set)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--label `a/b`"));
}

/// `--gate` and `--edge-jitter` make the synthetic sensor a speed counter whose pick-up
/// jitters: every running reading lies on a counter's levels 60 m / (P k tau) (whole m gaps
/// over whole k ticks; a pulse timer's have m = 1 only), the file's comment names both, and a
/// negative jitter is refused naming its flag.
#[test]
fn a_counter_with_edge_jitter_is_a_synthetic_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = cheap_config(dir.path());
    let set = dir.path().join("set");
    let o = rom()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--duration", "0.6", "--label", "d0", "--speed-noise", "0"])
        .args([
            "--timer-resolution",
            "5e-5",
            "--gate",
            "4e-3",
            "--edge-jitter",
            "1.5e-6",
        ])
        .arg("--measurement-out")
        .arg(&set)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(set.join("d0-run1.csv")).unwrap();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .contains("counter gate 0.004 s, edge jitter 0.0000015 s"),
        "{text:.300}"
    );
    let data = twin::measured::read_dataset(&set, 100).unwrap();
    let r = &data.recordings[0];
    // The file holds speeds to 0.001 rpm: a tick count k of up to 80 to within 1e-3. A 4 ms
    // gate holds at most 8 of the motor's pulse gaps.
    let tau_s = 5e-5;
    let on_counter_level = |n: f64| {
        (1..=8).any(|m| {
            let k = 60.0 * m as f64 / (60.0 * n * tau_s);
            (k - k.round()).abs() < 1e-3
        })
    };
    let running: Vec<f64> = r.driver_rpm[300..]
        .iter()
        .chain(&r.driven_rpm[300..])
        .copied()
        .filter(|&n| n > 100.0)
        .collect();
    assert!(running.len() > 500);
    assert!(running.iter().all(|&n| on_counter_level(n)), "{running:?}");
    // More than one count of gaps is read: not a pulse timer's levels alone.
    assert!(running.iter().any(|&n| {
        let k = 60.0 / (60.0 * n * tau_s);
        (k - k.round()).abs() > 1e-3
    }));
    let o = rom()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--duration", "0.1", "--edge-jitter", "-0.000001", "--out"])
        .arg(dir.path().join("never.csv"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--edge-jitter"));
    assert!(!dir.path().join("never.csv").exists());
}

#[test]
fn non_positive_centre_distance_flag_is_named() {
    let o = Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(["simulate", "--d", "-0.42", "--duration", "0.05", "--out"])
        .arg(std::env::temp_dir().join("beltwin-never-written.csv"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--d"), "{err}");
}

/// A bad manifest in the `--measurement-out` directory is reported before the run, and the
/// run's own `--out` file is not written.
#[test]
fn a_bad_manifest_in_the_measurement_directory_stops_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    std::fs::write(
        data.join("manifest.toml"),
        "format = \"belt-measurements/9\"\n",
    )
    .unwrap();
    let out = dir.path().join("run.csv");
    let o = rom()
        .args(["simulate", "--duration", "3", "--label", "d0", "--out"])
        .arg(&out)
        .arg("--measurement-out")
        .arg(&data)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("manifest.toml") && err.contains("unknown format"),
        "{err}"
    );
    // Before the check the run was simulated and its CSV written, then the append failed.
    assert!(!out.exists(), "no run file written");
}

/// More friction samples than a prediction can use are refused with the limit and why (ten
/// million took 90 s and 8.6 GB before); the limit itself is accepted.
#[test]
fn predict_refuses_more_samples_than_it_can_use() {
    let o = rom()
        .args(["predict", "--d", "0.42", "--samples", "10000000"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--samples") && err.contains("[1, 100000]") && err.contains("10000000"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
    let o = rom()
        .args(["predict", "--d", "0.42", "--samples", "100000"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A leave-one-out with no full-order run to stand in at the knee is refused before any work,
/// naming the flag, and writes no calibrated configuration.
#[test]
fn calibrate_refuses_zero_predictive_runs_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("calibrated.toml");
    let table = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/paper-table2-mean-slip.csv"
    );
    let o = rom()
        .args([
            "calibrate",
            "--table",
            table,
            "--leave-one-out",
            "--predictive-runs",
            "0",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--predictive-runs") && err.contains("at least 1"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
    assert!(!out.exists(), "no calibrated configuration written");
}

fn synchronous_config() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fom/configs/synchronous-arc.toml")
}

#[test]
fn toothed_run_writes_the_tooth_load_columns() {
    let dir = tempfile::tempdir().unwrap();
    let teeth = dir.path().join("teeth.csv");
    let o = rom()
        .args([
            "simulate",
            "--duration",
            "0.01",
            "--side-gap",
            "1e-4",
            "--config",
        ])
        .arg(synchronous_config())
        .arg("--out")
        .arg(dir.path().join("run.csv"))
        .arg("--tooth-loads")
        .arg(&teeth)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("max tooth load"), "{stdout}");
    let text = std::fs::read_to_string(&teeth).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,tooth,flank_a_n,flank_b_n,tip_n"
    );
    // 0.01 s at 1e-4 s rows: 100 rows of 60 teeth, every load a finite non-negative number.
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 100 * 60);
    assert!(rows
        .iter()
        .all(|r| r.len() == 5 && r[2..].iter().all(|v| *v >= 0.0)));
    assert_eq!(rows[61][1], 1.0);
}

#[test]
fn tooth_flags_on_a_v_belt_are_refused_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for flags in [["--tooth-loads", "teeth.csv"], ["--side-gap", "1e-4"]] {
        let o = rom()
            .current_dir(dir.path())
            .args(["simulate", "--duration", "0.05", "--out", "run.csv"])
            .args(flags)
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("needs a toothed belt"), "{err}");
    }
    // A slip campaign's settings on a toothed drive, and tooth ranges on a V-belt.
    std::fs::write(dir.path().join("slip.toml"), "samples = 8\n").unwrap();
    let o = rom()
        .current_dir(dir.path())
        .args([
            "train",
            "--data",
            "data",
            "--settings",
            "slip.toml",
            "--config",
        ])
        .arg(synchronous_config())
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("the drive has a toothed belt"), "{err}");
    std::fs::write(
        dir.path().join("tooth.toml"),
        "samples = 8\n[tooth]\nside_gap_m = [1e-4, 3e-4]\n",
    )
    .unwrap();
    let o = rom()
        .current_dir(dir.path())
        .args(["train", "--data", "data", "--settings", "tooth.toml"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("[tooth] applies to a toothed belt"), "{err}");
    std::fs::remove_file(dir.path().join("slip.toml")).unwrap();
    std::fs::remove_file(dir.path().join("tooth.toml")).unwrap();
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no files"
    );
}

#[test]
fn tooth_surrogate_flags_are_refused_on_a_slip_surrogate_and_d_is_required_there() {
    let o = rom()
        .args(["predict", "--side-gap", "0.25mm"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--d (the centre distance, m) is required"),
        "{err}"
    );
    let o = rom()
        .args(["predict", "--d", "0.42", "--shaft-load", "400"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cannot be used with"), "{err}");
}

#[test]
fn load_torque_on_a_load_without_a_torque_profile_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let o = rom()
        .current_dir(dir.path())
        .args(["simulate", "--duration", "0.05", "--out", "run.csv"])
        .args(["--load-torque", "3"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("applies to a driven load with a torque profile"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no files"
    );
}
