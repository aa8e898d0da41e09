//! The online twin behind `rom serve`: readings stream in per drive (MQTT or a replayed data
//! set), each drive's rolling buffer is cut into steady segments, each segment is diagnosed by
//! the surrogate, and state changes and alarms go out (SQLite, HTTP API, dashboard, MQTT).
//!
//! The types here are the contract between the sources (`replay`, `mqtt`), the engine and the
//! sinks; see `docs/guide/serve.md` for the payload schema users send.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// A batch of speed readings of one drive, as a source delivers it.
///
/// JSON payload (one MQTT message, topic `<prefix>/<drive>/readings`): columns as arrays of one
/// length, times in seconds on the gateway's clock, speeds in rpm; `seq` is the gateway's
/// batch counter (used to drop duplicates), `extra` holds optional channels by column name
/// (e.g. `driven_torque_nm`), each as long as `time_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Batch {
    /// The drive this batch belongs to (the MQTT topic's drive id, or the data set's label).
    #[serde(default)]
    pub drive: String,
    /// The sender's batch counter, if it keeps one.
    #[serde(default)]
    pub seq: Option<u64>,
    pub time_s: Vec<f64>,
    pub driver_rpm: Vec<f64>,
    pub driven_rpm: Vec<f64>,
    #[serde(default)]
    pub extra: BTreeMap<String, Vec<f64>>,
}

/// A drive's alarm state, from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum State {
    Healthy,
    Watch,
    Loose,
    UnexplainedGap,
}

/// What the engine tells the sinks (database, MQTT publication, the API's event log).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The drive's alarm state changed (after hysteresis).
    StateChanged {
        drive: String,
        from: State,
        to: State,
        /// Time of the segment's last reading that decided it, seconds on the drive's clock.
        at_s: f64,
    },
}

/// Somewhere events go (MQTT publication, a log). Sinks must not block ingestion for long.
pub trait Sink: Send {
    fn publish(&mut self, event: &Event);
}
