//! The measured-data exchange format (docs/measured-data.md): what it accepts and one
//! clear error per bad-input case, naming the file and, for CSV, the line.

use std::path::Path;

use twin::measured::{read_dataset, read_recording, DataSet, MeasuredError};

const MANIFEST: &str = r#"
format = "belt-measurements/1"
description = "test bed"
driver_pulley_diameter_m = 0.1016
driven_pulley_diameter_m = 0.2032
site = "plant 3"              # unknown top-level key: kept out of the way, not an error

[[run]]
file = "d0-run1.csv"
label = "d0"
center_distance_m = 0.43
operator = "kim"              # extra run key: metadata

[[run]]
file = "d3-run1.csv"
label = "d3"
"#;

const GOOD_CSV: &str = "# recorded 2026-03-02\n\
driven_rpm,vibration_g,time_s,driver_rpm\n\
874.9,0.1,0.000,1762.4\n\
# a comment in the middle\n\
874.7,0.1,0.001,1762.6\n\
874.8,0.2,0.002,1762.5\n";

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

fn good_set() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "manifest.toml", MANIFEST);
    write(d.path(), "d0-run1.csv", GOOD_CSV);
    write(d.path(), "d3-run1.csv", GOOD_CSV);
    d
}

fn csv_error(body: &str, min: usize) -> MeasuredError {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "r.csv", body);
    read_recording(&d.path().join("r.csv"), min).unwrap_err()
}

#[test]
fn a_valid_set_reads_with_extra_keys_columns_comments_and_any_column_order() {
    let d = good_set();
    let set = read_dataset(d.path(), 3).unwrap();
    assert_eq!(set.labels(), vec!["d0", "d3"]);
    let m = &set.manifest;
    assert_eq!(m.driver_pulley_diameter_m, Some(0.1016));
    assert_eq!(m.runs[0].center_distance_m, Some(0.43));
    assert_eq!(m.runs[1].center_distance_m, None, "absent = unknown");
    assert_eq!(m.runs[0].metadata["operator"].as_str(), Some("kim"));
    let r = &set.recordings[0];
    assert_eq!(r.time_s, vec![0.0, 0.001, 0.002]);
    assert_eq!(r.driver_rpm[1], 1762.6);
    assert_eq!(r.driven_rpm[2], 874.8);
}

#[test]
fn missing_manifest_is_named() {
    let d = tempfile::tempdir().unwrap();
    let e = read_dataset(d.path(), 1).unwrap_err();
    assert!(
        e.path.ends_with("manifest.toml") && e.message.contains("missing manifest"),
        "{e}"
    );
}

#[test]
fn a_missing_directory_and_a_file_in_its_place_are_named() {
    let d = tempfile::tempdir().unwrap();
    let missing = d.path().join("lose");
    let e = read_dataset(&missing, 1).unwrap_err();
    assert!(
        e.path == missing && e.message.contains("no such directory"),
        "{e}"
    );
    let file = d.path().join("d3-run1.csv");
    std::fs::write(&file, "time_s,driver_rpm,driven_rpm\n").unwrap();
    let e = read_dataset(&file, 1).unwrap_err();
    assert!(
        e.path == file && e.message.contains("not a directory"),
        "{e}"
    );
}

#[test]
fn unknown_format_string_is_refused() {
    let d = good_set();
    write(
        d.path(),
        "manifest.toml",
        &MANIFEST.replace("belt-measurements/1", "belt-measurements/2"),
    );
    let e = read_dataset(d.path(), 1).unwrap_err().to_string();
    assert!(
        e.contains("unknown format") && e.contains("belt-measurements/2"),
        "{e}"
    );
}

#[test]
fn missing_run_file_is_named() {
    let d = good_set();
    std::fs::remove_file(d.path().join("d3-run1.csv")).unwrap();
    let e = read_dataset(d.path(), 1).unwrap_err();
    assert!(
        e.path.ends_with("d3-run1.csv") && e.message.contains("missing run file"),
        "{e}"
    );
}

#[test]
fn run_without_label_is_refused() {
    let d = good_set();
    write(
        d.path(),
        "manifest.toml",
        &MANIFEST.replace("label = \"d3\"", ""),
    );
    let e = read_dataset(d.path(), 1).unwrap_err().to_string();
    assert!(e.contains("run 2: missing `label`"), "{e}");
}

#[test]
fn missing_required_column_is_named() {
    let e = csv_error("time_s,driver_rpm\n0,1\n", 1);
    assert!(
        e.message.contains("missing required column `driven_rpm`"),
        "{e}"
    );
}

