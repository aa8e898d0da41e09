//! What names an effect by its own line (docs/decisions/gap-signature-line.md): the line rule,
//! how confirmation runs confirm such an effect, and the variants on a first effect's
//! harmonics that the forward selection leaves out (docs/decisions/gap-forward-selection.md).

use fom::stats::rms;

use super::ranking::RankContext;
use super::twin_runs::Variant;
use super::verdict::{reduction_of, EXPLAINED_SHARE};

/// Relative distance from a whole order within which a line counts as on a harmonic: the
/// speed ratio's departure from its pulleys' ratio is the slip, below 2 % in creep.
const HARMONIC_TOLERANCE: f64 = 0.02;

/// The variants whose own line lies on the second or third harmonic of variant `v0`'s line
/// at transmission ratio `ratio`: not looked for beside `v0`. An eccentric pulley's harmonics
/// grow faster than its runout (the second with its square), so the first effect's fit
/// misses part of them, and on amplitude cells that part cannot be told from another effect
/// on that line: at the shipped 2:1 drive the fan pulley's second harmonic is the motor
/// pulley's 1x line (docs/decisions/gap-forward-selection.md).
pub(super) fn on_a_harmonic(vars: &[Variant], v0: usize, ratio: f64, blades: u32) -> Vec<usize> {
    let Some(f0) = vars[v0].line_order(ratio, blades) else {
        return Vec::new();
    };
    (0..vars.len())
        .filter(|&v| {
            vars[v].line_order(ratio, blades).is_some_and(|f| {
                v != v0
                    && [2.0, 3.0]
                        .iter()
                        .any(|k| (f / (k * f0) - 1.0).abs() < HARMONIC_TOLERANCE)
            })
        })
        .collect()
}

/// Whether confirmation runs confirm the best candidate, and how: `Some(false)` by the whole
/// gap, `Some(true)` by its own line, `None` not at all. Named by its line in the fit
/// (`fit_by_line`), the runs must explain that line; named by the whole gap in the fit, they
/// must explain the whole gap, or else its own line, where it has one that stands out
/// (`line_explained`: false without one): a plant that answers the effect with another shape
/// than the twin's can leave the whole gap where the fit promised half, and the effect is then
/// named by what only it does (docs/decisions/gap-signature-line.md).
pub(super) fn confirmed_by(
    fit_by_line: bool,
    whole_explained: bool,
    line_explained: bool,
) -> Option<bool> {
    match (fit_by_line, whole_explained, line_explained) {
        (true, _, true) => Some(true),
        (true, _, false) => None,
        (false, true, _) => Some(false),
        (false, false, true) => Some(true),
        (false, false, false) => None,
    }
}

/// The line rule (docs/decisions/gap-signature-line.md): variant `v`'s own line
/// (`Variant::line_cells`) stands out of noise at a withheld label before (a cell beyond the
/// family-wise threshold) and the variant's fit removes at least half of the line cells'
/// excess over noise. Then the line's cells, their RMS z before and after (the fit as ranked:
/// twin-equivalent magnitude free up to `fit_bound`); `None` otherwise.
pub(super) fn line_rule(
    r: &RankContext,
    vars: &[Variant],
    v: usize,
) -> Option<(Vec<usize>, f64, f64)> {
    let cells = vars[v].line_cells();
    if cells.is_empty() {
        return None;
    }
    let before = r.oos_cells(&r.none(), false, &cells);
    let after = r.oos_cells(&r.variant(v, &vars[v]), true, &cells);
    line_explained(&before, &after, r.threshold).map(|(b, a)| (cells, b, a))
}

