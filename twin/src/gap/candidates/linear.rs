//! A linear candidate: the cells of label l = twin + m S + a N, with S the effect's
//! sensitivity per unit magnitude and N the calibration's slip offset column (a nuisance
//! parameter: what calibration absorbs is not credited to an effect). Fitted robustly (Huber)
//! by iteratively reweighted least squares; every candidate of the catalogue, and "none", is
//! scored through this one model.

use fom::stats::{huber_loss, huber_weight};

use crate::gap::features::CELLS;

/// |z| beyond which a cell's residual weighs linearly, not quadratically, in the effects' fits
/// and scores (Huber's loss; three standard deviations: a noise-level cell keeps the
/// chi-square's weight).
pub(in crate::gap) const HUBER_Z: f64 = 3.0;

/// Huber's loss of a standardised residual on the chi-square's scale: z^2 within `HUBER_Z`,
/// 2 c |z| - c^2 beyond (Huber 1964, Ann. Math. Stat. 35, 73, eq. 2.2, doubled).
pub(in crate::gap) fn huber(z: f64) -> f64 {
    huber_loss(z, HUBER_Z)
}

/// A fitted linear candidate: the magnitude, its sd, and the slip offset.
#[derive(Debug, Clone, Copy)]
pub(in crate::gap) struct Fit {
    pub m: f64,
    pub sd: f64,
    pub offset: f64,
}

/// One candidate's linear model: cells of label l = twin + m S + a N (N the offset column).
pub(in crate::gap) struct LinearCandidate {
    /// Per label, per cell: (residual before = measured - twin, sensitivity per unit magnitude,
    /// sd, usable).
    pub rows: Vec<Vec<(f64, f64, f64, bool)>>,
    pub max: f64,
    pub nuis: Vec<Vec<f64>>,
}

impl LinearCandidate {
    /// Robust weighted least squares of the magnitude (in [0, max]) and the offset on `labels`
    /// (Huber's M-estimate by iteratively reweighted least squares, Huber 1964, Ann. Math.
    /// Stat. 35, 73: a cell whose residual lies beyond `HUBER_Z` standard deviations is
    /// down-weighted to `HUBER_Z / |z|`, so that one label's model-form miss cannot steer the
    /// fit of an effect that all labels show). Without the effect, the offset alone.
    pub fn fit(&self, labels: &[usize], with_effect: bool) -> Fit {
        let mut robust = vec![vec![1.0; CELLS.len()]; self.rows.len()];
        let mut out = self.weighted_fit(labels, with_effect, &robust);
        for _ in 0..20 {
            let mut changed = false;
            for &l in labels {
                for (i, &(g, s, sd, ok)) in self.rows[l].iter().enumerate() {
                    if ok {
                        let z = (g - out.m * s - out.offset * self.nuis[l][i]) / sd;
                        let w = huber_weight(z, HUBER_Z);
                        changed |= (w - robust[l][i]).abs() > 1e-6;
                        robust[l][i] = w;
                    }
                }
            }
            if !changed {
                break;
            }
            out = self.weighted_fit(labels, with_effect, &robust);
        }
        out
    }

    /// Weighted least squares of [`Self::fit`] with the robust weight factors `robust`
    /// (weights `robust / sd^2`); m clamped to its bounds, the offset then refitted with m
    /// fixed.
    fn weighted_fit(&self, labels: &[usize], with_effect: bool, robust: &[Vec<f64>]) -> Fit {
        // Sums of the normal equations of [m, a].
        let (mut smm, mut sma, mut saa, mut smy, mut say) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &l in labels {
            for (i, &(g, s, sd, ok)) in self.rows[l].iter().enumerate() {
                if ok {
                    let (w, n) = (robust[l][i] / (sd * sd), self.nuis[l][i]);
                    smm += w * s * s;
                    sma += w * s * n;
                    saa += w * n * n;
                    smy += w * s * g;
                    say += w * n * g;
                }
            }
        }
        // The offset for a fixed magnitude.
        let offset = |m: f64| {
            if saa > 0.0 {
                (say - m * sma) / saa
            } else {
                0.0
            }
        };
        if !with_effect || smm <= 0.0 {
            // No effect, or one that moves no usable cell: nothing to fit.
            let sd = if with_effect { f64::INFINITY } else { 0.0 };
            return Fit {
                m: 0.0,
                sd,
                offset: offset(0.0),
            };
        }
        let det = smm * saa - sma * sma;
        let (m, var) = if saa > 0.0 && det > 1e-12 * smm * saa {
            ((smy * saa - sma * say) / det, saa / det)
        } else {
            (smy / smm, 1.0 / smm)
        };
        let m = m.clamp(0.0, self.max);
        Fit {
            m,
            sd: var.sqrt(),
            offset: offset(m),
        }
    }

