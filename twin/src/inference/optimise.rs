//! Bounded local minimisation: a Nelder-Mead simplex that keeps every vertex inside the box.
//!
//! Why our own and not argmin's `NelderMead` (tried in this crate): argmin's simplex is
//! unbounded, so a box has to be imposed on the objective (evaluate at the clamped point, or a
//! penalty); vertices then leave the box onto flat or steep ground and the search ends
//! elsewhere. Measured on the seed paper's Table 2 calibration (test
//! `paper_table2_is_reproduced_within_five_percent`): with argmin's simplex on the clamped
//! objective the fit kept every condition within 5 % but lost the flat-then-steep shape (d2/d0
//! slip ratio 1.062 against the test's 1.05); with this one it holds.

/// Nelder-Mead simplex minimisation inside a box (Nelder & Mead, Comput. J. 7, 1965; standard
/// coefficients 1, 2, 0.5, 0.5); points outside the box are clamped.
pub fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    bounds: &[[f64; 2]],
    iters: usize,
) -> Vec<f64> {
    let n = x0.len();
    let clamp = |x: &mut Vec<f64>| {
        for (v, [lo, hi]) in x.iter_mut().zip(bounds) {
            *v = v.clamp(*lo, *hi);
        }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = vec![(x0.to_vec(), f(x0))];
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += 0.05 * (bounds[i][1] - bounds[i][0]);
        clamp(&mut x);
        let fx = f(&x);
        simplex.push((x, fx));
    }
    for _ in 0..iters {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|p| p.0[j]).sum::<f64>() / n as f64)
            .collect();
        let worst = simplex[n].clone();
        let along = |t: f64| {
            let mut x: Vec<f64> = (0..n)
                .map(|j| centroid[j] + t * (worst.0[j] - centroid[j]))
                .collect();
            clamp(&mut x);
            let fx = f(&x);
            (x, fx)
        };
        let r = along(-1.0);
        if r.1 < simplex[0].1 {
            let e = along(-2.0);
            simplex[n] = if e.1 < r.1 { e } else { r };
        } else if r.1 < simplex[n - 1].1 {
            simplex[n] = r;
        } else {
            let c = along(0.5);
            if c.1 < worst.1 {
                simplex[n] = c;
            } else {
                let best = simplex[0].0.clone();
                for p in simplex.iter_mut().skip(1) {
                    let mut x: Vec<f64> =
                        (0..n).map(|j| best[j] + 0.5 * (p.0[j] - best[j])).collect();
                    clamp(&mut x);
                    *p = (x.clone(), f(&x));
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0).0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_an_interior_minimum_and_stops_at_a_bound() {
        let f = |x: &[f64]| (x[0] - 0.3).powi(2) + 10.0 * (x[1] + 0.2).powi(2);
        let b = [[0.0, 1.0], [-1.0, 1.0]];
        let x = nelder_mead(&f, &[0.9, 0.8], &b, 400);
        assert!(
            (x[0] - 0.3).abs() < 1e-4 && (x[1] + 0.2).abs() < 1e-4,
            "{x:?}"
        );
        // Minimum outside the box on x[0]: the answer sits on the bound.
        let g = |x: &[f64]| (x[0] + 0.5).powi(2) + x[1].powi(2);
        let y = nelder_mead(&g, &[0.5, 0.5], &b, 400);
        assert!(y[0].abs() < 1e-6 && y[1].abs() < 1e-4, "{y:?}");
    }
}
