//! A drive's gap sample: the readings of its latest diagnosed segments, grouped by their
//! centre-distance estimate (one group per belt setting the drive went through), from which a
//! gap check's data set is made; and the rule that says when a check is due
//! (docs/decisions/serve-gap-check.md).

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;

use serde::Serialize;
use twin::diagnose::LabelVerdict;
use twin::measured::{DataSet, Manifest, Recording, RunEntry};

use crate::State;

/// Most groups (belt settings) a sample keeps; a new one drops the oldest.
pub const MAX_GROUPS: usize = 4;
/// Segments kept per group: the latest two (two labels at one setting when only one group
/// exists).
pub const SEGMENTS_PER_GROUP: usize = 2;
/// Longest recording kept per segment, s (its last part).
pub const MAX_RECORDING_S: f64 = 10.0;

/// When checks are due (`serve.toml`'s `gap_*` keys; docs/guide/serve.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DueRule {
    /// A check after this many new segments in the sample; 0: never on this count.
    pub every_segments: u64,
    /// A check when this many of the latest `misfit_window` diagnosed segments carry misfit
    /// flags pointing at an unexplained gap; 0: never on misfits.
    pub misfit_segments: usize,
    pub misfit_window: usize,
}

impl Default for DueRule {
    fn default() -> Self {
        DueRule {
            every_segments: 50,
            misfit_segments: 3,
            misfit_window: 10,
        }
    }
}

/// Why a check became due.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Trigger {
    /// `every_segments` new segments gathered.
    Segments,
    /// `misfit_segments` of the latest `misfit_window` segments flagged.
    Misfit,
}

/// One kept segment.
#[derive(Debug, Clone)]
pub struct SampleSegment {
    /// The drive's 1-based segment index.
    pub index: u64,
    pub center_distance_m: f64,
    pub center_distance_90_m: [f64; 2],
    /// The segment's readings, at most its last `MAX_RECORDING_S`.
    pub recording: Recording,
}

/// Where one label of a check's data set comes from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LabelSource {
    pub label: String,
    /// The drive's segment index.
    pub segment: u64,
    /// Time span of the readings used, s on the drive's clock.
    pub start_s: f64,
    pub end_s: f64,
    /// The segment's centre-distance estimate (its group's setting), m.
    pub center_distance_m: f64,
}

/// A drive's gap sample and the state of its due rule.
#[derive(Debug, Clone, Default)]
pub struct GapSample {
    /// Oldest group first; each group's segments oldest first.
    groups: VecDeque<VecDeque<SampleSegment>>,
    /// Segments added since the last check was queued.
    pub new_segments: u64,
    /// Misfit flags of the latest diagnosed segments since the last check was queued, oldest
    /// first.
    flags: VecDeque<bool>,
}

/// The last `MAX_RECORDING_S` of `rec`.
fn tail(rec: &Recording) -> Recording {
    let end = rec.time_s.last().copied().unwrap_or(0.0);
    let from = rec.time_s.partition_point(|&t| t < end - MAX_RECORDING_S);
    Recording {
        time_s: rec.time_s[from..].to_vec(),
        driver_rpm: rec.driver_rpm[from..].to_vec(),
        driven_rpm: rec.driven_rpm[from..].to_vec(),
    }
}

