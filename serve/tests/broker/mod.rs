//! A real Mosquitto broker for the tests (on 127.0.0.1, a free port, persistence in a temporary
//! folder), stopped by its guard; plus a test publisher and subscriber. Install the broker with
//! `bash .ci/install/mosquitto.sh`.

#![allow(dead_code)]

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rumqttc::{Client, Event, MqttOptions, Outgoing, Packet, QoS};
use serve::MqttSettings;

/// The broker executable, or a failure saying how to install it.
fn mosquitto() -> PathBuf {
    let on_path = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .chain([PathBuf::from("/usr/sbin")])
        .map(|d| d.join("mosquitto"))
        .find(|p| p.is_file());
    on_path.unwrap_or_else(|| {
        panic!("mosquitto (the MQTT broker) is not installed: run `bash .ci/install/mosquitto.sh`")
    })
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("no free port on 127.0.0.1")
        .port()
}

/// A running Mosquitto; killed when dropped.
pub struct Broker {
    pub port: u16,
    dir: tempfile::TempDir,
    child: Option<Child>,
}

impl Broker {
    pub fn start() -> Broker {
        let dir = tempfile::tempdir().unwrap();
        let mut b = Broker {
            port: free_port(),
            dir,
            child: None,
        };
        b.launch();
        b
    }

    fn launch(&mut self) {
        let conf = self.dir.path().join("mosquitto.conf");
        let data = self.dir.path().join("data");
        std::fs::create_dir_all(&data).unwrap();
        // Started as root, mosquitto drops to its own user: let it write its log and data here.
        for d in [self.dir.path(), data.as_path()] {
            std::fs::set_permissions(d, std::os::unix::fs::PermissionsExt::from_mode(0o777))
                .unwrap();
        }
        let text = format!(
            "listener {} 127.0.0.1\nallow_anonymous true\npersistence true\n\
             persistence_location {}/\nlog_dest file {}\nmax_queued_messages 10000\nlog_type all\n",
            self.port,
            data.display(),
            self.dir.path().join("mosquitto.log").display()
        );
        std::fs::write(&conf, text).unwrap();
        let child = Command::new(mosquitto())
            .arg("-c")
            .arg(&conf)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("cannot start mosquitto");
        self.child = Some(child);
        let end = Instant::now() + Duration::from_secs(10);
        while TcpStream::connect(("127.0.0.1", self.port)).is_err() {
            assert!(
                Instant::now() < end,
                "mosquitto did not listen on port {} within 10 s; its log: {}",
                self.port,
                self.log()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("mosquitto.log")).unwrap_or_default()
    }

    /// Stops the broker as a service manager would (SIGTERM: it saves its persistence file).
    pub fn stop(&mut self) {
        if let Some(mut child) = self.child.take() {
            // The shell's own `kill`: no procps needed.
            let _ = Command::new("sh")
                .arg("-c")
                .arg(format!("kill -TERM {}", child.id()))
                .status();
            let end = Instant::now() + Duration::from_secs(5);
            while child.try_wait().ok().flatten().is_none() && Instant::now() < end {
                std::thread::sleep(Duration::from_millis(10));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    /// Starts it again on the same port with the same persistence folder.
    pub fn restart(&mut self) {
        self.stop();
        self.launch();
    }

    pub fn data_dir(&self) -> &Path {
        self.dir.path()
    }

    pub fn settings(&self, prefix: &str, client_id: &str, group: Option<&str>) -> MqttSettings {
        MqttSettings {
            host: "127.0.0.1".into(),
            port: self.port,
            topic_prefix: prefix.into(),
            client_id: client_id.into(),
            share_group: group.map(str::to_string),
        }
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// A batch payload of `n` readings numbered `seq` (or without `seq`).
pub fn batch_json(seq: Option<u64>, n: usize) -> Vec<u8> {
    let t0 = seq.unwrap_or(0) as f64 * n as f64 * 1e-3;
    let time_s: Vec<f64> = (0..n).map(|i| t0 + i as f64 * 1e-3).collect();
    let mut v = serde_json::json!({
        "time_s": time_s,
        "driver_rpm": vec![1450.0; n],
        "driven_rpm": vec![935.5; n],
    });
    if let Some(s) = seq {
        v["seq"] = s.into();
    }
    serde_json::to_vec(&v).unwrap()
}

/// A message a test client received: topic, payload, retained flag.
pub type Received = (String, Vec<u8>, bool);

/// A test client on its own polling thread; counts the broker's acknowledgements and keeps
/// what arrives on its subscriptions.
pub struct TestClient {
    pub client: Client,
    acked: Arc<AtomicU64>,
    suback: Arc<AtomicU64>,
    pub received: Arc<Mutex<Vec<Received>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl TestClient {
    /// A persistent-session client (`clean_session = false`) that keeps retrying the broker.
    pub fn connect(port: u16, id: &str) -> TestClient {
        let mut o = MqttOptions::new(id, "127.0.0.1", port);
        o.set_clean_session(false)
            .set_keep_alive(Duration::from_secs(5))
            .set_max_packet_size(1 << 20, 1 << 20);
        let (client, mut connection) = Client::new(o, 10_000);
        let acked = Arc::new(AtomicU64::new(0));
        let suback = Arc::new(AtomicU64::new(0));
        let received = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (a, s, r, halt) = (
            acked.clone(),
            suback.clone(),
            received.clone(),
            stop.clone(),
        );
        let thread = std::thread::spawn(move || loop {
            match connection.recv() {
                Ok(Ok(Event::Incoming(Packet::PubAck(_)))) => {
                    a.fetch_add(1, Ordering::Relaxed);
                }
                Ok(Ok(Event::Incoming(Packet::SubAck(_)))) => {
                    s.fetch_add(1, Ordering::Relaxed);
                }
                Ok(Ok(Event::Incoming(Packet::Publish(p)))) => {
                    r.lock()
                        .unwrap()
                        .push((p.topic.clone(), p.payload.to_vec(), p.retain));
                }
                Ok(Ok(Event::Outgoing(Outgoing::Disconnect))) | Err(_) => return,
                Ok(Ok(_)) => {}
                Ok(Err(_)) if halt.load(Ordering::Relaxed) => return,
                Ok(Err(_)) => std::thread::sleep(Duration::from_millis(50)),
            }
        });
        TestClient {
            client,
            acked,
            suback,
            received,
            stop,
            thread: Some(thread),
        }
    }

    pub fn publish(&self, topic: &str, payload: Vec<u8>) {
        self.client
            .publish(topic, QoS::AtLeastOnce, false, payload)
            .unwrap();
    }

    /// Waits until the broker has acknowledged `n` publications in all.
    pub fn wait_acked(&self, n: u64) {
        wait_for(Duration::from_secs(10), "the broker's acks", || {
            self.acked.load(Ordering::Relaxed) >= n
        });
    }

    pub fn subscribe(&self, filter: &str) {
        let before = self.suback.load(Ordering::Relaxed);
        self.client.subscribe(filter, QoS::AtLeastOnce).unwrap();
        wait_for(Duration::from_secs(10), "the subscription", || {
            self.suback.load(Ordering::Relaxed) > before
        });
    }
}

impl Drop for TestClient {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        let _ = self.client.disconnect();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Polls `cond` every 5 ms; fails naming `what` after `limit`.
pub fn wait_for(limit: Duration, what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + limit;
    while !cond() {
        assert!(
            Instant::now() < end,
            "timed out after {limit:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}
