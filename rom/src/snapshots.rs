//! From a full-order run's time series to the two surrogate outputs: the start-up slip series
//! on a common time grid, and the steady-state slip distribution as a quantile function.

use fom::stats::quantile;
use training::SeriesRow;

use crate::RomError;

/// Width of one start-up grid cell, s (50 Hz: resolves the ~1.5 s run-up of the default drive).
pub const STARTUP_STEP_S: f64 = 0.02;
/// Number of probability levels of the quantile function.
pub const PROBABILITY_LEVELS: usize = 50;

/// Cell ends t_k = (k + 1) dt of the start-up grid, up to the start of the steady window.
pub fn startup_grid_s(steady_start_s: f64) -> Vec<f64> {
    let n = (steady_start_s / STARTUP_STEP_S + 1e-9).floor() as usize;
    (1..=n).map(|k| k as f64 * STARTUP_STEP_S).collect()
}

/// Mid-point probability levels (j + 1/2) / P: each level carries weight 1/P.
pub fn probability_levels() -> Vec<f64> {
    mid_levels(PROBABILITY_LEVELS)
}

/// `n` mid-point probability levels (j + 1/2) / n.
pub fn mid_levels(n: usize) -> Vec<f64> {
    (0..n).map(|j| (j as f64 + 0.5) / n as f64).collect()
}

/// Start-up slip per grid cell, %: 100 (1 - R_t sum(n_driven) / sum(n_driver)) over the rows of
/// the cell (paper eq. 1 applied to the angles turned in the cell, as a tachometer would).
pub fn startup_series(
    rows: &[SeriesRow],
    grid_s: &[f64],
    ratio: f64,
) -> Result<Vec<f64>, RomError> {
    let mut out = Vec::with_capacity(grid_s.len());
    let mut k = 0;
    for &t_end in grid_s {
        let t_start = t_end - STARTUP_STEP_S;
        let (mut s1, mut s2) = (0.0, 0.0);
        while k < rows.len() && rows[k].time_s <= t_end + 1e-9 {
            if rows[k].time_s > t_start + 1e-9 {
                s1 += rows[k].driver_rpm;
                s2 += rows[k].driven_rpm;
            }
            k += 1;
        }
        if rows.last().is_none_or(|r| r.time_s < t_end - 1e-9) {
            return Err(RomError::Data(format!(
                "run ends at {:.3} s, before the start-up grid's end {t_end:.3} s",
                rows.last().map_or(0.0, |r| r.time_s)
            )));
        }
        // A driver that has not turned in the cell carries no slip information: 0 by convention.
        out.push(if s1 > 1e-9 {
            fom::slip::slip_pct(ratio, s1, s2)
        } else {
            0.0
        });
    }
    Ok(out)
}

/// Sorted steady-window slip samples (t > steady_start_s, finite), %.
pub fn steady_samples(rows: &[SeriesRow], steady_start_s: f64) -> Vec<f64> {
    let mut s: Vec<f64> = rows
        .iter()
        .filter(|r| r.time_s > steady_start_s && r.slip_pct.is_finite())
        .map(|r| r.slip_pct)
        .collect();
    s.sort_by(f64::total_cmp);
    s
}

/// Quantile function of sorted samples at the probability levels.
pub fn quantile_function(sorted: &[f64], levels: &[f64]) -> Vec<f64> {
    levels.iter().map(|&p| quantile(sorted, p)).collect()
}

/// Output transform z = asinh(s / s0): log-like for slip well above s0, linear near zero and
/// defined for negative slip. Relative accuracy is what matters across 0.5-30 % slip.
pub const SLIP_SCALE_PCT: f64 = 0.5;

pub fn to_z(slip_pct: f64) -> f64 {
    (slip_pct / SLIP_SCALE_PCT).asinh()
}

pub fn from_z(z: f64) -> f64 {
    // sinh through one exp: (e^z - e^-z) / 2; ~3x faster than libm's sinh, and the absolute
    // error near z = 0 (1e-16 %) is far below any slip resolution. The branch-free exp lets
    // a loop over a slice vectorise.
    slip_of_exp(fom::fastmath::exp(z))
}

/// Slip, %, from e = exp(z): S sinh(z) = S (e - 1/e) / 2.
#[inline(always)]
fn slip_of_exp(e: f64) -> f64 {
    SLIP_SCALE_PCT * 0.5 * (e - 1.0 / e)
}

/// `from_z` of every element in place, with the exponentials taken in one vectorised pass
/// (`fom::fastmath::exp_in_place`); the same values as `from_z` bit for bit.
pub fn from_z_in_place(v: &mut [f64]) {
    fom::fastmath::exp_in_place(v);
    for x in v {
        *x = slip_of_exp(*x);
    }
}

/// d s / d z, for propagating variances through the transform.
pub fn ds_dz(z: f64) -> f64 {
    SLIP_SCALE_PCT * z.cosh()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, n1: f64, n2: f64) -> SeriesRow {
        SeriesRow {
            time_s: t,
            driver_rpm: n1,
            driven_rpm: n2,
            slip_pct: 100.0 * (1.0 - 2.0 * n2 / n1),
        }
    }

    #[test]
    fn startup_cells_use_turned_angles() {
        // 1 kHz rows; driver 1000 rpm, driven 490 rpm: slip 2 % with R_t = 2.
        let rows: Vec<SeriesRow> = (1..=100)
            .map(|k| row(k as f64 * 1e-3, 1000.0, 490.0))
            .collect();
        let grid = startup_grid_s(0.1);
        assert_eq!(grid.len(), 5);
        let s = startup_series(&rows, &grid, 2.0).unwrap();
        assert!(s.iter().all(|v| (v - 2.0).abs() < 1e-9), "{s:?}");
        assert!(startup_series(&rows, &startup_grid_s(0.2), 2.0).is_err());
    }

    #[test]
    fn transform_round_trips() {
        for s in [-3.0, 0.0, 0.7, 6.25, 40.0] {
            assert!((from_z(to_z(s)) - s).abs() < 1e-12);
            let h = 1e-6;
            let num = (from_z(to_z(s) + h) - from_z(to_z(s) - h)) / (2.0 * h);
            assert!((num - ds_dz(to_z(s))).abs() < 1e-6 * num.abs().max(1.0));
        }
    }
}
