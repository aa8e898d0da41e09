//! The queue and worker (one check at a time, a drive queued at most once), ingestion going on
//! while a check runs, and what a report tells the alarm.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{channel, Receiver};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use super::*;
use crate::config::{DriveModel, Models};
use crate::Batch;

fn model() -> Arc<DriveModel> {
    static M: OnceLock<Arc<DriveModel>> = OnceLock::new();
    M.get_or_init(|| Models::shipped().unwrap().default).clone()
}

fn job(drive: &str, at_s: f64) -> GapJob {
    let (set, sources) = GapSample::default().data_set((None, None));
    GapJob {
        drive: drive.into(),
        model: model(),
        set,
        sources,
        trigger: Trigger::Segments,
        at_s,
    }
}

/// A check due after every two segments, none on misfits.
fn every_two_segments() -> GapSettings {
    GapSettings {
        rule: DueRule {
            every_segments: 2,
            misfit_segments: 0,
            misfit_window: 10,
        },
        ..GapSettings::default()
    }
}

/// Waits (at most 30 s) until `f` holds.
fn until(what: &str, mut f: impl FnMut() -> bool) {
    let end = Instant::now() + Duration::from_secs(30);
    while !f() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A check that waits for a go on `gate` and records how many run at once.
fn gated(gate: Receiver<()>, busy: Arc<AtomicUsize>, most: Arc<AtomicUsize>) -> CheckFn {
    let gate = Mutex::new(gate);
    Box::new(move |j: &GapJob| {
        let now = busy.fetch_add(1, Ordering::SeqCst) + 1;
        most.fetch_max(now, Ordering::SeqCst);
        let _ = gate.lock().unwrap().recv();
        busy.fetch_sub(1, Ordering::SeqCst);
        Ok(serde_json::json!({"top_effect": "none", "named": [], "at": j.at_s}))
    })
}

#[test]
fn checks_run_one_at_a_time_and_a_drive_waits_in_the_queue_once() {
    let (go, gate) = channel();
    let (busy, most) = (Arc::default(), Arc::new(AtomicUsize::new(0)));
    let w = Worker::start(2, gated(gate, busy, most.clone())).unwrap();
    assert!(w.queue.push(job("a", 1.0)));
    until("a running", || w.queue.running().as_deref() == Some("a"));
    assert!(w.queue.push(job("b", 1.0)));
    assert!(w.queue.push(job("c", 1.0)));
    // b is queued again while it waits: it keeps its place and takes the newer job.
    assert!(!w.queue.push(job("b", 2.0)));
    // a runs, so it may wait once more behind the others.
    assert!(w.queue.push(job("a", 3.0)));
    assert_eq!(w.queue.pending(), ["b", "c", "a"]);
    let mut seen = Vec::new();
    for _ in 0..4 {
        go.send(()).unwrap();
        let o = w.outcomes.recv_timeout(Duration::from_secs(30)).unwrap();
        seen.push((o.drive, o.result.unwrap()["at"].as_f64().unwrap()));
    }
    let expected = [("a", 1.0), ("b", 2.0), ("c", 1.0), ("a", 3.0)];
    assert_eq!(seen, expected.map(|(d, t)| (d.to_string(), t)));
    assert_eq!(most.load(Ordering::SeqCst), 1, "two checks ran at once");
    until("idle", || w.queue.running().is_none());
}

/// The example loose drive's first recording, repeated `times` times one after another as
/// batches of 50 readings from `from` on (each repeat starts at standstill: one segment each).
fn replayed(times: usize) -> Vec<Batch> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/data/loose");
    let set = twin::measured::read_dataset(&dir, twin::signal::MIN_STEADY_SAMPLES).unwrap();
    let rec = &set.recordings[set.runs_of("d0")[0]];
    let span = rec.time_s[rec.len() - 1] - rec.time_s[0] + 0.002;
    let mut out = Vec::new();
    for k in 0..times {
        for i in (0..rec.len()).step_by(50) {
            let j = (i + 50).min(rec.len());
            out.push(Batch {
                drive: "d0".into(),
                seq: None,
                time_s: rec.time_s[i..j]
                    .iter()
                    .map(|t| t + k as f64 * span)
                    .collect(),
                driver_rpm: rec.driver_rpm[i..j].to_vec(),
                driven_rpm: rec.driven_rpm[i..j].to_vec(),
                extra: BTreeMap::new(),
            });
        }
    }
    out
}

