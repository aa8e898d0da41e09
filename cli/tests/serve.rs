//! `rom serve` as a process: killed with SIGKILL in the middle of a replay and restarted, its
//! database is intact and the replay continues with nothing recorded lost or doubled.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serve::store::Store;

use crate::support::{workspace, Killed};

fn serve_args(db: &Path) -> Vec<String> {
    let data = workspace().join("examples/data/loose");
    [
        "serve",
        "--replay",
        data.to_str().unwrap(),
        "--speed",
        "8",
        "--duration",
        "16",
        "--db",
        db.to_str().unwrap(),
    ]
    .map(String::from)
    .to_vec()
}

fn keys(db: &Path) -> Vec<(String, i64, f64, f64)> {
    let s = Store::open_reader(db).unwrap();
    assert_eq!(s.integrity_check().unwrap(), "ok");
    s.segment_keys().unwrap()
}

#[test]
fn a_server_killed_mid_replay_resumes_with_nothing_lost_or_doubled() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("serve.db");
    let mut child = Killed(
        Command::new(env!("CARGO_BIN_EXE_rom"))
            .args(serve_args(&db))
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let start = Instant::now();
    loop {
        let n = Store::open_reader(&db)
            .and_then(|s| s.segment_keys())
            .map_or(0, |k| k.len());
        if n >= 3 {
            break;
        }
        assert!(
            child.0.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no segment recorded"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.0.kill().unwrap();
    child.0.wait().unwrap();
    let before = keys(&db);
    let last_end = |k: &[(String, i64, f64, f64)], d: &str| {
        k.iter()
            .filter(|r| r.0 == d)
            .map(|r| r.3)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(
        ["d0", "d1", "d2", "d3"]
            .iter()
            .any(|d| last_end(&before, d) < 15.0),
        "the kill came after the replay's end: {before:?}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(serve_args(&db))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let after = keys(&db);
    // Everything recorded before the kill is still there, unchanged.
    for k in &before {
        assert!(after.contains(k), "{k:?} lost");
    }
    for d in ["d0", "d1", "d2", "d3"] {
        let segs: Vec<_> = after.iter().filter(|r| r.0 == d).collect();
        // Numbered 1..n without holes, in time order, none overlapping another.
        for (i, w) in segs.iter().enumerate() {
            assert_eq!(w.1, i as i64 + 1, "{d}: {segs:?}");
        }
        for w in segs.windows(2) {
            assert!(w[1].2 > w[0].3, "{d}: overlapping {w:?}");
        }
        assert!(last_end(&after, d) > 15.0, "{d} did not finish: {segs:?}");
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let state = |d: &str| {
        text.lines()
            .find(|l| l.starts_with(d))
            .and_then(|l| l.split_whitespace().nth(1))
            .unwrap_or_default()
            .to_string()
    };
    assert_eq!(state("d3"), "loose", "{text}");
    assert_eq!(state("d0"), "healthy", "{text}");
}

/// Replays the loose-belt example for `duration_s` of each drive's clock, as fast as it goes:
/// the loose label `d3` reaches loose, the healthy ones stay healthy, and no drive's alarm
/// changes more than that one time (no flapping). The segments' evidence alone: background
/// gap checks are off (`serve_gap.rs` covers them; ten minutes would make a dozen due).
fn loose_replay_keeps_its_states(duration_s: &str) {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("serve.db");
    let conf = dir.path().join("serve.toml");
    std::fs::write(&conf, "gap_every_segments = 0\ngap_misfit_segments = 0\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(["serve", "--config"])
        .arg(&conf)
        .arg("--replay")
        .arg(workspace().join("examples/data/loose"))
        .args(["--speed", "0", "--duration", duration_s, "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = Store::open_reader(&db).unwrap();
    for (d, want) in [
        ("d0", vec![]),
        ("d1", vec![]),
        ("d2", vec![]),
        ("d3", vec![("healthy", "loose")]),
    ] {
        let (segments, alarms) = s.history(d, f64::NEG_INFINITY, f64::INFINITY).unwrap();
        let changes: Vec<(&str, &str)> = alarms
            .iter()
            .map(|a| (a["from"].as_str().unwrap(), a["to"].as_str().unwrap()))
            .collect();
        assert_eq!(changes, want, "{d}: {alarms:?}");
        assert!(segments.len() >= 3, "{d}: {} segments", segments.len());
    }
}

#[test]
fn a_short_loose_replay_reaches_loose_on_the_loose_label_only() {
    loose_replay_keeps_its_states("20");
}

/// Ten minutes of each drive's clock (about 550 segments; minutes of computing).
#[test]
#[ignore]
fn a_ten_minute_loose_replay_never_flaps() {
    loose_replay_keeps_its_states("600");
}

#[test]
fn bad_input_fails_with_one_clear_error_and_no_database() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("serve.db");
    let data = workspace().join("examples/data/loose");
    let toml = dir.path().join("serve.toml");
    std::fs::write(&toml, "[[drive]]\nid = \"d0\"\n[[drive]]\nid = \"d0\"\n").unwrap();
    let gap_toml = dir.path().join("gap.toml");
    std::fs::write(
        &gap_toml,
        "gap_misfit_segments = 5\ngap_misfit_window = 4\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_rom"))
            .arg("serve")
            .args(extra)
            .arg("--db")
            .arg(&db)
            .output()
            .unwrap()
    };
    let missing = dir.path().join("nowhere");
    let cases: [(Vec<&str>, i32, &str); 6] = [
        (vec![], 1, "no source of readings"),
        (vec!["--replay", missing.to_str().unwrap()], 1, "nowhere"),
        (
            vec!["--replay", data.to_str().unwrap(), "--http", "999.1.1.1:80"],
            1,
            "--http 999.1.1.1:80",
        ),
        (
            vec![
                "--replay",
                data.to_str().unwrap(),
                "--config",
                toml.to_str().unwrap(),
            ],
            1,
            "appears twice",
        ),
        (
            vec![
                "--replay",
                data.to_str().unwrap(),
                "--config",
                gap_toml.to_str().unwrap(),
            ],
            1,
            "`gap_misfit_segments` = 5 must be at most `gap_misfit_window` = 4",
        ),
        (
            vec!["--replay", data.to_str().unwrap(), "--speed", "-1"],
            2,
            "--speed",
        ),
    ];
    for (args, code, what) in cases {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: {err}");
        assert!(!db.exists(), "{args:?} left a database");
    }
}
