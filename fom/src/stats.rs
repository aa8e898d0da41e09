//! The statistics every crate shares, one definition each: order statistics and quantiles,
//! the sample mean and standard deviation, the normal and chi-square quantiles, the Bonferroni
//! threshold, Huber's loss and a weighted slope through the origin. Used by the full-order
//! model's steady state, the readers of measured data, the surrogate's intervals and the
//! twin's gap diagnosis (docs/decisions/normal-quantiles.md).

/// Quantile of sorted data by linear interpolation between order statistics
/// (Hyndman & Fan 1996, definition 7); NaN for empty data.
pub fn quantile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let (lo, hi, w) = interpolation_ranks(sorted.len(), p);
    sorted[lo] + w * (sorted[hi] - sorted[lo])
}

/// Quantile of weighted values, (value, weight) pairs in any order: the smallest value at
/// which the cumulative weight reaches `p` of the total (the inverse of the weighted
/// empirical distribution function); NaN without positive total weight.
pub fn weighted_quantile(values: &[(f64, f64)], p: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|x| x.1).sum();
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return f64::NAN;
    }
    let mut acc = 0.0;
    for (x, w) in &v {
        acc += w;
        if acc >= p * total {
            return *x;
        }
    }
    v.last().map_or(f64::NAN, |x| x.0)
}

/// The two order statistics (0-based ranks) that `quantile` interpolates between at `p` in
/// `n >= 1` values, and the weight of the upper one.
fn interpolation_ranks(n: usize, p: f64) -> (usize, usize, f64) {
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    (lo, h.ceil() as usize, h - lo as f64)
}

/// `quantile` at each of `ps` of the values `f(v[i])`, for unsorted `v` and a
/// non-decreasing `f`: the order statistics are selected in `v` (`order_statistics`) and
/// only they are mapped through `f`. Equal to sorting `f` of every value and calling
/// `quantile`.
pub fn quantiles_of_map(v: &[f64], ps: &[f64], f: impl Fn(f64) -> f64) -> Vec<f64> {
    if v.is_empty() {
        return vec![f64::NAN; ps.len()];
    }
    let at: Vec<(usize, usize, f64)> = ps
        .iter()
        .map(|&p| interpolation_ranks(v.len(), p))
        .collect();
    let mut ranks: Vec<usize> = at.iter().flat_map(|&(lo, hi, _)| [lo, hi]).collect();
    ranks.sort_unstable();
    ranks.dedup();
    let stats = order_statistics(v, &ranks);
    let value = |r: usize| f(stats[ranks.binary_search(&r).expect("a selected rank")]);
    at.iter()
        .map(|&(lo, hi, w)| {
            let a = value(lo);
            a + w * (value(hi) - a)
        })
        .collect()
}

