//! A drive's alarm state with hysteresis (docs/decisions/serve-alarm-hysteresis.md): each
//! diagnosed segment gives one piece of evidence (a [`State`]); the state worsens only when
//! `RAISE_AFTER` segments in a row point at a worse state, and eases only when `EASE_AFTER`
//! segments in a row point at a better one, so a single noisy segment never moves it.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};
use twin::diagnose::{LabelVerdict, CLASSES, MIN_EFFECTIVE_SAMPLES};

use crate::State;

/// Consecutive segments that must point at a worse state before the state worsens.
pub const RAISE_AFTER: usize = 2;
/// Consecutive segments that must point at a better state before the state eases.
pub const EASE_AFTER: usize = 3;
/// Probability of the looser classes a segment needs to count as evidence of them.
pub const EVIDENCE_PROBABILITY: f64 = 0.5;

/// What one segment's diagnosis says, or `None` when it gives no verdict (not steady, too
/// short: such a segment neither raises nor eases the state).
///
/// Misfit flags other than few effective samples (the twin cannot reach the measured slip at
/// all, or it is beyond every training run) point at an unexplained gap; otherwise the class
/// probabilities of `rom diagnose` decide: moderate or looser at `EVIDENCE_PROBABILITY` or
/// more is loose, weak or looser at that probability is watch, else healthy.
pub fn evidence(v: &LabelVerdict) -> Option<State> {
    let e = v.estimate.as_ref()?;
    let thin = usize::from(e.effective_samples < MIN_EFFECTIVE_SAMPLES);
    if v.misfit.len() > thin {
        return Some(State::UnexplainedGap);
    }
    let p = &e.class_probability;
    debug_assert_eq!(p.len(), CLASSES.len());
    let loose: f64 = p[2..].iter().sum();
    if loose >= EVIDENCE_PROBABILITY {
        Some(State::Loose)
    } else if loose + p[1] >= EVIDENCE_PROBABILITY {
        Some(State::Watch)
    } else {
        Some(State::Healthy)
    }
}

/// The alarm of one drive: its state and the last segments' evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alarm {
    pub state: State,
    /// The latest evidence, oldest first (at most `max(RAISE_AFTER, EASE_AFTER)`).
    pub recent: VecDeque<State>,
}

impl Default for Alarm {
    fn default() -> Self {
        Alarm {
            state: State::Healthy,
            recent: VecDeque::new(),
        }
    }
}

impl Alarm {
    /// Takes one segment's evidence; returns the new state when it changed.
    pub fn update(&mut self, e: State) -> Option<State> {
        self.recent.push_back(e);
        while self.recent.len() > RAISE_AFTER.max(EASE_AFTER) {
            self.recent.pop_front();
        }
        let last = |n: usize| self.recent.iter().rev().take(n);
        let next = if self.recent.len() >= RAISE_AFTER && last(RAISE_AFTER).all(|&s| s > self.state)
        {
            // The best of the last segments: every one of them is at least that bad.
            last(RAISE_AFTER).min().copied()
        } else if self.recent.len() >= EASE_AFTER && last(EASE_AFTER).all(|&s| s < self.state) {
            // The worst of the last segments: none of them is worse.
            last(EASE_AFTER).max().copied()
        } else {
            None
        }?;
        (next != self.state).then(|| {
            self.state = next;
            next
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use State::*;

    fn run(seq: &[State]) -> (Alarm, Vec<State>) {
        let mut a = Alarm::default();
        let changes = seq.iter().filter_map(|&e| a.update(e)).collect();
        (a, changes)
    }

    #[test]
    fn a_noisy_healthy_sequence_does_not_flap() {
        // Every other segment noisy (watch or loose), never two in a row.
        let seq: Vec<State> = (0..60)
            .map(|i| match i % 4 {
                1 => Loose,
                3 => Watch,
                _ => Healthy,
            })
            .collect();
        let (a, changes) = run(&seq);
        assert_eq!(a.state, Healthy);
        assert!(changes.is_empty(), "{changes:?}");
    }

    #[test]
    fn a_loose_sequence_reaches_loose_and_stays_through_one_good_segment() {
        let mut seq = vec![Healthy, Healthy, Loose, Loose, Loose, Healthy, Loose, Loose];
        let (a, changes) = run(&seq);
        assert_eq!(a.state, Loose);
        assert_eq!(changes, vec![Loose]);
        // Three good segments in a row ease it; the worst of them decides how far.
        seq.extend([Healthy, Watch, Healthy]);
        let (a, changes) = run(&seq);
        assert_eq!(a.state, Watch);
        assert_eq!(changes, vec![Loose, Watch]);
    }

    #[test]
    fn mixed_bad_evidence_raises_to_the_least_bad_of_it() {
        let (a, changes) = run(&[Watch, Loose]);
        assert_eq!((a.state, changes), (Watch, vec![Watch]));
        let (a, _) = run(&[UnexplainedGap, Loose, UnexplainedGap]);
        assert_eq!(a.state, Loose);
    }

    #[test]
    fn a_restored_alarm_continues_where_it_stood() {
        let (mut a, _) = run(&[Loose, Loose, Healthy, Healthy]);
        let json = serde_json::to_string(&a).unwrap();
        let mut b: Alarm = serde_json::from_str(&json).unwrap();
        assert_eq!(a.update(Healthy), Some(Healthy));
        assert_eq!(b.update(Healthy), Some(Healthy));
    }
}
