//! The tachometer candidate: a grid of sensor models (pulses per revolution x timer
//! resolution), each a candidate with no magnitude, re-reading the baseline runs; per fold the
//! best grid point on the fitted labels is scored on the withheld ones.

use fom::stats::Z90;
use rayon::prelude::*;

use super::linear::{huber, LinearCandidate};
use super::Scored;
use crate::error::{Result, TwinError};
use crate::gap::cells::{fit_cell, label_cells, CellRow};
use crate::gap::features::{self, cell_index, Band, Cell, Signal, Statistic, Window, CELLS};
use crate::gap::ranking::{loss, RankContext};
use crate::gap::reading::{tachometer_sensor, twin_features};
use crate::gap::report::{Param, Ranked};
use crate::gap::Diagnosis;
use fom::stats::rms;

/// The candidate's name in the ranking.
pub(in crate::gap) const NAME: &str = "tachometer";

/// Whether `effect` is this candidate fitted to the readings' shape alone: no sensor
/// structure read in the recordings (`sensor_read` false), where that shape is what sensor
/// noise that is not white gives too (docs/decisions/sensor-first.md).
pub(in crate::gap) fn shape_alone(effect: &str, sensor_read: bool) -> bool {
    effect == NAME && !sensor_read
}

/// Sensor models of the tachometer candidate: pulses per revolution x timer resolution.
const PULSES: [u32; 10] = [1, 4, 8, 16, 30, 60, 100, 120, 360, 1024];
const TIMERS_S: [f64; 8] = [0.0, 1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4];

/// The driver speed's timer-lattice cell.
fn lattice_cell() -> usize {
    cell_index(Cell {
        window: Window::Steady,
        signal: Signal::DriverSpeed,
        statistic: Statistic::TimerLattice,
        band: Band::Level,
    })
}

/// The tachometer scored: the best grid point per fold, its withheld z and parameters.
pub(in crate::gap) fn score(r: &RankContext, d: &Diagnosis) -> Result<Scored> {
    let (grid, lattice_product) = grid(r);
    let cells = grid_cells(r, d, &grid);
    let usable = usable_points(r, &cells, lattice_product.is_some());
    if usable.is_empty() {
        return Err(TwinError::Gap(
            "no tachometer model gives usable readings at every label".into(),
        ));
    }
    let tach: Vec<LinearCandidate> = usable
        .iter()
        .map(|&g| candidate(r, cells[g].as_slice()))
        .collect();
    let grid: Vec<(u32, f64)> = usable.iter().map(|&g| grid[g]).collect();
    let mut per = vec![Vec::new(); r.n];
    let mut level_free = 0.0;
    for (fit, held) in &r.folds {
        let g = best_on(&tach, fit);
        let f = tach[g].fit(fit, false);
        for &h in held {
            per[h] = tach[g].held_z(h, &f);
            level_free += r.level_free_loss(&tach[g], &f, h);
        }
    }
    let z: Vec<Vec<f64>> = r.eval_labels.iter().map(|&l| per[l].clone()).collect();
    let g = best_on(&tach, &r.fitted);
    Ok((
        Ranked {
            effect: NAME.into(),
            score: loss(&z) - r.loss_none + 2.0 * r.ln_n,
            params: params(grid[g], lattice_product),
            gap_after: rms(&z.concat()),
            slip_offset_pct: tach[g].fit(&r.fitted, false).offset,
            signature: vec![CELLS[cell_index(Cell {
                window: Window::Steady,
                signal: Signal::DriverSpeed,
                statistic: Statistic::Kurtosis,
                band: Band::Level,
            })]
            .name()],
            score_beyond_slip_level: level_free - r.level_free_none + 2.0 * r.ln_n,
            line_only: false,
            variant: None,
        },
        z,
    ))
}

/// The grid of sensor models. Where the measured driver speed sits on a timer lattice
/// (`features::timer_lattice_s`), the grid also holds every pulse count at the timer that
/// lattice implies (the median P tau over the labels, also returned): the readings identify P
/// tau, which a fixed timer grid only brackets (a coarse-timer data set of 60 pulses at 2-5 us
/// was "unexplained" with the grid alone).
fn grid(r: &RankContext) -> (Vec<(u32, f64)>, Option<f64>) {
    let mut grid: Vec<(u32, f64)> = PULSES
        .iter()
        .flat_map(|&p| TIMERS_S.iter().map(move |&t| (p, t)))
        .collect();
    let lattice = lattice_cell();
    let measured_lattice: Vec<f64> = r
        .twins
        .iter()
        .map(|lt| lt.measured.cells[lattice].value)
        .filter(|c| *c > 0.0)
        .collect();
    let lattice_product =
        (!measured_lattice.is_empty()).then(|| fom::stats::median(measured_lattice));
    if let Some(c) = lattice_product {
        grid.extend(PULSES.iter().map(|&p| (p, c / p as f64)));
    }
    (grid, lattice_product)
}