#[test]
fn ingestion_goes_on_while_a_check_runs_and_the_report_is_stored_and_shown() {
    let dir = tempfile::tempdir().unwrap();
    let store = crate::store::Store::open(&dir.path().join("s.db"), None).unwrap();
    let mut e = Engine::new(Models::shipped().unwrap(), Some(store), Vec::new()).unwrap();
    let (go, gate) = channel();
    let (busy, most) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let settings = every_two_segments();
    e.start_gap_checks_with(settings, gated(gate, busy.clone(), most))
        .unwrap();
    let batches = replayed(6);
    let per_run = batches.len() / 6;
    let mut during = None;
    for (i, b) in batches.into_iter().enumerate() {
        e.ingest(b).unwrap();
        if i + 1 == 3 * per_run {
            // Two segments closed (the third run's stop closed the second): the check runs.
            until("the check to start", || busy.load(Ordering::SeqCst) == 1);
            during = Some(e.counters().clone());
            assert_eq!(e.gap_queue().0.as_deref(), Some("d0"));
        }
    }
    e.flush().unwrap();
    let before = during.expect("a check started");
    let after = e.counters().clone();
    // The check still waits on its gate: readings were taken and segments diagnosed meanwhile.
    assert_eq!(busy.load(Ordering::SeqCst), 1);
    assert!(after.readings > before.readings, "{before:?} {after:?}");
    assert!(
        after.segments >= before.segments + 3,
        "{before:?} {after:?}"
    );
    assert_eq!(after.gap_checks, 0);
    // The drive became due again meanwhile: queued once more, behind the running check.
    assert_eq!(e.gap_queue().1, ["d0"]);
    go.send(()).unwrap();
    go.send(()).unwrap();
    e.wait_gap_checks().unwrap();
    assert_eq!(e.counters().gap_checks, 2);
    let view = e.view();
    let v = view.read().unwrap();
    let g = v.drives["d0"].gap_report.as_ref().unwrap();
    assert_eq!(g["verdict"], "none");
    assert!(g["first_segment"].as_u64() < g["last_segment"].as_u64());
    drop(v);
    let reader = crate::store::Store::open_reader(&dir.path().join("s.db")).unwrap();
    assert_eq!(
        reader.gap_reports("d0", f64::MIN, f64::MAX).unwrap().len(),
        2
    );
}

#[test]
fn a_check_that_panics_is_a_failed_check_and_the_worker_goes_on() {
    let mut calls = 0;
    let w = Worker::start(
        1,
        Box::new(move |_: &GapJob| {
            calls += 1;
            if calls == 1 {
                panic!("bad data");
            }
            Ok(serde_json::json!({}))
        }),
    )
    .unwrap();
    w.queue.push(job("a", 1.0));
    let o = w.outcomes.recv_timeout(Duration::from_secs(30)).unwrap();
    assert!(o.result.unwrap_err().contains("bad data"));
    w.queue.push(job("a", 2.0));
    let o = w.outcomes.recv_timeout(Duration::from_secs(30)).unwrap();
    assert!(o.result.is_ok());
}

