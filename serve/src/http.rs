//! The HTTP JSON API and the dashboard, on one thread of a small synchronous server
//! (`tiny_http`). Live state comes from the engine's view, history from the database through a
//! read-only connection. Schema: docs/guide/serve.md, "HTTP API".

use std::path::Path;
use std::sync::{Arc, RwLock};
use std::thread::JoinHandle;

use serde_json::{json, Value};
use tiny_http::{Header, Method, Request, Response};

use crate::mqtt::{SourceCounts, SourceStats};

/// The bound listener [`bind`] gives and [`start`] serves on.
pub use tiny_http::Server;

use crate::engine::{DriveStatus, FleetView};
use crate::store::Store;

/// Version of the API's JSON documents; raised when a field changes meaning or goes away.
pub const SCHEMA_VERSION: u32 = 1;

/// The running server.
pub struct Http {
    /// The address it listens on (the port the system picked when asked for port 0).
    pub addr: std::net::SocketAddr,
    thread: JoinHandle<()>,
}

impl Http {
    /// Blocks for as long as the server runs.
    pub fn wait(self) {
        let _ = self.thread.join();
    }
}

/// Binds `addr` (`host:port`; port 0 picks a free one), before anything else is started, so a
/// bad address fails the command with nothing written.
pub fn bind(addr: &str) -> Result<Server, Box<dyn std::error::Error>> {
    Ok(Server::http(addr).map_err(|e| format!("--http {addr}: cannot listen there: {e}"))?)
}

/// Answers on `server` from `view` and the database at `db`, on a thread of its own; `source`:
/// the MQTT source's counters, shown beside the engine's (none when replaying).
pub fn start(
    server: Server,
    view: Arc<RwLock<FleetView>>,
    db: &Path,
    source: Option<Arc<SourceStats>>,
) -> Result<Http, Box<dyn std::error::Error>> {
    let addr = server
        .server_addr()
        .to_ip()
        .ok_or("--http: not an IP address")?;
    let db = db.to_path_buf();
    let thread = std::thread::spawn(move || {
        let mut reader: Option<Store> = None;
        for req in server.incoming_requests() {
            let source = source.as_ref().map(|s| s.snapshot());
            let (status, body, kind) = answer(&req, &view, &db, &mut reader, source);
            let resp = Response::from_string(body)
                .with_status_code(status)
                .with_header(header("Content-Type", kind))
                .with_header(header("Cache-Control", "no-store"));
            let _ = req.respond(resp);
        }
    });
    Ok(Http { addr, thread })
}

fn header(k: &str, v: &str) -> Header {
    Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("ASCII header")
}

const JSON: &str = "application/json";

fn error(status: u16, message: String) -> (u16, String, &'static str) {
    (
        status,
        json!({"schema_version": SCHEMA_VERSION, "error": message}).to_string(),
        JSON,
    )
}

/// The drive as `GET /api/drives` lists it: its label, state, latest estimate with its 90 %
/// interval and class, and how current it is.
fn summary(d: &DriveStatus) -> Value {
    let latest = d.latest.as_ref();
    json!({
        "label": d.label,
        "state": d.state,
        "segments": d.segments,
        "last_reading_s": d.last_reading_s,
        "silent": d.silent,
        "estimate": d.estimate,
        "estimate_at_s": d.estimate_at_s,
        "measured": latest.and_then(|l| l.pointer("/verdict/measured")).cloned(),
        "misfit": latest.and_then(|l| l.pointer("/verdict/misfit")).cloned(),
        "trend": d.trend,
    })
}

