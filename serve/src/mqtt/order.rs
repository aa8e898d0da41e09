//! Each drive's batches in `seq` order at the source boundary: a `seq` already handed on is a
//! duplicate (dropped); a batch that comes after a later one is put back in order if it comes
//! within the reorder window, else the missing numbers are given up on (a gap) and a late one
//! is handed on out of order, counted. Batches without `seq` pass as they come.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::{Duration, Instant};

use super::{bump, SourceStats};

/// How far below the next expected `seq` a number is still taken for a duplicate; further back
/// it means the gateway restarted its counter.
const RESET_SPAN: u64 = 1024;

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
    /// Numbers given up on that may still come (within `RESET_SPAN` below `next`).
    skipped: BTreeSet<u64>,
}

/// Per-drive ordering state; memory per drive is bounded by `max_held` items and `RESET_SPAN`
/// skipped numbers.
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
        let Some(d) = self.drives.get_mut(drive) else {
            self.drives.insert(
                drive.to_string(),
                DriveSeq {
                    next: seq.saturating_add(1),
                    held: BTreeMap::new(),
                    since: None,
                    skipped: BTreeSet::new(),
                },
            );
            out.push(Step::Deliver(item));
            return;
        };
        if seq == d.next {
            if !d.held.is_empty() {
                bump(&stats.out_of_order, 1);
            }
            out.push(Step::Deliver(item));
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
        } else if d.skipped.remove(&seq) {
            bump(&stats.out_of_order, 1);
            bump(&stats.late, 1);
            out.push(Step::Deliver(item));
        } else if d.next - seq <= RESET_SPAN {
            bump(&stats.duplicates, 1);
            out.push(Step::Duplicate(item));
        } else {
            bump(&stats.seq_resets, 1);
            out.extend(std::mem::take(&mut d.held).into_values().map(Step::Deliver));
            out.push(Step::Deliver(item));
            d.next = seq.saturating_add(1);
            d.since = None;
            d.skipped.clear();
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
            self.next = self.next.saturating_add(1);
        }
        self.since = (!self.held.is_empty()).then_some(now);
    }

    /// Skips the missing numbers before the first held item, then drains.
    fn skip_gap(&mut self, now: Instant, stats: &SourceStats, out: &mut Vec<Step<T>>) {
        let Some(&first) = self.held.keys().next() else {
            self.since = None;
            return;
        };
        bump(&stats.gaps, first - self.next);
        if first - self.next <= RESET_SPAN {
            self.skipped.extend(self.next..first);
        }
        self.next = first;
        self.drain(now, out);
        let floor = self.next.saturating_sub(RESET_SPAN);
        self.skipped = self.skipped.split_off(&floor);
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
        for (i, &q) in seqs.iter().enumerate() {
            let now = t0 + Duration::from_millis(10 * i as u64);
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
    fn a_counter_restart_is_taken_as_a_reset_not_duplicates() {
        let (out, c) = run(&[5000, 5001, 0, 1], 100);
        assert_eq!(out, ["5000", "5001", "0", "1"]);
        assert_eq!((c.seq_resets, c.duplicates), (1, 0));
    }
}