#[test]
fn a_gap_report_is_alarm_evidence_only_when_it_finds_a_gap() {
    let named = |n: &[&str]| n.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert_eq!(
        gap_evidence(Some("unexplained"), &[]),
        Some(State::UnexplainedGap)
    );
    assert_eq!(
        gap_evidence(Some("eccentricity"), &named(&["eccentricity"])),
        Some(State::Watch)
    );
    assert_eq!(gap_evidence(Some("none"), &[]), None);
    assert_eq!(gap_evidence(None, &[]), None);
}

/// The real path short of a full diagnosis: the data set a drive's sample makes is written in
/// the exchange format, read back by `twin::measured`'s reader and passes `twin::gap`'s
/// usable-label check; a data set `twin::gap` refuses is stored as a failed check and counted.
#[test]
fn the_sample_makes_a_data_set_the_gap_diagnosis_takes_and_a_refused_one_is_stored_failed() {
    let dir = tempfile::tempdir().unwrap();
    let keep = dir.path().join("kept");
    let db = dir.path().join("s.db");
    let store = crate::store::Store::open(&db, None).unwrap();
    let mut e = Engine::new(Models::shipped().unwrap(), Some(store), Vec::new()).unwrap();
    let read_back = Arc::new(Mutex::new(Vec::new()));
    let seen = read_back.clone();
    let kept = keep.clone();
    let check: CheckFn = Box::new(move |j: &GapJob| {
        let folder = keep_data_set(&kept, j)?;
        let set = twin::measured::read_dataset(&folder, twin::signal::MIN_STEADY_SAMPLES)
            .map_err(|e| e.to_string())?;
        let (usable, unusable) =
            twin::gap::usable_labels_of(&j.model.file.surrogate, &j.model.cfg, &set)
                .map_err(|e| e.to_string())?;
        seen.lock()
            .unwrap()
            .push((j.sources.clone(), usable, unusable));
        // The same job with each recording cut to 20 readings: the diagnosis refuses it.
        let mut short = GapJob {
            drive: j.drive.clone(),
            model: j.model.clone(),
            set: j.set.clone(),
            sources: j.sources.clone(),
            trigger: j.trigger,
            at_s: j.at_s,
        };
        for r in &mut short.set.recordings {
            r.time_s.truncate(20);
            r.driver_rpm.truncate(20);
            r.driven_rpm.truncate(20);
        }
        real_check(&short)
    });
    let settings = every_two_segments();
    e.start_gap_checks_with(settings, check).unwrap();
    for b in replayed(3) {
        e.ingest(b).unwrap();
    }
    e.wait_gap_checks().unwrap();
    let got = read_back.lock().unwrap().clone();
    assert_eq!(got.len(), 1, "one check");
    let (sources, usable, unusable) = &got[0];
    let labels: Vec<&str> = sources.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(labels, ["seg1", "seg2"]);
    assert_eq!(usable, &["seg1", "seg2"], "unusable: {unusable:?}");
    // Each label's readings span what the segment held (a 3 s run, under the 10 s bound).
    assert!(sources.iter().all(|s| s.end_s - s.start_s > 1.0));
    let c = e.counters();
    assert_eq!((c.gap_checks, c.gap_checks_failed), (1, 1));
    let reader = crate::store::Store::open_reader(&db).unwrap();
    let rows = reader.gap_reports("d0", f64::MIN, f64::MAX).unwrap();
    assert_eq!(rows.len(), 1);
    let err = rows[0]["error"].as_str().unwrap();
    assert!(err.contains("usable labels"), "{err}");
    assert!(rows[0]["report"].is_null() && rows[0]["evidence"].is_null());
    // Shown on the drive, and kept across a restart (the drive's row was written with it).
    drop(e);
    let store = crate::store::Store::open(&db, None).unwrap();
    let e = Engine::new(Models::shipped().unwrap(), Some(store), Vec::new()).unwrap();
    let view = e.view();
    let v = view.read().unwrap();
    assert_eq!(v.drives["d0"].gap_report.as_ref().unwrap()["error"], err);
    assert_eq!(v.counters.gap_checks_failed, 1);
}