    /// z of every usable cell of label l under `fit`.
    pub fn z(&self, l: usize, fit: &Fit) -> Vec<f64> {
        self.z_cells(l, fit).map(|(_, z)| z).collect()
    }

    /// (cell index, z) of every usable cell of label l under `fit`.
    pub fn z_cells<'a>(
        &'a self,
        l: usize,
        fit: &'a Fit,
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        self.rows[l]
            .iter()
            .enumerate()
            .filter(|(_, r)| r.3)
            .map(move |(i, &(g, s, sd, _))| {
                (i, (g - fit.m * s - fit.offset * self.nuis[l][i]) / sd)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_linear_fit_recovers_a_magnitude_and_an_offset_and_respects_its_bounds() {
        // Two labels, three cells each: residual = 0.7 S + 0.2 N exactly (N the offset column).
        let s = [[1.0, 0.0, 2.0], [0.5, 1.0, 0.0]];
        let n = [[1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        let rows: Vec<Vec<(f64, f64, f64, bool)>> = (0..2)
            .map(|l| {
                (0..3)
                    .map(|i| (0.7 * s[l][i] + 0.2 * n[l][i], s[l][i], 0.1, true))
                    .collect()
            })
            .collect();
        let nuis: Vec<Vec<f64>> = n.iter().map(|r| r.to_vec()).collect();
        let c = LinearCandidate {
            rows: rows.clone(),
            max: 5.0,
            nuis: nuis.clone(),
        };
        let f = c.fit(&[0, 1], true);
        assert!(
            (f.m - 0.7).abs() < 1e-9 && (f.offset - 0.2).abs() < 1e-9,
            "{f:?}"
        );
        assert!(f.sd > 0.0 && f.sd < 0.1);
        assert!(c.z(0, &f).iter().all(|z| z.abs() < 1e-6));
        // A bound below the truth clamps the magnitude; no effect fits the offset alone.
        let c = LinearCandidate {
            rows,
            max: 0.5,
            nuis,
        };
        assert_eq!(c.fit(&[0, 1], true).m, 0.5);
        assert_eq!(c.fit(&[0, 1], false).m, 0.0);
    }

    #[test]
    fn one_cell_far_off_does_not_steer_the_fit() {
        // Ten cells follow residual = 0.7 S exactly; one more, with the same sensitivity, sits
        // 50 sd off (a label's model-form miss). Least squares would move the magnitude by
        // 50 x 0.1 / 11 = 0.45; the Huber fit moves it by less than 0.1 (one cell at its
        // 3-sd weight).
        let mut cells: Vec<(f64, f64, f64, bool)> =
            (0..10).map(|_| (0.7, 1.0, 0.1, true)).collect();
        cells.push((0.7 + 5.0, 1.0, 0.1, true));
        let c = LinearCandidate {
            nuis: vec![vec![0.0; cells.len()]],
            rows: vec![cells],
            max: 10.0,
        };
        let m = c.fit(&[0], true).m;
        assert!((m - 0.7).abs() < 0.1, "{m}");
        // The loss charges the far cell linearly: 2 x 3 x 50 - 9, not 50^2.
        assert_eq!(huber(50.0), 291.0);
        assert_eq!(huber(-2.0), 4.0);
    }
}