#[test]
fn non_numeric_nan_and_infinite_values_name_line_and_column() {
    let head = "time_s,driver_rpm,driven_rpm\n0.0,1700,850\n";
    let e = csv_error(&format!("{head}0.1,abc,850\n"), 1);
    assert_eq!(e.line, Some(3));
    assert!(
        e.message.contains("`driver_rpm`") && e.message.contains("abc"),
        "{e}"
    );
    let e = csv_error(&format!("{head}0.1,1700,NaN\n"), 1);
    assert!(
        e.line == Some(3) && e.message.contains("not a finite number"),
        "{e}"
    );
    let e = csv_error(&format!("{head}inf,1700,850\n"), 1);
    assert!(e.line == Some(3) && e.message.contains("`time_s`"), "{e}");
}

#[test]
fn time_must_increase_strictly() {
    let e = csv_error(
        "time_s,driver_rpm,driven_rpm\n0.0,1,1\n0.1,1,1\n0.1,1,1\n",
        1,
    );
    assert_eq!(e.line, Some(4));
    assert!(e.message.contains("strictly increasing"), "{e}");
}

#[test]
fn negative_speed_is_refused() {
    let e = csv_error("time_s,driver_rpm,driven_rpm\n0.0,1700,-3\n", 1);
    assert_eq!(e.line, Some(2));
    assert!(e.message.contains("negative speed -3"), "{e}");
}

#[test]
fn too_few_samples_says_how_many_are_needed() {
    let e = csv_error("time_s,driver_rpm,driven_rpm\n0.0,1700,850\n", 500);
    assert!(
        e.message.contains("1 samples") && e.message.contains("at least 500"),
        "{e}"
    );
}

#[test]
fn slip_leaves_out_standstill_samples() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "r.csv",
        "time_s,driver_rpm,driven_rpm\n0,0,0\n0.1,50,0\n0.2,1000,490\n0.3,2000,980\n",
    );
    let r = read_recording(&d.path().join("r.csv"), 1).unwrap();
    // 50 rpm is below 5 % of the 2000 rpm maximum: no slip information.
    let s = r.slip_samples(2.0);
    assert_eq!(s.len(), 2);
    assert!(
        (s[0].1 - 2.0).abs() < 1e-12 && (s[1].1 - 2.0).abs() < 1e-12,
        "{s:?}"
    );
}

/// The spec: `file` is a path relative to the manifest. A path out of the data set's directory
/// (absolute, or climbing with `..`) is refused before it is opened, and the message does not
/// show what such a file holds.
#[test]
fn a_run_file_outside_the_data_set_is_refused_unread() {
    let outside = tempfile::tempdir().unwrap();
    write(
        outside.path(),
        "secret.csv",
        "time_s,driver_rpm,driven_rpm\nTOP-SECRET\n",
    );
    let absolute = outside.path().join("secret.csv");
    for file in [
        "../secret.csv".to_string(),
        "sub/../../secret.csv".to_string(),
        absolute.display().to_string(),
    ] {
        let d = good_set();
        let m = MANIFEST.replace("file = \"d3-run1.csv\"", &format!("file = {file:?}"));
        write(d.path(), "manifest.toml", &m);
        let e = read_dataset(d.path(), 3).unwrap_err().to_string();
        assert!(e.contains("manifest.toml") && e.contains("run 2"), "{e}");
        assert!(e.contains("relative to the manifest"), "{e}");
        assert!(!e.contains("TOP-SECRET"), "{e}");
    }
}

/// `run = []` is a data set without runs: refused, not an empty report.
#[test]
fn an_empty_run_array_is_refused() {
    let d = good_set();
    write(
        d.path(),
        "manifest.toml",
        "format = \"belt-measurements/1\"\nrun = []\n",
    );
    let e = read_dataset(d.path(), 3).unwrap_err().to_string();
    assert!(e.contains("no runs"), "{e}");
}

/// One diameter in the manifest overrides the model's for that pulley (the spec: "where
/// present they override the twin's defaults"); the other stays the model's.
#[test]
fn one_manifest_diameter_overrides_that_pulley_alone() {
    let cfg = fom::DriveConfig::default_hvac();
    let d = good_set();
    let only_driver = MANIFEST.replace("driven_pulley_diameter_m = 0.2032\n", "");
    write(d.path(), "manifest.toml", &only_driver);
    let set = read_dataset(d.path(), 3).unwrap();
    let expected = cfg.driven.pitch_diameter_m / 0.1016;
    assert!((set.speed_ratio(&cfg) - expected).abs() < 1e-12);
    assert!((set.speed_ratio(&cfg) - cfg.transmission_ratio()).abs() > 0.01);
}

