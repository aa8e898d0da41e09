//! `rom predict`: the surrogate's slip distribution at a design point.

use fom::config::BeltKind;
use fom::params::Variable;
use fom::DesignPoint;
use rom::tooth::ToothSurrogateFile;

use super::{load_model, CommandResult};
use crate::args::{Format, PredictArgs};

pub fn run(a: PredictArgs) -> CommandResult {
    if is_tooth_prediction(&a)? {
        return run_tooth(&a);
    }
    // Both outputs are checked before any work and renamed into place together at the end
    // (docs/decisions/output-files.md).
    let mut outputs = fom::output::OutputSet::new();
    for (path, flag) in [(&a.plot, "--plot"), (&a.startup, "--startup")] {
        if let Some(p) = path {
            outputs.add(p, flag)?;
        }
    }
    let d = a.d.ok_or(
        "--d (the centre distance, m) is required: the surrogate predicts slip at a centre \
         distance",
    )?;
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    let trained: Vec<Variable> = file
        .surrogate
        .settings
        .ranges()
        .iter()
        .map(|r| r.0)
        .collect();
    rom::inputs::refuse_untrained("slip surrogate", &given_inputs(&a)?, &trained, flag_of)?;
    let nominal = DesignPoint::nominal(&cfg);
    let mut q = DesignPoint {
        center_distance_m: d,
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
        load_torque_nm: None,
        shaft_load_n: None,
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
        outputs.write_with(p, |tmp| {
            rom::plot::box_plot_svg(
                tmp,
                &format!("Predicted slip at d = {:.4} m", dist.center_distance_m),
                &[rom::plot::BoxSpec {
                    category: format!("d = {:.4} m", dist.center_distance_m),
                    series: "twin (surrogate)".into(),
                    quantiles: [q.p05, q.p25, q.p50, q.p75, q.p95],
                }],
            )
        })?;
    }
    if let Some(p) = &a.startup {
        let series = file.surrogate.predict_startup(&cfg, &q);
        let mut text = String::from("time_s,slip_pct\n");
        for (t, v) in file.surrogate.startup_time_s.iter().zip(series) {
            text += &format!("{t:.3},{v:.5}\n");
        }
        outputs.write(p, |w| w.write_all(text.as_bytes()))?;
    }
    outputs.commit()?;
    print!("{out}");
    Ok(())
}

/// Whether the prediction is a toothed belt's tooth loads: `--model` is a tooth-load
/// surrogate, or (without `--model`) `--config` is a toothed drive.
fn is_tooth_prediction(a: &PredictArgs) -> Result<bool, Box<dyn std::error::Error>> {
    Ok(match (&a.model, &a.config) {
        (Some(m), _) => ToothSurrogateFile::is_tooth_file(m),
        (None, Some(c)) => fom::DriveConfig::from_file(c)?.belt.kind == BeltKind::Toothed,
        (None, None) => false,
    })
}

/// `rom predict` on a toothed belt: the tooth-load surrogate at (side gap, load torque, shaft
/// load), each the configuration's unless given.
fn run_tooth(a: &PredictArgs) -> CommandResult {
    if a.plot.is_some() || a.startup.is_some() {
        return Err("--plot and --startup belong to the slip surrogate".into());
    }
    let path = match &a.model {
        Some(p) => p.clone(),
        None => super::shipped_file(rom::tooth::SHIPPED_TOOTH_MODEL_PATH)?,
    };
    let file = ToothSurrogateFile::load(&path)?;
    let trained: Vec<Variable> = file
        .surrogate
        .settings
        .ranges()
        .iter()
        .map(|r| r.0)
        .collect();
    rom::inputs::refuse_untrained("tooth-load surrogate", &given_inputs(a)?, &trained, flag_of)?;
    let cfg = file.drive_config(a.config.as_deref())?;
    let q = DesignPoint::nominal(&cfg).with_tooth_inputs(a.side_gap, a.load_torque, a.shaft_load);
    let pred = file.surrogate.predict(&cfg, &q, a.allow_extrapolation)?;
    let out = match a.format {
        Format::Text => pred.to_text() + "\n",
        Format::Json => serde_json::to_string_pretty(&pred)? + "\n",
        Format::Csv => pred.to_csv(),
    };
    print!("{out}");
    Ok(())
}

/// The flag that gives `v` (`--effect-param KEY` for an effect's parameter).
fn flag_of(v: Variable) -> String {
    match v {
        Variable::CenterDistance => "--d".into(),
        Variable::Friction => "--mu".into(),
        Variable::InstallationTension => "--tension".into(),
        Variable::AxialStiffness => "--stiffness".into(),
        Variable::SideGap => "--side-gap".into(),
        Variable::LoadTorque => "--load-torque".into(),
        Variable::ShaftLoad => "--shaft-load".into(),
        Variable::Effect(_) => format!("--effect-param {}", v.key()),
    }
}

/// The design variables the request gives, each with its flag (the surrogate refuses those it
/// was not trained on: `rom::inputs`).
fn given_inputs(a: &PredictArgs) -> Result<Vec<(String, Variable)>, String> {
    let mut given: Vec<Variable> = [
        (a.d.is_some(), Variable::CenterDistance),
        (a.mu.is_some(), Variable::Friction),
        (a.tension.is_some(), Variable::InstallationTension),
        (a.stiffness.is_some(), Variable::AxialStiffness),
        (a.side_gap.is_some(), Variable::SideGap),
        (a.load_torque.is_some(), Variable::LoadTorque),
        (a.shaft_load.is_some(), Variable::ShaftLoad),
    ]
    .into_iter()
    .filter_map(|(is, v)| is.then_some(v))
    .collect();
    for spec in &a.effect_params {
        let key = spec.split_once('=').map_or(spec.as_str(), |kv| kv.0).trim();
        given.push(
            Variable::from_key(key)
                .filter(|v| matches!(v, Variable::Effect(_)))
                .ok_or_else(|| format!("--effect-param: `{key}` is not an effect parameter"))?,
        );
    }
    Ok(given.into_iter().map(|v| (flag_of(v), v)).collect())
}
