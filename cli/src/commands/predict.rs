//! `rom predict`: the surrogate's slip distribution at a design point.

use fom::params::Variable;
use fom::DesignPoint;

use super::{load_model, CommandResult};
use crate::args::{Format, PredictArgs};

pub fn run(a: PredictArgs) -> CommandResult {
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let nominal = DesignPoint::nominal(&cfg);
    let mut q = DesignPoint {
        center_distance_m: a.d,
        friction: a.mu.unwrap_or(nominal.friction),
        installation_tension_n: match (a.tension, cfg.belt.installation_tension_n) {
            (Some(t), _) | (None, Some(t)) => t,
            (None, None) => {
                return Err(
                    "the surrogate's configuration has no installation tension; pass --tension"
                        .into(),
                )
            }
        },
        axial_stiffness_n: a.stiffness,
        effects: Default::default(),
        side_gap_m: None,
    };
    for spec in &a.effect_params {
        let (key, value) = spec
            .split_once('=')
            .ok_or_else(|| format!("--effect-param `{spec}` is not EFFECT.KEY=VALUE"))?;
        let var = Variable::from_key(key.trim())
            .filter(|v| matches!(v, Variable::Effect(_)))
            .ok_or_else(|| format!("--effect-param: `{key}` is not an effect parameter"))?;
        let x: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("--effect-param {key}: `{value}` is not a number"))?;
        q.set(var, x);
    }
    let dist =
        rom::predict_distribution(&file.surrogate, &cfg, &q, a.samples, a.allow_extrapolation)?;
    let out = match a.format {
        Format::Text => dist.to_text() + "\n",
        Format::Json => serde_json::to_string_pretty(&dist)? + "\n",
        Format::Csv => dist.to_csv(),
    };
    if let Some(p) = &a.plot {
        let q = &dist.quantiles_pct;
        rom::plot::box_plot_svg(
            p,
            &format!("Predicted slip at d = {:.4} m", dist.center_distance_m),
            &[rom::plot::BoxSpec {
                category: format!("d = {:.4} m", dist.center_distance_m),
                series: "twin (surrogate)".into(),
                quantiles: [q.p05, q.p25, q.p50, q.p75, q.p95],
            }],
        )?;
    }
    if let Some(p) = &a.startup {
        let series = file.surrogate.predict_startup(&cfg, &q);
        let mut text = String::from("time_s,slip_pct\n");
        for (t, v) in file.surrogate.startup_time_s.iter().zip(series) {
            text += &format!("{t:.3},{v:.5}\n");
        }
        fom::output::write_atomic(p, |w| w.write_all(text.as_bytes()))?;
    }
    print!("{out}");
    Ok(())
}
