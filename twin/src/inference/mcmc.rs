//! Random-walk Metropolis sampling inside a box.

use rand::Rng;
use rand_xoshiro::rand_core::SeedableRng;

/// Random-walk Metropolis sampling of exp(-chi2 / 2) with a flat prior on the box (Metropolis
/// et al. 1953; Gelman et al., Bayesian Data Analysis, ch. 12): steps are adapted during the
/// first quarter towards ~25 % acceptance; the rest is returned.
pub fn metropolis(
    chi2: &(dyn Fn(&[f64]) -> f64 + Sync),
    start: &[f64],
    bounds: &[[f64; 2]],
    steps: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut gauss = move || -> (f64, f64) { (rng.sample(rand_distr::StandardNormal), rng.gen()) };
    let n = start.len();
    let mut scale: Vec<f64> = bounds.iter().map(|[lo, hi]| 0.01 * (hi - lo)).collect();
    let mut x = start.to_vec();
    let mut cx = chi2(&x);
    let burn = steps / 4;
    let mut out = Vec::with_capacity(steps - burn);
    for k in 0..steps {
        let j = k % n;
        let (z, u) = gauss();
        let mut y = x.clone();
        y[j] += scale[j] * z;
        if y[j] >= bounds[j][0] && y[j] <= bounds[j][1] {
            let cy = chi2(&y);
            if cy.is_finite() && u.ln() < -(cy - cx) / 2.0 {
                x = y;
                cx = cy;
                if k < burn {
                    scale[j] *= 1.1;
                }
            } else if k < burn {
                scale[j] *= 0.97;
            }
        } else if k < burn {
            scale[j] *= 0.97;
        }
        if k >= burn {
            out.push(x.clone());
        }
    }
    out
}
