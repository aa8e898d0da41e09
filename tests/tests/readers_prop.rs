//! Property-based tests of every reader: whatever the input, a reader returns either
//! a value that meets its documented invariants or one error; it never panics, never hangs and
//! never accepts garbage silently. The short variant runs 256 cases per reader; the long run
//! sets `PROPTEST_CASES` (`docs/validation/readers.md`).

use std::io::Write;

use proptest::prelude::*;
use proptest::test_runner::Config;

use fom::config::{DriveConfig, DEFAULT_HVAC_TOML};
use training::CampaignSettings;
use twin::measured::{read_dataset, read_recording};

/// 256 cases, or `PROPTEST_CASES`.
fn config() -> Config {
    Config {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(256),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A valid run file's lines, to be mutated.
const GOOD_CSV: &str = "# comment\ntime_s,driver_rpm,driven_rpm,extra\n\
0.000,1750.0,869.0,1\n0.001,1750.5,869.2,2\n0.002,1749.8,868.9,3\n0.003,1750.1,869.1,4\n";

/// Lines that a mutation may put in: numbers of every kind, separators, junk.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("-1".to_string()),
        Just("1e308".to_string()),
        Just("".to_string()),
        Just(",".to_string()),
        Just("\r".to_string()),
        Just("\"".to_string()),
        any::<f64>().prop_map(|x| x.to_string()),
        "[ -~]{0,12}",
    ]
}

/// A CSV built from the good one with lines replaced, dropped or cells scrambled.
fn mutated_csv() -> impl Strategy<Value = String> {
    let lines: Vec<String> = GOOD_CSV.lines().map(str::to_string).collect();
    (
        proptest::collection::vec((0..lines.len(), token(), 0..3usize), 0..6),
        any::<bool>(),
    )
        .prop_map(move |(edits, swap_header)| {
            let mut l = lines.clone();
            for (i, t, how) in edits {
                match how {
                    0 => l[i] = t,
                    1 => l[i] = format!("{},{t}", l[i]),
                    _ => l[i] = l[i].replacen('.', &t, 1),
                }
            }
            if swap_header {
                l.swap(1, 2);
            }
            l.join("\n")
        })
}