impl GapSample {
    /// Takes a diagnosed segment (`evidence` as the alarm read it). Segments without an
    /// estimate are not kept (there is no setting to group them by).
    pub fn add(
        &mut self,
        index: u64,
        verdict: &LabelVerdict,
        evidence: Option<State>,
        rec: &Recording,
        rule: &DueRule,
    ) {
        let Some(e) = &verdict.estimate else {
            return;
        };
        self.flags
            .push_back(evidence == Some(State::UnexplainedGap));
        while self.flags.len() > rule.misfit_window.max(1) {
            self.flags.pop_front();
        }
        let seg = SampleSegment {
            index,
            center_distance_m: e.center_distance_m,
            center_distance_90_m: e.center_distance_90_m,
            recording: tail(rec),
        };
        // The group whose latest segment's 90 % interval holds the estimate (the nearest of
        // several); none: a new setting.
        let d = seg.center_distance_m;
        let home = self
            .groups
            .iter()
            .enumerate()
            .filter_map(|(i, g)| {
                let last = g.back()?;
                let [lo, hi] = last.center_distance_90_m;
                (lo <= d && d <= hi).then_some((i, (last.center_distance_m - d).abs()))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        let g = match home {
            Some(i) => &mut self.groups[i],
            None => {
                if self.groups.len() == MAX_GROUPS {
                    self.groups.pop_front();
                }
                self.groups.push_back(VecDeque::new());
                self.groups.back_mut().expect("pushed")
            }
        };
        g.push_back(seg);
        if g.len() > SEGMENTS_PER_GROUP {
            g.pop_front();
        }
        self.new_segments += 1;
    }

    /// Groups kept (belt settings told apart).
    pub fn groups(&self) -> usize {
        self.groups.len()
    }

    /// Segments kept in all.
    pub fn segments(&self) -> usize {
        self.groups.iter().map(VecDeque::len).sum()
    }

    /// The segments a check reads: the latest of each group when there are two groups or
    /// more, else the two latest of the only group; none when that gives fewer than two.
    pub fn labels(&self) -> Vec<&SampleSegment> {
        let segs: Vec<&SampleSegment> = if self.groups.len() >= 2 {
            self.groups.iter().filter_map(|g| g.back()).collect()
        } else {
            self.groups.iter().flatten().collect()
        };
        if segs.len() >= 2 {
            segs
        } else {
            Vec::new()
        }
    }

    /// Whether a check is due, and why.
    pub fn due(&self, rule: &DueRule) -> Option<Trigger> {
        if self.labels().is_empty() {
            return None;
        }
        let flagged = self.flags.iter().filter(|&&f| f).count();
        if rule.every_segments > 0 && self.new_segments >= rule.every_segments {
            Some(Trigger::Segments)
        } else if rule.misfit_segments > 0 && flagged >= rule.misfit_segments {
            Some(Trigger::Misfit)
        } else {
            None
        }
    }

    /// A check was queued: the counts start again.
    pub fn queued(&mut self) {
        self.new_segments = 0;
        self.flags.clear();
    }

    /// The check's data set: one label per segment of [`GapSample::labels`] (named
    /// `seg<index>`), centre distance unknown (the calibration fits it), the drive's pulley
    /// diameters where the source gave them; and where each label comes from.
    pub fn data_set(&self, diameters_m: (Option<f64>, Option<f64>)) -> (DataSet, Vec<LabelSource>) {
        let segs = self.labels();
        let label = |s: &SampleSegment| format!("seg{}", s.index);
        let runs = segs
            .iter()
            .map(|s| RunEntry {
                file: format!("{}.csv", label(s)),
                label: label(s),
                center_distance_m: None,
                metadata: BTreeMap::new(),
            })
            .collect();
        let sources = segs
            .iter()
            .map(|s| LabelSource {
                label: label(s),
                segment: s.index,
                start_s: s.recording.time_s.first().copied().unwrap_or(0.0),
                end_s: s.recording.time_s.last().copied().unwrap_or(0.0),
                center_distance_m: s.center_distance_m,
            })
            .collect();
        let set = DataSet {
            dir: PathBuf::new(),
            manifest: Manifest {
                description: Some("gap sample of rom serve".into()),
                driver_pulley_diameter_m: diameters_m.0,
                driven_pulley_diameter_m: diameters_m.1,
                runs,
            },
            recordings: segs.iter().map(|s| s.recording.clone()).collect(),
        };
        (set, sources)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use twin::diagnose::Estimate;

    /// A verdict with an estimate at `d` (90 % interval +-`half`).
    pub fn verdict(d: f64, half: f64) -> LabelVerdict {
        LabelVerdict {
            label: "a".into(),
            runs: 1,
            known_center_distance_m: None,
            measured: None,
            estimate: Some(Estimate {
                center_distance_m: d,
                center_distance_90_m: [d - half, d + half],
                installation_tension_n: 200.0,
                installation_tension_90_n: [190.0, 210.0],
                class_probability: [1.0, 0.0, 0.0, 0.0, 0.0],
                class: "healthy".into(),
                twin_quantiles_pct: [0.5; 5],
                twin_mean_slip_pct: 0.5,
                effective_samples: 100.0,
                closest_sd: 0.1,
            }),
            cannot_diagnose: None,
            misfit: Vec::new(),
        }
    }

    /// `secs` of readings at 500 Hz ending at `end_s`.
    pub fn recording(end_s: f64, secs: f64) -> Recording {
        let n = (secs * 500.0) as usize;
        let t: Vec<f64> = (0..n).map(|i| end_s - (n - 1 - i) as f64 * 0.002).collect();
        Recording {
            driver_rpm: vec![1500.0; n],
            driven_rpm: vec![740.0; n],
            time_s: t,
        }
    }

    fn add(s: &mut GapSample, index: u64, d: f64) {
        let rule = DueRule::default();
        let rec = recording(index as f64 * 20.0, 12.0);
        s.add(index, &verdict(d, 0.001), None, &rec, &rule);
    }

    #[test]
    fn segments_group_by_setting_and_the_sample_stays_bounded() {
        let mut s = GapSample::default();
        add(&mut s, 1, 0.420);
        assert!(s.labels().is_empty(), "one segment is not two labels");
        add(&mut s, 2, 0.4205);
        assert_eq!((s.groups(), s.segments()), (1, 2));
        // One group: its two latest segments are the labels.
        let idx = |s: &GapSample| s.labels().iter().map(|x| x.index).collect::<Vec<_>>();
        assert_eq!(idx(&s), [1, 2]);
        add(&mut s, 3, 0.4202);
        assert_eq!((s.groups(), s.segments(), idx(&s)), (1, 2, vec![2, 3]));
        // Outside every group's interval: new groups, up to four.
        for (i, d) in [(4, 0.425), (5, 0.430), (6, 0.435)] {
            add(&mut s, i, d);
        }
        assert_eq!((s.groups(), idx(&s)), (4, vec![3, 4, 5, 6]));
        // A fifth setting drops the oldest group.
        add(&mut s, 7, 0.440);
        assert_eq!((s.groups(), idx(&s)), (4, vec![4, 5, 6, 7]));
        // Back at a kept setting: it joins that group (the nearest whose interval holds it).
        add(&mut s, 8, 0.4301);
        assert_eq!(
            (s.groups(), s.segments(), idx(&s)),
            (4, 5, vec![4, 8, 6, 7])
        );
        for i in 9..60 {
            add(&mut s, i, 0.400 + 0.005 * (i % 9) as f64);
        }
        assert!(s.groups() <= MAX_GROUPS);
        assert!(s.segments() <= MAX_GROUPS * SEGMENTS_PER_GROUP);
        // Each kept recording is its last 10 s (12 s were given).
        let kept = &s.labels()[0].recording;
        let span = kept.time_s.last().unwrap() - kept.time_s[0];
        assert!(
            span <= MAX_RECORDING_S && span > MAX_RECORDING_S - 0.01,
            "{span}"
        );
    }

    #[test]
    fn a_segment_without_an_estimate_is_not_kept() {
        let mut s = GapSample::default();
        let mut v = verdict(0.42, 0.001);
        v.estimate = None;
        s.add(1, &v, None, &recording(5.0, 3.0), &DueRule::default());
        assert_eq!((s.segments(), s.new_segments), (0, 0));
    }

    #[test]
    fn a_check_is_due_after_the_segment_count_or_the_misfit_flags() {
        let rule = DueRule {
            every_segments: 5,
            misfit_segments: 2,
            misfit_window: 4,
        };
        let mut s = GapSample::default();
        let push = |s: &mut GapSample, i: u64, flag: bool| {
            let ev = Some(if flag {
                State::UnexplainedGap
            } else {
                State::Healthy
            });
            s.add(
                i,
                &verdict(0.42, 0.001),
                ev,
                &recording(i as f64 * 5.0, 3.0),
                &rule,
            );
        };
        for i in 1..5 {
            push(&mut s, i, false);
            assert_eq!(s.due(&rule), None, "segment {i}");
        }
        push(&mut s, 5, false);
        assert_eq!(s.due(&rule), Some(Trigger::Segments));
        s.queued();
        assert_eq!(s.due(&rule), None);
        // Two flagged among the latest four: due on misfits.
        push(&mut s, 6, true);
        push(&mut s, 7, false);
        assert_eq!(s.due(&rule), None);
        push(&mut s, 8, true);
        assert_eq!(s.due(&rule), Some(Trigger::Misfit));
        s.queued();
        // Flags spread wider than the window do not add up.
        for (i, f) in [(9, true), (10, false), (11, false), (12, false), (13, true)] {
            push(&mut s, i, f);
        }
        assert_eq!(s.due(&rule), Some(Trigger::Segments), "five new segments");
        s.queued();
        for (i, f) in [(14, true), (15, false), (16, false), (17, false)] {
            push(&mut s, i, f);
        }
        push(&mut s, 18, true);
        // 14's flag left the window of four: only one flagged.
        assert_eq!(s.due(&rule), Some(Trigger::Segments));
        // Zero disables a rule.
        let off = DueRule {
            every_segments: 0,
            misfit_segments: 0,
            misfit_window: 4,
        };
        assert_eq!(s.due(&off), None);
        // Never due without two labels.
        assert_eq!(GapSample::default().due(&rule), None);
    }
}
