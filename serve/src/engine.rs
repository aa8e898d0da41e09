//! The engine: batches in (from any source, through [`Engine::ingest`] or [`Engine::run`]),
//! per drive a rolling buffer cut into segments, each segment diagnosed by `rom diagnose`'s
//! own functions (`twin::diagnose`), the alarm updated with hysteresis (`crate::alarm`), the
//! result stored (`crate::store`) and state changes sent to the sinks.

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use twin::diagnose::LabelVerdict;
use twin::measured::{DataSet, Manifest, Recording, RunEntry};

use crate::alarm::{evidence, Alarm};
use crate::config::{DriveModel, Models};
use crate::drive::{Buffer, CloseReason, Closed, Fate};
use crate::gap_check::{GapChecks, GapSample};
use crate::store::{Store, StoreError, StoredDrive};
use crate::{Batch, Event, Sink, State};

/// A drive that sends nothing for this long (wall clock) is silent: its open segment is closed
/// and diagnosed, and it is counted.
pub const SILENT_S: f64 = 30.0;
/// Segments the trend is fitted over (the latest ones).
pub const TREND_SEGMENTS: usize = 100;

/// What was counted, for the whole fleet or one drive.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Counters {
    pub batches: u64,
    pub readings: u64,
    /// Batches refused whole: unreadable, columns of unequal length, a number not finite, a
    /// negative speed, no drive id.
    pub malformed_batches: u64,
    pub duplicate_readings: u64,
    pub out_of_order_readings: u64,
    /// Forward steps over `drive::CLOCK_JUMP_S`, and batches behind by more than it.
    pub clock_jumps: u64,
    /// Forward steps over `drive::GAP_S` (readings missing).
    pub gaps: u64,
    /// Times a drive went silent (`SILENT_S`).
    pub silent: u64,
    pub segments: u64,
    /// Segments too short to diagnose (fewer than `twin::signal::MIN_STEADY_SAMPLES`), not
    /// recorded.
    pub short_segments: u64,
    /// Recorded segments that could not be diagnosed (not steady, ...).
    pub undiagnosed_segments: u64,
    pub state_changes: u64,
    /// Background gap checks stored (docs/guide/serve.md, "Gap checks"), failed ones included.
    pub gap_checks: u64,
    /// Gap checks that stopped with an error (stored with it).
    pub gap_checks_failed: u64,
}

/// One point of a drive's trend: a diagnosed segment's end, mean slip and distance estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrendPoint {
    pub end_s: f64,
    pub mean_slip_pct: f64,
    pub center_distance_m: f64,
}

/// The least-squares slope of y over x (NaN with fewer than two distinct x).
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let (mx, my) = (fom::stats::mean(x), fom::stats::mean(y));
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        f64::NAN
    }
}

/// The trend over a drive's latest segments: slopes per hour of the drive's clock.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trend {
    pub segments: usize,
    /// Mean slip's slope, percentage points per hour (a belt that stretches drifts up).
    pub slip_pp_per_h: Option<f64>,
    /// Centre-distance estimate's slope, m per hour.
    pub center_distance_m_per_h: Option<f64>,
}

fn trend_of(points: &VecDeque<TrendPoint>) -> Trend {
    let x: Vec<f64> = points.iter().map(|p| p.end_s / 3600.0).collect();
    let fit = |y: Vec<f64>| Some(slope(&x, &y)).filter(|s| s.is_finite());
    Trend {
        segments: points.len(),
        slip_pp_per_h: fit(points.iter().map(|p| p.mean_slip_pct).collect()),
        center_distance_m_per_h: fit(points.iter().map(|p| p.center_distance_m).collect()),
    }
}

/// What the API shows of one drive.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DriveStatus {
    /// The drive id (the MQTT topic's drive id, or the replayed data set's label).
    pub label: String,
    pub state: Option<State>,
    /// Name of the model the drive is diagnosed with (`shipped` for the embedded one).
    pub model: String,
    pub segments: u64,
    /// Time of the latest reading, s on the drive's clock.
    pub last_reading_s: Option<f64>,
    pub silent: bool,
    /// The latest recorded segment with its diagnosis (`Segment`'s JSON).
    pub latest: Option<serde_json::Value>,
    /// The latest estimate (`rom diagnose`'s: centre distance and tension with their 90 %
    /// intervals, class probabilities), from the latest segment that gave one.
    pub estimate: Option<serde_json::Value>,
    /// End of the segment `estimate` comes from, s on the drive's clock.
    pub estimate_at_s: Option<f64>,
    pub trend: Trend,
    pub counters: Counters,
    /// Why the drive's latest refused batch was refused.
    pub last_malformed: Option<String>,
    /// The latest background gap check's report (`twin::gap`), if one ran.
    pub gap_report: Option<serde_json::Value>,
    /// Time from a segment's close to its diagnosis stored and published, ms: the latest.
    pub publish_latency_ms: Option<f64>,
}

