//! The MQTT side of the online twin: readings in (`source`), events out (`sink`), and how
//! several instances split a fleet through one broker (`fleet`).
//!
//! Topics, payload schema, QoS and sessions: `docs/guide/serve-mqtt.md`; the ownership rule for
//! shared subscriptions: `docs/decisions/serve-shared-subscriptions.md`.

mod fleet;
mod order;
mod outbox;
mod sink;
mod source;

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

pub use sink::{MqttSink, SinkStats};
pub use source::{MqttSource, SourceOptions};

use crate::{Batch, MqttSettings};

/// Why the MQTT side could not start.
#[derive(Debug, thiserror::Error)]
pub enum MqttError {
    /// A setting of the `[mqtt]` table is unusable; names the setting.
    #[error("[mqtt] {setting}: {reason}")]
    Setting {
        setting: &'static str,
        reason: String,
    },
    /// The client refused a request (a topic it cannot publish or subscribe to).
    #[error("MQTT client: {0}")]
    Client(String),
}

/// What the source has seen, shared with the engine and the API (read with [`SourceStats::snapshot`]).
#[derive(Debug, Default)]
pub struct SourceStats {
    /// Messages received on a readings topic (direct or forwarded).
    pub received: AtomicU64,
    /// Batches handed on to the engine.
    pub delivered: AtomicU64,
    /// Payloads that are not a valid batch (bad JSON, columns of different lengths, no readings).
    pub malformed: AtomicU64,
    /// Batches whose `seq` was already handed on (a broker redelivery or a gateway resend), dropped.
    pub duplicates: AtomicU64,
    /// Batches that arrived after a later batch of their drive (put back in `seq` order when they
    /// came within the reorder window).
    pub out_of_order: AtomicU64,
    /// Of those, the ones that came after the window and were handed on late, out of order.
    pub late: AtomicU64,
    /// `seq` numbers given up on after the reorder window (never arrived in time).
    pub gaps: AtomicU64,
    /// A drive's `seq` fell far back: the gateway restarted its counter.
    pub seq_resets: AtomicU64,
    /// Batches passed on to the instance owning their drive (shared subscriptions).
    pub forwarded: AtomicU64,
    /// Connection attempts that failed or connections that dropped.
    pub connection_errors: AtomicU64,
    /// Successful connections (the first one and every reconnection).
    pub connections: AtomicU64,
    /// Subscriptions the broker confirmed (one per connection): the source is listening.
    pub subscribed: AtomicU64,
}

/// A plain copy of [`SourceStats`] at one moment (for the API's JSON).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct SourceCounts {
    pub received: u64,
    pub delivered: u64,
    pub malformed: u64,
    pub duplicates: u64,
    pub out_of_order: u64,
    pub late: u64,
    pub gaps: u64,
    pub seq_resets: u64,
    pub forwarded: u64,
    pub connection_errors: u64,
    pub connections: u64,
    pub subscribed: u64,
}

impl SourceStats {
    pub fn snapshot(&self) -> SourceCounts {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        SourceCounts {
            received: g(&self.received),
            delivered: g(&self.delivered),
            malformed: g(&self.malformed),
            duplicates: g(&self.duplicates),
            out_of_order: g(&self.out_of_order),
            late: g(&self.late),
            gaps: g(&self.gaps),
            seq_resets: g(&self.seq_resets),
            forwarded: g(&self.forwarded),
            connection_errors: g(&self.connection_errors),
            connections: g(&self.connections),
            subscribed: g(&self.subscribed),
        }
    }
}

pub(crate) fn bump(counter: &AtomicU64, by: u64) {
    counter.fetch_add(by, Ordering::Relaxed);
}

/// The topic a drive's readings come on: `<prefix>/<drive>/readings`.
pub fn readings_topic(prefix: &str, drive: &str) -> String {
    format!("{prefix}/{drive}/readings")
}

/// The retained topic of a drive's latest event: `<prefix>/<drive>/state`.
pub fn state_topic(prefix: &str, drive: &str) -> String {
    format!("{prefix}/{drive}/state")
}

/// The topic of a drive's alarm-state changes: `<prefix>/<drive>/alarm`.
pub fn alarm_topic(prefix: &str, drive: &str) -> String {
    format!("{prefix}/{drive}/alarm")
}

/// The retained topic of a drive's latest background gap check: `<prefix>/<drive>/gap`.
pub fn gap_topic(prefix: &str, drive: &str) -> String {
    format!("{prefix}/{drive}/gap")
}

/// The drive id of a readings topic under `prefix`, if `topic` is one.
pub(crate) fn drive_of(prefix: &str, topic: &str) -> Option<String> {
    let drive = topic
        .strip_prefix(prefix)?
        .strip_prefix('/')?
        .strip_suffix("/readings")?;
    (!drive.is_empty() && !drive.contains('/')).then(|| drive.to_string())
}

