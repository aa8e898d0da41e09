//! Stage "where": every cell of `features::CELLS` at every label compared with the twin,
//! z = (measured - twin) / sd, with sd from the measurement's standard error, the twin's, and
//! the twin's own tolerance (`twin_tolerance`). Also the nuisance column the candidates' fits
//! share (what the calibration's slip offset moves).

use super::baseline::LabelTwin;
use super::features::Features;
use super::features::{cell_index, wasserstein1, Band, Cell, Signal, Statistic, Window, CELLS};
use super::report::CellGap;
use crate::inference::likelihood::MODEL_DISCREPANCY;

/// (measured, twin, sd) of one cell at one label.
pub(super) type CellRow = (f64, f64, f64);

/// Whether a cell is a slip level (what the slip offset moves).
pub(super) fn is_slip_level(c: &Cell) -> bool {
    c.signal == Signal::Slip
        && matches!(
            c.statistic,
            Statistic::Mean | Statistic::P05 | Statistic::P50 | Statistic::P95
        )
}

/// How much the twin's reduced-resolution runs (`twin_runs::Resolution`) may misplace the
/// motor's torque, as a share of it: on the default drive's labels from tight to near the knee
/// they load the motor by 0.13-0.36 % more than full resolution (the belt's internal losses
/// depend on its segments; docs/validation/gap-model-forms.md, "The driver's speed level and
/// the reduced resolution").
const RESOLUTION_TORQUE_SHARE: f64 = 0.004;

/// The start-up cells' own uncertainty as a share of their value, 1 sd: the motor law's, the
/// inertias' and the reduced resolution's accuracy in timing a run-up (`twin_tolerance`).
pub(super) const STARTUP_MODEL_SHARE: f64 = 0.05;

/// The twin's own uncertainty of a cell beyond the two recordings' standard errors, 1 sd: the
/// slip level carries the surrogate's variance, the model discrepancy of the calibration
/// likelihood, the friction uncertainty and the calibration posterior's spread at the label
/// (`baseline::posterior_slip_sd`: large where the twin sits on its knee's cliff) (also
/// through the driven speed); the start-up,
/// timed by the motor law and inertias, 5 % of its value (the reduced resolution's and the
/// motor model's accuracy), the start-up slip also the calibration posterior's spread; every
/// other steady cell the friction uncertainty through the twin's runs (`run_spread`). On the
/// knee's cliff every cell not already carrying the posterior's spread gets the tension's
/// through the twin's runs (`baseline::tension_sd`) in quadrature. The driver's speed level
/// also carries the reduced resolution's misplacement of the motor's torque: well below the
/// breakdown slip the Kloss curve (fom/src/drive.rs) is a line through the synchronous speed,
/// so a torque share dT / T moves the speed by that share of the motor's slip speed,
/// dn = (n_sync - n) dT / T.
fn twin_tolerance(i: usize, lt: &LabelTwin, twin_value: f64) -> f64 {
    let c = &CELLS[i];
    let slip_sd = (lt.slip_sd_pct.powi(2)
        + (MODEL_DISCREPANCY * lt.slip_pct).powi(2)
        + lt.friction_sd_pct.powi(2)
        + lt.posterior_slip_sd_pct.powi(2))
    .sqrt();
    match (c.window, c.signal, c.statistic) {
        (Window::Steady, Signal::Slip, _) if is_slip_level(c) => slip_sd,
        (Window::Steady, Signal::DrivenSpeed, Statistic::Mean) => {
            lt.measured.frequencies_hz[1] * 60.0 / 100.0 * slip_sd
        }
        (Window::Steady, Signal::DriverSpeed, Statistic::Mean) => {
            let resolution = lt.synchronous_rpm.map_or(0.0, |n_sync| {
                RESOLUTION_TORQUE_SHARE * (n_sync - twin_value).max(0.0)
            });
            lt.run_spread[i]
                .hypot(tension_term(i, lt))
                .hypot(resolution)
        }
        (Window::StartUp, Signal::Slip, _) => {
            (STARTUP_MODEL_SHARE.hypot(lt.startup_share)) * twin_value.abs()
        }
        (Window::StartUp, _, _) => {
            (STARTUP_MODEL_SHARE * twin_value.abs()).hypot(tension_term(i, lt))
        }
        _ => lt.run_spread[i].hypot(tension_term(i, lt)),
    }
}

