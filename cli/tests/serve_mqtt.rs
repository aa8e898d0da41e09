//! `rom serve` over MQTT, end to end, against a real Mosquitto on 127.0.0.1 (started by
//! `serve/tests/broker/`): a loose-belt recording's batches published by a gateway reach the
//! server through its persistent session, and the drive's state topic says `loose`.

#[path = "../../serve/tests/broker/mod.rs"]
mod broker;

use std::collections::BTreeMap;
use std::time::Duration;

use broker::{wait_for, Broker, TestClient};
use serve::replay::{ReplayOptions, Stream};

use crate::support::{get, serve_http, workspace};

#[test]
fn a_loose_belt_published_over_mqtt_turns_its_state_topic_loose() {
    let broker = Broker::start();
    let dir = tempfile::tempdir().unwrap();
    let conf = dir.path().join("serve.toml");
    std::fs::write(
        &conf,
        format!(
            "[mqtt]\nhost = \"127.0.0.1\"\nport = {}\ntopic_prefix = \"plant\"\n\
             client_id = \"rom-serve\"\n",
            broker.port
        ),
    )
    .unwrap();
    // The server's persistent session exists before it starts: the broker keeps for it what
    // the gateway publishes meanwhile.
    drop({
        let c = TestClient::connect(broker.port, "rom-serve");
        c.subscribe("plant/+/readings");
        c
    });
    let bms = TestClient::connect(broker.port, "bms");
    bms.subscribe("plant/+/state");
    let gateway = TestClient::connect(broker.port, "gateway");
    // d3 (lost tension at the shortest centre distance) and d0 (healthy), 40 s of each.
    let set = twin::measured::read_dataset(
        &workspace().join("examples/data/loose"),
        twin::signal::MIN_STEADY_SAMPLES,
    )
    .unwrap();
    let opts = ReplayOptions {
        speed: 0.0,
        duration_s: Some(40.0),
    };
    let mut seq: BTreeMap<String, u64> = BTreeMap::new();
    let mut sent = 0;
    for mut b in Stream::new(set, opts, &BTreeMap::new()) {
        if b.drive != "d3" && b.drive != "d0" {
            continue;
        }
        let s = seq.entry(b.drive.clone()).or_default();
        b.seq = Some(*s);
        *s += 1;
        let topic = format!("plant/{}/readings", b.drive);
        gateway.publish(&topic, serde_json::to_vec(&b).unwrap());
        sent += 1;
    }
    gateway.wait_acked(sent);
    let db = dir.path().join("serve.db");
    let (_server, _lines, addr) = serve_http([
        "--config".as_ref(),
        conf.as_os_str(),
        "--db".as_ref(),
        db.as_os_str(),
    ]);
    let states = || -> Vec<(String, serde_json::Value)> {
        bms.received
            .lock()
            .unwrap()
            .iter()
            .map(|(t, p, _)| (t.clone(), serde_json::from_slice(p).unwrap()))
            .collect()
    };
    wait_for(
        Duration::from_secs(120),
        "d3's state topic to say loose",
        || {
            states()
                .iter()
                .any(|(t, e)| t == "plant/d3/state" && e["to"] == "loose")
        },
    );
    let d0_loose = states()
        .into_iter()
        .filter(|(t, e)| t == "plant/d0/state" && e["to"] != "healthy")
        .collect::<Vec<_>>();
    assert!(
        d0_loose.is_empty(),
        "the healthy drive left healthy: {d0_loose:?}"
    );
    // The API shows the MQTT source's counts: every batch the gateway sent handed on once,
    // none malformed or doubled.
    let counts = || -> serde_json::Value {
        serde_json::from_str::<serde_json::Value>(&get(&addr, "/api/counters")).unwrap()
            ["source_counters"]
            .clone()
    };
    wait_for(
        Duration::from_secs(30),
        "the API to count every batch delivered",
        || counts()["delivered"] == sent,
    );
    let c = counts();
    assert_eq!(c["malformed"], 0, "{c}");
    assert_eq!(c["duplicates"], 0, "{c}");
    assert!(c["connections"].as_u64() >= Some(1), "{c}");
}
