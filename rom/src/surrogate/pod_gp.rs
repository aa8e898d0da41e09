//! One POD basis with a Gaussian process per retained coefficient: the machinery both surrogate
//! kinds (slip, tooth load) fit and evaluate.

use ndarray::{Array1, Array2};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::gp::{self, Gp};
use crate::pod::PodBasis;
use crate::snapshots::{ds_dz, from_z};
use crate::RomError;

/// Default POD energy criterion.
pub const DEFAULT_ENERGY: f64 = 0.999;

/// One POD basis with a Gaussian process per retained coefficient.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PodGp {
    pub basis: PodBasis,
    /// The fitted egobox processes: kept in memory for the fit's leave-one-out check, read
    /// from format-1/2 files, never written (format 3 keeps `means` and `variances`).
    #[serde(default, skip_serializing)]
    pub gps: Vec<Gp>,
    /// The processes' mean predictors in direct form, for the Monte Carlo loop.
    pub means: Vec<gp::KrigingMean>,
    /// The processes' variance predictors (steady processes only; empty for the start-up
    /// series, which is predicted from its means alone).
    #[serde(default)]
    pub variances: Vec<gp::KrigingVariance>,
}

impl PodGp {
    /// Fits the basis and the processes; also returns each snapshot's coefficients.
    /// With `variances`, also the variance predictors (the steady processes).
    pub(crate) fn fit(
        x: &Array2<f64>,
        snapshots: &[Vec<f64>],
        energy: f64,
        variances: bool,
    ) -> Result<(Self, Vec<Vec<f64>>), RomError> {
        let (basis, coef) = PodBasis::fit(snapshots, energy)?;
        let gps = (0..basis.modes.len())
            .into_par_iter()
            .map(|k| gp::fit(x, &coef.iter().map(|c| c[k]).collect::<Array1<f64>>()))
            .collect::<Result<Vec<_>, _>>()?;
        let mut means = Vec::with_capacity(gps.len());
        let mut vars = Vec::new();
        for g in &gps {
            let (m, v) = gp::direct_predictors(g, variances)?;
            means.push(m);
            vars.extend(v);
        }
        Ok((
            Self {
                basis,
                gps,
                means,
                variances: vars,
            },
            coef,
        ))
    }

    /// Files of format 1 and 2 carry the egobox processes but no variance predictors: reads
    /// them from the processes, then drops the processes.
    pub(crate) fn upgrade_from_processes(&mut self) -> Result<(), RomError> {
        if self.variances.is_empty() && !self.gps.is_empty() {
            self.variances = self
                .gps
                .iter()
                .map(gp::KrigingVariance::from_gp)
                .collect::<Result<Vec<_>, _>>()?;
        }
        self.gps.clear();
        Ok(())
    }

    /// The reconstructed transformed quantiles z, the quantiles (%, unsorted) and their mean
    /// slip (%) from coefficient means.
    fn steady_quantiles(&self, coef: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
        let mut z = vec![0.0; self.basis.mean.len()];
        self.basis.reconstruct_into(coef, &mut z);
        let s: Vec<f64> = z.iter().map(|&v| from_z(v)).collect();
        let mean = s.iter().sum::<f64>() / z.len() as f64;
        (z, s, mean)
    }

    /// Mean slip (%) from coefficient means: `steady_moments`'s, without the variance.
    pub(crate) fn steady_mean(&self, coef: &[f64]) -> f64 {
        self.steady_quantiles(coef).2
    }

    /// Quantile function (%, sorted), mean slip (%) and its variance (%^2) from coefficient
    /// means and variances. Delta method through the output transform:
    /// d(mean)/d(a_k) = (1/P) sum_p ds/dz(z_p) phi_k(p), independent processes.
    pub(crate) fn steady_moments(&self, coef: &[f64], coef_var: &[f64]) -> (Vec<f64>, f64, f64) {
        let (z, mut s, mean) = self.steady_quantiles(coef);
        let p = z.len() as f64;
        let var = self
            .basis
            .modes
            .iter()
            .zip(coef_var)
            .map(|(phi, vk)| {
                let g: f64 = phi
                    .iter()
                    .zip(&z)
                    .map(|(f, &zp)| f * ds_dz(zp))
                    .sum::<f64>()
                    / p;
                g * g * vk
            })
            .sum::<f64>();
        // Monotone rearrangement: a quantile function cannot decrease (Chernozhukov,
        // Fernández-Val & Galichon, Econometrica 78, 2010).
        s.sort_by(f64::total_cmp);
        (s, mean, var)
    }
}