/// A payload read as a [`Batch`] of `drive` (the topic's drive id wins over the payload's),
/// or why it is not one.
pub fn parse_batch(drive: &str, payload: &[u8]) -> Result<Batch, String> {
    let mut batch: Batch = serde_json::from_slice(payload).map_err(|e| e.to_string())?;
    let n = batch.time_s.len();
    if n == 0 {
        return Err("no readings (time_s is empty)".into());
    }
    if batch.driver_rpm.len() != n || batch.driven_rpm.len() != n {
        return Err(format!(
            "columns of different lengths: time_s {n}, driver_rpm {}, driven_rpm {}",
            batch.driver_rpm.len(),
            batch.driven_rpm.len()
        ));
    }
    if let Some((name, col)) = batch.extra.iter().find(|(_, c)| c.len() != n) {
        return Err(format!(
            "extra column {name} has {} values, time_s {n}",
            col.len()
        ));
    }
    batch.drive = drive.to_string();
    Ok(batch)
}

/// Checks the settings once; names the first unusable one.
pub(crate) fn check_settings(s: &MqttSettings) -> Result<(), MqttError> {
    let level = |setting: &'static str, v: &str, may_slash: bool| {
        let bad = v.is_empty()
            || v.contains(['+', '#'])
            || (!may_slash && v.contains('/'))
            || v.starts_with('$')
            || v.starts_with('/')
            || v.ends_with('/');
        if bad {
            let what = if may_slash {
                "topic levels"
            } else {
                "one topic level"
            };
            return Err(MqttError::Setting {
                setting,
                reason: format!(
                    "{v:?} is not usable: it must be {what}, not empty, without '+', '#' or a leading '$'"
                ),
            });
        }
        Ok(())
    };
    if s.host.is_empty() {
        return Err(MqttError::Setting {
            setting: "host",
            reason: "empty".into(),
        });
    }
    if s.port == 0 {
        return Err(MqttError::Setting {
            setting: "port",
            reason: "0 is not a port".into(),
        });
    }
    level("topic_prefix", &s.topic_prefix, true)?;
    level("client_id", &s.client_id, false)?;
    if let Some(g) = &s.share_group {
        level("share_group", g, false)?;
    }
    Ok(())
}

/// Waits between reconnection attempts: doubles from 100 ms up to 5 s, reset on success.
#[derive(Debug)]
pub(crate) struct Backoff {
    next: Duration,
}

impl Backoff {
    const FIRST: Duration = Duration::from_millis(100);
    const MAX: Duration = Duration::from_secs(5);

    pub(crate) fn new() -> Self {
        Backoff { next: Self::FIRST }
    }
    pub(crate) fn reset(&mut self) {
        self.next = Self::FIRST;
    }
    /// The wait before the next attempt (and doubles the one after).
    pub(crate) fn step(&mut self) -> Duration {
        let d = self.next;
        self.next = (self.next * 2).min(Self::MAX);
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drive_of_takes_one_level_under_the_prefix() {
        assert_eq!(drive_of("a/b", "a/b/d7/readings").as_deref(), Some("d7"));
        assert_eq!(drive_of("a/b", "a/b/x/d7/readings"), None);
        assert_eq!(drive_of("a/b", "a/c/d7/readings"), None);
        assert_eq!(drive_of("a", "a//readings"), None);
        assert_eq!(drive_of("a", "a/d7/state"), None);
    }

    #[test]
    fn parse_batch_names_what_is_wrong_and_takes_the_topic_drive() {
        let ok = br#"{"drive":"other","seq":3,"time_s":[0.0,0.001],"driver_rpm":[1450,1450],"driven_rpm":[900,901]}"#;
        let b = parse_batch("d1", ok).unwrap();
        assert_eq!(
            (b.drive.as_str(), b.seq, b.time_s.len()),
            ("d1", Some(3), 2)
        );
        let short = br#"{"time_s":[0.0,0.001],"driver_rpm":[1450],"driven_rpm":[900,901]}"#;
        assert!(parse_batch("d1", short)
            .unwrap_err()
            .contains("driver_rpm 1"));
        let extra = br#"{"time_s":[0.0],"driver_rpm":[1],"driven_rpm":[1],"extra":{"t_nm":[1,2]}}"#;
        assert!(parse_batch("d1", extra).unwrap_err().contains("t_nm"));
        assert!(parse_batch("d1", b"{not json").is_err());
        let empty = br#"{"time_s":[],"driver_rpm":[],"driven_rpm":[]}"#;
        assert!(parse_batch("d1", empty)
            .unwrap_err()
            .contains("no readings"));
    }

    #[test]
    fn settings_are_checked_by_name() {
        let mut s = MqttSettings {
            host: "127.0.0.1".into(),
            port: 1883,
            topic_prefix: "plant/beltwin".into(),
            client_id: "serve-1".into(),
            share_group: Some("fleet".into()),
        };
        assert!(check_settings(&s).is_ok());
        s.client_id = "a/b".into();
        let e = check_settings(&s).unwrap_err().to_string();
        assert!(e.contains("client_id"), "{e}");
        s.client_id = "ok".into();
        s.topic_prefix = "plant/#".into();
        assert!(check_settings(&s)
            .unwrap_err()
            .to_string()
            .contains("topic_prefix"));
    }

    #[test]
    fn backoff_doubles_to_a_cap_and_resets() {
        let mut b = Backoff::new();
        let waits: Vec<u128> = (0..8).map(|_| b.step().as_millis()).collect();
        assert_eq!(waits, [100, 200, 400, 800, 1600, 3200, 5000, 5000]);
        b.reset();
        assert_eq!(b.step().as_millis(), 100);
    }
}
