//! Bad data through the engine: malformed batches, duplicates, out-of-order readings, gaps,
//! clock jumps. Each is counted, per drive and for the fleet; none stops the engine, and no
//! segment mixes readings from both sides of a break.

use std::collections::BTreeMap;

use serve::config::Models;
use serve::{Batch, Engine};

fn batch(drive: &str, t: &[f64]) -> Batch {
    Batch {
        drive: drive.into(),
        seq: None,
        time_s: t.to_vec(),
        driver_rpm: vec![1500.0; t.len()],
        driven_rpm: vec![740.0; t.len()],
        extra: BTreeMap::new(),
    }
}

fn times(from: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| from + i as f64 * 0.002).collect()
}

#[test]
fn bad_data_is_counted_and_never_fatal() {
    let mut e = Engine::new(Models::shipped().unwrap(), None, Vec::new()).unwrap();
    e.ingest(batch("a", &times(0.0, 20))).unwrap();
    // The same batch again: every reading a duplicate.
    e.ingest(batch("a", &times(0.0, 20))).unwrap();
    // Readings between ones already taken, older than the latest: out of order.
    e.ingest(batch("a", &[0.001, 0.003])).unwrap();
    // Malformed: unequal columns, a NaN speed, a negative speed, no drive id.
    let mut b = batch("a", &times(1.0, 5));
    b.driven_rpm.pop();
    e.ingest(b).unwrap();
    let mut b = batch("a", &times(1.0, 5));
    b.driver_rpm[2] = f64::NAN;
    e.ingest(b).unwrap();
    let mut b = batch("a", &times(1.0, 5));
    b.driven_rpm[0] = -3.0;
    e.ingest(b).unwrap();
    e.ingest(batch("", &times(1.0, 5))).unwrap();
    e.malformed(Some("a"));
    // A gap of 2 s, then a clock jump of an hour forward, then one back behind it.
    e.ingest(batch("a", &times(2.0, 20))).unwrap();
    e.ingest(batch("a", &times(3602.0, 20))).unwrap();
    e.ingest(batch("a", &times(100.0, 20))).unwrap();
    e.flush().unwrap();

    let c = e.counters().clone();
    assert_eq!(c.readings, 60);
    assert_eq!(c.duplicate_readings, 20);
    assert_eq!(c.out_of_order_readings, 2);
    assert_eq!(c.malformed_batches, 5);
    assert_eq!(c.gaps, 1);
    assert_eq!(c.clock_jumps, 2);
    // Three segments of 20 readings each (before the gap, between, after the jump): each too
    // short to diagnose, none merged across a break.
    assert_eq!((c.short_segments, c.segments), (3, 0));
    let view = e.view();
    let v = view.read().unwrap();
    let a = &v.drives["a"].counters;
    assert_eq!((a.readings, a.malformed_batches, a.clock_jumps), (60, 4, 2));
    let why = v.drives["a"].last_malformed.as_deref().unwrap();
    assert!(why.contains("negative"), "{why}");
    assert_eq!(v.drives["a"].last_reading_s, Some(3602.0 + 19.0 * 0.002));
}
