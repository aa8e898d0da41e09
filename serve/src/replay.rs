//! `--replay DIR [--speed X] [--duration S]`: a data set in the exchange format
//! (`twin::measured`, docs/measured-data.md) sent to the engine as if live, one drive per
//! label, the labels' readings interleaved in time and paced by X (0: as fast as possible).
//! A label's runs follow one another in manifest order; with a duration they start over
//! until it is reached, each repeat after the last (the drive's clock runs on).

use std::collections::BTreeMap;
use std::sync::mpsc::{sync_channel, Receiver};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use twin::measured::DataSet;

use crate::Batch;

/// Readings per replayed batch (0.1 s at the example data's 500 Hz).
pub const BATCH_READINGS: usize = 50;
/// Batches the channel to the engine holds before the replay waits.
const CHANNEL_BATCHES: usize = 256;

/// How to replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayOptions {
    /// Replayed seconds per wall second; 0: as fast as the engine takes them.
    pub speed: f64,
    /// Replay each label for this long on its clock, repeating its runs. [default: once]
    pub duration_s: Option<f64>,
}

/// One label's readings in order, its runs repeated until the duration.
struct Cursor {
    label: String,
    runs: Vec<usize>,
    run: usize,
    i: usize,
    /// Added to the current run's times.
    offset_s: f64,
    end_s: f64,
    /// Readings at or before this time are skipped (already recorded).
    after_s: f64,
    done: bool,
}

impl Cursor {
    fn next(&mut self, set: &DataSet) -> Option<(f64, f64, f64)> {
        loop {
            if self.done {
                return None;
            }
            let rec = &set.recordings[self.runs[self.run]];
            if self.i >= rec.len() {
                // The next run starts one sample spacing after this one's end.
                let n = rec.len();
                let dt = if n > 1 {
                    rec.time_s[n - 1] - rec.time_s[n - 2]
                } else {
                    1e-3
                };
                self.run = (self.run + 1) % self.runs.len();
                let first = set.recordings[self.runs[self.run]].time_s[0];
                self.offset_s = rec.time_s[n - 1] + self.offset_s + dt - first;
                self.i = 0;
                if self.run == 0 && self.offset_s + first > self.end_s {
                    self.done = true;
                }
                continue;
            }
            let t = rec.time_s[self.i] + self.offset_s;
            let reading = (t, rec.driver_rpm[self.i], rec.driven_rpm[self.i]);
            self.i += 1;
            if t > self.end_s {
                self.done = true;
                return None;
            }
            if t > self.after_s {
                return Some(reading);
            }
        }
    }
}

/// The replay's batches, in time order across labels (at most one pending reading a label).
pub struct Stream {
    set: DataSet,
    cursors: Vec<Cursor>,
    pending: Vec<Option<(f64, f64, f64)>>,
}

impl Stream {
    /// The stream of `set`; a label in `recorded_until_s` resumes after that time.
    pub fn new(
        set: DataSet,
        opts: ReplayOptions,
        recorded_until_s: &BTreeMap<String, f64>,
    ) -> Self {
        let mut cursors: Vec<Cursor> = set
            .labels()
            .into_iter()
            .map(|label| {
                let runs = set.runs_of(&label);
                let t0 = set.recordings[runs[0]]
                    .time_s
                    .first()
                    .copied()
                    .unwrap_or(0.0);
                Cursor {
                    after_s: recorded_until_s
                        .get(&label)
                        .copied()
                        .unwrap_or(f64::NEG_INFINITY),
                    runs,
                    run: 0,
                    i: 0,
                    offset_s: 0.0,
                    end_s: opts.duration_s.map_or(f64::INFINITY, |d| t0 + d),
                    done: false,
                    label,
                }
            })
            .collect();
        // Without a duration, each label's runs are replayed once.
        if opts.duration_s.is_none() {
            for c in &mut cursors {
                let mut end = 0.0;
                let mut offset = 0.0;
                for (k, &r) in c.runs.iter().enumerate() {
                    let rec = &set.recordings[r];
                    let n = rec.len();
                    if k > 0 {
                        let prev = &set.recordings[c.runs[k - 1]];
                        let m = prev.len();
                        let dt = if m > 1 {
                            prev.time_s[m - 1] - prev.time_s[m - 2]
                        } else {
                            1e-3
                        };
                        offset = end + dt - rec.time_s[0];
                    }
                    end = rec.time_s[n - 1] + offset;
                }
                c.end_s = end;
            }
        }
        let pending = cursors.iter_mut().map(|c| c.next(&set)).collect();
        Stream {
            set,
            cursors,
            pending,
        }
    }

    /// The pulley diameters the data set's manifest gives, m.
    pub fn diameters_m(&self) -> (Option<f64>, Option<f64>) {
        let m = &self.set.manifest;
        (m.driver_pulley_diameter_m, m.driven_pulley_diameter_m)
    }