/// An empty file, or one of blank lines (CR only), has no header row: said so, not "header
/// has: " with nothing after it.
#[test]
fn an_empty_or_blank_run_file_says_it_has_no_header() {
    for body in ["", "\r", "\r\n\r\n", "# only a comment\n"] {
        let e = csv_error(body, 1).to_string();
        assert!(
            e.contains("no header row") && e.contains("time_s"),
            "{body:?}: {e}"
        );
    }
}

/// The good set read with run 1's extra key replaced by `first` and a second run of d0
/// (its keys `second`) added.
fn with_second_d0_run(dir: &Path, first: &str, second: &str) -> Result<DataSet, MeasuredError> {
    write(dir, "d0-run2.csv", GOOD_CSV);
    let m = format!("{MANIFEST}\n[[run]]\nfile = \"d0-run2.csv\"\nlabel = \"d0\"\n{second}\n")
        .replace(
            "operator = \"kim\"              # extra run key: metadata",
            first,
        );
    write(dir, "manifest.toml", &m);
    read_dataset(dir, 3)
}

/// `load_torque_nm` (two load levels, docs/measured-data.md): read per label, positive, and
/// alike in the runs of one label; a run at another load needs a label of its own.
#[test]
fn a_load_torque_is_read_per_label_and_must_agree_within_a_label() {
    let d = good_set();
    let with = |first: &str, second: &str| with_second_d0_run(d.path(), first, second);
    let set = with("load_torque_nm = 8.8", "load_torque_nm = 8.8").unwrap();
    assert_eq!(set.load_torque_nm("d0"), Some(8.8));
    assert_eq!(
        set.load_torque_nm("d3"),
        None,
        "absent: the drive's own load"
    );
    let e = with("load_torque_nm = 8.8", "load_torque_nm = 14.2")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("run 3")
            && e.contains("load_torque_nm")
            && e.contains("differs from run 1")
            && e.contains("its own label")
            && e.contains("line 21"),
        "{e}"
    );
    let e = with("load_torque_nm = 8.8", "").unwrap_err().to_string();
    assert!(
        e.contains("run 3: no `load_torque_nm`") && e.contains("run 1"),
        "{e}"
    );
    let e = with("load_torque_nm = -1.0", "").unwrap_err().to_string();
    assert!(
        e.contains("line 12: run 1: `load_torque_nm` must be positive"),
        "{e}"
    );
}

/// `static_tension_n` and `static_tension_sd_n` (a tension meter's reading,
/// docs/measured-data.md): read per label, the sd 5 % of the reading where absent, positive,
/// the readings of a label's runs pooled, and no sd without a reading.
#[test]
fn a_tension_reading_is_read_per_label_with_its_sd() {
    let d = good_set();
    let with = |first: &str, second: &str| with_second_d0_run(d.path(), first, second);
    let set = with("static_tension_n = 280.0", "static_tension_n = 280.0").unwrap();
    // Two readings of 280 N, each with sd 14 N (5 %): 280 N with sd 14 / sqrt(2).
    let r = set.tension_reading("d0").unwrap();
    assert_eq!(r.tension_n, 280.0);
    assert!((r.sd_n - 14.0 / 2f64.sqrt()).abs() < 1e-9, "{r:?}");
    assert_eq!(set.tension_reading("d3"), None, "absent: not read");
    let both = "static_tension_n = 280.0\nstatic_tension_sd_n = 9.0";
    let r = with(both, "").unwrap().tension_reading("d0").unwrap();
    assert_eq!((r.tension_n, r.sd_n), (280.0, 9.0));
    // Read again before the second run: the two readings weighted by their inverse variances
    // (sd 5 %: 14 and 12 N); a run without a reading adds nothing.
    let r = with("static_tension_n = 280.0", "static_tension_n = 240.0")
        .unwrap()
        .tension_reading("d0")
        .unwrap();
    let (w1, w2) = (14.0_f64.powi(-2), 12.0_f64.powi(-2));
    assert!(
        (r.tension_n - (280.0 * w1 + 240.0 * w2) / (w1 + w2)).abs() < 1e-9,
        "{r:?}"
    );
    assert!(
        (r.tension_n - 256.9).abs() < 0.1 && (r.sd_n - 9.11).abs() < 0.01,
        "{r:?}"
    );
    let r = with("static_tension_n = 280.0", "")
        .unwrap()
        .tension_reading("d0");
    assert_eq!(r.map(|r| (r.tension_n, r.sd_n)), Some((280.0, 14.0)));
    let e = with("static_tension_sd_n = 9.0", "")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("run 1: `static_tension_sd_n` without `static_tension_n`"),
        "{e}"
    );
    let e = with("static_tension_n = 0", "").unwrap_err().to_string();
    assert!(
        e.contains("line 12: run 1: `static_tension_n` must be positive"),
        "{e}"
    );
}
