//! `rom predict`: the surrogate's answer at a design point, whatever its kind (`rom::Kind`:
//! slip, or a toothed belt's tooth loads). The kind names its inputs, predicts and renders;
//! `crate::kinds` words the refusal of a flag it does not take.

use fom::params::Variable;
use fom::DesignPoint;
use rom::kind::Request;
use rom::ModelFile;

use super::CommandResult;
use crate::args::{Format, PredictArgs};
use crate::kinds;

pub fn run(a: PredictArgs) -> CommandResult {
    // Both outputs are checked before any work and renamed into place together at the end
    // (docs/decisions/output-files.md).
    let mut outputs = fom::output::OutputSet::new();
    for (path, flag) in [(&a.plot, "--plot"), (&a.startup, "--startup")] {
        if let Some(p) = path {
            outputs.add(p, flag)?;
        }
    }
    let (model, cfg) = ModelFile::open(a.model.as_deref(), a.config.as_deref())?;
    let kind = model.kind();
    let given = kinds::given_inputs(&a)?;
    let vars: Vec<Variable> = given.iter().map(|(v, _)| *v).collect();
    kinds::check_request(kind, &vars).map_err(|message| super::UsageError {
        kind: clap::error::ErrorKind::MissingRequiredArgument,
        message,
    })?;
    let named: Vec<(String, Variable)> = given
        .iter()
        .map(|(v, _)| (kinds::flag_for(*v), *v))
        .collect();
    rom::inputs::refuse_untrained(
        kind.name(),
        &named,
        &model.ranges().variables(),
        kinds::flag_for,
    )?;
    let mut q = DesignPoint::nominal(&cfg);
    // The installation tension a request leaves open is the configuration's own setting.
    if kind.inputs().contains(&Variable::InstallationTension) && a.tension.is_none() {
        q.installation_tension_n = cfg
            .belt
            .installation_tension_n
            .ok_or("the surrogate's configuration has no installation tension; pass --tension")?;
    }
    for (v, x) in given {
        q.set(v, x);
    }
    let startup = match &a.startup {
        Some(p) => Some((p, model.startup_series(&cfg, &q).ok_or(EXTRAS)?)),
        None => None,
    };
    let request = Request {
        point: q,
        samples: a.samples,
        allow_extrapolation: a.allow_extrapolation,
    };
    let pred = model.predict(&cfg, &request)?;
    let out = match a.format {
        Format::Text => pred.to_text() + "\n",
        Format::Json => pred.to_json(model.model_id()) + "\n",
        Format::Csv => pred.to_csv(),
    };
    if let Some(p) = &a.plot {
        let (title, spec) = pred.box_plot().ok_or(EXTRAS)?;
        outputs.write_with(p, |tmp| rom::plot::box_plot_svg(tmp, &title, &[spec]))?;
    }
    if let Some((p, rows)) = startup {
        let mut text = String::from("time_s,slip_pct\n");
        for [t, v] in rows {
            text += &format!("{t:.3},{v:.5}\n");
        }
        outputs.write(p, |w| w.write_all(text.as_bytes()))?;
    }
    outputs.commit()?;
    print!("{out}");
    Ok(())
}

/// The refusal of `--plot` or `--startup` by a kind without a box plot or start-up series.
const EXTRAS: &str = "--plot and --startup belong to the slip surrogate";
