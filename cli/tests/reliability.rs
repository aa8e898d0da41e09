//! What `rom` promises about its files (docs/reliability.md): outputs never clobber what is not
//! theirs and are written all together or not at all; inputs never reach outside their data
//! set; nothing undiagnosable exits 0. Device-like targets are stood in for by a FIFO, links
//! and read-only files in a temporary folder, never by a real device.

use std::path::Path;
use std::process::{Command, Output};

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::support::stderr;

fn rom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rom"))
}

fn run(args: &[&std::ffi::OsStr]) -> Output {
    rom().args(args).output().unwrap()
}

/// An input error: exit status 1 with a message on stderr.
fn assert_input_error(o: &Output, needle: &str) {
    assert_eq!(o.status.code(), Some(1), "{}", stderr(o));
    assert!(stderr(o).contains(needle), "{}", stderr(o));
}

fn mkfifo(path: &Path) {
    let s = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(s.success());
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn os(s: &str) -> &std::ffi::OsStr {
    s.as_ref()
}

#[cfg(unix)]
#[test]
fn outputs_refuse_a_fifo_a_directory_and_a_link_and_leave_them() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    let spare = dir.path().join("spare.csv");
    for (first, second) in [
        ("--out", "--tension-profile"),
        ("--tension-profile", "--out"),
    ] {
        let o = run(&[
            os("simulate"),
            os("--duration"),
            os("0.05"),
            os(first),
            fifo.as_os_str(),
            os(second),
            spare.as_os_str(),
        ]);
        assert_input_error(&o, "FIFO");
    }
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--plot"),
        fifo.as_os_str(),
    ]);
    assert_input_error(&o, "FIFO");
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    let o = run(&[
        os("simulate"),
        os("--duration"),
        os("0.05"),
        os("--out"),
        dir.path().as_os_str(),
    ]);
    assert_input_error(&o, "directory");
    let target = dir.path().join("target.csv");
    std::fs::write(&target, "theirs").unwrap();
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--startup"),
        link.as_os_str(),
    ]);
    assert_input_error(&o, "symbolic link");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "theirs");
}

/// Checked on the mode bits: the tests run as root, who could write the file anyway.
#[cfg(unix)]
#[test]
fn outputs_refuse_a_read_only_file_and_keep_an_existing_files_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let ro = dir.path().join("ro.csv");
    std::fs::write(&ro, "keep").unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--startup"),
        ro.as_os_str(),
    ]);
    assert_input_error(&o, "read-only");
    assert_eq!(std::fs::read_to_string(&ro).unwrap(), "keep");
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&ro), 0o444);
    let own = dir.path().join("own.csv");
    std::fs::write(&own, "old").unwrap();
    std::fs::set_permissions(&own, std::fs::Permissions::from_mode(0o640)).unwrap();
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--startup"),
        own.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(mode(&own), 0o640);
    assert!(std::fs::read_to_string(&own)
        .unwrap()
        .starts_with("time_s,slip_pct"));
}

#[test]
fn one_path_for_two_outputs_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("f.csv");
    let o = run(&[
        os("simulate"),
        os("--duration"),
        os("0.05"),
        os("--out"),
        f.as_os_str(),
        os("--tension-profile"),
        f.as_os_str(),
    ]);
    assert_input_error(&o, "--out");
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--plot"),
        f.as_os_str(),
        os("--startup"),
        dir.path().join(".").join("f.csv").as_os_str(),
    ]);
    assert_input_error(&o, "--plot");
    assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
}

#[test]
fn a_failed_command_leaves_none_of_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.svg");
    let nodir = dir.path().join("nodir");
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--plot"),
        p.as_os_str(),
        os("--startup"),
        nodir.join("s.csv").as_os_str(),
    ]);
    assert_input_error(&o, "nodir");
    let x = dir.path().join("x.csv");
    let o = run(&[
        os("simulate"),
        os("--duration"),
        os("0.05"),
        os("--out"),
        x.as_os_str(),
        os("--tension-profile"),
        nodir.join("tp.csv").as_os_str(),
    ]);
    assert_input_error(&o, "nodir");
    let file = dir.path().join("existing");
    std::fs::write(&file, "theirs").unwrap();
    let o = run(&[
        os("simulate"),
        os("--duration"),
        os("0.05"),
        os("--out"),
        x.as_os_str(),
        os("--label"),
        os("a"),
        os("--measurement-out"),
        file.as_os_str(),
    ]);
    assert_input_error(&o, "not a directory");
    assert_eq!(names(dir.path()), ["existing"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "theirs");
}

