//! Latin-hypercube designs (egobox-doe, maximin-optimised by the Enhanced Stochastic
//! Evolutionary algorithm of Jin, Chen & Sudjianto 2005).

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;

/// One design point: centre distance (m), friction, installation tension (N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignPoint {
    pub center_distance_m: f64,
    pub friction: f64,
    pub installation_tension_n: f64,
}

impl DesignPoint {
    pub fn as_array(&self) -> [f64; 3] {
        [
            self.center_distance_m,
            self.friction,
            self.installation_tension_n,
        ]
    }
}

/// A maximin-optimised Latin hypercube of `samples` points in the box `ranges`; a pure function
/// of the seed.
pub fn latin_hypercube(ranges: &[[f64; 2]; 3], samples: usize, seed: u64) -> Vec<DesignPoint> {
    let xlimits = Array2::from_shape_fn((3, 2), |(i, j)| ranges[i][j]);
    let doe = Lhs::new_with_rng(&xlimits, Xoshiro256Plus::seed_from_u64(seed))
        .kind(LhsKind::Optimized)
        .sample(samples);
    doe.rows()
        .into_iter()
        .map(|r| DesignPoint {
            center_distance_m: r[0],
            friction: r[1],
            installation_tension_n: r[2],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const RANGES: [[f64; 2]; 3] = [[0.415, 0.424], [0.6, 0.8], [200.0, 300.0]];

    #[test]
    fn each_stratum_holds_exactly_one_point() {
        let n = 20;
        let pts = latin_hypercube(&RANGES, n, 7);
        assert_eq!(pts.len(), n);
        for (k, [lo, hi]) in RANGES.iter().enumerate() {
            let mut hit = vec![0usize; n];
            for p in &pts {
                let u = (p.as_array()[k] - lo) / (hi - lo);
                assert!((0.0..=1.0).contains(&u), "point outside the range");
                hit[((u * n as f64) as usize).min(n - 1)] += 1;
            }
            assert!(hit.iter().all(|&h| h == 1), "dimension {k}: {hit:?}");
        }
    }

    #[test]
    fn same_seed_same_design_other_seed_other_design() {
        assert_eq!(
            latin_hypercube(&RANGES, 8, 1),
            latin_hypercube(&RANGES, 8, 1)
        );
        assert_ne!(
            latin_hypercube(&RANGES, 8, 1),
            latin_hypercube(&RANGES, 8, 2)
        );
    }
}