/// The values of 0-based `ranks` (each below `v.len()`) in the total order of `v`
/// (`f64::total_cmp`'s), without sorting all of `v`: the values are counted into as many
/// equal-width buckets over [min, max] as there are values (bucket sort; Cormen et al.,
/// Introduction to Algorithms, 3rd ed., sec. 8.4), and only the buckets holding a wanted rank
/// are sorted. The bucket index is a non-decreasing function of the value, so the buckets
/// hold consecutive runs of the order. For the 5,000 pooled values of a `rom predict`
/// distribution and its ~110 ranks, 10,000 predictions spent 0.18 s here against 0.44 s in
/// `sort_total` (perf profile of `rom/examples/predict_sweep.rs`). Non-finite values fall
/// back to a full sort.
pub fn order_statistics(v: &[f64], ranks: &[usize]) -> Vec<f64> {
    // Plain comparisons (NaN is caught separately) vectorise; `f64::min` does not.
    let (mut lo, mut hi, mut nan) = (f64::INFINITY, f64::NEG_INFINITY, false);
    for &x in v {
        lo = if x < lo { x } else { lo };
        hi = if x > hi { x } else { hi };
        nan |= x.is_nan();
    }
    if nan || !(lo.is_finite() && hi.is_finite()) {
        let sorted = sort_total(v.to_vec());
        return ranks.iter().map(|&r| sorted[r]).collect();
    }
    let nb = v.len();
    let scale = if hi > lo { nb as f64 / (hi - lo) } else { 0.0 };
    // Monotone: IEEE subtraction and multiplication round monotonically, and so does the
    // truncation; the clamp puts the maximum in the last bucket.
    let bucket: Vec<u32> = v
        .iter()
        .map(|&x| (((x - lo) * scale) as usize).min(nb - 1) as u32)
        .collect();
    let mut start = vec![0usize; nb + 1];
    for &k in &bucket {
        start[k as usize + 1] += 1;
    }
    for k in 0..nb {
        start[k + 1] += start[k];
    }
    // The bucket of each rank: the last k with start[k] <= r.
    let bucket_of = |r: usize| start.partition_point(|&s| s <= r) - 1;
    let of_rank: Vec<usize> = ranks.iter().map(|&r| bucket_of(r)).collect();
    let mut wanted = vec![false; nb];
    for &k in &of_rank {
        wanted[k] = true;
    }
    let picked: Vec<f64> = v
        .iter()
        .zip(&bucket)
        .filter(|(_, &k)| wanted[k as usize])
        .map(|(&x, _)| x)
        .collect();
    let picked = sort_total(picked);
    // A rank's place in `picked`: the sizes of the wanted buckets below its own, plus its
    // place in its bucket.
    let mut below = vec![0usize; nb];
    let mut acc = 0;
    for (k, w) in wanted.iter().enumerate() {
        below[k] = acc;
        if *w {
            acc += start[k + 1] - start[k];
        }
    }
    ranks
        .iter()
        .zip(&of_rank)
        .map(|(&r, &k)| picked[below[k] + r - start[k]])
        .collect()
}

/// Sorts `v` into the IEEE 754 total order (`f64::total_cmp`'s), by sorting integer keys
/// that have that order (the key is `total_cmp`'s own: the bits, with the magnitude bits
/// flipped for negative numbers, compared as signed integers). Same result as
/// `v.sort_by(f64::total_cmp)`, whose key computation it does once per value instead of per
/// comparison: on the 5,000 pooled values of a `rom predict` distribution, 44 us against
/// 62 us for `sort_unstable_by(f64::total_cmp)` and 86-122 us for `sort_by` (measured on
/// three points of the shipped surrogate, 10,000 repetitions each).
pub fn sort_total(v: Vec<f64>) -> Vec<f64> {
    let key = |x: f64| {
        let b = x.to_bits() as i64;
        b ^ (((b >> 63) as u64) >> 1) as i64
    };
    let mut k: Vec<i64> = v.into_iter().map(key).collect();
    k.sort_unstable();
    // The key flips only magnitude bits selected by the sign, so it is its own inverse.
    k.into_iter()
        .map(|b| f64::from_bits(key(f64::from_bits(b as u64)) as u64))
        .collect()
}

/// Mean and population variance (divided by n) of `v`; NaN for none. Summed in eight
/// independent partial sums, which the compiler keeps in vector registers (one running sum is
/// a chain of dependent additions); the rounding differs from a left-to-right sum by a few ulp.
pub fn mean_and_variance(v: &[f64]) -> (f64, f64) {
    let sum = |f: &dyn Fn(f64) -> f64| {
        let mut acc = [0.0f64; 8];
        let chunks = v.chunks_exact(8);
        let tail: f64 = chunks.remainder().iter().map(|&x| f(x)).sum();
        for c in chunks {
            for k in 0..8 {
                acc[k] += f(c[k]);
            }
        }
        acc.iter().sum::<f64>() + tail
    };
    let n = v.len() as f64;
    let mean = sum(&|x| x) / n;
    (mean, sum(&|x| (x - mean) * (x - mean)) / n)
}

/// Median of unsorted data (NaN for none).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    quantile(&v, 0.5)
}

/// Arithmetic mean, summed left to right; NaN for none.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Sample standard deviation (divided by n - 1); NaN for fewer than two values.
pub fn sample_std(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt()
}