    pub fn labels(&self) -> Vec<String> {
        self.cursors.iter().map(|c| c.label.clone()).collect()
    }
}

impl Iterator for Stream {
    type Item = Batch;

    /// The next batch: up to `BATCH_READINGS` readings of the label whose next reading is the
    /// earliest.
    fn next(&mut self) -> Option<Batch> {
        let k = (0..self.cursors.len())
            .filter(|&k| self.pending[k].is_some())
            .min_by(|&a, &b| {
                let t = |k: usize| self.pending[k].map_or(f64::INFINITY, |p| p.0);
                t(a).total_cmp(&t(b))
            })?;
        let mut b = Batch {
            drive: self.cursors[k].label.clone(),
            seq: None,
            time_s: Vec::with_capacity(BATCH_READINGS),
            driver_rpm: Vec::with_capacity(BATCH_READINGS),
            driven_rpm: Vec::with_capacity(BATCH_READINGS),
            extra: BTreeMap::new(),
        };
        while b.time_s.len() < BATCH_READINGS {
            let Some((t, n1, n2)) = self.pending[k] else {
                break;
            };
            b.time_s.push(t);
            b.driver_rpm.push(n1);
            b.driven_rpm.push(n2);
            self.pending[k] = self.cursors[k].next(&self.set);
        }
        Some(b)
    }
}

/// Sends `stream` on a channel from a thread of its own, paced by `speed` (replayed seconds
/// per wall second; 0: no pacing). The channel closes at the end.
pub fn spawn(mut stream: Stream, speed: f64) -> (Receiver<Batch>, JoinHandle<()>) {
    let (tx, rx) = sync_channel(CHANNEL_BATCHES);
    let handle = std::thread::spawn(move || {
        let start = Instant::now();
        let mut origin_s: Option<f64> = None;
        for b in stream.by_ref() {
            let last = b.time_s[b.time_s.len() - 1];
            let origin = *origin_s.get_or_insert(b.time_s[0]);
            if speed > 0.0 {
                let due = Duration::from_secs_f64(((last - origin) / speed).max(0.0));
                if let Some(wait) = due.checked_sub(start.elapsed()) {
                    std::thread::sleep(wait);
                }
            }
            if tx.send(b).is_err() {
                return;
            }
        }
    });
    (rx, handle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use twin::measured::{Manifest, Recording, RunEntry};

    fn set() -> DataSet {
        let rec = |n: usize, rpm: f64| Recording {
            time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
            driver_rpm: vec![rpm; n],
            driven_rpm: vec![rpm / 2.0; n],
        };
        let run = |file: &str, label: &str| RunEntry {
            file: file.into(),
            label: label.into(),
            center_distance_m: None,
            metadata: BTreeMap::new(),
        };
        DataSet {
            dir: Default::default(),
            manifest: Manifest {
                runs: vec![run("a1", "a"), run("b1", "b"), run("a2", "a")],
                ..Manifest::default()
            },
            recordings: vec![rec(120, 1000.0), rec(70, 900.0), rec(30, 1100.0)],
        }
    }

    fn readings(s: Stream) -> BTreeMap<String, Vec<f64>> {
        let mut out: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut last = f64::NEG_INFINITY;
        for b in s {
            assert!(b.time_s[0] >= last - 0.5, "batches out of time order");
            last = b.time_s[0];
            out.entry(b.drive).or_default().extend(b.time_s);
        }
        out
    }

    #[test]
    fn labels_interleave_runs_follow_and_repeat_and_a_resume_skips_what_was_recorded() {
        let opts = ReplayOptions {
            speed: 0.0,
            duration_s: None,
        };
        let r = readings(Stream::new(set(), opts, &BTreeMap::new()));
        assert_eq!((r["a"].len(), r["b"].len()), (150, 70));
        assert!(r["a"].windows(2).all(|w| w[1] > w[0]));
        // The second run of `a` starts one spacing after the first's end.
        assert!((r["a"][120] - 1.20).abs() < 1e-9);
        let long = ReplayOptions {
            duration_s: Some(5.0),
            ..opts
        };
        let r = readings(Stream::new(set(), long, &BTreeMap::new()));
        assert!(r["a"].windows(2).all(|w| w[1] > w[0]));
        assert!(r["a"].last().unwrap() <= &5.0 && r["a"].last().unwrap() > &4.9);
        assert!(r["b"].len() > 490 && r["b"].len() <= 501);
        let resume = BTreeMap::from([("a".to_string(), 2.0)]);
        let r2 = readings(Stream::new(set(), long, &resume));
        assert!(r2["a"][0] > 2.0);
        assert_eq!(r2["a"][..], r["a"][r["a"].len() - r2["a"].len()..]);
        assert_eq!(r2["b"], r["b"]);
    }
}