/// A data set in `dir` of one label `a` whose run file `name` holds 1 kHz rows of
/// (time, driver, driven) over 2 s.
fn data_set(dir: &Path, name: &str, speeds: impl Fn(f64) -> (f64, f64)) {
    data_set_over(dir, name, 2.0, speeds)
}

/// [`data_set`] over `seconds`.
fn data_set_over(dir: &Path, name: &str, seconds: f64, speeds: impl Fn(f64) -> (f64, f64)) {
    std::fs::create_dir_all(dir).unwrap();
    let mut csv = String::from("time_s,driver_rpm,driven_rpm\n");
    for i in 0..(seconds * 1000.0) as usize {
        let t = i as f64 * 1e-3;
        let (n1, n2) = speeds(t);
        csv += &format!("{t:.6},{n1:.3},{n2:.3}\n");
    }
    std::fs::write(dir.join(name), csv).unwrap();
    std::fs::write(
        dir.join("manifest.toml"),
        format!("format = \"belt-measurements/1\"\n[[run]]\nfile = \"{name}\"\nlabel = \"a\"\n"),
    )
    .unwrap();
}

/// `rom diagnose --measured SET --report REPORT`.
fn diagnose_with_report(set: &Path, report: &Path) -> Output {
    run(&[
        os("diagnose"),
        os("--measured"),
        set.as_os_str(),
        os("--report"),
        report.as_os_str(),
    ])
}

/// Samples of noise uniform within 1 rpm over 5 s at 1 kHz, from a generator seeded with
/// `seed`.
fn noise_rpm(seed: u64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..5000).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// [`data_set_over`] of 5 s at 1 kHz with the slip `slip_pct(t)`: the driver at 1760 rpm, the
/// fan (twice the driver's pitch diameter) at half its speed less the slip, each with the noise
/// of [`noise_rpm`] of its seed.
fn slip_data_set(dir: &Path, name: &str, seeds: [u64; 2], slip_pct: impl Fn(f64) -> f64) {
    let (n1, n2) = (noise_rpm(seeds[0]), noise_rpm(seeds[1]));
    data_set_over(dir, name, 5.0, |t| {
        let i = (t * 1000.0).round() as usize;
        (1760.0 + n1[i], 880.0 * (1.0 - slip_pct(t) / 100.0) + n2[i])
    });
}

#[test]
fn a_belt_still_settling_is_diagnosed_at_its_extrapolated_slip_and_says_so() {
    // A belt sliding after start-up: slip 9 % + 75 % exp(-t / 0.9 s), 9.3 % at 5 s and still
    // falling 0.3 pp/s; the driver steady at 1760 rpm, the fan (twice the driver's pitch diameter) at
    // half its speed less the slip.
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    slip_data_set(&set, "slides.csv", [1, 2], |t| {
        9.0 + 75.0 * (-t / 0.9).exp()
    });
    let report = dir.path().join("report");
    let o = diagnose_with_report(&set, &report);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("a still settling: slides.csv extrapolated from"),
        "{out}"
    );
    assert!(out.contains("critical"), "{out}");
    let json = std::fs::read_to_string(report.join("diagnosis.json")).unwrap();
    assert!(json.contains("\"settling\""), "{json}");

    // A straight fall shows no settle: exit 1, the reason named, no report.
    let line = dir.path().join("line");
    slip_data_set(&line, "falls.csv", [3, 4], |t| 12.0 - t);
    let report = dir.path().join("report2");
    let o = diagnose_with_report(&line, &report);
    assert_input_error(&o, "falls.csv");
    assert!(
        stderr(&o).contains("no settling in sight"),
        "{}",
        stderr(&o)
    );
    assert!(
        stderr(&o).contains("record until the slip has settled for 1 s"),
        "{}",
        stderr(&o)
    );
    assert!(!report.exists());
}

#[test]
fn an_undiagnosable_data_set_fails_naming_the_file_and_writes_no_report() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    data_set(&set, "stopped.csv", |_| (0.0, 0.0));
    let report = dir.path().join("report");
    let o = diagnose_with_report(&set, &report);
    assert_input_error(&o, "stopped.csv");
    assert!(stderr(&o).contains("cannot diagnose"), "{}", stderr(&o));
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(!report.exists());
}

