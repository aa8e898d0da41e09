//! The command line's face of each surrogate kind (`rom::Kind`): which flag sets which input,
//! and the refusal of a required flag left out. The command modules never match on the kind; this table does, once.

use fom::params::Variable;
use rom::Kind;

use crate::args::PredictArgs;

/// The flag that sets a design variable in `rom predict`.
pub fn flag_of(v: Variable) -> &'static str {
    match v {
        Variable::CenterDistance => "--d",
        Variable::Friction => "--mu",
        Variable::InstallationTension => "--tension",
        Variable::AxialStiffness => "--stiffness",
        Variable::Effect(_) => "--effect",
        Variable::SideGap => "--side-gap",
        Variable::LoadTorque => "--load-torque",
        Variable::ShaftLoad => "--shaft-load",
    }
}

/// The message of a required input left out.
fn missing(kind: Kind, v: Variable) -> String {
    match (kind, v) {
        (Kind::Slip, Variable::CenterDistance) => "--d (the centre distance, m) is required: \
             the surrogate predicts slip at a centre distance"
            .into(),
        _ => format!("{} is required by the {}", flag_of(v), kind.name()),
    }
}

/// Refuses a request that leaves out an input the kind requires; `given` are the variables
/// the flags set. (Inputs the model was not trained on are refused before, the same way for
/// every kind: `rom::inputs::refuse_untrained`.)
pub fn check_request(kind: Kind, given: &[Variable]) -> Result<(), String> {
    match kind.required().iter().find(|v| !given.contains(v)) {
        Some(v) => Err(missing(kind, *v)),
        None => Ok(()),
    }
}

/// The flag that sets `v`, naming an effect parameter's key (`--effect NAME.KEY`).
pub fn flag_for(v: Variable) -> String {
    match v {
        Variable::Effect(_) => format!("{} {}", flag_of(v), v.key()),
        _ => flag_of(v).to_string(),
    }
}

/// The design variables `rom predict`'s flags set, with their values (effect parameters
/// from `--effect NAME:KEY=VALUE`).
pub fn given_inputs(a: &PredictArgs) -> Result<Vec<(Variable, f64)>, String> {
    let mut given: Vec<(Variable, f64)> = [
        (Variable::CenterDistance, a.d),
        (Variable::SideGap, a.side_gap),
        (Variable::LoadTorque, a.load_torque),
        (Variable::ShaftLoad, a.shaft_load),
        (Variable::Friction, a.mu),
        (Variable::InstallationTension, a.tension),
        (Variable::AxialStiffness, a.stiffness),
    ]
    .into_iter()
    .filter_map(|(v, x)| Some((v, x?)))
    .collect();
    for spec in &a.effects {
        if spec.params.is_empty() {
            return Err(format!(
                "--effect {}: name the parameter, NAME:KEY=VALUE",
                spec.to_spec()
            ));
        }
        for (key, value) in &spec.params {
            let full = format!("{}.{key}", spec.name);
            let var = Variable::from_key(&full)
                .filter(|v| matches!(v, Variable::Effect(_)))
                .ok_or_else(|| format!("--effect: `{full}` is not an effect parameter"))?;
            let x: f64 = value
                .parse()
                .map_err(|_| format!("--effect {full}: `{value}` is not a number"))?;
            given.push((var, x));
        }
    }
    Ok(given)
}

/// Name of the model file `rom train` writes into the data set when `--model` is not given.
pub fn file_in_data_set(kind: Kind) -> &'static str {
    match kind {
        Kind::Slip => "surrogate.json",
        Kind::ToothLoad => "tooth-surrogate.json",
    }
}

/// Monte Carlo points of the refused-share estimate (standard error below 0.07 pp at 1 %).
const REFUSED_SHARE_SAMPLES: usize = 20_000;

/// What `rom train` prints of a model it fitted to `ds` in `fit_s` seconds and wrote to
/// `path`.
pub fn fit_summary(
    file: &rom::ModelFile,
    path: &std::path::Path,
    ds: &training::Dataset,
    fit_s: f64,
) -> String {
    match file {
        rom::ModelFile::Slip(f) => slip_summary(&f.surrogate, path, ds, fit_s),
        rom::ModelFile::ToothLoad(f) => {
            let s = &f.surrogate;
            format!(
                "tooth-load surrogate {}: {} runs ({} failed or unbalanced), {} modes ({:.3} % \
                 energy), leave-one-out error (rms) {:.1} % in the mean pass peak and {:.1} % in \
                 the run's largest tooth load, sd factor {:.2}, fitted in {:.1} s",
                path.display(),
                s.training_runs,
                s.failed_runs,
                s.model.means.len(),
                100.0 * s.model.basis.energy_kept,
                100.0 * s.loo_rms_rel[0],
                100.0 * s.loo_rms_rel[1],
                s.std_calibration,
                fit_s
            )
        }
    }
}

/// [`fit_summary`] of a slip surrogate: the fit, the knee-aligned exponent, the refused share
/// of the box and how to calibrate its intervals.
fn slip_summary(
    s: &rom::Surrogate,
    path: &std::path::Path,
    ds: &training::Dataset,
    fit_s: f64,
) -> String {
    let mut t = format!(
        "surrogate {}: {} runs ({} failed, unsettled or unbalanced; {} on the gross-slip branch, above {} %, left out), start-up {} modes ({:.3} % energy), steady {} modes \
         ({:.3} % energy), leave-one-out sd factor {:.2} ({} at the knee), fitted in {:.1} s",
        path.display(),
        s.training_runs,
        s.failed_runs,
        s.gross_slip_runs,
        rom::surrogate::GROSS_SLIP_PCT,
        s.startup.means.len(),
        100.0 * s.startup.basis.energy_kept,
        s.steady.means.len(),
        100.0 * s.steady.basis.energy_kept,
        s.std_calibration,
        s.std_calibration_knee.map_or_else(
            || "the same".to_string(),
            |k| format!("{k:.2}")
        ),
        fit_s
    );
    if s.friction_exponent_likelihoods.len() > 1 {
        let tried: Vec<String> = s
            .friction_exponent_likelihoods
            .iter()
            .map(|(c, ll)| format!("{c} ({ll:.1})"))
            .collect();
        t += &format!(
            "\nknee-aligned input u mu^c: c = {} by likelihood; tried (log likelihood): {}",
            s.aligned_capacity.map_or(0.0, |a| a.friction_exponent),
            tried.join(", ")
        );
    }
    t += &format!(
        "\ndomain: {:.2} % of the trained box is refused, as looser than any training run (rom \
         predict names the nearest accepted point) or predicted beyond the trained slip",
        100.0 * s.refused_share(&ds.config, REFUSED_SHARE_SAMPLES)
    );
    t += &format!(
        "\n90 % intervals: leave-one-out, which overstates them after refinement rounds; to \
         calibrate them on held-out runs, `rom validate --model {m} --json V.json` (uniform and \
         --knee, seeds other than {seed}) then `rom validate --model {m} --calibrate-intervals \
         V.json,... --out FILE`",
        m = path.display(),
        seed = s.settings.seed
    );
    t
}
