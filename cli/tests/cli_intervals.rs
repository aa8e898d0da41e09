//! `rom validate --calibrate-intervals`: a surrogate's 90 % intervals calibrated on the
//! held-out full-order runs of the `rom validate --json` files in `tests/fixtures/validation/`
//! (made on the shipped surrogate before its intervals were calibrated; the runs do not depend
//! on the intervals); no full-order run is made here.

use std::path::{Path, PathBuf};

use crate::support::{run_rom as rom, stderr};

fn artifact(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/validation")
        .join(name)
}

/// The held-out files the shipped model's intervals were calibrated on: uniform, knee-band and
/// onset validations.
fn held_out_files() -> Vec<PathBuf> {
    [
        "validation.json",
        "validation-knee.json",
        "validation-knee-seed20261125.json",
        "validation-knee-seed20261126.json",
        "validation-onset-seed20261129.json",
        "validation-onset-seed20261132.json",
    ]
    .iter()
    .map(|f| artifact(f))
    .collect()
}

fn join(paths: &[PathBuf]) -> String {
    paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(",")
}

#[test]
fn calibrated_intervals_cover_their_held_out_runs_and_keep_the_means() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let files = held_out_files();
    let o = rom(&[
        "validate",
        "--calibrate-intervals",
        &join(&files),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let shipped = rom::shipped::slip_model().unwrap();
    let cal = rom::SurrogateFile::load(&out).unwrap();
    let (s0, s1) = (&shipped.surrogate, &cal.surrogate);
    let c = s1
        .interval_calibration
        .as_ref()
        .expect("calibration recorded");
    assert_eq!(
        c.seeds,
        vec![20261124, 20261125, 20261126, 20261129, 20261132]
    );
    // The twin's likelihoods keep the leave-one-out factors.
    assert_eq!(s1.std_calibration, s0.std_calibration);
    assert_eq!(s1.std_calibration_knee, s0.std_calibration_knee);
    let cfg = s0.config().unwrap();
    let band = s1.knee_band_n.unwrap();
    // Split conformal: on the runs it was calibrated on, each part's 90 % interval holds at
    // least ceil((n + 1) 0.9) of its n runs (creep plateau, onset, knee band).
    let (mut covered, mut n) = ([0usize; 3], [0usize; 3]);
    for f in &files {
        let (_, runs, _) = rom::validate::read_held_out(f, &cal.header.config_sha256).unwrap();
        for r in runs {
            let p0 = s0.predict_point(&cfg, &r.point).unwrap();
            let p1 = s1.predict_point(&cfg, &r.point).unwrap();
            assert_eq!(
                p0.mean_slip_pct, p1.mean_slip_pct,
                "the means must not move"
            );
            let u = rom::features::capacity_feature_n(&cfg, &r.point);
            let part = match rom::surrogate::interval_part(band, u, p1.mean_slip_pct) {
                rom::surrogate::IntervalPart::Creep => 0,
                rom::surrogate::IntervalPart::Onset => 1,
                rom::surrogate::IntervalPart::KneeBand => 2,
            };
            n[part] += 1;
            let half = rom::stats::Z90 * p1.surrogate_std_pct;
            covered[part] += usize::from((p1.mean_slip_pct - r.mean_slip_pct).abs() <= half);
        }
    }
    assert_eq!(n, [c.runs_outside_band, c.runs_onset, c.runs_in_band]);
    for part in 0..3 {
        let need = ((n[part] + 1) as f64 * 0.9).ceil() as usize;
        assert!(
            covered[part] >= need.min(n[part]),
            "part {part}: {} of {} covered, need {need}",
            covered[part],
            n[part]
        );
    }
    // The seeds it was calibrated on are no fresh validation any more.
    let o = rom(&[
        "validate",
        "--model",
        out.to_str().unwrap(),
        "--seed",
        "20261125",
        "--points",
        "1",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("validation seed 20261125"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_held_out_files_are_refused_by_name_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let point = r#"{"center_distance_m": 0.42, "friction": 0.7, "installation_tension_n": 250.0,
                    "error": null, "fom_mean_slip_pct": 0.69}"#;
    let other_drive = write(
        "other.json",
        &format!(r#"{{"seed": 7, "config_sha256": "00ff", "points": [{point}]}}"#),
    );
    let not_validation = write("tooth.json", r#"[{"side_gap_m": 0.0002}]"#);
    let few = write(
        "few.json",
        &format!(r#"{{"seed": 7, "points": [{point}, {point}, {point}]}}"#),
    );
    let no_truth = write(
        "notruth.json",
        r#"{"seed": 7, "points": [{"center_distance_m": 0.42, "friction": 0.7,
            "installation_tension_n": 250.0, "error": null, "fom_mean_slip_pct": null}]}"#,
    );
    let cases: [(&Path, &str); 5] = [
        (&other_drive, "another drive configuration"),
        (&not_validation, "not a `rom validate --json` file"),
        (
            &few,
            "are too few: 3 on the creep plateau, 0 at the knee's onset and 0 in the knee band",
        ),
        (
            &no_truth,
            "point 0 (0-based) has no error and no finite full-order mean",
        ),
        (Path::new("/nonexistent/v.json"), "cannot read"),
    ];
    for (file, says) in cases {
        let o = rom(&[
            "validate",
            "--calibrate-intervals",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success(), "{} accepted", file.display());
        let err = stderr(&o);
        assert!(err.contains(says), "{}: {err}", file.display());
        assert!(
            !out.exists(),
            "a refused calibration wrote {}",
            out.display()
        );
    }
    // --out is required, and the mode runs no validation (--knee, --json, --seed refused).
    let o = rom(&["validate", "--calibrate-intervals", few.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
    let o = rom(&[
        "validate",
        "--calibrate-intervals",
        few.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--knee",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--knee"), "{}", stderr(&o));
}

#[test]
fn the_onset_design_lies_outside_the_knee_band_at_predicted_onset_slip() {
    let file = rom::shipped::slip_model().unwrap();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let band = s.knee_band_n.unwrap();
    let onset = rom::validate::onset_design(s, 12, 7).unwrap();
    assert_eq!(onset.len(), 12);
    for q in &onset {
        let u = rom::features::capacity_feature_n(&cfg, q);
        let p = s.predict_point(&cfg, q).unwrap();
        assert!(u > band, "{q:?}: capacity {u} N inside the band {band} N");
        assert!(
            p.mean_slip_pct >= rom::surrogate::ONSET_SLIP_PCT,
            "{q:?}: {p:?}"
        );
        assert!(s.extrapolation(&cfg, q).is_none(), "{q:?}");
    }
    for q in rom::validate::knee_design(s, 12, 7).unwrap() {
        assert!(rom::features::capacity_feature_n(&cfg, &q) <= band, "{q:?}");
    }
    // --knee and --onset are two designs, not one.
    let o = rom(&["validate", "--knee", "--onset", "--points", "1"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--onset"), "{}", stderr(&o));
}
