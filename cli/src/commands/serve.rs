//! `rom serve`: the online twin over a replayed data set (and the HTTP API and dashboard).

use std::collections::BTreeMap;

use serve::config::{Models, ServeConfig};
use serve::replay::{self, ReplayOptions, Stream};
use serve::store::Store;
use serve::Engine;

use super::CommandResult;
use crate::args::ServeArgs;

pub fn run(a: ServeArgs) -> CommandResult {
    let conf = match &a.config {
        Some(p) => ServeConfig::read(p)?,
        None => ServeConfig::default(),
    };
    let Some(dir) = &a.replay else {
        return Err(
            "no source of readings: give --replay DIR (a measured data set); the MQTT \
                    source is configured by the [mqtt] table of --config serve.toml"
                .into(),
        );
    };
    let set = twin::measured::read_dataset(dir, twin::signal::MIN_STEADY_SAMPLES)?;
    let listener = a.http.as_deref().map(serve::http::bind).transpose()?;
    let models = if conf.drive.is_empty() {
        Models::shipped()?
    } else {
        conf.models()?
    };
    let store = Store::open(&a.db, conf.retention_days)?;
    let mut engine = Engine::new(models, Some(store), Vec::new())?;
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
    let http = match listener {
        Some(server) => {
            let h = serve::http::start(server, engine.view(), &a.db)?;
            eprintln!(
                "serving http://{} (the dashboard, and the API under /api/)",
                h.addr
            );
            Some(h)
        }
        None => None,
    };
    let (rx, replayer) = replay::spawn(stream, a.speed);
    engine.run(&rx)?;
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
