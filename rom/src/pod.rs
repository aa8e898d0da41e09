//! Proper orthogonal decomposition of snapshot vectors (thin SVD with faer).
//!
//! Snapshots y_i (one per training run, m values each) are centred on their mean; the thin SVD
//! Y_c = U S V^T gives the modes (columns of V) and the coefficients a_i = U_i S. Modes are kept
//! until their share of the energy sum(S^2) reaches the criterion (Holmes, Lumley & Berkooz,
//! Turbulence, Coherent Structures, Dynamical Systems and Symmetry, 1996, ch. 3).

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::RomError;

/// A POD basis: mean snapshot and retained modes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PodBasis {
    /// Mean snapshot (m values).
    pub mean: Vec<f64>,
    /// Retained modes, each m values, orthonormal.
    pub modes: Vec<Vec<f64>>,
    /// All singular values, largest first.
    pub singular_values: Vec<f64>,
    /// Share of the snapshot energy the retained modes hold.
    pub energy_kept: f64,
}

impl PodBasis {
    /// Fits the basis to `snapshots` (each of equal length) keeping the fewest modes whose
    /// energy share reaches `energy` (e.g. 0.999). Returns the basis and each snapshot's
    /// coefficients.
    pub fn fit(snapshots: &[Vec<f64>], energy: f64) -> Result<(Self, Vec<Vec<f64>>), RomError> {
        let n = snapshots.len();
        let m = snapshots.first().map_or(0, Vec::len);
        if n < 2 || m == 0 || snapshots.iter().any(|s| s.len() != m) {
            return Err(RomError::Fit(format!(
                "POD needs at least 2 snapshots of equal, non-zero length (got {n})"
            )));
        }
        if !(energy > 0.0 && energy <= 1.0) {
            return Err(RomError::Fit(format!(
                "POD energy criterion {energy} must lie in (0, 1]"
            )));
        }
        let mean: Vec<f64> = (0..m)
            .map(|j| snapshots.iter().map(|s| s[j]).sum::<f64>() / n as f64)
            .collect();
        let y = Mat::from_fn(n, m, |i, j| snapshots[i][j] - mean[j]);
        let svd = y
            .thin_svd()
            .map_err(|e| RomError::Fit(format!("SVD of the snapshot matrix failed: {e:?}")))?;
        let s = svd.S().column_vector();
        let singular_values: Vec<f64> = (0..s.nrows()).map(|k| s[k]).collect();
        let total: f64 = singular_values.iter().map(|v| v * v).sum();
        let mut kept = 0;
        let mut acc = 0.0;
        while kept < singular_values.len() {
            acc += singular_values[kept].powi(2);
            kept += 1;
            if total <= 0.0 || acc >= energy * total {
                break;
            }
        }
        let v = svd.V();
        let u = svd.U();
        let modes: Vec<Vec<f64>> = (0..kept)
            .map(|k| (0..m).map(|j| v[(j, k)]).collect())
            .collect();
        let coefficients: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..kept).map(|k| u[(i, k)] * singular_values[k]).collect())
            .collect();
        let energy_kept = if total > 0.0 { acc / total } else { 1.0 };
        Ok((
            Self {
                mean,
                modes,
                singular_values,
                energy_kept,
            },
            coefficients,
        ))
    }

    /// Coefficients of a snapshot (projection onto the modes).
    pub fn project(&self, y: &[f64]) -> Vec<f64> {
        self.modes
            .iter()
            .map(|phi| {
                phi.iter()
                    .zip(y.iter().zip(&self.mean))
                    .map(|(p, (v, m))| p * (v - m))
                    .sum()
            })
            .collect()
    }

    /// The snapshot a set of coefficients stands for, into `out`.
    pub fn reconstruct_into(&self, coefficients: &[f64], out: &mut [f64]) {
        out.copy_from_slice(&self.mean);
        for (c, phi) in coefficients.iter().zip(&self.modes) {
            for (o, p) in out.iter_mut().zip(phi) {
                *o += c * p;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rank_two_snapshots_need_two_modes_and_reconstruct_exactly() {
        // y_i(x) = a_i sin(x) + b_i x^2 + 1: mean plus two directions.
        let xs: Vec<f64> = (0..30).map(|j| j as f64 / 10.0).collect();
        let snaps: Vec<Vec<f64>> = (0..12)
            .map(|i| {
                let (a, b) = ((i as f64).cos(), 0.1 * i as f64);
                xs.iter().map(|x| a * x.sin() + b * x * x + 1.0).collect()
            })
            .collect();
        let (pod, coef) = PodBasis::fit(&snaps, 0.999_999).unwrap();
        assert_eq!(pod.modes.len(), 2, "sv: {:?}", pod.singular_values);
        let mut out = vec![0.0; xs.len()];
        for (s, c) in snaps.iter().zip(&coef) {
            pod.reconstruct_into(c, &mut out);
            let err = s
                .iter()
                .zip(&out)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-10, "reconstruction error {err}");
            let p = pod.project(s);
            assert!(p.iter().zip(c).all(|(a, b)| (a - b).abs() < 1e-10));
        }
    }

    #[test]
    fn energy_criterion_drops_small_modes() {
        let snaps: Vec<Vec<f64>> = (0..10)
            .map(|i| {
                let t = i as f64;
                vec![t, 2.0 * t, 1e-4 * t.sin(), 0.0]
            })
            .collect();
        let (pod, _) = PodBasis::fit(&snaps, 0.999).unwrap();
        assert_eq!(pod.modes.len(), 1);
        assert!(pod.energy_kept >= 0.999);
    }
}