/// One condition recorded too short among settled ones: the settled ones are printed, the
/// refused one in its row with the reason; exit 1 and no report files.
#[test]
fn a_partly_diagnosable_data_set_prints_what_it_could_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    slip_data_set(&set, "steady.csv", [5, 6], |_| 0.7);
    // A second condition recorded for 0.8 s of steady running: too short to judge.
    let (n1, n2) = (noise_rpm(5), noise_rpm(6));
    let mut short = String::from("time_s,driver_rpm,driven_rpm\n");
    for i in 0..800 {
        let (t, k) = (i as f64 * 1e-3, 1000 + i);
        short += &format!("{t:.6},{:.3},{:.3}\n", 1760.0 + n1[k], 873.8 + n2[k]);
    }
    std::fs::write(set.join("short.csv"), short).unwrap();
    let manifest = std::fs::read_to_string(set.join("manifest.toml")).unwrap();
    std::fs::write(
        set.join("manifest.toml"),
        format!("{manifest}\n[[run]]\nfile = \"short.csv\"\nlabel = \"b\"\n"),
    )
    .unwrap();
    let report = dir.path().join("report");
    let o = diagnose_with_report(&set, &report);
    assert_input_error(&o, "short.csv");
    assert!(
        stderr(&o).contains("1 of 2 conditions cannot be diagnosed"),
        "{}",
        stderr(&o)
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("healthy"), "{out}");
    assert!(out.contains("| cannot diagnose: short.csv"), "{out}");
    assert!(!report.exists());
}

#[cfg(unix)]
#[test]
fn diagnose_refuses_a_run_file_outside_the_data_set_and_never_shows_it() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    data_set(&set, "r.csv", |_| (1750.0, 870.0));
    let secret = dir.path().join("passwd");
    std::fs::write(&secret, "root:x:0:0:SECRET\n").unwrap();
    std::fs::remove_file(set.join("r.csv")).unwrap();
    std::os::unix::fs::symlink(&secret, set.join("r.csv")).unwrap();
    let o = run(&[os("diagnose"), os("--measured"), set.as_os_str()]);
    assert_input_error(&o, "outside the data set's folder");
    assert!(!stderr(&o).contains("SECRET"), "{}", stderr(&o));
    std::fs::remove_file(set.join("r.csv")).unwrap();
    mkfifo(&set.join("r.csv"));
    let o = run(&[os("diagnose"), os("--measured"), set.as_os_str()]);
    assert_input_error(&o, "FIFO");
}

#[test]
fn a_model_too_large_is_refused_by_its_key_before_any_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("huge.toml");
    let text =
        fom::config::DEFAULT_HVAC_TOML.replacen("segments = 240", "segments = 100000000000", 1);
    assert_ne!(text, fom::config::DEFAULT_HVAC_TOML);
    std::fs::write(&cfg, text).unwrap();
    let o = run(&[
        os("simulate"),
        os("--config"),
        cfg.as_os_str(),
        os("--duration"),
        os("0.05"),
        os("--out"),
        dir.path().join("run.csv").as_os_str(),
    ]);
    assert_input_error(&o, "belt.segments = 100000000000");
}

#[test]
fn a_bad_number_is_named_by_its_flag_and_shown_short() {
    for (flag, value) in [
        ("--d", "-inf"),
        ("--mu", "NaN"),
        ("--mu", "inf"),
        ("--tension", "-1"),
    ] {
        let mut args = vec![os("predict"), os("--allow-extrapolation")];
        if flag != "--d" {
            args.extend([os("--d"), os("0.42")]);
        }
        args.extend([os(flag), os(value)]);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {}", stderr(&o));
        assert!(stderr(&o).contains(flag), "{}", stderr(&o));
        assert!(
            !stderr(&o).contains("unexpected argument"),
            "{}",
            stderr(&o)
        );
    }
    let o = run(&[os("predict"), os("--d"), os("1e308")]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!stderr(&o).contains("0000000000000000"), "{}", stderr(&o));
    let o = run(&[
        os("predict"),
        os("--d"),
        os("0.42"),
        os("--mu"),
        os("1e308"),
        os("--allow-extrapolation"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("mu = 1e308"), "{}", stderr(&o));
}

#[test]
fn the_tooth_load_surrogate_refuses_a_centre_distance_as_the_slip_one_refuses_a_side_gap() {
    let cfg = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fom/configs/synchronous-arc.toml"
    );
    let o = run(&[os("predict"), os("--config"), os(cfg), os("--d"), os("1e9")]);
    assert_input_error(&o, "--d: not trained over");
    assert!(stderr(&o).contains("--side-gap"), "{}", stderr(&o));
}
