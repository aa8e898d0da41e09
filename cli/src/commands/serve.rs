//! `rom serve`: the online twin over a replayed data set or an MQTT broker (and the HTTP API
//! and dashboard; state changes and alarms also to the broker when `serve.toml` names one).

use std::collections::BTreeMap;
use std::sync::mpsc::{channel, Receiver};
use std::sync::Arc;

use serve::config::{Models, ServeConfig};
use serve::http::{Http, Server};
use serve::mqtt::{MqttError, MqttSink, MqttSource, SourceOptions, SourceStats};
use serve::replay::{self, ReplayOptions, Stream};
use serve::store::Store;
use serve::{Batch, Engine, MqttSettings, Sink};

use super::CommandResult;
use crate::args::ServeArgs;

pub fn run(a: ServeArgs) -> CommandResult {
    let conf = match &a.config {
        Some(p) => ServeConfig::read(p)?,
        None => ServeConfig::default(),
    };
    if a.replay.is_none() && conf.mqtt.is_none() {
        return Err(
            "no source of readings: give --replay DIR (a measured data set), or an [mqtt] \
                    table in --config serve.toml (docs/guide/serve-mqtt.md)"
                .into(),
        );
    }
    // Bad input (data set, address) is refused before the database is created.
    let set = match &a.replay {
        Some(dir) => Some(twin::measured::read_dataset(
            dir,
            twin::signal::MIN_STEADY_SAMPLES,
        )?),
        None => None,
    };
    let listener = a.http.as_deref().map(serve::http::bind).transpose()?;
    let models = if conf.drive.is_empty() {
        Models::shipped()?
    } else {
        conf.models()?
    };
    // State changes and alarms go to the broker when serve.toml names one.
    let named = |e: MqttError| match &a.config {
        Some(p) => format!("{}: {e}", p.display()),
        None => e.to_string(),
    };
    let mut sinks: Vec<Box<dyn Sink>> = Vec::new();
    if let Some(m) = &conf.mqtt {
        sinks.push(Box::new(MqttSink::start(m, SINK_QUEUE).map_err(named)?));
    }
    let store = Store::open(&a.db, conf.retention_days)?;
    let mut engine = Engine::new(models, Some(store), sinks)?;
    engine.start_gap_checks(conf.gap_settings())?;
    match (set, &conf.mqtt) {
        (Some(set), _) => replay(&a, set, listener, engine),
        (None, Some(m)) => {
            let (tx, rx) = channel();
            let source = MqttSource::start(m, SourceOptions::default(), tx).map_err(named)?;
            live(&a, engine, &rx, m, listener, source.stats())?;
            source.stop();
            Ok(())
        }
        (None, None) => Ok(()),
    }
}

/// Events waiting for the broker before the publisher drops them (it never blocks the twin).
const SINK_QUEUE: usize = 4096;

/// The HTTP API and dashboard on the bound listener, if any.
fn serve_http(
    listener: Option<Server>,
    engine: &Engine,
    a: &ServeArgs,
    source: Option<Arc<SourceStats>>,
) -> Result<Option<Http>, Box<dyn std::error::Error>> {
    listener
        .map(|server| serve::http::start(server, engine.view(), &a.db, source))
        .transpose()
}

/// Readings from the MQTT source until the process is stopped.
fn live(
    a: &ServeArgs,
    mut engine: Engine,
    rx: &Receiver<Batch>,
    m: &MqttSettings,
    listener: Option<Server>,
    source: Arc<SourceStats>,
) -> CommandResult {
    let http = serve_http(listener, &engine, a, Some(source))?;
    eprintln!(
        "listening on mqtt://{}:{} for {}/+/readings{}",
        m.host,
        m.port,
        m.topic_prefix,
        http.as_ref()
            .map(|h| format!("; serving http://{}", h.addr))
            .unwrap_or_default()
    );
    engine.run(rx)?;
    Ok(())
}

/// A measured data set replayed as if live.
fn replay(
    a: &ServeArgs,
    set: twin::measured::DataSet,
    listener: Option<Server>,
    mut engine: Engine,
) -> CommandResult {
    let opts = ReplayOptions {
        speed: a.speed,
        duration_s: a.duration,
    };
    let resume: BTreeMap<String, f64> = set
        .labels()
        .into_iter()
        .filter_map(|l| engine.recorded_until_s(&l).map(|t| (l, t)))
        .collect();
    let stream = Stream::new(set, opts, &resume);
    let (d1, d2) = stream.diameters_m();
    for label in stream.labels() {
        engine.set_diameters(&label, d1, d2);
    }
    let http = serve_http(listener, &engine, a, None)?;
    if let Some(h) = &http {
        eprintln!(
            "serving http://{} (the dashboard, and the API under /api/)",
            h.addr
        );
    }
    let (rx, replayer) = replay::spawn(stream, a.speed);
    engine.run(&rx)?;
    // Every gap check that became due is stored before the replay's summary.
    let (running, waiting) = engine.gap_queue();
    let checks = usize::from(running.is_some()) + waiting.len();
    if checks > 0 {
        eprintln!(
            "replay read; finishing {checks} background gap check(s) before the summary \
             (about a minute of CPU each; Ctrl-C stops)"
        );
    }
    engine.wait_gap_checks()?;
    replayer
        .join()
        .map_err(|_| "the replay thread stopped unexpectedly")?;
    print!("{}", summary(&engine));
    if let Some(h) = http {
        eprintln!(
            "replay done; serving http://{} until stopped (Ctrl-C)",
            h.addr
        );
        h.wait();
    }
    Ok(())
}

/// One line per drive: its state, segments and latest estimate.
fn summary(engine: &Engine) -> String {
    let view = engine.view();
    let v = view.read().map_err(|_| ()).ok();
    let mut out = String::from("drive  state            segments | latest d estimate (m) [90 %]\n");
    for (id, d) in v.iter().flat_map(|v| v.drives.iter()) {
        let est = d
            .estimate
            .as_ref()
            .and_then(|e| {
                Some(format!(
                    "{:.4} [{:.4}, {:.4}]",
                    e["center_distance_m"].as_f64()?,
                    e["center_distance_90_m"][0].as_f64()?,
                    e["center_distance_90_m"][1].as_f64()?
                ))
            })
            .unwrap_or_else(|| "-".into());
        let state = d.state.map(|s| serde_json::to_value(s).unwrap_or_default());
        out += &format!(
            "{id:<6} {:<16} {:>8} | {est}\n",
            state.as_ref().and_then(|s| s.as_str()).unwrap_or("-"),
            d.segments
        );
    }
    out
}