/// A recorded segment with its diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct Segment {
    pub drive: String,
    /// 1-based count of the drive's recorded segments.
    pub index: u64,
    pub start_s: f64,
    pub end_s: f64,
    pub samples: usize,
    pub reason: CloseReason,
    /// What this segment says on its own (none when it could not be diagnosed).
    pub evidence: Option<State>,
    /// The drive's alarm state after it.
    pub state: State,
    pub verdict: LabelVerdict,
}

/// What the HTTP API reads while the engine works.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FleetView {
    pub drives: BTreeMap<String, DriveStatus>,
    pub counters: Counters,
    /// The drive whose gap check runs now.
    pub gap_running: Option<String>,
    /// Drives whose gap check waits, in order.
    pub gap_queued: Vec<String>,
    /// The gap queue's version these two were read at.
    #[serde(skip)]
    pub gap_version: Option<u64>,
}

pub(crate) struct DriveTwin {
    pub(crate) model: Arc<DriveModel>,
    pub(crate) buffer: Buffer,
    pub(crate) alarm: Alarm,
    pub(crate) trend: VecDeque<TrendPoint>,
    pub(crate) status: DriveStatus,
    last_batch: Instant,
    /// Pulley diameters from the source (a replayed data set's manifest), m.
    pub(crate) diameters_m: (Option<f64>, Option<f64>),
    /// The latest segments a gap check reads (`crate::gap_check::sample`).
    pub(crate) sample: GapSample,
}

/// The online twin of a fleet.
pub struct Engine {
    models: Models,
    pub(crate) drives: BTreeMap<String, DriveTwin>,
    pub(crate) counters: Counters,
    pub(crate) sinks: Vec<Box<dyn Sink>>,
    pub(crate) store: Option<Store>,
    view: Arc<RwLock<FleetView>>,
    /// Background gap checks, when started (`crate::gap_check`).
    pub(crate) gap: Option<GapChecks>,
}

impl Engine {
    /// An engine with its models, its database (resumed: drives, states, trends and counters
    /// as stored) and its sinks.
    pub fn new(
        models: Models,
        store: Option<Store>,
        sinks: Vec<Box<dyn Sink>>,
    ) -> Result<Self, StoreError> {
        let mut e = Engine {
            models,
            drives: BTreeMap::new(),
            counters: Counters::default(),
            sinks,
            store,
            view: Arc::default(),
            gap: None,
        };
        if let Some(s) = &e.store {
            let (drives, counters) = s.load()?;
            e.counters = counters;
            for d in drives {
                e.restore(d);
            }
        }
        e.publish_view();
        Ok(e)
    }

    fn restore(&mut self, d: StoredDrive) {
        let model = self.models.of(&d.id);
        let twin = DriveTwin {
            buffer: Buffer::resumed(d.recorded_until_s),
            alarm: d.alarm,
            trend: d.trend,
            status: DriveStatus {
                model: model.name.clone(),
                ..d.status
            },
            model,
            last_batch: Instant::now(),
            diameters_m: (None, None),
            sample: GapSample::default(),
        };
        self.drives.insert(d.id, twin);
    }

    /// The view the HTTP API reads (updated as the engine goes).
    pub fn view(&self) -> Arc<RwLock<FleetView>> {
        self.view.clone()
    }

    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Where a drive's recorded readings end, s on its clock: a replay resumes after it.
    pub fn recorded_until_s(&self, drive: &str) -> Option<f64> {
        self.drives.get(drive)?.buffer.recorded_until_s
    }

    /// Sets the pulley diameters a source knows for `drive` (a data set's manifest), m.
    pub fn set_diameters(&mut self, drive: &str, driver_m: Option<f64>, driven_m: Option<f64>) {
        self.twin(drive).diameters_m = (driver_m, driven_m);
    }

    pub(crate) fn twin(&mut self, drive: &str) -> &mut DriveTwin {
        if !self.drives.contains_key(drive) {
            let model = self.models.of(drive);
            self.drives.insert(
                drive.to_string(),
                DriveTwin {
                    status: DriveStatus {
                        label: drive.to_string(),
                        state: Some(State::Healthy),
                        model: model.name.clone(),
                        ..DriveStatus::default()
                    },
                    model,
                    buffer: Buffer::default(),
                    alarm: Alarm::default(),
                    trend: VecDeque::new(),
                    last_batch: Instant::now(),
                    diameters_m: (None, None),
                    sample: GapSample::default(),
                },
            );
        }
        self.drives.get_mut(drive).expect("inserted above")
    }

