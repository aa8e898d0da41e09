//! Signs that the twin cannot reproduce the targets.

use super::options::Target;
use super::result::{ConditionResult, Fitted};
use crate::inference::likelihood::misfit_variance;

/// The words of a flag that a fitted parameter sits at a bound of the trained box
/// (`misfit_flags`), which `bound_parameters` reads back.
const AT_BOUND: &str = "sits at its";

/// The words of such a flag where the parameter's 90 % interval lies inside the box.
const ALONG_RIDGE: &str = "the data leave it free along a ridge";

/// The parameters that `flags` (`misfit_flags`) say the data push against a bound of the
/// trained box (the fitted value and its 90 % interval at the bound), by name: the
/// calibration then holds a forced baseline. A parameter at a bound with its interval inside
/// is not one: the data leave it free along a ridge, and the prior or the search's end put it
/// there (a drive's distance and tension at one setting).
pub fn bound_parameters(flags: &[String]) -> Vec<&str> {
    flags
        .iter()
        .filter(|f| f.contains(AT_BOUND) && !f.contains(ALONG_RIDGE))
        .filter_map(|f| f.split(" = ").next())
        .collect()
}

/// Signs that the twin cannot reproduce the targets, each with what it means: a
/// fitted parameter at its bound (within 0.5 % of the range) while its posterior lies inside
/// (a ridge) or at it (the data want more); a measured slip beyond every training run's (with
/// the offset) or below the least; a residual beyond three standard deviations of the
/// calibration's own likelihood.
pub(super) fn misfit_flags(
    max_trained_slip_pct: Option<f64>,
    parameters: &[Fitted],
    bounds: &[[f64; 2]],
    conditions: &[ConditionResult],
    targets: &[Target],
    pred: &[(f64, f64)],
) -> Vec<String> {
    let mut flags = Vec::new();
    for (p, [lo, hi]) in parameters.iter().zip(bounds) {
        let edge = 0.005 * (hi - lo);
        for (bound, name) in [(*lo, "lower"), (*hi, "upper")] {
            if (p.value - bound).abs() <= edge {
                let inside = p.interval90[0] > lo + edge && p.interval90[1] < hi - edge;
                flags.push(format!(
                    "{} = {:.5} {AT_BOUND} {name} bound {bound}{}",
                    p.name,
                    p.value,
                    if inside {
                        format!(" while its 90 % interval lies inside: {ALONG_RIDGE}")
                    } else {
                        ": the data ask for more than the trained box holds".to_string()
                    }
                ));
            }
        }
    }
    let offset = parameters
        .iter()
        .find(|p| p.name == "slip_offset_pct")
        .map_or(0.0, |p| p.value);
    for ((c, t), (m, var)) in conditions.iter().zip(targets).zip(pred) {
        if let Some(max) = max_trained_slip_pct {
            if t.mean_slip_pct > max + offset {
                flags.push(format!(
                    "{}: measured slip {:.3} % is beyond every training run ({:.3} % with the \
                     offset): out of the twin's reach",
                    c.label,
                    t.mean_slip_pct,
                    max + offset
                ));
            }
        }
        let sd = misfit_variance(t.mean_se_pct, *var, t.mean_slip_pct).sqrt();
        let z = (t.mean_slip_pct - m) / sd;
        if z.abs() > 3.0 {
            flags.push(format!(
                "{}: the residual {:+.3} pp is {z:+.1} sd of what noise and the surrogate explain",
                c.label,
                t.mean_slip_pct - m
            ));
        }
    }
    flags
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_at_its_bound_a_slip_out_of_reach_and_a_large_residual_are_flagged() {
        let fitted = |name: &str, value, interval90| Fitted {
            name: name.into(),
            value,
            interval90,
        };
        let params = [
            fitted("friction", 0.7, [0.65, 0.75]),
            fitted("installation_tension_n", 150.0, [152.0, 190.0]),
            fitted("slip_offset_pct", 0.0, [-0.1, 0.1]),
        ];
        let bounds = [[0.6, 0.8], [150.0, 300.0], [-5.0, 5.0]];
        let target = |label: &str, slip| Target {
            label: label.into(),
            mean_slip_pct: slip,
            mean_se_pct: 0.001,
            known_center_distance_m: None,
            position: 0.0,
        };
        let condition = |label: &str, slip, twin| ConditionResult {
            label: label.into(),
            center_distance_m: 0.42,
            measured_mean_slip_pct: slip,
            twin_mean_slip_pct: twin,
            error_pct: 0.0,
            fom_mean_slip_pct: None,
            fom_error_pct: None,
        };
        let targets = [target("a", 0.70), target("b", 40.0), target("c", 1.0)];
        let conditions = [
            condition("a", 0.70, 0.70),
            condition("b", 40.0, 30.0),
            condition("c", 1.0, 0.8),
        ];
        let pred = [(0.70, 1e-6), (30.0, 1e-6), (0.8, 1e-6)];
        let flags = misfit_flags(Some(32.0), &params, &bounds, &conditions, &targets, &pred);
        // The tension at its lower bound with its interval inside: a ridge.
        assert!(flags[0].contains("installation_tension_n") && flags[0].contains("ridge"));
        assert!(flags
            .iter()
            .any(|f| f.starts_with("b:") && f.contains("reach")));
        // c misses by 0.2 pp against an sd of ~0.02 pp (2 % of 1 %).
        assert!(flags
            .iter()
            .any(|f| f.starts_with("c:") && f.contains("sd")));
        assert!(!flags
            .iter()
            .any(|f| f.starts_with("a:") || f.contains("friction")));
        // Read back: the tension's bound is a ridge's, not a forced baseline; a friction the
        // data push against its bound is.
        assert!(bound_parameters(&flags).is_empty(), "{flags:?}");
        let forced = [fitted("friction", 0.6, [0.6, 0.62])];
        let flags = misfit_flags(None, &forced, &[[0.6, 0.8]], &[], &[], &[]);
        assert!(flags[0].contains("ask for more"), "{flags:?}");
        assert_eq!(bound_parameters(&flags), ["friction"]);
    }
}
