//! The background gap check (docs/decisions/serve-gap-check.md): per drive a bounded gap
//! sample of its latest segments (`sample`), a check queued when it is due, run one at a time
//! on a worker of its own (`worker`), and its report stored, shown, published and fed to the
//! alarm (here). Ingestion never waits on a check: the engine pushes jobs and collects
//! outcomes with `try_recv`.

pub mod sample;
pub mod worker;

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Serialize;

use crate::engine::Engine;
use crate::store::{StoreError, StoredDrive};
use crate::{Event, State};
pub use sample::{DueRule, GapSample, LabelSource, Trigger};
pub use worker::{real_check, CheckFn, GapJob, GapOutcome, Worker};

/// How the server runs gap checks (`serve.toml`'s `gap_*` keys).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GapSettings {
    pub rule: DueRule,
    /// Threads of the checks' own rayon pool.
    pub threads: usize,
    /// Folder where each check's data set is kept (exchange format), to rerun `rom gap` on.
    pub keep_dir: Option<PathBuf>,
}

impl Default for GapSettings {
    fn default() -> Self {
        GapSettings {
            rule: DueRule::default(),
            threads: 1,
            keep_dir: None,
        }
    }
}

/// A stored gap check: what it read, what it said (or why it failed) and what the alarm took
/// from it. The drive's `gap_report` on the API, one row of `gap_reports`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapRecord {
    pub drive: String,
    /// Wall-clock time the check was stored, s since 1970.
    pub wall_unix_s: f64,
    /// The first and last segment index read.
    pub first_segment: u64,
    pub last_segment: u64,
    /// End of the latest segment read, s on the drive's clock.
    pub at_s: f64,
    pub trigger: Trigger,
    /// The report's `top_effect`: a catalogue effect, `none` or `unexplained`; null when the
    /// check failed.
    pub verdict: Option<String>,
    /// Every effect the report names.
    pub named: Vec<String>,
    /// What the alarm took from it (`gap_evidence`).
    pub evidence: Option<State>,
    pub error: Option<String>,
    pub elapsed_s: f64,
    /// Where each label of the check's data set comes from.
    pub labels: Vec<LabelSource>,
    /// The report as `rom gap --format json` writes it.
    pub report: Option<serde_json::Value>,
}

/// What a gap report tells the alarm: an unexplained gap is evidence of `unexplained_gap`; a
/// named effect (the twin lacks a known effect, the belt is not the suspect) is `watch`; `none`
/// and a failed check are no evidence.
pub fn gap_evidence(verdict: Option<&str>, named: &[String]) -> Option<State> {
    match verdict? {
        "unexplained" => Some(State::UnexplainedGap),
        "none" if named.is_empty() => None,
        _ => Some(State::Watch),
    }
}

/// The check's data set written to a new folder under `dir` (named by drive and segments), so
/// that `rom gap` can be run on exactly what the check read.
pub fn keep_data_set(dir: &Path, job: &GapJob) -> Result<PathBuf, String> {
    let (a, b) = segment_range(&job.sources);
    let folder = dir.join(format!("{}-seg{a}-{b}", job.drive));
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", folder.display());
    std::fs::create_dir_all(&folder).map_err(|e| err(&e))?;
    for (run, rec) in job.set.manifest.runs.iter().zip(&job.set.recordings) {
        twin::measured::write_recording(&folder.join(&run.file), rec, "gap sample of rom serve")
            .map_err(|e| err(&e))?;
    }
    twin::measured::write_manifest(&folder, &job.set.manifest).map_err(|e| err(&e))?;
    Ok(folder)
}

fn segment_range(sources: &[LabelSource]) -> (u64, u64) {
    let idx = sources.iter().map(|s| s.segment);
    (idx.clone().min().unwrap_or(0), idx.max().unwrap_or(0))
}