    /// Counts a message a source could not read as a batch (`drive` when it knows whose).
    pub fn malformed(&mut self, drive: Option<&str>) {
        self.counters.malformed_batches += 1;
        if let Some(d) = drive.filter(|d| !d.is_empty()) {
            self.twin(d).status.counters.malformed_batches += 1;
        }
        self.publish_view();
    }

    /// Takes one batch: checks it, buffers its readings, and diagnoses, stores and publishes
    /// every segment it closes. Bad data is counted, never an error.
    pub fn ingest(&mut self, b: Batch) -> Result<(), StoreError> {
        self.collect_gap_checks()?;
        self.counters.batches += 1;
        if let Some(why) = malformed_why(&b) {
            self.malformed(Some(&b.drive));
            if let Some(t) = self.drives.get_mut(&b.drive) {
                t.status.last_malformed = Some(why);
                self.publish_view_of(&b.drive);
            }
            return Ok(());
        }
        let mut closed = Vec::new();
        let mut c = Counters {
            batches: 1,
            ..Counters::default()
        };
        let twin = self.twin(&b.drive);
        twin.last_batch = Instant::now();
        twin.status.silent = false;
        let (jumps0, gaps0) = (twin.buffer.clock_jumps_forward, twin.buffer.gaps);
        let mut jumped_back = false;
        for i in 0..b.time_s.len() {
            match twin
                .buffer
                .push(b.time_s[i], b.driver_rpm[i], b.driven_rpm[i], &mut closed)
            {
                Fate::Accepted => c.readings += 1,
                Fate::Duplicate => c.duplicate_readings += 1,
                Fate::OutOfOrder => c.out_of_order_readings += 1,
                Fate::ClockJumpBack => jumped_back = true,
            }
        }
        c.clock_jumps = twin.buffer.clock_jumps_forward - jumps0 + u64::from(jumped_back);
        c.gaps = twin.buffer.gaps - gaps0;
        twin.status.last_reading_s = twin.buffer.last_s;
        add(&mut twin.status.counters, &c);
        c.batches = 0;
        add(&mut self.counters, &c);
        for seg in closed {
            self.close(&b.drive, seg)?;
        }
        self.publish_view_of(&b.drive);
        Ok(())
    }

    /// Diagnoses, stores and publishes one closed segment.
    fn close(&mut self, drive: &str, seg: Closed) -> Result<(), StoreError> {
        let closed_at = Instant::now();
        let rec = seg.recording;
        if rec.len() < twin::signal::MIN_STEADY_SAMPLES {
            self.counters.short_segments += 1;
            self.twin(drive).status.counters.short_segments += 1;
            return Ok(());
        }
        let (start_s, end_s, samples) = (rec.time_s[0], rec.time_s[rec.len() - 1], rec.len());
        let kept = self.gap.is_some().then(|| rec.clone());
        let twin = self.twin(drive);
        let verdict = diagnose_segment(&twin.model, drive, twin.diameters_m, rec);
        let ev = evidence(&verdict);
        let from = twin.alarm.state;
        let changed = ev.and_then(|e| twin.alarm.update(e));
        if let (Some(e), Some(m)) = (&verdict.estimate, &verdict.measured) {
            twin.trend.push_back(TrendPoint {
                end_s,
                mean_slip_pct: m.mean_pct,
                center_distance_m: e.center_distance_m,
            });
            while twin.trend.len() > TREND_SEGMENTS {
                twin.trend.pop_front();
            }
        }
        let mut c = Counters {
            segments: 1,
            undiagnosed_segments: u64::from(ev.is_none()),
            state_changes: u64::from(changed.is_some()),
            ..Counters::default()
        };
        let s = &mut twin.status;
        s.segments += 1;
        let segment = Segment {
            drive: drive.to_string(),
            index: s.segments,
            start_s,
            end_s,
            samples,
            reason: seg.reason,
            evidence: ev,
            state: twin.alarm.state,
            verdict,
        };
        let json = serde_json::to_value(&segment).map_err(StoreError::json)?;
        s.state = Some(twin.alarm.state);
        if let Some(e) = json.pointer("/verdict/estimate").filter(|e| !e.is_null()) {
            s.estimate = Some(e.clone());
            s.estimate_at_s = Some(end_s);
        }
        s.latest = Some(json.clone());
        s.trend = trend_of(&twin.trend);
        add(&mut s.counters, &c);
        c.batches = 0;
        add(&mut self.counters, &c);
        let event = changed.map(|to| Event::StateChanged {
            drive: drive.to_string(),
            from,
            to,
            at_s: end_s,
        });
        if let Some(store) = &mut self.store {
            let twin = &self.drives[drive];
            store.record_segment(
                &StoredDrive {
                    id: drive.to_string(),
                    status: twin.status.clone(),
                    alarm: twin.alarm.clone(),
                    trend: twin.trend.clone(),
                    recorded_until_s: twin.buffer.recorded_until_s,
                },
                &segment,
                &json,
                event.as_ref(),
                &self.counters,
            )?;
        }
        if let Some(ev) = &event {
            for sink in &mut self.sinks {
                sink.publish(ev);
            }
        }
        let twin = self.twin(drive);
        twin.status.publish_latency_ms = Some(closed_at.elapsed().as_secs_f64() * 1e3);
        if let Some(rec) = kept {
            self.sample_segment(drive, &segment, &rec);
        }
        Ok(())
    }

