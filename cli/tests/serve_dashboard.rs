//! The dashboard in a real browser: `rom serve` replays a small data set, headless Chromium
//! (driven over the DevTools protocol) loads the page, and the drives table, the states and
//! estimates it shows and its charts' data points are compared with the HTTP API.
//! Chromium comes from `.ci/install/chromium.sh`.

use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::support::{get, serve_http, stderr_lines, wait_line, workspace, Killed};

/// One DevTools session over a websocket: commands numbered, answers matched by id.
struct DevTools {
    ws: tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<TcpStream>>,
    next: u64,
}

impl DevTools {
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let msg = json!({"id": id, "method": method, "params": params}).to_string();
        self.ws.send(tungstenite::Message::text(msg)).unwrap();
        loop {
            let m = self.ws.read().unwrap();
            if let Ok(text) = m.to_text() {
                let v: Value = serde_json::from_str(text).unwrap_or(Value::Null);
                if v["id"] == json!(id) {
                    assert!(v.get("error").is_none(), "{method}: {v}");
                    return v["result"].clone();
                }
            }
        }
    }

    fn eval(&mut self, expr: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expr, "returnByValue": true}),
        );
        r["result"]["value"].clone()
    }
}

#[test]
fn the_dashboard_shows_what_the_api_reports() {
    if Command::new("chromium").arg("--version").output().is_err() {
        panic!("chromium is not installed: run .ci/install/chromium.sh (Debian's chromium)");
    }
    let dir = tempfile::tempdir().unwrap();
    let (loose, db) = (
        workspace().join("examples/data/loose"),
        dir.path().join("serve.db"),
    );
    let (_server, lines, addr) = serve_http([
        "--replay".as_ref(),
        loose.as_os_str(),
        "--speed".as_ref(),
        "0".as_ref(),
        "--duration".as_ref(),
        "9".as_ref(),
        "--db".as_ref(),
        db.as_os_str(),
    ]);
    wait_line(&lines, "replay done", 60);
    let api: Value = serde_json::from_str(&get(&addr, "/api/drives")).unwrap();
    assert_eq!(api["schema_version"], json!(1));
    let drives = api["drives"].as_array().unwrap();
    assert_eq!(drives.len(), 4);
    let first = drives[0]["label"].as_str().unwrap().to_string();
    let hist: Value =
        serde_json::from_str(&get(&addr, &format!("/api/drives/{first}/history"))).unwrap();
    let with = |key: &str| {
        hist["segments"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|s| !s["verdict"][key].is_null())
            .count()
    };
    assert!(with("estimate") > 0, "{hist}");

    let profile = dir.path().join("chromium-profile");
    let mut browser = Killed(
        Command::new("chromium")
            .args([
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--no-first-run",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg("about:blank")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let blines = stderr_lines(&mut browser.0);
    let listening = wait_line(&blines, "DevTools listening on ws://", 30);
    let debug_addr = listening
        .split("ws://")
        .nth(1)
        .and_then(|s| s.split('/').next())
        .unwrap()
        .to_string();
    let targets: Value = serde_json::from_str(&get(&debug_addr, "/json/list")).unwrap();
    let page = targets
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["type"] == "page")
        .expect("a page target");
    let (ws, _) = tungstenite::connect(page["webSocketDebuggerUrl"].as_str().unwrap()).unwrap();
    let mut dt = DevTools { ws, next: 0 };
    dt.call("Page.navigate", json!({"url": format!("http://{addr}/")}));
    let end = Instant::now() + Duration::from_secs(20);
    let shown = loop {
        let v = dt.eval(
            "(window.dash && dash.loaded && dash.points.slip > 0) ? JSON.stringify({ \
             drives: dash.drives, points: dash.points, selected: dash.selected, \
             rows: Array.from(document.querySelectorAll('#drives tbody tr')).map(r => \
               [r.dataset.drive, r.dataset.state, r.cells[3].textContent]), \
             gap: document.getElementById('gap').textContent }) : null",
        );
        if let Some(s) = v.as_str() {
            break serde_json::from_str::<Value>(s).unwrap();
        }
        assert!(Instant::now() < end, "the dashboard did not load its data");
        std::thread::sleep(Duration::from_millis(100));
    };
    let rows = shown["rows"].as_array().unwrap();
    assert_eq!(rows.len(), drives.len(), "{shown}");
    for (row, d) in rows.iter().zip(drives) {
        assert_eq!(row[0], d["label"], "{shown}");
        assert_eq!(row[1], d["state"], "{shown}");
        let e = &d["estimate"];
        let text = format!(
            "{:.4} [{:.4}, {:.4}]",
            e["center_distance_m"].as_f64().unwrap(),
            e["center_distance_90_m"][0].as_f64().unwrap(),
            e["center_distance_90_m"][1].as_f64().unwrap()
        );
        assert_eq!(row[2].as_str().unwrap(), text, "{shown}");
    }
    assert_eq!(shown["selected"], json!(first));
    assert_eq!(shown["points"]["slip"], json!(with("measured")), "{shown}");
    assert_eq!(
        shown["points"]["estimate"],
        json!(with("estimate")),
        "{shown}"
    );
    assert_eq!(shown["gap"], json!("no gap report yet"));
}
