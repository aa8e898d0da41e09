//! Latin-hypercube designs (egobox-doe, maximin-optimised by the Enhanced Stochastic
//! Evolutionary algorithm of Jin, Chen & Sudjianto 2005).

use egobox_doe::{Lhs, LhsKind, SamplingMethod};
use fom::params::Variable;
use fom::DesignPoint;
use ndarray::Array2;
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256Plus;

/// A maximin-optimised Latin hypercube of `samples` points over the variables and ranges
/// `vars` (`CampaignSettings::ranges`); a pure function of the seed.
pub fn latin_hypercube(
    vars: &[(Variable, [f64; 2])],
    samples: usize,
    seed: u64,
) -> Vec<DesignPoint> {
    latin_hypercube_about(&DesignPoint::from_columns(&[], &[]), vars, samples, seed)
}

/// The same design with the variables `vars` does not name taken from `base` (a toothed
/// campaign's points keep the configuration's centre distance, friction and tension).
pub fn latin_hypercube_about(
    base: &DesignPoint,
    vars: &[(Variable, [f64; 2])],
    samples: usize,
    seed: u64,
) -> Vec<DesignPoint> {
    let xlimits = Array2::from_shape_fn((vars.len(), 2), |(i, j)| vars[i].1[j]);
    let which: Vec<Variable> = vars.iter().map(|(v, _)| *v).collect();
    // egobox-doe's optimised (ESE) design does not return for a single sample (it spun for
    // 11 min in `rom validate --points 1`); one point of a Latin hypercube is a uniform draw
    // over the box, which the classic design gives. Designs of two and more are unchanged.
    let kind = if samples < 2 {
        LhsKind::Classic
    } else {
        LhsKind::Optimized
    };
    let doe = Lhs::new_with_rng(&xlimits, Xoshiro256Plus::seed_from_u64(seed))
        .kind(kind)
        .sample(samples);
    doe.rows()
        .into_iter()
        .map(|r| base.with_columns(&which, &r.to_vec()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The design of `latin_hypercube` over d, mu, T (and EA when given), in that order.
    fn lhs(ranges: &[[f64; 2]], samples: usize, seed: u64) -> Vec<DesignPoint> {
        let vars: Vec<(Variable, [f64; 2])> = Variable::ALL
            .into_iter()
            .zip(ranges.iter().copied())
            .collect();
        latin_hypercube(&vars, samples, seed)
    }

    const RANGES: [[f64; 2]; 3] = [[0.415, 0.424], [0.6, 0.8], [200.0, 300.0]];

    #[test]
    fn a_design_of_one_point_is_one_point_inside_the_box() {
        for seed in [1, 20261124] {
            let d = lhs(&RANGES, 1, seed);
            assert_eq!(d.len(), 1);
            let p = d[0];
            assert!((0.415..=0.424).contains(&p.center_distance_m), "{p:?}");
            assert!((0.6..=0.8).contains(&p.friction), "{p:?}");
            assert!((200.0..=300.0).contains(&p.installation_tension_n), "{p:?}");
        }
    }

    #[test]
    fn each_stratum_holds_exactly_one_point() {
        let n = 20;
        let pts = lhs(&RANGES, n, 7);
        assert_eq!(pts.len(), n);
        for (k, [lo, hi]) in RANGES.iter().enumerate() {
            let mut hit = vec![0usize; n];
            for p in &pts {
                let u = (p.columns()[k] - lo) / (hi - lo);
                assert!((0.0..=1.0).contains(&u), "point outside the range");
                hit[((u * n as f64) as usize).min(n - 1)] += 1;
            }
            assert!(hit.iter().all(|&h| h == 1), "dimension {k}: {hit:?}");
        }
    }

    #[test]
    fn a_fourth_variable_is_sampled_when_given() {
        let mut r = RANGES.to_vec();
        r.push([5000.0, 20000.0]);
        let pts = lhs(&r, 10, 3);
        assert!(pts.iter().all(|p| p
            .axial_stiffness_n
            .is_some_and(|e| (5000.0..=20000.0).contains(&e))));
        assert!(lhs(&RANGES, 10, 3)
            .iter()
            .all(|p| p.axial_stiffness_n.is_none()));
    }

    #[test]
    fn same_seed_same_design_other_seed_other_design() {
        assert_eq!(lhs(&RANGES, 8, 1), lhs(&RANGES, 8, 1));
        assert_ne!(lhs(&RANGES, 8, 1), lhs(&RANGES, 8, 2));
    }
}
