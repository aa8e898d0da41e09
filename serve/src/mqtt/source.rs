//! Readings in: one persistent MQTT session (QoS 1, `clean_session = false`, a stable client
//! id) whose thread parses each message into a [`Batch`], puts each drive's batches in `seq`
//! order, hands them to the engine's channel and only then acknowledges them (manual acks), so
//! what was not handed on is redelivered by the broker to the restarted server.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rumqttc::{
    Client, Connection, Event, LastWill, MqttOptions, Outgoing, Packet, Publish, QoS,
    RecvTimeoutError, SubscribeFilter,
};

use super::fleet::{forward_topic, presence_filter, presence_topic, Fleet};
use super::order::{Sequencer, Step};
use super::outbox::{Outbox, Request};
use super::{bump, check_settings, drive_of, parse_batch, Backoff, MqttError, SourceStats};
use crate::{Batch, MqttSettings};

/// How the source orders and paces what it receives (defaults suit a plant network).
#[derive(Debug, Clone)]
pub struct SourceOptions {
    /// How long a drive's later batches wait for a missing `seq` before it is given up on.
    pub reorder_window: Duration,
    /// At most this many batches held per drive while waiting (then the gap is given up on).
    pub max_held: usize,
    /// MQTT keep-alive: how soon a dead connection is noticed.
    pub keep_alive: Duration,
    /// Largest message accepted, bytes (a second of 1 kHz readings is about 60 kB of JSON).
    pub max_message_bytes: usize,
}

impl Default for SourceOptions {
    fn default() -> Self {
        SourceOptions {
            reorder_window: Duration::from_millis(250),
            max_held: 64,
            keep_alive: Duration::from_secs(5),
            max_message_bytes: 4 << 20,
        }
    }
}

/// The running MQTT source. Dropping it (or [`MqttSource::stop`]) says goodbye to the broker
/// and joins its thread; the broker keeps the session for the next start with the same id.
pub struct MqttSource {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    stats: Arc<SourceStats>,
    instances: Arc<AtomicU64>,
}

impl MqttSource {
    /// Connects (in the background, retrying with backoff) and starts handing batches to `tx`.
    pub fn start(
        settings: &MqttSettings,
        options: SourceOptions,
        tx: Sender<Batch>,
    ) -> Result<MqttSource, MqttError> {
        check_settings(settings)?;
        let mut mqtt = MqttOptions::new(&settings.client_id, &settings.host, settings.port);
        mqtt.set_clean_session(false)
            .set_manual_acks(true)
            .set_keep_alive(options.keep_alive.max(Duration::from_secs(1)))
            .set_max_packet_size(options.max_message_bytes, options.max_message_bytes);
        let prefix = settings.topic_prefix.clone();
        if settings.share_group.is_some() {
            let p = presence_topic(&prefix, &settings.client_id);
            // An instance that dies unannounced is cleared by the broker: an empty retained will.
            mqtt.set_last_will(LastWill::new(&p, Vec::new(), QoS::AtLeastOnce, true));
        }
        let (client, connection) = Client::new(mqtt, 1024);
        let stats = Arc::new(SourceStats::default());
        let stop = Arc::new(AtomicBool::new(false));
        let instances = Arc::new(AtomicU64::new(1));
        let worker = Worker {
            out: Outbox::new(client),
            prefix,
            share_group: settings.share_group.clone(),
            fleet: settings
                .share_group
                .as_ref()
                .map(|_| Fleet::new(&settings.client_id)),
            order: Sequencer::new(options.reorder_window, options.max_held),
            tx,
            stats: stats.clone(),
            stop: stop.clone(),
            instances: instances.clone(),
            ready: Vec::new(),
        };
        let thread = std::thread::Builder::new()
            .name(format!("mqtt-source-{}", settings.client_id))
            .spawn(move || worker.run(connection, options.reorder_window))
            .map_err(|e| MqttError::Client(format!("cannot start the source thread: {e}")))?;
        Ok(MqttSource {
            stop,
            thread: Some(thread),
            stats,
            instances,
        })
    }

    /// The source's counters (shared: read them while it runs).
    pub fn stats(&self) -> Arc<SourceStats> {
        self.stats.clone()
    }

    /// How many instances (this one included) share the fleet as this one sees them.
    pub fn instances(&self) -> u64 {
        self.instances.load(Ordering::Relaxed)
    }

    /// Says goodbye and joins the thread. Sharing a fleet, it first leaves the shared
    /// subscription (else the broker would keep queueing a share of the messages for this
    /// instance's session) and clears its presence, so the others take its drives.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        let Some(thread) = self.thread.take() else {
            return;
        };
        self.stop.store(true, Ordering::Relaxed);
        let _ = thread.join();
    }
}

