//! The verdict's confirmation runs: at the fitted magnitude, and where they fall short, at a
//! searched magnitude or a re-fitted installation tension.

use super::super::confirmation::{confirm, over_tension, Confirmed, Run};
use super::super::ranking::RankContext;
use super::super::report::FailedRun;
use super::super::unfitted::{over_magnitude, MagnitudeSearch};
use super::super::Diagnosis;

/// The confirmation runs of the candidate `run`: at its fitted magnitude, and where they fall
/// short of what the fit promised (`explains`), again at the magnitude searched at the labels
/// no fold fits (`unfitted::over_magnitude`) and, unless those explain, at the installation
/// tension re-fitted within its posterior (`over_tension`); `short_confirmation` keeps one.
/// The runs, whether one failed, and the magnitude search where its runs are the ones kept.
pub(super) fn confirmation_runs(
    d: &Diagnosis,
    r: &RankContext,
    run: Run,
    line: &[usize],
    explains: impl Fn([f64; 2]) -> bool,
    failed_runs: &mut Vec<FailedRun>,
) -> (Option<Confirmed>, bool, Option<MagnitudeSearch>) {
    match confirm(d, r, run, line, failed_runs) {
        (Some(c), false) if !explains(c.rms_z) => {
            let by_magnitude = over_magnitude(d, r, run, line, failed_runs);
            let (c, s) = short_confirmation(by_magnitude, explains, || {
                over_tension(d, r, run, line, &c).unwrap_or(c)
            });
            (Some(c), false, s)
        }
        (c, failed) => (c, failed, None),
    }
}

/// Of the runs at a searched magnitude (with its search) and those at a re-fitted tension,
/// both made where the runs at the fitted magnitude fell short: the first where they explain
/// the gap (the tension search is then not run), the second where they do, else whichever
/// leaves the smaller withheld RMS z (docs/decisions/gap-unfitted-labels.md, "A named
/// effect's magnitude").
fn short_confirmation<S>(
    by_magnitude: Option<(Confirmed, S)>,
    explains: impl Fn([f64; 2]) -> bool,
    by_tension: impl FnOnce() -> Confirmed,
) -> (Confirmed, Option<S>) {
    match by_magnitude {
        Some((c, s)) if explains(c.rms_z) => (c, Some(s)),
        by_magnitude => {
            let t = by_tension();
            match by_magnitude {
                Some((c, s)) if !explains(t.rms_z) && c.rms_z[0] < t.rms_z[0] => (c, Some(s)),
                _ => (t, None),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(rms_z: f64) -> Confirmed {
        runs_with_line(rms_z, f64::NAN)
    }

    /// Runs leaving `rms_z` over all cells and `line` over the effect's line.
    fn runs_with_line(rms_z: f64, line: f64) -> Confirmed {
        Confirmed {
            rms_z: [rms_z, line],
            rows: Vec::new(),
            z_cells: Vec::new(),
            tension_n: None,
        }
    }

    /// The searched magnitude's runs that explain the gap are kept without a tension search;
    /// otherwise those at the re-fitted tension where they explain it, else the runs leaving
    /// the smaller withheld gap, and without a search those at the re-fitted tension.
    #[test]
    fn the_runs_kept_where_the_fitted_magnitude_falls_short() {
        let explains = |c: [f64; 2]| c[0] <= 1.5;
        let never = || -> Confirmed { panic!("no tension search where the magnitude explains") };
        let (c, s) = short_confirmation(Some((runs(1.0), "searched")), explains, never);
        assert_eq!((c.rms_z[0], s), (1.0, Some("searched")));
        let (c, s) = short_confirmation(Some((runs(3.0), "searched")), explains, || runs(4.0));
        assert_eq!((c.rms_z[0], s), (3.0, Some("searched")));
        let (c, s) = short_confirmation(Some((runs(5.0), "searched")), explains, || runs(4.0));
        assert_eq!((c.rms_z[0], s), (4.0, None));
        let (c, s) = short_confirmation(None::<(Confirmed, &str)>, explains, || runs(4.0));
        assert_eq!((c.rms_z[0], s), (4.0, None));
        // Named by its line: runs that explain the line are kept over runs that leave less
        // of the whole gap but not the line.
        let by_line = |c: [f64; 2]| c[1] <= 1.0;
        let searched = Some((runs_with_line(2.0, 3.0), "searched"));
        let (c, s) = short_confirmation(searched, by_line, || runs_with_line(2.5, 0.5));
        assert_eq!((c.rms_z, s), ([2.5, 0.5], None));
    }
}
