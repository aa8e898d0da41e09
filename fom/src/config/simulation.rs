//! `[simulation]`: time integration, output and when a run ends.

use serde::{Deserialize, Deserializer, Serialize};

use super::exact_array;
use super::limits::{
    finite_all, positive, MAX_OUTPUT_ROWS, MAX_STEPS, OUTPUT_ROW_BYTES, RELAXATION_MAX_S,
};
// The steady-window lengths are the statistics leaf's (`steady.rs` imports nothing of the
// crate), so the configuration stays a leaf of the model.
use crate::steady::{MIN_WINDOW_S, SHORTEST_WINDOW_S};

/// The integrator step of a configuration: `step_s = 1.0e-5` or `step_s = "auto"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepSize {
    /// A fixed step, s.
    Seconds(f64),
    /// The largest stable step that divides the output interval, chosen when the model is
    /// built (it depends on the belt, the effects and the design point).
    Auto,
}

impl Serialize for StepSize {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            StepSize::Seconds(v) => s.serialize_f64(*v),
            StepSize::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for StepSize {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Word(String),
        }
        match Raw::deserialize(d) {
            Ok(Raw::Number(v)) => Ok(StepSize::Seconds(v)),
            Ok(Raw::Word(w)) if w == "auto" => Ok(StepSize::Auto),
            _ => Err(serde::de::Error::custom(
                "step_s must be a number of seconds or \"auto\"",
            )),
        }
    }
}

/// Time integration and output settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SimulationConfig {
    /// Simulated time after static equilibrium, s.
    pub duration_s: f64,
    /// Integrator step: seconds, below the explicit stability limit (checked when the model is
    /// built), or `"auto"`: the largest step within that limit that divides the output
    /// interval (`Model::resolve_step`).
    pub step_s: StepSize,
    /// Interval of the output rows, s; each row holds the mean over the preceding interval.
    pub output_interval_s: f64,
    /// Start of the steady window, s, fixed by the user; absent (the default), the one
    /// steady-state definition (`fom::steady`) finds it. Either way the summary says whether
    /// the run had settled.
    #[serde(default)]
    pub steady_start_s: Option<f64>,
    /// Run until settled (`fom::steady`): `duration_s` is then the longest run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until_settled: Option<UntilSettled>,
    /// Gravity vector in the drive plane, m/s^2 (x along the line of centres, y up).
    #[serde(default, deserialize_with = "exact_array")]
    pub gravity_m_s2: [f64; 2],
}

/// Ending a run once it has settled.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UntilSettled {
    /// The run is not stopped before this time, s.
    pub min_duration_s: f64,
    /// Steady running needed before the run stops, s (at least `fom::steady::SHORTEST_WINDOW_S`).
    pub steady_length_s: f64,
}

impl UntilSettled {
    /// Least window the settling verdict rests on, s: the default's, or the steady length if
    /// shorter. The run goes on until the steady window found is `steady_length_s` long, so
    /// the start-up is never forced into it.
    pub fn judging_window_s(&self) -> f64 {
        MIN_WINDOW_S.min(self.steady_length_s)
    }
}

impl Default for UntilSettled {
    /// At least 3 s (the default drive's fan runs up in about 1.5 s) and 2 s of steady running
    /// (2000 samples at 1 kHz), as training had before runs ended on settling.
    fn default() -> Self {
        Self {
            min_duration_s: 3.0,
            steady_length_s: 2.0,
        }
    }
}

/// Checks a run's step `step_s` (fixed, or chosen by `Model::resolve_step`) against its output
/// interval and the step-count limit `MAX_STEPS`.
pub(crate) fn check_step_count(s: &SimulationConfig, step_s: f64) -> Result<(), String> {
    if s.output_interval_s < step_s {
        return Err(format!(
            "simulation.output_interval_s = {} is shorter than simulation.step_s = {step_s}",
            s.output_interval_s
        ));
    }
    let steps = (s.duration_s + RELAXATION_MAX_S) / step_s;
    if steps > MAX_STEPS {
        return Err(format!(
            "simulation.step_s = {step_s} over simulation.duration_s = {} s (plus up to {} s of \
             static-equilibrium search) makes {steps:.3e} steps; at most {MAX_STEPS:.0e} \
             (about 16 days on one core): lengthen the step (step_s = \"auto\" picks the \
             largest stable one) or shorten the run",
            s.duration_s, RELAXATION_MAX_S
        ));
    }
    Ok(())
}

impl SimulationConfig {
    /// The table's first error, naming the key and the offending value.
    pub(crate) fn check(&self) -> Result<(), String> {
        let s = self;
        positive("simulation.duration_s", s.duration_s)?;
        positive("simulation.output_interval_s", s.output_interval_s)?;
        // The run's rows are kept in memory until it ends: refuse what would not fit rather
        // than abort on the allocation.
        let rows = s.duration_s / s.output_interval_s;
        if rows > MAX_OUTPUT_ROWS {
            return Err(format!(
                "simulation.duration_s = {} at simulation.output_interval_s = {} makes {rows:.3e} \
                 output rows ({:.1} GB in memory); at most {MAX_OUTPUT_ROWS:.0e}: lengthen the \
                 output interval or shorten the run",
                s.duration_s,
                s.output_interval_s,
                rows * OUTPUT_ROW_BYTES as f64 / 1e9
            ));
        }
        if let StepSize::Seconds(step_s) = s.step_s {
            positive("simulation.step_s", step_s)?;
            check_step_count(s, step_s)?;
        }
        if s.duration_s < 2.0 * s.output_interval_s {
            return Err(format!(
                "simulation.duration_s = {} is shorter than two output intervals ({} s): the \
                 run would have no rows to summarise",
                s.duration_s,
                2.0 * s.output_interval_s
            ));
        }
        if let Some(t) = s.steady_start_s {
            if !(t.is_finite() && t >= 0.0 && t < s.duration_s) {
                return Err(format!(
                    "simulation.steady_start_s = {t} must lie in [0, duration_s = {})",
                    s.duration_s
                ));
            }
        }
        if let Some(u) = s.until_settled {
            positive("simulation.until_settled.min_duration_s", u.min_duration_s)?;
            if !(u.steady_length_s >= SHORTEST_WINDOW_S
                && u.steady_length_s <= u.min_duration_s.min(s.duration_s))
            {
                return Err(format!(
                    "simulation.until_settled.steady_length_s = {} must lie in [{}, \
                     min(min_duration_s = {}, duration_s = {})]",
                    u.steady_length_s, SHORTEST_WINDOW_S, u.min_duration_s, s.duration_s
                ));
            }
        }
        finite_all("simulation.gravity_m_s2", &s.gravity_m_s2)?;
        Ok(())
    }
}