/// Quantile of unsorted data (`quantile` of a sorted copy).
pub fn quantile_unsorted(v: &[f64], p: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    quantile(&s, p)
}

/// z of the two-sided 90 % normal interval (the 95 % quantile of the standard normal).
pub const Z90: f64 = 1.644_853_626_951_472_2;

/// Standard normal distribution function by the complementary error function (Abramowitz &
/// Stegun 7.1.26, |error| < 1.5e-7).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / 2f64.sqrt();
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erfc = poly * (-z * z).exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// Standard normal quantile by bisection on [`normal_cdf`] (100 halvings of [-10, 10]).
pub fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-10.0, 10.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Chi-square quantile with `k` degrees of freedom (Wilson & Hilferty 1931, Proc. Natl. Acad.
/// Sci. 17, 684: the cube root of chi2 / k is nearly normal).
pub fn chi2_quantile(p: f64, k: usize) -> f64 {
    let k = k.max(1) as f64;
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + normal_quantile(p) * h.sqrt()).powi(3)
}

/// Two-sided |z| threshold of family-wise level `alpha` over `n` tests (Bonferroni).
pub fn bonferroni_z(alpha: f64, n: usize) -> f64 {
    normal_quantile(1.0 - alpha / (2.0 * n.max(1) as f64))
}

/// Huber's loss of a standardised residual `z` with threshold `c`, on the chi-square's scale:
/// z^2 within c, 2 c |z| - c^2 beyond (Huber 1964, Ann. Math. Stat. 35, 73, eq. 2.2, doubled).
pub fn huber_loss(z: f64, c: f64) -> f64 {
    if z.abs() <= c {
        z * z
    } else {
        2.0 * c * z.abs() - c * c
    }
}

/// Huber's weight of a standardised residual in iteratively reweighted least squares:
/// min(1, c / |z|) (Huber 1964).
pub fn huber_weight(z: f64, c: f64) -> f64 {
    (c / z.abs()).min(1.0)
}

