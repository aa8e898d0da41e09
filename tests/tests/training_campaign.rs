//! Training campaigns: sharding, merging, resuming, failures.

use std::path::Path;

use beltwin_tests::{cheap_drive, cheap_settings};
use training::{merge, run_campaign, CampaignSettings, Dataset, Event, Shard};

fn tiny_settings() -> CampaignSettings {
    let mut s = cheap_settings(5, 3);
    s.duration_s = 0.3;
    s.min_duration_s = 0.3;
    s.steady_length_s = 0.1;
    s
}

fn quiet(_: Event) {}

/// All files of a data set except the wall times, which differ from run to run, and the
/// (empty) lock files.
fn contents(dir: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut push = |p: &Path| {
        let name = p.strip_prefix(dir).unwrap().display().to_string();
        if name.ends_with(".lock") {
            return;
        }
        let text = std::fs::read_to_string(p).unwrap();
        let text = if name.ends_with(".toml") && name.starts_with("runs") {
            text.lines()
                .filter(|l| !l.starts_with("wall_time_s"))
                .collect::<Vec<_>>()
                .join("\n")
        } else if name == "points.csv" {
            // Drop the wall_time_s column (6th).
            text.lines()
                .map(|l| {
                    let mut f: Vec<&str> = l.split(',').collect();
                    f.remove(5);
                    f.join(",")
                })
                .collect::<Vec<_>>()
                .join("\n")
        } else {
            text
        };
        out.push((name, text));
    };
    for top in std::fs::read_dir(dir).unwrap() {
        let p = top.unwrap().path();
        if p.is_dir() {
            for f in std::fs::read_dir(&p).unwrap() {
                push(&f.unwrap().path());
            }
        } else {
            push(&p);
        }
    }
    out.sort();
    out
}

#[test]
fn two_shards_and_merge_equal_one_unsharded_run() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let cfg = cheap_drive();
    let s = tiny_settings();
    let full = run_campaign(a.path(), &cfg, &s, None, &quiet).unwrap();
    assert!(
        full.complete && full.ran == 5 && full.failed == 0,
        "{full:?}"
    );
    for i in 1..=2 {
        let r = run_campaign(
            b.path(),
            &cfg,
            &s,
            Some(Shard { index: i, count: 2 }),
            &quiet,
        )
        .unwrap();
        assert!(!r.complete, "a shard must not write points.csv");
    }
    assert!(!b.path().join("points.csv").exists());
    merge(b.path()).unwrap();
    let (ca, cb) = (contents(a.path()), contents(b.path()));
    assert_eq!(
        ca.len(),
        2 * 5 + 4,
        "files: {:?}",
        ca.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    assert_eq!(ca, cb);
}

#[test]
fn merge_names_missing_points_of_an_unfinished_shard() {
    let dir = tempfile::tempdir().unwrap();
    let s = tiny_settings();
    run_campaign(
        dir.path(),
        &cheap_drive(),
        &s,
        Some(Shard { index: 1, count: 2 }),
        &quiet,
    )
    .unwrap();
    let err = merge(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("2 of 5 points") && err.contains("1, 3"),
        "{err}"
    );
    assert!(!dir.path().join("points.csv").exists());
    assert!(Dataset::load(dir.path()).is_err());
}

#[test]
fn resumed_campaign_recomputes_nothing_and_refuses_other_settings() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = cheap_drive();
    let s = tiny_settings();
    run_campaign(
        dir.path(),
        &cfg,
        &s,
        Some(Shard { index: 2, count: 2 }),
        &quiet,
    )
    .unwrap();
    let status1 = std::fs::read_to_string(dir.path().join("runs/point-0001.toml")).unwrap();
    let again = run_campaign(dir.path(), &cfg, &s, None, &quiet).unwrap();
    assert_eq!((again.ran, again.skipped, again.complete), (3, 2, true));
    // Point 1 was finished by the shard; its status (with its wall time) is untouched.
    let status2 = std::fs::read_to_string(dir.path().join("runs/point-0001.toml")).unwrap();
    assert_eq!(status1, status2);
    let third = run_campaign(dir.path(), &cfg, &s, None, &quiet).unwrap();
    assert_eq!((third.ran, third.skipped), (0, 5));

    let mut other = s.clone();
    other.seed += 1;
    let err = run_campaign(dir.path(), &cfg, &other, None, &quiet)
        .unwrap_err()
        .to_string();
    assert!(err.contains("other settings"), "{err}");
    let mut cfg2 = cfg.clone();
    cfg2.belt.axial_stiffness_n *= 1.1;
    let err = run_campaign(dir.path(), &cfg2, &s, None, &quiet)
        .unwrap_err()
        .to_string();
    assert!(err.contains("another drive configuration"), "{err}");
}

