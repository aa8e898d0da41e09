//! The calibration's posterior: pooled Metropolis chains over the objective (Gelman et al.,
//! Bayesian Data Analysis, 3rd ed., 2013, sec. 11.2), the fitted values' 90 % intervals from
//! them, and the thinned draws that predictions are made over.

use rayon::prelude::*;

use super::layout::Layout;
use super::options::{Distances, FreeSet};
use super::result::{Draw, Fitted};
use crate::inference::mcmc::metropolis;

/// Metropolis steps per chain.
const STEPS: usize = 6000;

/// Thinned draws kept: enough for a 90 % predictive interval.
const DRAWS: usize = 400;

/// One chain of `STEPS` from each start (seeds 11, 12, ...), pooled in start order.
pub(super) fn sample(
    chi2: &(dyn Fn(&[f64]) -> f64 + Sync),
    starts: &[Vec<f64>],
    bounds: &[[f64; 2]],
) -> Vec<Vec<f64>> {
    starts
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, x0)| metropolis(chi2, x0, bounds, STEPS, 11 + k as u64))
        .collect()
}

/// Each free parameter's fitted value (`best`) with the chain's 5 % and 95 % quantiles.
pub(super) fn fitted_parameters(layout: &Layout, chain: &[Vec<f64>], best: &[f64]) -> Vec<Fitted> {
    (0..layout.bounds.len())
        .map(|j| {
            let mut v: Vec<f64> = chain.iter().map(|x| x[j]).collect();
            v.sort_by(f64::total_cmp);
            Fitted {
                name: layout.names[j].clone(),
                value: best[j],
                interval90: [
                    fom::stats::quantile(&v, 0.05),
                    fom::stats::quantile(&v, 0.95),
                ],
            }
        })
        .collect()
}

/// The chain thinned to about `DRAWS` draws.
pub(super) fn draws(layout: &Layout, chain: &[Vec<f64>], free: FreeSet) -> Vec<Draw> {
    let thin = (chain.len() / DRAWS).max(1);
    chain
        .iter()
        .step_by(thin)
        .map(|x| {
            let q = layout.decode(x);
            Draw {
                spacing_m: (free.distances == Distances::EquallySpaced).then(|| [x[0], x[1]]),
                friction: q.mu,
                installation_tension_n: q.t,
                slip_offset_pct: q.offset,
                axial_stiffness_n: q.ea,
            }
        })
        .collect()
}