fn answer(
    req: &Request,
    view: &RwLock<FleetView>,
    db: &Path,
    reader: &mut Option<Store>,
    source: Option<SourceCounts>,
) -> (u16, String, &'static str) {
    if req.method() != &Method::Get {
        return error(405, "only GET is served".into());
    }
    let url = req.url();
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let Ok(v) = view.read() else {
        return error(500, "the engine stopped".into());
    };
    let parts: Vec<String> = path
        .trim_matches('/')
        .split('/')
        .map(percent_decode)
        .collect();
    let parts: Vec<&str> = parts.iter().map(String::as_str).collect();
    match parts.as_slice() {
        [""] | ["index.html"] => (
            200,
            crate::dashboard::PAGE.to_string(),
            "text/html; charset=utf-8",
        ),
        ["assets", name] => match crate::dashboard::asset(name) {
            Some((body, kind)) => (200, body.to_string(), kind),
            None => error(404, format!("no asset {name:?}")),
        },
        ["api", "drives"] => (
            200,
            json!({
                "schema_version": SCHEMA_VERSION,
                "drives": v.drives.values().map(summary).collect::<Vec<_>>(),
                "counters": v.counters,
                "source_counters": source,
            })
            .to_string(),
            JSON,
        ),
        ["api", "counters"] => (
            200,
            json!({
                "schema_version": SCHEMA_VERSION,
                "counters": v.counters,
                "source_counters": source,
                "gap_check": {"running": v.gap_running, "queued": v.gap_queued},
                "drives": v
                    .drives
                    .iter()
                    .map(|(k, d)| (k.clone(), json!(d.counters)))
                    .collect::<serde_json::Map<String, Value>>(),
            })
            .to_string(),
            JSON,
        ),
        ["api", "drives", id] => match v.drives.get(*id) {
            Some(d) => (
                200,
                json!({"schema_version": SCHEMA_VERSION, "drive": d}).to_string(),
                JSON,
            ),
            None => error(404, format!("no drive {id:?}")),
        },
        ["api", "drives", id, what @ ("history" | "gap_reports")] => {
            if !v.drives.contains_key(*id) {
                return error(404, format!("no drive {id:?}"));
            }
            let id = id.to_string();
            drop(v);
            history(&id, what, query, db, reader)
        }
        _ => error(404, format!("no such page {path:?}")),
    }
}

/// `GET /api/drives/{id}/history?from=S&to=S`: the drive's segments whose end lies in the
/// range (drive clock, s; both optional), and its alarms there; `.../gap_reports?from=S&to=S`:
/// its gap checks whose `at_s` lies in the range.
fn history(
    id: &str,
    what: &str,
    query: &str,
    db: &Path,
    reader: &mut Option<Store>,
) -> (u16, String, &'static str) {
    let mut range = [f64::NEG_INFINITY, f64::INFINITY];
    for kv in query.split('&').filter(|s| !s.is_empty()) {
        let (k, val) = kv.split_once('=').unwrap_or((kv, ""));
        let slot = match k {
            "from" => 0,
            "to" => 1,
            _ => return error(400, format!("unknown query parameter {k:?} (from, to)")),
        };
        match percent_decode(val).parse::<f64>() {
            Ok(x) if !x.is_nan() => range[slot] = x,
            _ => return error(400, format!("`{k}` = {val:?} is not a number of seconds")),
        }
    }
    if reader.is_none() {
        match Store::open_reader(db) {
            Ok(s) => *reader = Some(s),
            Err(e) => return error(500, e.to_string()),
        }
    }
    let Some(store) = reader.as_ref() else {
        return error(500, "no database".into());
    };
    let mut doc = json!({
        "schema_version": SCHEMA_VERSION,
        "drive": id,
        "from_s": range[0].is_finite().then_some(range[0]),
        "to_s": range[1].is_finite().then_some(range[1]),
    });
    let found = if what == "gap_reports" {
        store
            .gap_reports(id, range[0], range[1])
            .map(|r| doc["gap_reports"] = json!(r))
    } else {
        store.history(id, range[0], range[1]).map(|(s, a)| {
            doc["segments"] = json!(s);
            doc["alarms"] = json!(a);
        })
    };
    match found {
        Ok(()) => (200, doc.to_string(), JSON),
        Err(e) => error(500, e.to_string()),
    }
}

/// `%XX` escapes of a URL part decoded (invalid ones kept as written).
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[i],
            b.get(i + 1).and_then(|&c| hex(c)),
            b.get(i + 2).and_then(|&c| hex(c)),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    #[test]
    fn percent_escapes_are_decoded() {
        assert_eq!(super::percent_decode("pump%201%2Fa"), "pump 1/a");
        assert_eq!(super::percent_decode("100%"), "100%");
    }
}
