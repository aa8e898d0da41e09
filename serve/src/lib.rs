//! The online twin behind `rom serve`: readings stream in per drive (MQTT or a replayed data
//! set), each drive's rolling buffer is cut into steady segments, each segment is diagnosed by
//! the surrogate, and state changes and alarms go out (SQLite, HTTP API, dashboard, MQTT).
//!
//! The types here are the contract between the sources (`replay`, `mqtt`), the engine and the
//! sinks; see `docs/guide/serve.md` for the payload schema users send.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

pub mod alarm;
pub mod config;
pub mod dashboard;
pub mod drive;
pub mod engine;
pub mod gap_check;
pub mod http;
pub mod mqtt;
pub mod replay;
pub mod store;

pub use config::{DriveModel, ServeConfig};
pub use engine::{Counters, Engine};

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
    /// A background gap check finished (`gap_check`); the full report is on the API.
    GapReport {
        drive: String,
        /// End of the latest segment it read, seconds on the drive's clock.
        at_s: f64,
        first_segment: u64,
        last_segment: u64,
        /// The report's `top_effect` (an effect, `none`, `unexplained`); null when it failed.
        verdict: Option<String>,
        named: Vec<String>,
        /// What the alarm took from it.
        evidence: Option<State>,
        error: Option<String>,
    },
}

/// Somewhere events go (MQTT publication, a log). Sinks must not block ingestion for long.
pub trait Sink: Send {
    fn publish(&mut self, event: &Event);
}

/// The `[mqtt]` table of `serve.toml`: the broker and how this instance subscribes.
///
/// Readings arrive on `<topic_prefix>/<drive>/readings`; with `share_group` set the instance
/// subscribes through the broker's shared subscription `$share/<share_group>/...`, so several
/// instances split a fleet, each drive owned by one instance at a time.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MqttSettings {
    /// Broker host name or address.
    pub host: String,
    /// Broker port (1883 for plain MQTT).
    pub port: u16,
    /// Topic prefix; a drive's readings come on `<topic_prefix>/<drive>/readings`.
    pub topic_prefix: String,
    /// Client id of the persistent session (QoS 1: the broker keeps what arrives while away).
    pub client_id: String,
    /// Shared-subscription group, if several instances share the fleet.
    #[serde(default)]
    pub share_group: Option<String>,
}