/// The record of an outcome.
fn record_of(o: GapOutcome, wall_unix_s: f64) -> GapRecord {
    let (first_segment, last_segment) = segment_range(&o.sources);
    let (report, error) = match o.result {
        Ok(r) => (Some(r), None),
        Err(e) => (None, Some(e)),
    };
    let verdict = report
        .as_ref()
        .and_then(|r| r["top_effect"].as_str())
        .map(str::to_string);
    let named: Vec<String> = report
        .as_ref()
        .and_then(|r| r["named"].as_array())
        .map(|a| {
            a.iter()
                .filter_map(|n| n["effect"].as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    GapRecord {
        drive: o.drive,
        wall_unix_s,
        first_segment,
        last_segment,
        at_s: o.at_s,
        trigger: o.trigger,
        evidence: gap_evidence(verdict.as_deref(), &named),
        verdict,
        named,
        error,
        elapsed_s: o.elapsed_s,
        labels: o.sources,
        report,
    }
}

/// The engine's side of the checks: the worker and the rule.
pub struct GapChecks {
    pub settings: GapSettings,
    pub worker: Worker,
}

impl Engine {
    /// Starts background gap checks running `twin::gap` (`real_check`).
    pub fn start_gap_checks(&mut self, settings: GapSettings) -> std::io::Result<()> {
        let keep = settings.keep_dir.clone();
        let check: CheckFn = Box::new(move |job: &GapJob| {
            if let Some(dir) = &keep {
                keep_data_set(dir, job)?;
            }
            real_check(job)
        });
        self.start_gap_checks_with(settings, check)
    }

    /// Starts background gap checks running `check` (tests inject a slow or failing one).
    pub fn start_gap_checks_with(
        &mut self,
        settings: GapSettings,
        check: CheckFn,
    ) -> std::io::Result<()> {
        let worker = Worker::start(settings.threads, check)?;
        self.gap = Some(GapChecks { settings, worker });
        Ok(())
    }

    /// Adds a diagnosed segment to the drive's sample and queues a check when one is due.
    pub(crate) fn sample_segment(
        &mut self,
        drive: &str,
        seg: &crate::engine::Segment,
        rec: &twin::measured::Recording,
    ) {
        let Some(gap) = &self.gap else { return };
        let rule = gap.settings.rule;
        let twin = self.drives.get_mut(drive).expect("a drive with a segment");
        twin.sample
            .add(seg.index, &seg.verdict, seg.evidence, rec, &rule);
        let Some(trigger) = twin.sample.due(&rule) else {
            return;
        };
        let (set, sources) = twin.sample.data_set(twin.diameters_m);
        let at_s = sources
            .iter()
            .map(|s| s.end_s)
            .fold(f64::NEG_INFINITY, f64::max);
        twin.sample.queued();
        let job = GapJob {
            drive: drive.to_string(),
            model: twin.model.clone(),
            set,
            sources,
            trigger,
            at_s,
        };
        gap.worker.queue.push(job);
    }

    /// Takes every finished check's outcome without waiting.
    pub fn collect_gap_checks(&mut self) -> Result<(), StoreError> {
        while let Some(o) = self
            .gap
            .as_ref()
            .and_then(|g| g.worker.outcomes.try_recv().ok())
        {
            self.gap_outcome(o)?;
        }
        Ok(())
    }

    /// Waits until no check waits or runs, taking each outcome as it comes (the end of a
    /// replay).
    pub fn wait_gap_checks(&mut self) -> Result<(), StoreError> {
        loop {
            let Some(g) = &self.gap else { return Ok(()) };
            let busy = g.worker.queue.running().is_some() || !g.worker.queue.pending().is_empty();
            match g.worker.outcomes.recv_timeout(Duration::from_millis(500)) {
                Ok(o) => self.gap_outcome(o)?,
                Err(_) if !busy => return self.collect_gap_checks(),
                Err(_) => self.publish_view(),
            }
        }
    }

    /// The drive whose check runs now, and the drives waiting.
    pub fn gap_queue(&self) -> (Option<String>, Vec<String>) {
        match &self.gap {
            Some(g) => (g.worker.queue.running(), g.worker.queue.pending()),
            None => (None, Vec::new()),
        }
    }

    /// Stores one check's outcome with the drive's new state in one transaction, shows it,
    /// feeds its evidence to the alarm and publishes it.
    fn gap_outcome(&mut self, o: GapOutcome) -> Result<(), StoreError> {
        let drive = o.drive.clone();
        let rec = record_of(o, crate::store::now_unix_s());
        let json = serde_json::to_value(&rec).map_err(StoreError::json)?;
        let twin = self.twin(&drive);
        let from = twin.alarm.state;
        let changed = rec.evidence.and_then(|e| twin.alarm.update(e));
        let c = crate::engine::Counters {
            gap_checks: 1,
            gap_checks_failed: u64::from(rec.error.is_some()),
            state_changes: u64::from(changed.is_some()),
            ..Default::default()
        };
        let s = &mut twin.status;
        s.state = Some(twin.alarm.state);
        s.gap_report = Some(json.clone());
        crate::engine::add(&mut s.counters, &c);
        crate::engine::add(&mut self.counters, &c);
        let state_event = changed.map(|to| Event::StateChanged {
            drive: drive.clone(),
            from,
            to,
            at_s: rec.at_s,
        });
        if let Some(store) = &mut self.store {
            let t = &self.drives[&drive];
            store.record_gap(
                &StoredDrive {
                    id: drive.clone(),
                    status: t.status.clone(),
                    alarm: t.alarm.clone(),
                    trend: t.trend.clone(),
                    recorded_until_s: t.buffer.recorded_until_s,
                },
                &rec,
                &json,
                state_event.as_ref(),
                &self.counters,
            )?;
        }
        let event = Event::GapReport {
            drive: drive.clone(),
            at_s: rec.at_s,
            first_segment: rec.first_segment,
            last_segment: rec.last_segment,
            verdict: rec.verdict,
            named: rec.named,
            evidence: rec.evidence,
            error: rec.error,
        };
        for ev in state_event.iter().chain([&event]) {
            for sink in &mut self.sinks {
                sink.publish(ev);
            }
        }
        self.publish_view_of(&drive);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
