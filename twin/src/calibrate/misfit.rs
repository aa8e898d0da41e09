//! Signs that the twin cannot reproduce the targets.

use super::options::Target;
use super::result::{ConditionResult, Fitted};
use crate::inference::likelihood::misfit_variance;

/// The words of a flag that a fitted parameter sits at a bound of the trained box
/// (`misfit_flags`), which `bound_parameters` reads back.
const AT_BOUND: &str = "sits at its";

/// The words of such a flag where the parameter's 90 % interval lies inside the box.
const ALONG_RIDGE: &str = "the data leave it free along a ridge";

/// The words of the flag `tension_reading_flag` raises, which `tension_reading_side` reads
/// back.
const FROM_READINGS: &str = "from the tension readings";

/// Where `flags` hold `tension_reading_flag`'s flag: the side the slips ask for against the
/// meter ("looser" or "tighter") and the flag itself.
pub fn tension_reading_side(flags: &[String]) -> Option<(&'static str, &str)> {
    let f = flags.iter().find(|f| f.contains(FROM_READINGS))?;
    let side = if f.contains("a looser belt") {
        "looser"
    } else {
        "tighter"
    };
    Some((side, f.split(": the slips").next().unwrap_or(f)))
}

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

/// How far, in standard deviations, the calibrated installation tension may lie from what the
/// tension readings give before `tension_reading_flag` flags it (as for a residual).
pub const TENSION_READING_Z: f64 = 3.0;

/// A sign that the slips ask for another installation tension than a tension meter reads:
/// the calibrated tension `t_n` (its 90 % interval from `parameters` where it was free, taken
/// as a normal's) against the readings' `(tension, sd)` in N (`layout::tension_from_readings`),
/// beyond `TENSION_READING_Z` standard deviations of both together. Where it is, the
/// calibration does not take the readings in: held at the meter's tension, the loosest labels'
/// slip becomes a gap that any effect raising it there explains, the twin's knee being placed
/// otherwise than the drive's among them; where it is not, they become the tension's prior
/// (`LocalFit::finish`; docs/decisions/tension-reading.md).
pub(super) fn tension_reading_flag(
    parameters: &[Fitted],
    t_n: f64,
    read: Option<(f64, f64)>,
) -> Option<String> {
    let (t_read, sd_read) = read?;
    // A normal's 90 % interval is 2 Z90 sd wide.
    let sd_fit = parameters
        .iter()
        .find(|p| p.name == "installation_tension_n")
        .map_or(0.0, |p| {
            (p.interval90[1] - p.interval90[0]) / (2.0 * fom::stats::Z90)
        });
    let z = (t_n - t_read) / sd_read.hypot(sd_fit);
    (z.abs() > TENSION_READING_Z).then(|| {
        format!(
            "installation_tension_n = {t_n:.1} N against {t_read:.1} +- {sd_read:.1} N \
             {FROM_READINGS} (z {z:+.1}): the slips ask for a {} belt than the meter reads, \
             so the slip is not the belt's tension at work (an effect, or the twin's knee placed \
             otherwise than the drive's)",
            if z < 0.0 { "looser" } else { "tighter" }
        )
    })
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
            tension_reading: None,
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

    /// The calibrated tension against the readings, in the sd of both together: flagged beyond
    /// three, with the side it lies on; its own interval widens what it may lie from them.
    #[test]
    fn a_calibrated_tension_the_readings_contradict_is_flagged_with_its_side() {
        let t = |value, interval90| {
            [Fitted {
                name: "installation_tension_n".into(),
                value,
                interval90,
            }]
        };
        let read = Some((250.0, 5.0));
        let looser = tension_reading_flag(&t(160.0, [157.0, 163.0]), 160.0, read).unwrap();
        assert!(
            looser.contains("z -16.9") && looser.contains("looser belt"),
            "{looser}"
        );
        let tighter = tension_reading_flag(&t(290.0, [287.0, 293.0]), 290.0, read).unwrap();
        assert!(tighter.contains("tighter belt"), "{tighter}");
        let flags = |f: &str| vec!["d3: a residual".to_string(), f.to_string()];
        assert_eq!(
            tension_reading_side(&flags(&looser)),
            Some((
                "looser",
                "installation_tension_n = 160.0 N against 250.0 +- 5.0 N from the tension \
                 readings (z -16.9)"
            ))
        );
        assert_eq!(tension_reading_side(&flags(&tighter)).unwrap().0, "tighter");
        assert_eq!(tension_reading_side(&flags("d3: a residual")), None);
        // 14 N off: 2.7 sd of the reading alone, so not flagged; 20 N off is flagged with a
        // narrow interval and not with one 33 N wide (sd 10 N: z 1.8).
        assert_eq!(
            tension_reading_flag(&t(236.0, [235.0, 237.0]), 236.0, read),
            None
        );
        assert!(tension_reading_flag(&t(230.0, [229.0, 231.0]), 230.0, read).is_some());
        assert_eq!(
            tension_reading_flag(&t(230.0, [213.5, 246.5]), 230.0, read),
            None
        );
        assert_eq!(
            tension_reading_flag(&t(160.0, [157.0, 163.0]), 160.0, None),
            None
        );
    }
}