/// Root mean square; NaN for none.
pub fn rms(z: &[f64]) -> f64 {
    if z.is_empty() {
        return f64::NAN;
    }
    (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt()
}

/// The weighted least-squares slope through the origin of y on x, each point [y, x, sd]:
/// s = sum(y x / sd^2) / sum(x^2 / sd^2), with sd(s) = sum(x^2 / sd^2)^(-1/2) (Press et al.,
/// Numerical Recipes, 3rd ed., 2007, sec. 15.2). Points without a positive sd are left out;
/// `None` where no x is non-zero or a sum is not finite.
pub fn slope_through_origin(points: impl IntoIterator<Item = [f64; 3]>) -> Option<(f64, f64)> {
    let (sxy, sxx) = points
        .into_iter()
        .filter(|p| p[2] > 0.0)
        .fold((0.0, 0.0), |(sxy, sxx), [y, x, sd]| {
            (sxy + y * x / (sd * sd), sxx + x * x / (sd * sd))
        });
    (sxx > 0.0 && sxx.is_finite() && sxy.is_finite()).then(|| (sxy / sxx, sxx.recip().sqrt()))
}

/// The inverse-variance weighted mean of values, each point [value, sd], with its sd:
/// sum(v / sd^2) / sum(1 / sd^2), sd sum(1 / sd^2)^(-1/2) (Bevington and Robinson, Data
/// Reduction and Error Analysis for the Physical Sciences, 3rd ed., 2003, sec. 4.1). Points
/// without a positive sd are left out;
/// `None` where none is left or a sum is not finite.
pub fn inverse_variance_mean(points: impl IntoIterator<Item = [f64; 2]>) -> Option<(f64, f64)> {
    let (sw, swv) =
        points
            .into_iter()
            .filter(|p| p[1] > 0.0)
            .fold((0.0, 0.0), |(sw, swv), [v, sd]| {
                let w = sd.powi(-2);
                (sw + w, swv + w * v)
            });
    (sw > 0.0 && sw.is_finite() && swv.is_finite()).then(|| (swv / sw, sw.powf(-0.5)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Readings of 280 and 240 with sds 14 and 12 weigh 144 : 196; equal sds give the plain
    /// mean with sd / sqrt(n); no positive sd, no mean.
    #[test]
    fn an_inverse_variance_mean_weighs_each_value_by_its_sd() {
        let (m, sd) = inverse_variance_mean([[280.0, 14.0], [240.0, 12.0]]).unwrap();
        assert!(
            (m - (280.0 * 144.0 + 240.0 * 196.0) / 340.0).abs() < 1e-9,
            "{m}"
        );
        assert!(
            (sd - (196.0 * 144.0 / 340.0_f64).sqrt()).abs() < 1e-9,
            "{sd}"
        );
        let (m, sd) = inverse_variance_mean([[1.0, 2.0], [3.0, 2.0]]).unwrap();
        assert_eq!(m, 2.0);
        assert!((sd - 2.0 / 2f64.sqrt()).abs() < 1e-12, "{sd}");
        assert_eq!(inverse_variance_mean([[1.0, 0.0]]), None);
    }

    /// A line of slope 0.8 is read as 0.8 with the weighted fit's sd; a point with a wide sd
    /// counts for little against the others; without a non-zero x there is no slope.
    #[test]
    fn a_slope_through_origin_weighs_each_point_by_its_sd() {
        let runs = [0.77, 0.79, 0.85, 3.0];
        let sds = [0.04, 0.04, 0.13, 0.06];
        let exact: Vec<[f64; 3]> = runs
            .iter()
            .zip(&sds)
            .map(|(&delta, &sd)| [0.8 * delta, delta, sd])
            .collect();
        let (s, sd) = slope_through_origin(exact.iter().copied()).expect("a line");
        assert!((s - 0.8).abs() < 1e-12, "{s}");
        let info: f64 = runs.iter().zip(&sds).map(|(d, e)| (d / e).powi(2)).sum();
        assert!((sd - info.sqrt().recip()).abs() < 1e-12, "{sd}");
        // One point at slope 1.25, the others at 0.8: with its sd widened tenfold it moves the
        // slope by less than 0.02, at its own sd by more than 0.2.
        let mut off = exact.clone();
        off[3][0] = 1.25 * off[3][1];
        off[3][2] = 0.6;
        assert!((slope_through_origin(off.iter().copied()).unwrap().0 - 0.8).abs() < 0.02);
        off[3][2] = 0.06;
        assert!(slope_through_origin(off.iter().copied()).unwrap().0 - 0.8 > 0.2);
        assert_eq!(slope_through_origin([[0.5, 0.0, 0.1]]), None);
        assert_eq!(slope_through_origin([]), None);
    }

    #[test]
    fn sort_total_matches_the_total_order_sort() {
        let mut v: Vec<f64> = (0..2000)
            .map(|i| ((i * 7919) % 2003) as f64 * if i % 3 == 0 { -1.5 } else { 0.25 })
            .collect();
        v.extend([
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -1e-300,
        ]);
        let mut want = v.clone();
        want.sort_by(f64::total_cmp);
        let got = sort_total(v);
        assert!(got
            .iter()
            .zip(&want)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(got.len(), want.len());
    }

    #[test]
    fn order_statistics_match_sorting() {
        let cases: Vec<Vec<f64>> = vec![
            (0..5000)
                .map(|i| ((i * 7919) % 5003) as f64 * 1e-3 - 2.0)
                .collect(),
            // Clustered with an outlier, ties, a single value, all equal, signed zeros.
            (0..300)
                .map(|i| if i == 7 { 1e6 } else { (i % 13) as f64 * 1e-9 })
                .collect(),
            vec![4.2],
            vec![1.5; 40],
            vec![0.0, -0.0, 3.0, -3.0, f64::INFINITY, -1.0],
        ];
        for v in cases {
            let sorted = sort_total(v.clone());
            let ranks: Vec<usize> = (0..v.len()).step_by(7).chain([v.len() - 1]).collect();
            let got = order_statistics(&v, &ranks);
            for (&r, g) in ranks.iter().zip(&got) {
                assert_eq!(g.to_bits(), sorted[r].to_bits(), "rank {r} of {}", v.len());
            }
            let ps = [0.0, 0.05, 0.3333, 0.5, 0.95, 1.0];
            let f = |x: f64| x.atan();
            let fs: Vec<f64> = sorted.iter().map(|&x| f(x)).collect();
            for (p, q) in ps.iter().zip(quantiles_of_map(&v, &ps, f)) {
                assert_eq!(q, quantile(&fs, *p), "p {p}");
            }
        }
    }

    #[test]
    fn mean_and_variance_agree_with_the_two_pass_formula() {
        let v: Vec<f64> = (0..1003)
            .map(|i| ((i * 37) % 101) as f64 * 0.01 + 5.0)
            .collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64;
        let (gm, gv) = mean_and_variance(&v);
        assert!((gm - m).abs() <= 1e-14 * m && (gv - var).abs() <= 1e-12 * var);
        assert!(mean_and_variance(&[]).0.is_nan());
    }

    #[test]
    fn weighted_quantile_inverts_the_weighted_distribution() {
        let v = [(3.0, 1.0), (1.0, 1.0), (2.0, 2.0)];
        assert_eq!(weighted_quantile(&v, 0.25), 1.0);
        assert_eq!(weighted_quantile(&v, 0.5), 2.0);
        assert_eq!(weighted_quantile(&v, 0.75), 2.0);
        assert_eq!(weighted_quantile(&v, 0.9), 3.0);
        // A zero weight removes a value; no weight at all gives NaN.
        assert_eq!(weighted_quantile(&[(5.0, 0.0), (1.0, 1.0)], 0.9), 1.0);
        assert!(weighted_quantile(&[(5.0, 0.0)], 0.5).is_nan());
        assert!(weighted_quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn quantile_interpolates_order_statistics() {
        let d = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&d, 0.0), 1.0);
        assert_eq!(quantile(&d, 0.5), 3.0);
        assert!((quantile(&d, 0.95) - 4.8).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
    }

    #[test]
    fn normal_and_chi_square_quantiles_match_tables() {
        // The erfc formula's 1.5e-7 over the density (0.0034 at 3.09) bounds the error: 5e-5.
        assert!((normal_quantile(0.975) - 1.959_964).abs() < 1e-5);
        assert!((normal_quantile(0.999) - 3.090_232).abs() < 5e-5);
        assert!((normal_quantile(0.95) - Z90).abs() < 1e-5);
        // chi2 0.999 quantiles: 29.588 (k = 10), 149.449 (k = 100) (Abramowitz & Stegun
        // table 26.8); Wilson-Hilferty is within 0.5 % there.
        assert!((chi2_quantile(0.999, 10) / 29.588 - 1.0).abs() < 0.01);
        assert!((chi2_quantile(0.999, 100) / 149.449 - 1.0).abs() < 0.005);
        // Bonferroni over 20 tests at 5 %: the 99.875 % quantile.
        assert!((bonferroni_z(0.05, 20) - 3.023).abs() < 1e-3);
    }

    #[test]
    fn huber_charges_far_residuals_linearly() {
        assert_eq!(huber_loss(50.0, 3.0), 291.0);
        assert_eq!(huber_loss(-2.0, 3.0), 4.0);
        assert_eq!(huber_weight(6.0, 3.0), 0.5);
        assert_eq!(huber_weight(-1.0, 3.0), 1.0);
    }

    #[test]
    fn mean_std_and_rms() {
        let v = [1.0, 2.0, 3.0];
        assert_eq!(mean(&v), 2.0);
        assert_eq!(sample_std(&v), 1.0);
        assert_eq!(rms(&[3.0, 4.0, 0.0, 0.0]), 2.5);
        assert!(rms(&[]).is_nan());
        assert_eq!(quantile_unsorted(&[3.0, 1.0, 2.0], 0.5), 2.0);
    }
}