impl Drop for MqttSource {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// The shared subscription of group `group` to every drive's readings.
fn shared_filter(group: &str, prefix: &str) -> String {
    format!("$share/{group}/{prefix}/+/readings")
}

/// Leaving the broker in order: a shared-subscription member clears its presence and
/// unsubscribes (and waits for the broker's confirmation), passes on to the drives' new owners
/// what still comes until 200 ms pass without a message, then disconnects; at most 2 s in all.
struct Leave {
    deadline: Instant,
    unsubscribing: bool,
    last_message: Instant,
    said_goodbye: bool,
}

impl Leave {
    const QUIET: Duration = Duration::from_millis(200);

    /// `shared`: whether it leaves a shared subscription (else it says goodbye at once).
    fn new(shared: bool) -> Self {
        let now = Instant::now();
        Leave {
            deadline: now + Duration::from_secs(2),
            unsubscribing: shared,
            last_message: if shared { now } else { now - Self::QUIET },
            said_goodbye: false,
        }
    }

    fn unsubscribed(&mut self) {
        self.unsubscribing = false;
        self.last_message = Instant::now();
    }

    fn received(&mut self) {
        self.last_message = Instant::now();
    }

    /// Advances; true when the thread should end now.
    fn step(&mut self, out: &mut Outbox) -> bool {
        let now = Instant::now();
        if now >= self.deadline {
            return true;
        }
        let drained = !self.unsubscribing && now.duration_since(self.last_message) >= Self::QUIET;
        if drained && !self.said_goodbye {
            self.said_goodbye = true;
            out.push(Request::Disconnect);
        }
        false
    }
}

/// The source thread's state.
struct Worker {
    out: Outbox,
    prefix: String,
    share_group: Option<String>,
    fleet: Option<Fleet>,
    order: Sequencer<(Batch, Publish)>,
    tx: Sender<Batch>,
    stats: Arc<SourceStats>,
    stop: Arc<AtomicBool>,
    instances: Arc<AtomicU64>,
    ready: Vec<Step<(Batch, Publish)>>,
}

/// The engine's end of the channel is gone: stop without acknowledging.
struct Closed;

impl Worker {
    fn run(mut self, mut connection: Connection, window: Duration) {
        let mut backoff = Backoff::new();
        let mut connected = false;
        let mut leave: Option<Leave> = None;
        loop {
            if leave.is_none() && self.stop.load(Ordering::Relaxed) {
                leave = Some(self.start_leaving(window, connected));
            }
            if let Some(l) = &mut leave {
                if !connected || l.step(&mut self.out) {
                    return;
                }
            }
            // While connected, wake up often enough to give up on gaps; while connecting, block
            // (a timed-out poll would restart the connection attempt).
            self.out.flush();
            let tick = if self.order.holding() || leave.is_some() || self.out.waiting() {
                (window / 4).clamp(Duration::from_millis(5), Duration::from_millis(50))
            } else {
                Duration::from_millis(500)
            };
            let event = if connected {
                match connection.recv_timeout(tick) {
                    Ok(e) => e,
                    Err(RecvTimeoutError::Timeout) => {
                        if self.expire().is_err() {
                            return;
                        }
                        continue;
                    }
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            } else {
                match connection.recv() {
                    Ok(e) => e,
                    Err(_) => return,
                }
            };
            match event {
                Ok(Event::Incoming(Packet::ConnAck(_))) => {
                    connected = true;
                    backoff.reset();
                    bump(&self.stats.connections, 1);
                    self.on_connect();
                }
                Ok(Event::Incoming(Packet::SubAck(_))) => bump(&self.stats.subscribed, 1),
                Ok(Event::Incoming(Packet::UnsubAck(_))) => {
                    if let Some(l) = &mut leave {
                        l.unsubscribed();
                    }
                }
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    if let Some(l) = &mut leave {
                        l.received();
                    }
                    if self.on_publish(p).is_err() {
                        return;
                    }
                }
                Ok(Event::Outgoing(Outgoing::Disconnect)) => return,
                Ok(_) => {}
                Err(_) => {
                    connected = false;
                    if leave.is_some() {
                        return;
                    }
                    bump(&self.stats.connection_errors, 1);
                    self.sleep(backoff.step());
                }
            }
            if self.expire().is_err() {
                return;
            }
        }
    }

