//! What a calibration found: the fitted parameters with their intervals, each condition's
//! match, the misfit flags and the posterior draws; as text.

use fom::DesignPoint;
use serde::Serialize;

/// Fitted values with 90 % intervals.
#[derive(Debug, Clone, Serialize)]
pub struct Fitted {
    pub name: String,
    pub value: f64,
    pub interval90: [f64; 2],
}

#[derive(Debug, Clone, Serialize)]
pub struct ConditionResult {
    pub label: String,
    pub center_distance_m: f64,
    pub measured_mean_slip_pct: f64,
    pub twin_mean_slip_pct: f64,
    pub error_pct: f64,
    /// The full-order model's slip at the fitted point (with the ratio correction), if run.
    pub fom_mean_slip_pct: Option<f64>,
    pub fom_error_pct: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    pub parameters: Vec<Fitted>,
    pub conditions: Vec<ConditionResult>,
    pub friction: f64,
    pub installation_tension_n: f64,
    pub slip_offset_pct: f64,
    /// Fitted effective axial stiffness, N (when free).
    pub axial_stiffness_n: Option<f64>,
    pub distances_m: Vec<f64>,
    /// (d_0, Delta) when the distances are equally spaced.
    pub spacing_m: Option<[f64; 2]>,
    pub within_tolerance: bool,
    pub tolerance_pct: f64,
    /// Full-order confirmations run (the update loop of the seed paper's Figure 1).
    pub confirmations: usize,
    /// Signs of misfit (see `misfit_flags`); empty when none.
    pub misfit: Vec<String>,
    /// Where the tension readings were taken in as the installation tension's prior: what
    /// they give, and what the speeds alone gave (`LocalFit::finish`); None otherwise.
    pub tension_prior: Option<TensionPrior>,
    /// Draws from the posterior (the Metropolis chains, thinned), for predictions with their
    /// spread (`predictive`).
    #[serde(skip)]
    pub posterior: Vec<Draw>,
}

/// The tension readings taken in as the installation tension's prior, where the calibration
/// from the speeds alone agreed with them within `misfit::TENSION_READING_Z` standard
/// deviations (docs/decisions/tension-reading.md, "Where the speeds agree").
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TensionPrior {
    /// The installation tension the readings give together, N, and its standard deviation.
    pub read_n: f64,
    pub read_sd_n: f64,
    /// The installation tension calibrated from the speeds alone, N, and its 90 % interval.
    pub speeds_only_n: f64,
    pub speeds_only_interval90: [f64; 2],
}

impl TensionPrior {
    /// One line: what the readings give and what the speeds alone gave.
    pub fn to_text(&self) -> String {
        format!(
            "installation tension from the tension readings, {:.1} +- {:.1} N, taken as its \
             prior, the speeds alone agreeing with it ({:.1} N, 90 % interval {:.1}-{:.1} N)",
            self.read_n,
            self.read_sd_n,
            self.speeds_only_n,
            self.speeds_only_interval90[0],
            self.speeds_only_interval90[1]
        )
    }
}

/// One posterior draw of a calibration's parameters.
#[derive(Debug, Clone, Copy)]
pub struct Draw {
    /// (d_0, Delta) when the distances are equally spaced.
    pub spacing_m: Option<[f64; 2]>,
    pub friction: f64,
    pub installation_tension_n: f64,
    pub slip_offset_pct: f64,
    pub axial_stiffness_n: Option<f64>,
}

impl Calibration {
    /// The fitted parameter named `name`, if free.
    pub fn parameter(&self, name: &str) -> Option<&Fitted> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// The 90 % posterior interval of parameter `name`; `[v, v]` when it was not fitted.
    pub fn interval90(&self, name: &str, v: f64) -> [f64; 2] {
        self.parameter(name).map_or([v, v], |p| p.interval90)
    }

    /// The calibrated design point at centre distance `d` (friction, tension, stiffness).
    pub fn design_point(&self, d: f64) -> DesignPoint {
        DesignPoint::drive(
            d,
            self.friction,
            self.installation_tension_n,
            self.axial_stiffness_n,
        )
    }

    pub fn to_text(&self) -> String {
        let mut t = String::from(
            "condition | centre distance (m) | measured mean slip (%) | surrogate slip (%) | \
             error (%) | twin (FOM) slip (%) | twin error (%)\n",
        );
        for c in &self.conditions {
            t += &format!(
                "{:<9} | {:>19.5} | {:>22.4} | {:>18.4} | {:>9.2} | {:>19} | {:>14}\n",
                c.label,
                c.center_distance_m,
                c.measured_mean_slip_pct,
                c.twin_mean_slip_pct,
                c.error_pct,
                c.fom_mean_slip_pct
                    .map_or("-".into(), |v| format!("{v:.4}")),
                c.fom_error_pct.map_or("-".into(), |v| format!("{v:.2}")),
            );
        }
        t += "fitted parameters (value, 90 % interval):\n";
        for p in &self.parameters {
            t += &format!(
                "  {:<28} {:.5}  [{:.5}, {:.5}]\n",
                p.name, p.value, p.interval90[0], p.interval90[1]
            );
        }
        t += &format!(
            "full-order confirmations: {}; all errors within {:.1} %: {}",
            self.confirmations,
            self.tolerance_pct,
            if self.within_tolerance { "yes" } else { "NO" }
        );
        if let Some(tp) = &self.tension_prior {
            t += &format!("\n{}", tp.to_text());
        }
        if !self.misfit.is_empty() {
            t += "\nmisfit:";
            for f in &self.misfit {
                t += &format!("\n  - {f}");
            }
            t += "\n  what the model misses: `rom gap --measured DIR` (recordings needed)";
        }
        t
    }
}

/// Each condition's match at the fitted point `p`: the surrogate's prediction `pred` and, if
/// run, the full-order model's slip `fom` (without the offset).
pub(super) fn conditions(
    targets: &[super::options::Target],
    p: &super::layout::Point,
    pred: &[(f64, f64)],
    fom: Option<&[f64]>,
) -> Vec<ConditionResult> {
    targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let err = |v: f64| 100.0 * (v - t.mean_slip_pct).abs() / t.mean_slip_pct;
            let f = fom.map(|f| f[i] + p.offset);
            ConditionResult {
                label: t.label.clone(),
                center_distance_m: p.d[i],
                measured_mean_slip_pct: t.mean_slip_pct,
                twin_mean_slip_pct: pred[i].0,
                error_pct: err(pred[i].0),
                fom_mean_slip_pct: f,
                fom_error_pct: f.map(err),
            }
        })
        .collect()
}