    /// Marks drives that sent nothing for `SILENT_S` as silent and closes their open
    /// segments; call now and then while no batch arrives.
    pub fn tick(&mut self) -> Result<(), StoreError> {
        self.collect_gap_checks()?;
        let now = Instant::now();
        let quiet: Vec<String> = self
            .drives
            .iter()
            .filter(|(_, t)| {
                !t.status.silent && now.duration_since(t.last_batch).as_secs_f64() > SILENT_S
            })
            .map(|(id, _)| id.clone())
            .collect();
        for id in quiet {
            self.counters.silent += 1;
            let twin = self.twin(&id);
            twin.status.silent = true;
            twin.status.counters.silent += 1;
            self.flush_drive(&id, CloseReason::Break)?;
            self.publish_view_of(&id);
        }
        Ok(())
    }

    fn flush_drive(&mut self, id: &str, reason: CloseReason) -> Result<(), StoreError> {
        let mut closed = Vec::new();
        self.twin(id).buffer.close(reason, &mut closed);
        for seg in closed {
            self.close(id, seg)?;
        }
        Ok(())
    }

    /// Closes every open segment (the end of a replay).
    pub fn flush(&mut self) -> Result<(), StoreError> {
        let ids: Vec<String> = self.drives.keys().cloned().collect();
        for id in ids {
            self.flush_drive(&id, CloseReason::Break)?;
            self.publish_view_of(&id);
        }
        if let Some(s) = &mut self.store {
            s.save_counters(&self.counters)?;
        }
        Ok(())
    }

    /// Takes batches from `rx` until every sender is gone, then flushes; between batches
    /// looks for silent drives.
    pub fn run(&mut self, rx: &Receiver<Batch>) -> Result<(), StoreError> {
        loop {
            match rx.recv_timeout(Duration::from_secs(1)) {
                Ok(b) => self.ingest(b)?,
                Err(RecvTimeoutError::Timeout) => self.tick()?,
                Err(RecvTimeoutError::Disconnected) => return self.flush(),
            }
        }
    }

    pub(crate) fn publish_view_of(&self, drive: &str) {
        if let (Ok(mut v), Some(t)) = (self.view.write(), self.drives.get(drive)) {
            v.drives.insert(drive.to_string(), t.status.clone());
            v.counters = self.counters.clone();
            // The gap queue read only when it changed (a lock and a list of names).
            let version = self.gap.as_ref().map(|g| g.worker.queue.version());
            if version != v.gap_version {
                v.gap_version = version;
                (v.gap_running, v.gap_queued) = self.gap_queue();
            }
        }
    }

    pub(crate) fn publish_view(&self) {
        if let Ok(mut v) = self.view.write() {
            v.drives = self
                .drives
                .iter()
                .map(|(k, t)| (k.clone(), t.status.clone()))
                .collect();
            v.counters = self.counters.clone();
            (v.gap_running, v.gap_queued) = self.gap_queue();
        }
    }
}

pub(crate) fn add(to: &mut Counters, c: &Counters) {
    to.batches += c.batches;
    to.readings += c.readings;
    to.malformed_batches += c.malformed_batches;
    to.duplicate_readings += c.duplicate_readings;
    to.out_of_order_readings += c.out_of_order_readings;
    to.clock_jumps += c.clock_jumps;
    to.gaps += c.gaps;
    to.silent += c.silent;
    to.segments += c.segments;
    to.short_segments += c.short_segments;
    to.undiagnosed_segments += c.undiagnosed_segments;
    to.state_changes += c.state_changes;
    to.gap_checks += c.gap_checks;
    to.gap_checks_failed += c.gap_checks_failed;
}