#[test]
fn failed_point_is_recorded_with_its_error_and_the_campaign_completes() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = tiny_settings();
    // From d = 0.40 m the belt installed at 200-300 N at 0.42 m is slack: those points fail.
    s.center_distance_m = [0.40, 0.424];
    let failures = std::sync::Mutex::new(Vec::new());
    let on_event = |e: Event| {
        if let Event::Finished {
            index,
            error: Some(err),
        } = e
        {
            failures.lock().unwrap().push((index, err));
        }
    };
    let r = run_campaign(dir.path(), &cheap_drive(), &s, None, &on_event).unwrap();
    assert!(r.complete);
    assert!(r.failed >= 1 && r.failed < 5, "{r:?}");
    let ds = Dataset::load(dir.path()).unwrap();
    let failed: Vec<_> = ds
        .points
        .iter()
        .filter(|p| p.status.status == "failed")
        .collect();
    assert_eq!(failed.len(), r.failed);
    // Runs of 0.3 s from standstill may end unsettled: reported too, with the drift.
    let unsettled: Vec<_> = ds
        .points
        .iter()
        .filter(|p| p.status.status == "unsettled")
        .collect();
    assert_eq!(unsettled.len(), r.unsettled);
    for p in &unsettled {
        assert!(
            p.status.error.as_deref().unwrap().contains("in 0.3 s"),
            "{p:?}"
        );
    }
    assert_eq!(
        failures.lock().unwrap().len(),
        r.failed + r.unsettled + r.unbalanced
    );
    for p in failed {
        assert!(p.point.center_distance_m < 0.412, "{p:?}");
        assert!(
            p.status.error.as_deref().unwrap().contains("slack"),
            "{p:?}"
        );
        assert!(!dir
            .path()
            .join(format!("runs/point-{:04}.csv", p.index))
            .exists());
    }
    let points = std::fs::read_to_string(dir.path().join("points.csv")).unwrap();
    assert!(
        points.contains(",failed,") && points.contains("slack"),
        "{points}"
    );
}

#[test]
fn bad_settings_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    let mut s = tiny_settings();
    s.friction = [0.8, 0.6];
    let err = run_campaign(&out, &cheap_drive(), &s, None, &quiet)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("friction") && err.contains("not a range"),
        "{err}"
    );
    assert!(!out.exists());
    let err = CampaignSettings::from_toml_str("samples = 4\nsead = 1\n", "my.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("my.toml") && err.contains("sead"), "{err}");
}

/// A campaign too small for the surrogate's fit is refused by its settings check, before any
/// run (it used to run every point and then fail the fit).
#[test]
fn a_campaign_too_small_to_fit_is_refused_before_it_runs() {
    let e = CampaignSettings::from_toml_str("samples = 4\n", "campaign.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("samples = 4") && e.contains("at least 5"), "{e}");
    assert!(CampaignSettings::from_toml_str("samples = 5\n", "campaign.toml").is_ok());
}

/// A design box none of whose corners can be built (here every belt is slack) is refused
/// before anything is written; it used to run every point to failure first.
#[test]
fn a_box_where_no_point_can_run_is_refused_before_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    let mut s = tiny_settings();
    s.center_distance_m = [0.36, 0.38];
    let e = run_campaign(&out, &cheap_drive(), &s, None, &quiet)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no corner") && e.contains("center_distance_m = 0.36") && e.contains("slack"),
        "{e}"
    );
    assert!(!out.join("campaign.toml").exists() && !out.join("runs").exists());
    // Too many points for the design's optimisation and the fit: refused by the settings.
    let e = CampaignSettings::from_toml_str("samples = 5001\n", "campaign.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("samples = 5001") && e.contains("5000"), "{e}");
}

/// A temporary file left by a writer killed between create and rename is removed when the
/// campaign is resumed under its exclusive lock; the resumed data set equals a clean one.
#[test]
fn a_resumed_campaign_removes_what_a_killed_writer_left() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, s) = (cheap_drive(), tiny_settings());
    run_campaign(dir.path(), &cfg, &s, None, &quiet).unwrap();
    let clean = contents(dir.path());
    let stale = [
        dir.path().join(".drive.toml.4242-0-17.tmp"),
        dir.path().join("runs/.point-0001.csv.4242-3-99.tmp"),
    ];
    for p in &stale {
        std::fs::write(p, "half a file").unwrap();
    }
    run_campaign(dir.path(), &cfg, &s, None, &quiet).unwrap();
    for p in &stale {
        assert!(!p.exists(), "{} left behind", p.display());
    }
    assert_eq!(contents(dir.path()), clean);
}

/// A second `rom train` on a directory in use is refused at once with a message that names the
/// directory (before the lock, two processes with different settings both passed the "campaign
/// exists?" check and paired one design with the other's results); shards share the directory.
#[test]
fn a_campaign_directory_in_use_is_refused_and_shards_share_it() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, s) = (cheap_drive(), tiny_settings());
    let lock = std::fs::File::create(dir.path().join(".campaign.lock")).unwrap();
    // Another unsharded run holds the directory.
    lock.lock().unwrap();
    let e = run_campaign(dir.path(), &cfg, &s, None, &quiet).unwrap_err();
    assert!(
        matches!(e, training::TrainingError::Busy(_)) && e.to_string().contains("in use"),
        "{e}"
    );
    let shard = Some(Shard { index: 1, count: 2 });
    assert!(run_campaign(dir.path(), &cfg, &s, shard, &quiet).is_err());
    assert!(
        !dir.path().join("campaign.toml").exists(),
        "nothing written"
    );
    // Another shard holds it: a shard may run, an unsharded run and a merge may not.
    lock.unlock().unwrap();
    lock.lock_shared().unwrap();
    let r = run_campaign(dir.path(), &cfg, &s, shard, &quiet).unwrap();
    assert!(r.ran > 0, "{r:?}");
    assert!(run_campaign(dir.path(), &cfg, &s, None, &quiet).is_err());
    assert!(merge(dir.path()).is_err());
}
