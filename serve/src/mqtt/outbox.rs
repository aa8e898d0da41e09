//! The source thread's requests to its MQTT client, in order and never blocking: the client's
//! request channel is drained only by the same thread's polling, so a blocking send into a full
//! channel (a burst of messages, each asking for an ack) would stall it for good. What does not
//! fit waits here and goes at the next turn of the loop.

use std::collections::VecDeque;

use rumqttc::{Client, Publish, QoS, SubscribeFilter};

/// One request to the client. Topics are valid by construction (checked settings, drive ids
/// read from topic names), so a refused request means a full channel.
pub(crate) enum Request {
    Ack(Publish),
    Publish {
        topic: String,
        payload: Vec<u8>,
        retain: bool,
    },
    Subscribe(Vec<SubscribeFilter>),
    Unsubscribe(String),
    Disconnect,
}

pub(crate) struct Outbox {
    client: Client,
    queue: VecDeque<Request>,
}

impl Outbox {
    pub(crate) fn new(client: Client) -> Self {
        Outbox {
            client,
            queue: VecDeque::new(),
        }
    }

    /// Sends `r` after whatever waits, or queues it.
    pub(crate) fn push(&mut self, r: Request) {
        self.queue.push_back(r);
        self.flush();
    }

    /// Sends what waits, in order, until the channel is full.
    pub(crate) fn flush(&mut self) {
        while let Some(r) = self.queue.front() {
            let sent = match r {
                Request::Ack(p) => self.client.try_ack(p),
                Request::Publish {
                    topic,
                    payload,
                    retain,
                } => self.client.try_publish(
                    topic.as_str(),
                    QoS::AtLeastOnce,
                    *retain,
                    payload.clone(),
                ),
                Request::Subscribe(f) => self.client.try_subscribe_many(f.clone()),
                Request::Unsubscribe(t) => self.client.try_unsubscribe(t.as_str()),
                Request::Disconnect => self.client.try_disconnect(),
            };
            if sent.is_err() {
                return;
            }
            self.queue.pop_front();
        }
    }

    /// Whether requests wait (the loop then turns often).
    pub(crate) fn waiting(&self) -> bool {
        !self.queue.is_empty()
    }
}
