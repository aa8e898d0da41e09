//! Events out: each [`Event`] as JSON on its drive's retained `state` topic (QoS 1), and the
//! alarm state's changes also on its `alarm` topic (QoS 1, not retained), for the
//! building-management system; gap checks' reports only on their own retained `gap` topic. Publishing never blocks the engine: a full queue drops the
//! message and counts it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rumqttc::{Client, Connection, MqttOptions, Outgoing, QoS, RecvTimeoutError};

use super::{alarm_topic, bump, check_settings, gap_topic, state_topic, Backoff, MqttError};
use crate::{Event, MqttSettings, Sink};

/// What the sink has done.
#[derive(Debug, Default)]
pub struct SinkStats {
    /// Messages queued for the broker.
    pub published: AtomicU64,
    /// Messages dropped: the queue to the broker was full (the broker unreachable long), or an
    /// event named no drive.
    pub dropped: AtomicU64,
}

/// Publishes events to the broker from its own connection (client id `<client_id>-pub`).
pub struct MqttSink {
    client: Client,
    prefix: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    stats: Arc<SinkStats>,
}

impl MqttSink {
    /// Connects in the background (retrying with backoff); events published before the
    /// connection is up wait in a queue of `queue` messages.
    pub fn start(settings: &MqttSettings, queue: usize) -> Result<MqttSink, MqttError> {
        check_settings(settings)?;
        let id = format!("{}-pub", settings.client_id);
        let mut mqtt = MqttOptions::new(id, &settings.host, settings.port);
        // A persistent session: messages in flight when the broker restarts are sent again.
        mqtt.set_clean_session(false)
            .set_keep_alive(Duration::from_secs(5));
        let (client, connection) = Client::new(mqtt, queue.max(1));
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name(format!("mqtt-sink-{}", settings.client_id))
            .spawn(move || drive_connection(connection, &flag))
            .map_err(|e| MqttError::Client(format!("cannot start the sink thread: {e}")))?;
        Ok(MqttSink {
            client,
            prefix: settings.topic_prefix.clone(),
            stop,
            thread: Some(thread),
            stats: Arc::new(SinkStats::default()),
        })
    }

    /// The sink's counters (shared).
    pub fn stats(&self) -> Arc<SinkStats> {
        self.stats.clone()
    }

    fn send(&self, topic: String, retain: bool, payload: Vec<u8>) {
        match self
            .client
            .try_publish(topic, QoS::AtLeastOnce, retain, payload)
        {
            Ok(()) => bump(&self.stats.published, 1),
            Err(_) => bump(&self.stats.dropped, 1),
        }
    }
}

/// Where an event goes besides nowhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// The retained state topic.
    State,
    /// The retained state topic and the alarm topic.
    StateAndAlarm,
    /// The retained gap topic only (a report is not the drive's state).
    Gap,
}

/// The drive an event is about and its route, read from its JSON so that every kind of event
/// has one: the `drive` field; the alarm topic too for `state_changed` and any kind named
/// `..alarm..`; the gap topic alone for `gap_report`.
fn route(json: &serde_json::Value) -> Option<(&str, Route)> {
    let drive = json.get("drive")?.as_str()?;
    let kind = json.get("event").and_then(|k| k.as_str()).unwrap_or("");
    let r = if kind == "gap_report" {
        Route::Gap
    } else if kind == "state_changed" || kind.contains("alarm") {
        Route::StateAndAlarm
    } else {
        Route::State
    };
    Some((drive, r))
}

impl Sink for MqttSink {
    fn publish(&mut self, event: &Event) {
        let value = serde_json::to_value(event).ok();
        let Some((drive, route)) = value.as_ref().and_then(route) else {
            bump(&self.stats.dropped, 1);
            return;
        };
        // The event's own serialisation keeps its fields in order (the kind first).
        let json = serde_json::to_vec(event).unwrap_or_default();
        if route == Route::Gap {
            self.send(gap_topic(&self.prefix, drive), true, json);
            return;
        }
        self.send(state_topic(&self.prefix, drive), true, json.clone());
        if route == Route::StateAndAlarm {
            self.send(alarm_topic(&self.prefix, drive), false, json);
        }
    }
}

impl Drop for MqttSink {
    fn drop(&mut self) {
        if let Some(thread) = self.thread.take() {
            // The disconnect goes out after what is queued before it.
            let _ = self.client.try_disconnect();
            self.stop.store(true, Ordering::Relaxed);
            let _ = thread.join();
        }
    }
}

/// Polls the connection until told to stop (then until the disconnect is out, at most 1 s).
fn drive_connection(mut connection: Connection, stop: &AtomicBool) {
    let mut backoff = Backoff::new();
    let mut connected = false;
    let mut deadline = None;
    loop {
        if stop.load(Ordering::Relaxed)
            && Instant::now() >= *deadline.get_or_insert(Instant::now() + Duration::from_secs(1))
        {
            return;
        }
        let event = if connected {
            match connection.recv_timeout(Duration::from_millis(100)) {
                Ok(e) => e,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => return,
            }
        } else {
            match connection.recv() {
                Ok(e) => e,
                Err(_) => return,
            }
        };
        match event {
            Ok(rumqttc::Event::Incoming(rumqttc::Packet::ConnAck(_))) => {
                connected = true;
                backoff.reset();
            }
            Ok(rumqttc::Event::Outgoing(Outgoing::Disconnect)) => return,
            Ok(_) => {}
            Err(_) => {
                connected = false;
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                let end = Instant::now() + backoff.step();
                while Instant::now() < end && !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::State;

    #[test]
    fn events_are_routed_by_their_drive_and_kind() {
        let e = Event::StateChanged {
            drive: "belt-7".into(),
            from: State::Watch,
            to: State::Healthy,
            at_s: 3.0,
        };
        let v = serde_json::to_value(&e).unwrap();
        assert_eq!(route(&v), Some(("belt-7", Route::StateAndAlarm)));
        let estimate = serde_json::json!({"event": "segment_diagnosed", "drive": "belt-7"});
        assert_eq!(route(&estimate), Some(("belt-7", Route::State)));
        let gap = Event::GapReport {
            drive: "belt-7".into(),
            at_s: 9.0,
            first_segment: 3,
            last_segment: 4,
            verdict: Some("unexplained".into()),
            named: Vec::new(),
            evidence: Some(State::UnexplainedGap),
            error: None,
        };
        let v = serde_json::to_value(&gap).unwrap();
        assert_eq!(route(&v), Some(("belt-7", Route::Gap)));
        assert_eq!(route(&serde_json::json!({"event": "state_changed"})), None);
    }
}
