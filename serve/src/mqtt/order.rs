//! Each drive's batches in `seq` order at the source boundary: a `seq` already handed on is a
//! duplicate (dropped); a batch that comes after a later one is put back in order if it comes
//! within the reorder window, else the missing numbers are given up on (a gap) and a late one
//! is handed on out of order, counted. Batches without `seq` pass as they come.

use std::collections::{BTreeMap, HashMap};
use std::time::{Duration, Instant};

use super::{bump, SourceStats};

/// How far below the next expected `seq` a number is remembered (handed on or not); further
/// back it means the gateway restarted its counter.
const RESET_SPAN: u64 = 1024;

/// Which of the `RESET_SPAN` numbers below `next` were handed on: one bit per number, at
/// `seq % RESET_SPAN` (128 bytes per drive).
#[derive(Debug, Default)]
struct Handed([u64; (RESET_SPAN / 64) as usize]);

impl Handed {
    fn get(&self, seq: u64) -> bool {
        let i = seq % RESET_SPAN;
        self.0[(i / 64) as usize] >> (i % 64) & 1 == 1
    }
    fn set(&mut self, seq: u64, on: bool) {
        let i = seq % RESET_SPAN;
        let (w, b) = ((i / 64) as usize, i % 64);
        self.0[w] = (self.0[w] & !(1 << b)) | (u64::from(on) << b);
    }
    /// Marks `from..to` as not handed on (numbers given up on).
    fn clear(&mut self, from: u64, to: u64) {
        if to - from >= RESET_SPAN {
            self.0 = Default::default();
        } else {
            (from..to).for_each(|s| self.set(s, false));
        }
    }
}

/// What to do with an item offered to the [`Sequencer`].
#[derive(Debug, PartialEq)]
pub(crate) enum Step<T> {
    /// Hand it on (in this order).
    Deliver(T),
    /// Already handed on: drop it (but acknowledge it).
    Duplicate(T),
}

#[derive(Debug)]
struct DriveSeq<T> {
    /// The next `seq` expected.
    next: u64,
    /// Items with `seq > next` waiting for the missing ones.
    held: BTreeMap<u64, T>,
    /// When the current wait began.
    since: Option<Instant>,
    /// Which recent numbers below `next` were handed on (the others may still come, late).
    handed: Handed,
    /// False while the drive's first batches are held for one window, so a stream joined
    /// mid-way (a restart, a drive passed from another instance) starts at its lowest `seq`.
    started: bool,
}

/// Per-drive ordering state; memory per drive is bounded by `max_held` items and a bitmap of
/// `RESET_SPAN` bits.
#[derive(Debug)]
pub(crate) struct Sequencer<T> {
    drives: HashMap<String, DriveSeq<T>>,
    window: Duration,
    max_held: usize,
}

impl<T> Sequencer<T> {
    pub(crate) fn new(window: Duration, max_held: usize) -> Self {
        Sequencer {
            drives: HashMap::new(),
            window,
            max_held: max_held.max(1),
        }
    }

    /// Offers `item` (of `drive`, numbered `seq`); appends what is ready to `out`.
    pub(crate) fn offer(
        &mut self,
        drive: &str,
        seq: Option<u64>,
        item: T,
        now: Instant,
        stats: &SourceStats,
        out: &mut Vec<Step<T>>,
    ) {
        let Some(seq) = seq else {
            out.push(Step::Deliver(item));
            return;
        };
        if !self.drives.contains_key(drive) {
            let fresh = DriveSeq {
                next: seq,
                held: BTreeMap::new(),
                since: None,
                handed: Handed::default(),
                started: false,
            };
            self.drives.insert(drive.to_string(), fresh);
        }
        let Some(d) = self.drives.get_mut(drive) else {
            return;
        };
        if !d.started {
            if d.held.contains_key(&seq) {
                bump(&stats.duplicates, 1);
                out.push(Step::Duplicate(item));
                return;
            }
            if d.held.keys().next_back().is_some_and(|&last| seq < last) {
                bump(&stats.out_of_order, 1);
            }
            d.held.insert(seq, item);
            d.since.get_or_insert(now);
            if d.held.len() > self.max_held {
                d.skip_gap(now, stats, out);
            }
            return;
        }
        if seq == d.next {
            if !d.held.is_empty() {
                bump(&stats.out_of_order, 1);
            }
            out.push(Step::Deliver(item));
            d.handed.set(seq, true);
            d.next = seq.saturating_add(1);
            d.drain(now, out);
        } else if seq > d.next {
            if d.held.contains_key(&seq) {
                bump(&stats.duplicates, 1);
                out.push(Step::Duplicate(item));
                return;
            }
            d.held.insert(seq, item);
            d.since.get_or_insert(now);
            if d.held.len() > self.max_held {
                d.skip_gap(now, stats, out);
            }
        } else if d.next - seq > RESET_SPAN {
            bump(&stats.seq_resets, 1);
            out.extend(std::mem::take(&mut d.held).into_values().map(Step::Deliver));
            out.push(Step::Deliver(item));
            d.next = seq.saturating_add(1);
            d.since = None;
            d.handed = Handed::default();
            d.handed.set(seq, true);
        } else if d.handed.get(seq) {
            bump(&stats.duplicates, 1);
            out.push(Step::Duplicate(item));
        } else {
            bump(&stats.out_of_order, 1);
            bump(&stats.late, 1);
            d.handed.set(seq, true);
            out.push(Step::Deliver(item));
        }
    }

    /// Gives up on gaps older than the window; appends what becomes ready to `out`.
    pub(crate) fn expire(&mut self, now: Instant, stats: &SourceStats, out: &mut Vec<Step<T>>) {
        for d in self.drives.values_mut() {
            if d.since
                .is_some_and(|t| now.duration_since(t) >= self.window)
            {
                d.skip_gap(now, stats, out);
            }
        }
    }

