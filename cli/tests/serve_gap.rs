//! The background gap check of `rom serve` end to end: a replay with a configuration that
//! makes a check due early; the report comes on the API while readings keep being ingested,
//! it is in the database and on the endpoint the dashboard reads, and it is the report
//! `rom gap` gives on the recordings the check read. A full gap diagnosis: minutes of wall
//! time, so ignored (docs/testing.md, long tests); the serve crate's unit tests check the
//! queue, the sample and the refused-data-set path in a few seconds.

use std::time::{Duration, Instant};

use serde_json::Value;
use serve::store::Store;

use crate::support::{get, run_rom, serve_http, stdout, workspace};

/// The example loose data set's label `d0` alone (one drive: one check).
fn one_drive(dir: &std::path::Path) -> std::path::PathBuf {
    let src = workspace().join("examples/data/loose");
    let set = twin::measured::read_dataset(&src, twin::signal::MIN_STEADY_SAMPLES).unwrap();
    let out = dir.join("d0");
    std::fs::create_dir(&out).unwrap();
    let mut m = set.manifest.clone();
    m.runs.retain(|r| r.label == "d0");
    for r in &m.runs {
        std::fs::copy(src.join(&r.file), out.join(&r.file)).unwrap();
    }
    twin::measured::write_manifest(&out, &m).unwrap();
    out
}

fn json(addr: &str, path: &str) -> Value {
    serde_json::from_str(&get(addr, path)).unwrap()
}

#[test]
#[ignore = "a full gap diagnosis: minutes (docs/testing.md)"]
fn a_gap_check_runs_beside_ingestion_and_matches_rom_gap() {
    let started = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let data = one_drive(dir.path());
    let conf = dir.path().join("serve.toml");
    std::fs::write(
        &conf,
        "gap_every_segments = 4\ngap_misfit_segments = 0\ngap_threads = 2\n\
         gap_keep_dir = \"kept\"\n",
    )
    .unwrap();
    let db = dir.path().join("serve.db");
    let (server, _lines, addr) = serve_http([
        "--config".as_ref(),
        conf.as_os_str(),
        "--replay".as_ref(),
        data.as_os_str(),
        "--speed".as_ref(),
        "1".as_ref(),
        "--duration".as_ref(),
        "21".as_ref(),
        "--db".as_ref(),
        db.as_os_str(),
    ]);
    // The drive is known from its first batch on.
    while json(&addr, "/api/drives")["drives"]
        .as_array()
        .unwrap()
        .is_empty()
    {
        assert!(started.elapsed() < Duration::from_secs(60), "no drive");
        std::thread::sleep(Duration::from_millis(100));
    }
    // While the check runs, readings keep coming in.
    let readings = |c: &Value| c["counters"]["readings"].as_u64().unwrap();
    let (mut at_start, mut during) = (None, 0);
    let report = loop {
        assert!(
            started.elapsed() < Duration::from_secs(1800),
            "no gap report within 30 min"
        );
        let c = json(&addr, "/api/counters");
        if c["gap_check"]["running"] == "d0" {
            let n = readings(&c);
            at_start.get_or_insert(n);
            during = during.max(n);
        }
        let d = json(&addr, "/api/drives/d0");
        if !d["drive"]["gap_report"].is_null() {
            break d["drive"]["gap_report"].clone();
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    let at_start = at_start.expect("the check was seen running");
    assert!(
        during > at_start,
        "no reading ingested while the check ran ({at_start} at its start)"
    );
    assert!(report["error"].is_null(), "{report}");
    let verdict = report["verdict"].as_str().unwrap().to_string();
    let named = report["named"].clone();
    assert_eq!(report["report"]["top_effect"], verdict.as_str());
    // In the database and on the history endpoint.
    let rows = Store::open_reader(&db)
        .unwrap()
        .gap_reports("d0", f64::MIN, f64::MAX)
        .unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["verdict"], verdict.as_str());
    let h = json(&addr, "/api/drives/d0/gap_reports");
    assert_eq!(h["gap_reports"][0]["named"], named);
    drop(server);
    // `rom gap` on the recordings the check read gives the same verdict and named effects.
    let (a, b) = (&report["first_segment"], &report["last_segment"]);
    let kept = dir.path().join(format!("kept/d0-seg{a}-{b}"));
    let out = run_rom(&[
        "gap",
        "--measured",
        kept.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(out.status.success(), "{out:?}");
    let cli: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(cli["top_effect"], verdict.as_str());
    let cli_named: Vec<Value> = cli["named"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["effect"].clone())
        .collect();
    assert_eq!(Value::from(cli_named), named);
    eprintln!(
        "gap check end to end: {:.0} s (the check {:.0} s)",
        started.elapsed().as_secs_f64(),
        report["elapsed_s"].as_f64().unwrap()
    );
}