/// Per grid point, per label: the baseline run re-read with that sensor (None where the
/// sensor gives no steady reading).
fn grid_cells(
    r: &RankContext,
    d: &Diagnosis,
    grid: &[(u32, f64)],
) -> Vec<Vec<Option<Vec<CellRow>>>> {
    let lattice = lattice_cell();
    grid.par_iter()
        .map(|&(p, tau)| {
            r.twins
                .iter()
                .map(|lt| {
                    let sensor =
                        tachometer_sensor(lt, (p, tau), &d.sensor, (d.model_ratio, d.ratio))?;
                    let mut f = twin_features(
                        lt,
                        &lt.baseline_rows,
                        &sensor,
                        d.model_ratio,
                        d.ratio,
                        &d.ctx,
                    )
                    .ok()?;
                    // The twin knows its sensor: where the measurement reveals a lattice, the
                    // twin's is its own P tau, whether or not its simulated speed happens to
                    // visit two levels (which a speed a fraction of an rpm off decides).
                    if tau > 0.0 && lt.measured.cells[lattice].value > 0.0 {
                        f.cells[lattice] = features::lattice_measure(p as f64 * tau);
                    }
                    Some(label_cells(lt, &f))
                })
                .collect()
        })
        .collect()
}

/// Grid points that are candidates. Grid points whose sensor fails at some label (readings
/// too coarse to read a steady window) are not. A grid point must also leave every cell the
/// baseline has usable (fewer cells would lower its chi-square for nothing). And where no
/// recording shows a timer lattice, a sensor whose readings show one at some label is refuted:
/// the lattice cell is left out of the fits where the measurement has no lattice, so without
/// this a coarse timer could explain a recording's scatter (another simulator's eccentric fan
/// pulley, whose slip spread was called "tachometer") while the recordings lack the levels
/// that timer would print. (Not label by label: whether a speed visits two levels depends on
/// where it sits between them, so a true coarse timer shows its lattice at some labels only.)
fn usable_points(
    r: &RankContext,
    cells: &[Vec<Option<Vec<CellRow>>>],
    measured_lattice: bool,
) -> Vec<usize> {
    let lattice = lattice_cell();
    (0..cells.len())
        .filter(|&g| {
            cells[g].iter().zip(&r.base_cells).all(|(t, b)| {
                t.as_ref().is_some_and(|t| {
                    (0..CELLS.len()).all(|i| !fit_cell(i, b[i]) || fit_cell(i, t[i]))
                        && (measured_lattice || t[lattice].1 <= 0.0)
                })
            })
        })
        .collect()
}

/// A usable grid point's linear candidate (no magnitude: the residuals with that sensor).
fn candidate(r: &RankContext, cells: &[Option<Vec<CellRow>>]) -> LinearCandidate {
    let rows = (0..r.n)
        .map(|l| {
            let label = cells[l].as_ref().expect("usable grid point");
            label
                .iter()
                .enumerate()
                .map(|(i, &(m, t, sd))| {
                    let ok = fit_cell(i, (m, t, sd)) && fit_cell(i, r.base_cells[l][i]);
                    // Every candidate is judged on the baseline's sd, as the mechanical
                    // ones are: a sensor whose own readings scatter more must not shrink
                    // the gap by widening its yardstick.
                    (m - t, 0.0, r.base_cells[l][i].2, ok)
                })
                .collect()
        })
        .collect();
    LinearCandidate {
        rows,
        max: 0.0,
        nuis: r.nuis.clone(),
        form_sd: 0.0,
    }
}

/// The grid point with the least Huber loss on `labels` (fitted in sample).
fn best_on(tach: &[LinearCandidate], labels: &[usize]) -> usize {
    let loss_of = |g: usize| {
        let f = tach[g].fit(labels, false);
        labels
            .iter()
            .flat_map(|&l| tach[g].z(l, &f))
            .map(huber)
            .sum::<f64>()
    };
    (0..tach.len())
        .map(|g| (g, loss_of(g)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |x| x.0)
}

/// The reported parameters of the best grid point.
fn params((pulses, tau): (u32, f64), lattice_product: Option<f64>) -> Vec<Param> {
    vec![
        Param {
            name: "pulses_per_rev".into(),
            value: pulses as f64,
            interval90: [f64::NAN, f64::NAN],
        },
        Param {
            name: "timer_resolution_s".into(),
            value: tau,
            interval90: [f64::NAN, f64::NAN],
        },
        // What the speeds identify: the quantisation step n^2 P tau / 60 sets the
        // readings (`sensor.rs`), so P and tau trade against each other.
        Param {
            name: "pulses_per_rev x timer_resolution_s".into(),
            value: pulses as f64 * tau,
            interval90: [f64::NAN, f64::NAN],
        },
    ]
    .into_iter()
    .chain(lattice_product.map(|c| Param {
        // What the readings' levels say directly (the cell's 2 % error), beside
        // what the best sensor model over all cells has.
        name: "pulses_per_rev x timer_resolution_s from the readings' lattice".into(),
        value: c,
        interval90: [
            c * (1.0 - Z90 * features::LATTICE_RELATIVE_SE),
            c * (1.0 + Z90 * features::LATTICE_RELATIVE_SE),
        ],
    }))
    .collect()
}