    /// Whether any drive holds items (the caller then polls [`Sequencer::expire`] often).
    pub(crate) fn holding(&self) -> bool {
        self.drives.values().any(|d| !d.held.is_empty())
    }
}

impl<T> DriveSeq<T> {
    /// Hands on the held items that follow `next` without a gap.
    fn drain(&mut self, now: Instant, out: &mut Vec<Step<T>>) {
        while let Some(item) = self.held.remove(&self.next) {
            out.push(Step::Deliver(item));
            self.handed.set(self.next, true);
            self.next = self.next.saturating_add(1);
        }
        self.since = (!self.held.is_empty()).then_some(now);
    }

    /// Skips the missing numbers before the first held item (or, for a drive not started,
    /// starts at it), then drains.
    fn skip_gap(&mut self, now: Instant, stats: &SourceStats, out: &mut Vec<Step<T>>) {
        let Some(&first) = self.held.keys().next() else {
            self.since = None;
            return;
        };
        if !self.started {
            self.started = true;
            self.next = first;
            self.drain(now, out);
            return;
        }
        bump(&stats.gaps, first - self.next);
        self.handed.clear(self.next, first);
        self.next = first;
        self.drain(now, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(seqs: &[u64], window_ms: u64) -> (Vec<String>, crate::mqtt::SourceCounts) {
        let stats = SourceStats::default();
        let mut s = Sequencer::new(Duration::from_millis(window_ms), 8);
        let t0 = Instant::now();
        let mut out = Vec::new();
        // The first batch alone starts the drive (held one window); the others follow.
        for (i, &q) in seqs.iter().enumerate() {
            let after = if i == 0 { 0 } else { window_ms + 10 * i as u64 };
            let now = t0 + Duration::from_millis(after);
            s.expire(now, &stats, &mut out);
            s.offer("d", Some(q), q, now, &stats, &mut out);
        }
        s.expire(t0 + Duration::from_secs(60), &stats, &mut out);
        let shown = out
            .into_iter()
            .map(|st| match st {
                Step::Deliver(q) => q.to_string(),
                Step::Duplicate(q) => format!("dup{q}"),
            })
            .collect();
        (shown, stats.snapshot())
    }

    #[test]
    fn in_order_passes_and_duplicates_drop() {
        let (out, c) = run(&[5, 6, 6, 7, 5], 100);
        assert_eq!(out, ["5", "6", "dup6", "7", "dup5"]);
        assert_eq!((c.duplicates, c.out_of_order, c.gaps), (2, 0, 0));
    }

    #[test]
    fn a_swap_within_the_window_is_put_back_in_order() {
        let (out, c) = run(&[1, 3, 4, 2, 5], 100);
        assert_eq!(out, ["1", "2", "3", "4", "5"]);
        assert_eq!((c.out_of_order, c.late, c.gaps, c.duplicates), (1, 0, 0, 0));
    }

    #[test]
    fn a_gap_past_the_window_is_skipped_and_a_late_batch_still_handed_on() {
        // 10 ms between offers, a 25 ms window: 2 is given up on when 6 comes.
        let (out, c) = run(&[1, 3, 4, 5, 6, 2, 2], 25);
        assert_eq!(out, ["1", "3", "4", "5", "6", "2", "dup2"]);
        assert_eq!((c.gaps, c.out_of_order, c.late, c.duplicates), (1, 1, 1, 1));
    }

    #[test]
    fn holding_more_than_the_cap_skips_the_gap() {
        let seqs: Vec<u64> = std::iter::once(0).chain(2..12).collect();
        let (out, c) = run(&seqs, 10_000);
        let expect: Vec<String> = seqs.iter().map(|q| q.to_string()).collect();
        assert_eq!(out, expect);
        assert_eq!(c.gaps, 1);
    }

    #[test]
    fn a_drive_joined_mid_stream_starts_at_its_lowest_seq_within_the_window() {
        let stats = SourceStats::default();
        let mut s = Sequencer::new(Duration::from_millis(100), 8);
        let t0 = Instant::now();
        let mut out = Vec::new();
        for (i, q) in [7, 5, 8, 5, 6].into_iter().enumerate() {
            s.offer(
                "d",
                Some(q),
                q,
                t0 + Duration::from_millis(10 * i as u64),
                &stats,
                &mut out,
            );
        }
        assert!(
            out.iter().all(|st| matches!(st, Step::Duplicate(5))),
            "{out:?}"
        );
        s.expire(t0 + Duration::from_millis(99), &stats, &mut out);
        assert_eq!(out.len(), 1, "nothing before the window ends");
        s.expire(t0 + Duration::from_millis(100), &stats, &mut out);
        assert_eq!(out[1..], [5, 6, 7, 8].map(Step::Deliver));
        s.offer(
            "d",
            Some(4),
            4,
            t0 + Duration::from_millis(200),
            &stats,
            &mut out,
        );
        assert_eq!(
            out.last(),
            Some(&Step::Deliver(4)),
            "earlier than the start: late"
        );
        let c = stats.snapshot();
        assert_eq!((c.out_of_order, c.late, c.duplicates, c.gaps), (3, 1, 1, 0));
    }

    #[test]
    fn a_counter_restart_is_taken_as_a_reset_not_duplicates() {
        let (out, c) = run(&[5000, 5001, 0, 1], 100);
        assert_eq!(out, ["5000", "5001", "0", "1"]);
        assert_eq!((c.seq_resets, c.duplicates), (1, 0));
    }
}