/// What an accepted recording must be (docs/measured-data.md).
fn valid_recording(r: &twin::measured::Recording, min: usize) -> bool {
    r.len() >= min
        && r.time_s.windows(2).all(|w| w[1] > w[0])
        && r.time_s.iter().all(|t| t.is_finite())
        && r.driver_rpm
            .iter()
            .chain(&r.driven_rpm)
            .all(|v| v.is_finite() && *v >= 0.0)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn the_run_csv_reader_accepts_only_valid_recordings(text in mutated_csv(), min in 1usize..5) {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        if let Ok(r) = read_recording(f.path(), min) {
            prop_assert!(valid_recording(&r, min), "accepted {text:?}");
        }
    }

    #[test]
    fn the_run_csv_reader_survives_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(&bytes).unwrap();
        if let Ok(r) = read_recording(f.path(), 1) {
            prop_assert!(valid_recording(&r, 1));
        }
    }

    #[test]
    fn the_manifest_reader_names_what_is_wrong(
        format in prop_oneof![Just("belt-measurements/1".to_string()), "[ -~]{0,20}"],
        file in prop_oneof![Just("r.csv".to_string()), Just("../r.csv".to_string()),
                            Just("/etc/passwd".to_string()), "[ -~]{0,16}"],
        label in "[ -~]{0,8}",
        d in prop_oneof![Just("0.42".to_string()), Just("-1".to_string()), Just("nan".to_string()),
                         Just("\"x\"".to_string()), Just("[0.4, 0.5]".to_string())],
        extra in prop_oneof![Just(String::new()), Just("run = []\n".to_string()),
                             Just("driver_pulley_diameter_m = 0\n".to_string())],
    ) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("r.csv"), GOOD_CSV).unwrap();
        let manifest = format!(
            "format = {format:?}\n{extra}[[run]]\nfile = {file:?}\nlabel = {label:?}\ncenter_distance_m = {d}\n"
        );
        std::fs::write(dir.path().join("manifest.toml"), &manifest).unwrap();
        match read_dataset(dir.path(), 1) {
            Ok(set) => {
                // Accepted: the right format, a file inside the directory, a non-empty label,
                // a positive distance.
                prop_assert_eq!(format.as_str(), "belt-measurements/1");
                prop_assert!(!file.contains("..") && !file.starts_with('/'));
                let run = &set.manifest.runs[0];
                prop_assert!(!run.label.trim().is_empty());
                prop_assert!(run.center_distance_m.is_none_or(|d| d > 0.0));
                prop_assert!(valid_recording(&set.recordings[0], 1));
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    #[test]
    fn the_drive_config_reader_accepts_only_valid_configurations(
        line in 0usize..120,
        value in prop_oneof![Just("-1".to_string()), Just("0".to_string()), Just("nan".to_string()),
                             Just("1e300".to_string()), Just("\"x\"".to_string()),
                             Just("[1, 2, 3]".to_string()), any::<f64>().prop_map(|x| format!("{x:?}"))],
    ) {
        // Replace the value of one `key = value` line of the default file.
        let lines: Vec<&str> = DEFAULT_HVAC_TOML.lines().collect();
        let keyed: Vec<usize> = (0..lines.len())
            .filter(|&i| lines[i].contains(" = ") && !lines[i].trim_start().starts_with('#'))
            .collect();
        let i = keyed[line % keyed.len()];
        let key = lines[i].split(" = ").next().unwrap();
        let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        edited[i] = format!("{key} = {value}");
        let text = edited.join("\n");
        if let Ok(cfg) = DriveConfig::from_toml_str(&text, "drive.toml") {
            prop_assert!(cfg.check().is_ok());
            prop_assert!(cfg.center_distance_m().is_finite());
        }
    }

    #[test]
    fn the_campaign_settings_reader_accepts_only_valid_settings(
        key in prop_oneof![Just("samples"), Just("seed"), Just("center_distance_m"),
                           Just("friction"), Just("installation_tension_n"), Just("duration_s"),
                           Just("min_duration_s"), Just("steady_length_s"), Just("axial_stiffness_n")],
        value in prop_oneof![Just("-1".to_string()), Just("0".to_string()), Just("nan".to_string()),
                             Just("4".to_string()), Just("[0.5, 0.4]".to_string()),
                             Just("[0.4, 0.5, 0.6]".to_string()), Just("[1e-300, 1e300]".to_string()),
                             any::<f64>().prop_map(|x| format!("{x:?}"))],
    ) {
        if let Ok(s) = CampaignSettings::from_toml_str(&format!("{key} = {value}\n"), "campaign.toml") {
            prop_assert!(s.validate().is_ok());
            prop_assert!(s.samples >= training::MIN_FIT_SAMPLES);
            for (_, [lo, hi]) in s.ranges() {
                prop_assert!(lo.is_finite() && hi.is_finite() && lo < hi);
            }
        }
    }
}

/// Any single-byte change of the shipped model file is refused (the checksum covers header and
/// payload), whatever the byte and the place.
#[test]
fn every_sampled_one_byte_edit_of_the_model_file_is_refused() {
    let bytes = rom::shipped::SLIP.bytes.to_vec();
    let cases = config().cases as usize;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let mut refused = 0;
    for k in 0..cases.min(bytes.len()) {
        // Spread over the file, the header line first.
        let at = if k < 64 {
            k * 9 % 600
        } else {
            (k * 7919) % bytes.len()
        };
        let mut b = bytes.clone();
        b[at] = b[at].wrapping_add(1 + (k % 200) as u8);
        std::fs::write(&out, &b).unwrap();
        assert!(
            rom::SurrogateFile::load(&out).is_err(),
            "edit at byte {at} accepted"
        );
        refused += 1;
    }
    assert!(refused >= 64.min(cases));
}

/// What a data set's run file is on disk (docs/reliability.md, "Inputs").
#[derive(Debug, Clone, Copy, PartialEq)]
enum OnDisk {
    /// A regular file inside the folder.
    Regular,
    /// A link to a regular file inside the folder.
    LinkInside,
    /// A link to a valid run file outside the folder.
    LinkOutside,
    /// A link to a text file outside the folder (whose first line must never be shown).
    LinkToSecret,
    /// `sub/x.csv` where `sub` links to a folder outside.
    ThroughLinkedFolder,
    /// A FIFO inside the folder (reading it would block forever).
    Fifo,
    /// A link to a FIFO outside the folder.
    LinkToOutsideFifo,
    /// A directory.
    Directory,
    /// A link to nothing.
    Dangling,
}

impl OnDisk {
    fn accepted(self) -> bool {
        matches!(self, OnDisk::Regular | OnDisk::LinkInside)
    }
}

const SECRET: &str = "root:x:0:0:SECRET-FIRST-LINE";

fn mkfifo(path: &std::path::Path) {
    let s = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap();
    assert!(s.success());
}

/// Makes run file `k` as `what` in `dir` (with `outside` a folder beside it); returns its
/// manifest `file` entry.
#[cfg(unix)]
fn make_run_file(
    dir: &std::path::Path,
    outside: &std::path::Path,
    k: usize,
    what: OnDisk,
) -> String {
    use std::os::unix::fs::symlink;
    let name = format!("r{k}.csv");
    let at = dir.join(&name);
    match what {
        OnDisk::Regular => std::fs::write(&at, GOOD_CSV).unwrap(),
        OnDisk::LinkInside => {
            std::fs::write(dir.join(format!("real{k}.csv")), GOOD_CSV).unwrap();
            symlink(format!("real{k}.csv"), &at).unwrap();
        }
        OnDisk::LinkOutside => symlink(outside.join("good.csv"), &at).unwrap(),
        OnDisk::LinkToSecret => symlink(outside.join("secret.txt"), &at).unwrap(),
        OnDisk::ThroughLinkedFolder => {
            symlink(outside, dir.join(format!("sub{k}"))).unwrap();
            return format!("sub{k}/good.csv");
        }
        OnDisk::Fifo => mkfifo(&at),
        OnDisk::LinkToOutsideFifo => symlink(outside.join("pipe"), &at).unwrap(),
        OnDisk::Directory => std::fs::create_dir(&at).unwrap(),
        OnDisk::Dangling => symlink(dir.join("nothing.csv"), &at).unwrap(),
    }
    name
}

/// `read_dataset` on `dir` in a thread: `None` when it has not returned within 20 s (a hang).
fn read_dataset_in_time(
    dir: &std::path::Path,
) -> Option<Result<twin::measured::DataSet, twin::measured::MeasuredError>> {
    let (tx, rx) = std::sync::mpsc::channel();
    let dir = dir.to_path_buf();
    std::thread::spawn(move || {
        let _ = tx.send(read_dataset(&dir, 1));
    });
    rx.recv_timeout(std::time::Duration::from_secs(20)).ok()
}

fn on_disk() -> impl Strategy<Value = OnDisk> {
    prop_oneof![
        Just(OnDisk::Regular),
        Just(OnDisk::LinkInside),
        Just(OnDisk::LinkOutside),
        Just(OnDisk::LinkToSecret),
        Just(OnDisk::ThroughLinkedFolder),
        Just(OnDisk::Fifo),
        Just(OnDisk::LinkToOutsideFifo),
        Just(OnDisk::Directory),
        Just(OnDisk::Dangling),
    ]
}

#[cfg(unix)]
proptest! {
    #![proptest_config(Config { cases: config().cases.min(64), ..config() })]

    /// Whatever the run files and the manifest are on disk, the reader returns in time, accepts
    /// only regular files inside the data set's folder, and never shows a refused file's text.
    #[test]
    fn the_data_set_reader_reads_only_regular_files_inside_its_folder(
        runs in proptest::collection::vec(on_disk(), 1..4),
        manifest_outside in any::<bool>(),
    ) {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("set");
        let outside = root.path().join("outside");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::create_dir_all(&outside).unwrap();
        std::fs::write(outside.join("good.csv"), GOOD_CSV).unwrap();
        std::fs::write(outside.join("secret.txt"), format!("{SECRET}\nmore\n")).unwrap();
        mkfifo(&outside.join("pipe"));
        let mut manifest = String::from("format = \"belt-measurements/1\"\n");
        for (k, what) in runs.iter().enumerate() {
            let file = make_run_file(&dir, &outside, k, *what);
            manifest += &format!("[[run]]\nfile = {file:?}\nlabel = \"a\"\n");
        }
        if manifest_outside {
            std::fs::write(outside.join("manifest.toml"), &manifest).unwrap();
            std::os::unix::fs::symlink(outside.join("manifest.toml"), dir.join("manifest.toml"))
                .unwrap();
        } else {
            std::fs::write(dir.join("manifest.toml"), &manifest).unwrap();
        }
        let result = read_dataset_in_time(&dir);
        prop_assert!(result.is_some(), "the reader hung on {runs:?}");
        let ok = !manifest_outside && runs.iter().all(|r| r.accepted());
        match result.unwrap() {
            Ok(set) => {
                prop_assert!(ok, "accepted {runs:?} (manifest outside: {manifest_outside})");
                prop_assert_eq!(set.recordings.len(), runs.len());
            }
            Err(e) => {
                prop_assert!(!ok, "refused {runs:?}: {e}");
                prop_assert!(!e.to_string().contains("SECRET"), "{e}");
            }
        }
    }
}

#[cfg(unix)]
#[test]
fn a_fifo_or_a_directory_given_as_one_run_file_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    mkfifo(&fifo);
    let (tx, rx) = std::sync::mpsc::channel();
    let f = fifo.clone();
    std::thread::spawn(move || {
        let _ = tx.send(read_recording(&f, 1).map(|_| ()));
    });
    let e = rx
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("the reader returns")
        .unwrap_err();
    assert!(e.to_string().contains("FIFO"), "{e}");
    let e = read_recording(dir.path(), 1).unwrap_err();
    assert!(e.to_string().contains("directory"), "{e}");
}

