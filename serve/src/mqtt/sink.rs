//! Events out: each [`Event`] as JSON on its drive's retained `state` topic (QoS 1), and the
//! alarm state's changes also on its `alarm` topic (QoS 1, not retained), for the
//! building-management system. Publishing never blocks the engine: a full queue drops the
//! message and counts it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rumqttc::{Client, Connection, MqttOptions, Outgoing, QoS, RecvTimeoutError};

use super::{alarm_topic, bump, check_settings, state_topic, Backoff, MqttError};
use crate::{Event, MqttSettings, Sink};

/// What the sink has done.
#[derive(Debug, Default)]
pub struct SinkStats {
    /// Messages queued for the broker.
    pub published: AtomicU64,
    /// Messages dropped because the queue to the broker was full (the broker unreachable long).
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

/// The drive an event is about, and whether it changes the alarm state.
fn route(event: &Event) -> (&str, bool) {
    match event {
        Event::StateChanged { drive, .. } => (drive, true),
    }
}

impl Sink for MqttSink {
    fn publish(&mut self, event: &Event) {
        let Ok(json) = serde_json::to_vec(event) else {
            bump(&self.stats.dropped, 1);
            return;
        };
        let (drive, alarm) = route(event);
        self.send(state_topic(&self.prefix, drive), true, json.clone());
        if alarm {
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