/// Why a batch is refused whole, if it is.
pub fn malformed_why(b: &Batch) -> Option<String> {
    let n = b.time_s.len();
    if b.drive.trim().is_empty() {
        return Some("no drive id".into());
    }
    if n == 0 {
        return Some("no readings".into());
    }
    if b.driver_rpm.len() != n || b.driven_rpm.len() != n {
        return Some(format!(
            "columns of unequal length: time_s {n}, driver_rpm {}, driven_rpm {}",
            b.driver_rpm.len(),
            b.driven_rpm.len()
        ));
    }
    if let Some((k, v)) = b.extra.iter().find(|(_, v)| v.len() != n) {
        return Some(format!(
            "extra channel `{k}` has {} values, time_s {n}",
            v.len()
        ));
    }
    if b.time_s.iter().any(|t| !t.is_finite()) {
        return Some("a time is not a finite number".into());
    }
    if b.driver_rpm
        .iter()
        .chain(&b.driven_rpm)
        .any(|v| !(v.is_finite() && *v >= 0.0))
    {
        return Some("a speed is negative or not a finite number".into());
    }
    None
}

/// `rom diagnose` on one segment: the segment as a one-run data set of label `drive`, through
/// `twin::diagnose::diagnose_with` and the model's prior made once (steady part by `fom::steady`, slip distribution, inversion,
/// classes, misfit flags: one definition).
pub fn diagnose_segment(
    model: &DriveModel,
    drive: &str,
    diameters_m: (Option<f64>, Option<f64>),
    rec: Recording,
) -> LabelVerdict {
    let set = DataSet {
        dir: PathBuf::new(),
        manifest: Manifest {
            description: None,
            driver_pulley_diameter_m: diameters_m.0,
            driven_pulley_diameter_m: diameters_m.1,
            runs: vec![RunEntry {
                file: "segment".into(),
                label: drive.to_string(),
                center_distance_m: None,
                metadata: BTreeMap::new(),
            }],
        },
        recordings: vec![rec],
    };
    match twin::diagnose::diagnose_with(&model.file.surrogate, &model.cfg, &model.prior, &set) {
        Ok(mut v) if !v.is_empty() => v.swap_remove(0),
        other => LabelVerdict {
            label: drive.to_string(),
            runs: 1,
            known_center_distance_m: None,
            measured: None,
            estimate: None,
            cannot_diagnose: Some(match other {
                Err(e) => e.to_string(),
                Ok(_) => "no verdict".into(),
            }),
            misfit: Vec::new(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trend_is_the_least_squares_slope_per_hour() {
        let pts: VecDeque<TrendPoint> = (0..5)
            .map(|i| TrendPoint {
                end_s: 3600.0 * i as f64,
                mean_slip_pct: 0.7 + 0.1 * i as f64,
                center_distance_m: 0.42 - 0.001 * i as f64,
            })
            .collect();
        let t = trend_of(&pts);
        assert!((t.slip_pp_per_h.unwrap() - 0.1).abs() < 1e-12);
        assert!((t.center_distance_m_per_h.unwrap() + 0.001).abs() < 1e-12);
        assert_eq!(
            trend_of(&pts.iter().take(1).copied().collect()).slip_pp_per_h,
            None
        );
    }

    #[test]
    fn malformed_batches_are_told_why() {
        let ok = Batch {
            drive: "a".into(),
            seq: None,
            time_s: vec![0.0, 0.1],
            driver_rpm: vec![1500.0, 1500.0],
            driven_rpm: vec![740.0, 741.0],
            extra: BTreeMap::new(),
        };
        assert_eq!(malformed_why(&ok), None);
        let mut b = ok.clone();
        b.driven_rpm.pop();
        assert!(malformed_why(&b).unwrap().contains("unequal"));
        let mut b = ok.clone();
        b.driver_rpm[1] = f64::NAN;
        assert!(malformed_why(&b).unwrap().contains("finite"));
        let mut b = ok.clone();
        b.driver_rpm[1] = -1.0;
        assert!(malformed_why(&b).unwrap().contains("negative"));
        let b = Batch {
            drive: String::new(),
            ..ok
        };
        assert!(malformed_why(&b).unwrap().contains("drive id"));
    }
}