/// The tension's spread through the twin's runs that a cell's sd carries (`twin_tolerance`):
/// `baseline::tension_sd` (zero off the knee's cliff), except on the cells that carry the
/// calibration posterior's spread through the surrogate already (the slip level, the driven
/// speed's level, the start-up slip).
pub(super) fn tension_term(i: usize, lt: &LabelTwin) -> f64 {
    let c = &CELLS[i];
    let posterior = is_slip_level(c)
        || (c.window == Window::Steady
            && c.signal == Signal::DrivenSpeed
            && c.statistic == Statistic::Mean)
        || (c.window == Window::StartUp && c.signal == Signal::Slip);
    if posterior {
        0.0
    } else {
        lt.tension_sd[i]
    }
}

/// Whether a cell is set aside where the sensor stage read a timer lattice: the slip's
/// percentiles and its distance between distributions. Readings on a lattice make the slip a
/// quantity on a lattice of atoms (one per pair of the two shafts' levels), whose percentiles
/// jump from atom to atom with how the shafts' level visits go together, while its mean and sd
/// move smoothly (docs/decisions/gap-sensor-cells.md).
pub(super) fn set_aside_on_lattice(c: &Cell) -> bool {
    c.window == Window::Steady
        && c.signal == Signal::Slip
        && matches!(
            c.statistic,
            Statistic::P05 | Statistic::P50 | Statistic::P95 | Statistic::Wasserstein1
        )
}

/// Whether a cell is set aside where the sensor stage read a counter (`sensor_counter`): the
/// timer-lattice cells. A counter's closest pair of levels is often a pair of two counts of
/// pulse gaps, one of which holds a few per cent of the readings (pulses whose stamp falls on
/// the gate's edge), so the cell, which takes a level holding 1 % of the readings, flips with
/// that share, which the pulses' phase against the clock sets; the counter itself is read
/// from all the levels (docs/decisions/sensor-first.md, "A counter's gate").
pub(super) fn set_aside_on_counter(c: &Cell) -> bool {
    c.window == Window::Steady && c.statistic == Statistic::TimerLattice
}

/// Cells of one label: measured, twin, sd, z (sd NaN: set aside, `set_aside_on_lattice`,
/// `set_aside_on_counter`). The Wasserstein cell compares the distributions.
pub(super) fn label_cells(lt: &LabelTwin, twin: &Features) -> Vec<CellRow> {
    CELLS
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let (m, t) = (lt.measured.cells[i], twin.cells[i]);
            if (lt.lattice_read && set_aside_on_lattice(c))
                || (lt.sensor.gate_s > 0.0 && set_aside_on_counter(c))
            {
                return (m.value, t.value, f64::NAN);
            }
            if c.statistic == Statistic::Wasserstein1 {
                let w = wasserstein1(&lt.measured.slip_sorted, &twin.slip_sorted);
                let p50 = cell_index(Cell {
                    statistic: Statistic::P50,
                    ..*c
                });
                let sd = (lt.measured.cells[p50].se.powi(2)
                    + twin.cells[p50].se.powi(2)
                    + twin_tolerance(p50, lt, twin.cells[p50].value).powi(2))
                .sqrt();
                return (w, 0.0, sd);
            }
            let t = if c.window == Window::StartUp && c.signal == Signal::Slip {
                t.value + lt.startup_shift_pct
            } else {
                t.value
            };
            let sd =
                (m.se.powi(2) + twin.cells[i].se.powi(2) + twin_tolerance(i, lt, t).powi(2)).sqrt();
            (m.value, t, sd)
        })
        .collect()
}

/// Cells that enter fits and gap sums: finite, with a positive sd, not the pair distance.
pub(super) fn fit_cell(i: usize, cell: CellRow) -> bool {
    CELLS[i].statistic != Statistic::Wasserstein1
        && cell.0.is_finite()
        && cell.1.is_finite()
        && cell.2.is_finite()
        && cell.2 > 0.0
}