/// A data set of one label with `runs` (manifest entries) and `r.csv` holding `csv`.
fn data_set(runs: &str, csv: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("r.csv"), csv).unwrap();
    std::fs::write(
        dir.path().join("manifest.toml"),
        format!("format = \"belt-measurements/1\"\n{runs}"),
    )
    .unwrap();
    dir
}

#[test]
fn a_run_file_listed_twice_is_refused_with_its_line() {
    let dir = data_set(
        "[[run]]\nfile = \"r.csv\"\nlabel = \"a\"\n\n[[run]]\nfile = \"./r.csv\"\nlabel = \"b\"\n",
        GOOD_CSV,
    );
    let e = read_dataset(dir.path(), 1).unwrap_err();
    assert_eq!(e.line, Some(7), "{e}");
    assert!(e.to_string().contains("r.csv"), "{e}");
}

#[test]
fn a_label_with_a_line_break_is_refused_with_its_line() {
    let dir = data_set("[[run]]\nfile = \"r.csv\"\nlabel = \"a\\nb\"\n", GOOD_CSV);
    let e = read_dataset(dir.path(), 1).unwrap_err();
    assert_eq!(e.line, Some(4), "{e}");
    assert!(e.to_string().contains("label"), "{e}");
}

#[test]
fn a_duplicated_column_is_refused_with_the_header_line() {
    let csv = GOOD_CSV.replace("driven_rpm,extra", "driven_rpm,driver_rpm");
    let dir = data_set("[[run]]\nfile = \"r.csv\"\nlabel = \"a\"\n", &csv);
    let e = read_dataset(dir.path(), 1).unwrap_err();
    assert_eq!(e.line, Some(2), "{e}");
    assert!(e.to_string().contains("driver_rpm"), "{e}");
}

#[test]
fn a_number_too_long_for_a_float_is_shown_short_and_named_as_too_large() {
    let long = format!("1{}", "0".repeat(100_000));
    let csv = GOOD_CSV.replacen("1750.5", &long, 1);
    let dir = data_set("[[run]]\nfile = \"r.csv\"\nlabel = \"a\"\n", &csv);
    let e = read_dataset(dir.path(), 1).unwrap_err().to_string();
    assert!(
        e.contains("too large") && e.contains("100001 characters"),
        "{e}"
    );
    assert!(e.len() < 400, "{e}");
}