/// A line's withheld z before and after a fit: its RMS z before and after where a cell stood
/// beyond `threshold` before and the fit removes at least half of the excess over noise.
pub(super) fn line_explained(before: &[f64], after: &[f64], threshold: f64) -> Option<(f64, f64)> {
    if !before.iter().any(|z| z.abs() > threshold) {
        return None;
    }
    let (b, a) = (rms(before), rms(after));
    (reduction_of(b, a) >= EXPLAINED_SHARE).then_some((b, a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::features;
    use crate::gap::twin_runs::variants;

    #[test]
    fn runs_short_of_the_whole_gap_the_fit_promised_name_the_effect_by_its_line_if_they_explain_it()
    {
        // Named by the whole gap in the fit: the runs explain it, or else the line.
        assert_eq!(confirmed_by(false, true, true), Some(false));
        assert_eq!(confirmed_by(false, true, false), Some(false));
        assert_eq!(confirmed_by(false, false, true), Some(true));
        assert_eq!(confirmed_by(false, false, false), None);
        // Named by its line in the fit: the runs must explain the line.
        assert_eq!(confirmed_by(true, true, true), Some(true));
        assert_eq!(confirmed_by(true, false, true), Some(true));
        assert_eq!(confirmed_by(true, true, false), None);
    }

    #[test]
    fn a_line_out_of_noise_that_the_fit_halves_names_its_effect_and_others_do_not() {
        let threshold = 3.0;
        // The plant's line 12 and 8 sd above the twin's at two withheld labels; the fit of a
        // twin-equivalent magnitude leaves 2 and 1.
        let (b, a) = line_explained(&[12.0, 8.0], &[2.0, 1.0], threshold).expect("named");
        assert!((b - (104.0f64).sqrt()).abs() < 1e-12 && (a - (2.5f64).sqrt()).abs() < 1e-12);
        // Within noise before: nothing to name by.
        assert!(line_explained(&[2.5, -2.0], &[0.5, 0.2], threshold).is_none());
        // Out of noise, but the fit removes less than half of the excess (RMS 10 -> 6).
        assert!(line_explained(&[10.0, 10.0], &[6.0, 6.0], threshold).is_none());
    }

    #[test]
    fn the_motor_pulley_runout_is_not_looked_for_on_the_fan_pulley_runouts_second_harmonic() {
        let vars = variants(8);
        let find = |choice: &str| vars.iter().position(|v| v.choice == choice).unwrap();
        let (driver, driven) = (find("pulley=driver"), find("pulley=driven"));
        // The shipped 2:1 drive: the fan pulley's second harmonic is the motor's 1x line.
        assert_eq!(on_a_harmonic(&vars, driven, 2.0, 8), vec![driver]);
        // 3:1 too (the third harmonic), with the measured ratio 1 % off the pulleys'.
        assert_eq!(on_a_harmonic(&vars, driven, 3.03, 8), vec![driver]);
        // 2.5:1: the lines are apart; and the fan pulley's 1x is no harmonic of the motor's,
        // nor is the blade pass (4 motor orders at 2:1 with 8 blades).
        assert!(on_a_harmonic(&vars, driven, 2.5, 8).is_empty());
        assert!(on_a_harmonic(&vars, driver, 2.0, 8).is_empty());
        // A variant without a line has no harmonics.
        let drag = vars
            .iter()
            .position(|v| v.effect == "bearing-drag")
            .unwrap();
        assert!(on_a_harmonic(&vars, drag, 2.0, 8).is_empty());
    }

    #[test]
    fn each_line_belongs_to_one_effect_alone() {
        let vars = variants(8);
        let mut seen = std::collections::HashMap::new();
        for v in &vars {
            for i in v.line_cells() {
                let name = features::CELLS[i].name();
                assert!(name.contains("amplitude"), "{name}");
                if let Some(other) = seen.insert(i, v.spec(v.reference)) {
                    panic!(
                        "{name} is the line of both {other} and {}",
                        v.spec(v.reference)
                    );
                }
            }
        }
        // Both runouts and the blade pass have a line; drag, Stribeck and hysteresis none.
        let with_line: Vec<&str> = vars
            .iter()
            .filter(|v| !v.line_cells().is_empty())
            .map(|v| v.effect)
            .collect();
        assert_eq!(
            with_line,
            [
                "pulley-eccentricity",
                "pulley-eccentricity",
                "blade-pass-pulsation"
            ]
        );
    }
}