/// The nuisance parameter's column at one label: what a slip offset of 1 pp (the calibration's
/// `ratio`, refitted with every candidate so that what calibration absorbs is not credited to
/// an effect) does to each cell. (Friction and tension refitted as linear nuisances too,
/// through the surrogate's slip gradient at each label, were tried and left out: on another
/// simulator's data they made the leave-one-label-out prediction of the knee label worse and
/// turned no verdict.)
pub(super) fn nuisance(lt: &LabelTwin, i: usize) -> f64 {
    let c = &CELLS[i];
    if is_slip_level(c) {
        1.0
    } else if c.window == Window::Steady
        && c.signal == Signal::DrivenSpeed
        && c.statistic == Statistic::Mean
    {
        // n2 = n1 (1 - s / 100) / R: 1 pp more slip lowers n2 by n2 / (100 - s).
        -lt.measured.cells[i].value / (100.0 - lt.slip_pct).max(1.0)
    } else {
        0.0
    }
}

/// The where-table: every baseline cell with a finite value and a positive sd, its z and
/// whether |z| lies beyond `threshold` (in-sample nuisance: the calibration as fitted).
pub(super) fn where_cells(
    twins: &[LabelTwin],
    base_cells: &[Vec<CellRow>],
    threshold: f64,
) -> Vec<CellGap> {
    let mut where_cells = Vec::new();
    for (l, lt) in twins.iter().enumerate() {
        for (i, &(m, t, sd)) in base_cells[l].iter().enumerate() {
            if !(m.is_finite() && t.is_finite() && sd > 0.0) {
                continue;
            }
            let z = (m - t) / sd;
            where_cells.push(CellGap {
                label: lt.label.clone(),
                cell: CELLS[i].name(),
                measured: m,
                twin: t,
                sd,
                z,
                significant: z.abs() > threshold,
            });
        }
    }
    where_cells
}

pub(super) fn slip_mean_cell() -> usize {
    cell_index(Cell {
        window: Window::Steady,
        signal: Signal::Slip,
        statistic: Statistic::Mean,
        band: Band::Level,
    })
}

pub(super) fn startup_slip_cell() -> usize {
    cell_index(Cell {
        window: Window::StartUp,
        signal: Signal::Slip,
        statistic: Statistic::Mean,
        band: Band::Level,
    })
}

pub(super) fn t90_cell() -> usize {
    cell_index(Cell {
        window: Window::StartUp,
        signal: Signal::DrivenSpeed,
        statistic: Statistic::T90,
        band: Band::Level,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::baseline::tests::label_twin_of;
    use crate::gap::features::Measure;

    /// The driver's speed level at a twin speed of 1752 rpm under an 1800 rpm motor: its
    /// tolerance gains 0.4 % of the 48 rpm slip speed in quadrature; without a motor (a
    /// prescribed speed) it keeps the runs' spread alone, and no other cell changes.
    #[test]
    fn the_driver_speed_level_carries_the_reduced_resolutions_torque_share() {
        let i = cell_index(Cell::new(
            Window::Steady,
            Signal::DriverSpeed,
            Statistic::Mean,
            Band::Level,
        ));
        let features = Features {
            cells: vec![
                Measure {
                    value: 1.0,
                    se: 0.0
                };
                CELLS.len()
            ],
            ..Features::default()
        };
        let mut lt = label_twin_of(features, false);
        lt.run_spread = vec![0.03; CELLS.len()];
        let prescribed: Vec<f64> = (0..CELLS.len())
            .map(|k| twin_tolerance(k, &lt, 1752.0))
            .collect();
        assert!((prescribed[i] - 0.03).abs() < 1e-12, "{}", prescribed[i]);
        lt.synchronous_rpm = Some(1800.0);
        let motor: Vec<f64> = (0..CELLS.len())
            .map(|k| twin_tolerance(k, &lt, 1752.0))
            .collect();
        let want = 0.03f64.hypot(0.004 * 48.0);
        assert!((motor[i] - want).abs() < 1e-12, "{} vs {want}", motor[i]);
        for k in (0..CELLS.len()).filter(|&k| k != i) {
            assert_eq!(motor[k], prescribed[k], "{}", CELLS[k].name());
        }
    }
}