    /// Begins leaving: hands on what waits for a gap, and leaves the shared subscription.
    fn start_leaving(&mut self, window: Duration, connected: bool) -> Leave {
        let mut ready = std::mem::take(&mut self.ready);
        self.order
            .expire(Instant::now() + window, &self.stats, &mut ready);
        self.ready = ready;
        let _ = self.hand_on();
        let shared = self
            .share_group
            .as_ref()
            .map(|g| shared_filter(g, &self.prefix));
        if let (Some(fleet), Some(f), true) = (&mut self.fleet, &shared, connected) {
            // Goodbye first, so the others stop passing batches here, then out of the share.
            fleet.leave();
            self.out.push(Request::Publish {
                topic: presence_topic(&self.prefix, fleet.me()),
                payload: Vec::new(),
                retain: true,
            });
            self.out.push(Request::Unsubscribe(f.clone()));
        }
        Leave::new(shared.is_some() && connected)
    }

    /// Sleeps `d`, waking early when asked to stop.
    fn sleep(&self, d: Duration) {
        let end = Instant::now() + d;
        while Instant::now() < end && !self.stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(20).min(end - Instant::now()));
        }
    }

    /// (Re)subscribes on every connection (harmless when the broker kept the session, needed
    /// when it did not) and announces this instance.
    fn on_connect(&mut self) {
        let p = &self.prefix;
        let filters = match (&self.share_group, &self.fleet) {
            (Some(g), Some(fleet)) => vec![
                shared_filter(g, p),
                presence_filter(p),
                forward_topic(p, fleet.me(), "+"),
            ],
            _ => vec![format!("{p}/+/readings")],
        };
        let filters = filters
            .into_iter()
            .map(|f| SubscribeFilter::new(f, QoS::AtLeastOnce))
            .collect();
        self.out.push(Request::Subscribe(filters));
        if let Some(fleet) = &self.fleet {
            self.out.push(Request::Publish {
                topic: presence_topic(p, fleet.me()),
                payload: b"online".to_vec(),
                retain: true,
            });
        }
    }

    fn on_publish(&mut self, p: Publish) -> Result<(), Closed> {
        let topic = p.topic.clone();
        if let Some(fleet) = &mut self.fleet {
            let presence_prefix = presence_topic(&self.prefix, "");
            if let Some(id) = topic.strip_prefix(&presence_prefix) {
                fleet.presence(id, &p.payload);
                self.instances.store(fleet.len() as u64, Ordering::Relaxed);
                self.out.push(Request::Ack(p));
                return Ok(());
            }
        }
        let (drive, forwarded) = match self.readings_drive(&topic) {
            Some(d) => d,
            None => {
                self.out.push(Request::Ack(p));
                return Ok(());
            }
        };
        bump(&self.stats.received, 1);
        let batch = match parse_batch(&drive, &p.payload) {
            Ok(b) => b,
            Err(_) => {
                bump(&self.stats.malformed, 1);
                self.out.push(Request::Ack(p));
                return Ok(());
            }
        };
        // A forwarded batch is this instance's to handle, unless it is leaving: then it passes
        // every batch on to the drive's new owner.
        let pass_to = match &self.fleet {
            Some(f) if !forwarded || f.leaving() => {
                f.owner(&drive).filter(|o| *o != f.me()).map(str::to_string)
            }
            _ => None,
        };
        if let Some(owner) = pass_to {
            self.out.push(Request::Publish {
                topic: forward_topic(&self.prefix, &owner, &drive),
                payload: p.payload.to_vec(),
                retain: false,
            });
            bump(&self.stats.forwarded, 1);
            self.out.push(Request::Ack(p));
            return Ok(());
        }
        let seq = batch.seq;
        let mut ready = std::mem::take(&mut self.ready);
        self.order.offer(
            &drive,
            seq,
            (batch, p),
            Instant::now(),
            &self.stats,
            &mut ready,
        );
        self.ready = ready;
        self.hand_on()
    }

    /// The drive of a readings topic, and whether another instance passed it on to this one.
    fn readings_drive(&self, topic: &str) -> Option<(String, bool)> {
        if let Some(d) = drive_of(&self.prefix, topic) {
            return Some((d, false));
        }
        let fleet = self.fleet.as_ref()?;
        let own = forward_topic(&self.prefix, fleet.me(), "");
        let own = own.strip_suffix("//readings")?;
        drive_of(own, topic).map(|d| (d, true))
    }

    fn expire(&mut self) -> Result<(), Closed> {
        let mut ready = std::mem::take(&mut self.ready);
        self.order.expire(Instant::now(), &self.stats, &mut ready);
        self.ready = ready;
        self.hand_on()
    }

    /// Hands the ready batches on in order, acknowledging each after it is handed on.
    fn hand_on(&mut self) -> Result<(), Closed> {
        for step in self.ready.drain(..) {
            match step {
                Step::Deliver((batch, p)) => {
                    self.tx.send(batch).map_err(|_| Closed)?;
                    bump(&self.stats.delivered, 1);
                    self.out.push(Request::Ack(p));
                }
                Step::Duplicate((_, p)) => {
                    self.out.push(Request::Ack(p));
                }
            }
        }
        Ok(())
    }
}
