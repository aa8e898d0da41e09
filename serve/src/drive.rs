//! One drive's rolling buffer: readings checked as they come (duplicates, out-of-order
//! readings, gaps, clock jumps), running samples gathered into a segment, and the segment
//! closed when the drive stops, the data break off, or it reaches its bound.

use serde::Serialize;

/// Most samples one drive's open segment holds: 10 s at 1 kHz. With three f64 a sample the
/// buffer stays under 240 KB per drive whatever the run time (docs/guide/serve.md, "Memory").
pub const MAX_SEGMENT_SAMPLES: usize = 10_000;
/// Longest open segment, s: a drive running without stop is cut into segments this long.
pub const MAX_SEGMENT_S: f64 = 10.0;
/// A forward step in a drive's clock longer than this closes its open segment (data missing).
pub const GAP_S: f64 = 1.0;
/// A step in a drive's clock longer than this, either way, is a clock jump.
pub const CLOCK_JUMP_S: f64 = 60.0;

/// Why a segment was closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CloseReason {
    /// The driver stopped.
    Stopped,
    /// The segment reached `MAX_SEGMENT_S` or `MAX_SEGMENT_SAMPLES`.
    Full,
    /// Readings broke off (a gap, a clock jump, a silent drive, the end of a replay).
    Break,
}

/// A closed segment's readings.
#[derive(Debug, Clone)]
pub struct Closed {
    pub recording: twin::measured::Recording,
    pub reason: CloseReason,
}

/// What became of one reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    Accepted,
    /// Already recorded (at or before the end of the last closed segment) or already in the
    /// open segment.
    Duplicate,
    /// Older than the drive's latest reading, not a duplicate: dropped.
    OutOfOrder,
    /// Behind the drive's latest reading by more than `CLOCK_JUMP_S`: dropped.
    ClockJumpBack,
}

/// One drive's open segment and clock.
#[derive(Debug, Clone, Default)]
pub struct Buffer {
    t: Vec<f64>,
    n1: Vec<f64>,
    n2: Vec<f64>,
    /// Time of the latest accepted reading, s.
    pub last_s: Option<f64>,
    /// End of the last closed segment, s: readings at or before it are duplicates.
    pub recorded_until_s: Option<f64>,
    /// Forward clock jumps seen.
    pub clock_jumps_forward: u64,
    /// Gaps (forward steps over `GAP_S`, under `CLOCK_JUMP_S`).
    pub gaps: u64,
}

impl Buffer {
    /// A buffer that resumes after a segment recorded up to `recorded_until_s`.
    pub fn resumed(recorded_until_s: Option<f64>) -> Self {
        Buffer {
            last_s: recorded_until_s,
            recorded_until_s,
            ..Buffer::default()
        }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Takes one reading (time s, speeds rpm, already checked finite and non-negative); a
    /// segment it closes is pushed to `closed`.
    pub fn push(&mut self, t: f64, n1: f64, n2: f64, closed: &mut Vec<Closed>) -> Fate {
        if let Some(last) = self.last_s {
            if t <= last {
                return if t < last - CLOCK_JUMP_S {
                    Fate::ClockJumpBack
                } else if self.recorded_until_s.is_some_and(|r| t <= r)
                    || self.t.binary_search_by(|x| x.total_cmp(&t)).is_ok()
                {
                    Fate::Duplicate
                } else {
                    Fate::OutOfOrder
                };
            }
            if t - last > GAP_S {
                if t - last > CLOCK_JUMP_S {
                    self.clock_jumps_forward += 1;
                } else {
                    self.gaps += 1;
                }
                self.close(CloseReason::Break, closed);
            }
        }
        self.last_s = Some(t);
        if !fom::steady::turns(n1) {
            // Standstill carries no slip (docs/decisions/running-sample.md): a stop ends the
            // running segment.
            self.close(CloseReason::Stopped, closed);
            self.recorded_until_s = Some(t);
            return Fate::Accepted;
        }
        if self.t.len() >= MAX_SEGMENT_SAMPLES
            || self.t.first().is_some_and(|&t0| t - t0 >= MAX_SEGMENT_S)
        {
            self.close(CloseReason::Full, closed);
        }
        self.t.push(t);
        self.n1.push(n1);
        self.n2.push(n2);
        Fate::Accepted
    }

    /// Closes the open segment (if it holds readings) into `closed`.
    pub fn close(&mut self, reason: CloseReason, closed: &mut Vec<Closed>) {
        if self.t.is_empty() {
            return;
        }
        self.recorded_until_s = self.t.last().copied();
        closed.push(Closed {
            recording: twin::measured::Recording {
                time_s: std::mem::take(&mut self.t),
                driver_rpm: std::mem::take(&mut self.n1),
                driven_rpm: std::mem::take(&mut self.n2),
            },
            reason,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(b: &mut Buffer, t: &[f64], n1: f64) -> (Vec<Fate>, Vec<Closed>) {
        let mut closed = Vec::new();
        let fates = t
            .iter()
            .map(|&t| b.push(t, n1, n1 / 2.0, &mut closed))
            .collect();
        (fates, closed)
    }

    #[test]
    fn duplicates_out_of_order_and_jumps_are_told_apart() {
        let mut b = Buffer::default();
        let (f, c) = feed(&mut b, &[0.0, 0.1, 0.2, 0.1, 0.15, 0.2], 1000.0);
        use Fate::*;
        assert_eq!(
            f,
            vec![Accepted, Accepted, Accepted, Duplicate, OutOfOrder, Duplicate]
        );
        assert!(c.is_empty());
        // A gap closes the segment, a clock jump too (and is counted).
        let (_, c) = feed(&mut b, &[2.0], 1000.0);
        assert_eq!((c.len(), c[0].recording.len(), b.gaps), (1, 3, 1));
        let (f, c) = feed(&mut b, &[500.0, 400.0], 1000.0);
        assert_eq!(f, vec![Accepted, ClockJumpBack]);
        assert_eq!((c.len(), b.clock_jumps_forward), (1, 1));
        let (f, _) = feed(&mut b, &[499.5, 500.0], 1000.0);
        assert_eq!(f, vec![OutOfOrder, Duplicate]);
    }

    #[test]
    fn a_stop_or_the_bound_closes_the_segment() {
        let mut b = Buffer::default();
        let t: Vec<f64> = (0..(MAX_SEGMENT_SAMPLES + 5))
            .map(|i| i as f64 * 1e-4)
            .collect();
        let (_, c) = feed(&mut b, &t, 1000.0);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].recording.len(), MAX_SEGMENT_SAMPLES);
        assert_eq!(c[0].reason, CloseReason::Full);
        let (_, c) = feed(&mut b, &[1.5], 0.0);
        assert_eq!(
            (c[0].reason, c[0].recording.len()),
            (CloseReason::Stopped, 5)
        );
        assert!(b.is_empty());
        let resumed = Buffer::resumed(Some(1.5));
        assert_eq!(resumed.recorded_until_s, Some(1.5));
    }
}
