//! One Gaussian process per POD coefficient: egobox-gp behind a small wrapper.
//!
//! Kriging with a constant mean and a Matérn 5/2 correlation (Rasmussen & Williams, Gaussian
//! Processes for Machine Learning, 2006, eq. 4.17): twice differentiable, so it follows the
//! steep knee of slip versus tension without the over-smoothing of a squared exponential.
//! Hyperparameters (one length scale per input) maximise the likelihood (egobox: COBYLA,
//! multistart); egobox scales inputs and outputs to zero mean and unit variance itself.

use egobox_gp::correlation_models::Matern52Corr;
use egobox_gp::mean_models::ConstantMean;
use egobox_gp::{GaussianProcess, ThetaTuning};
use linfa::prelude::{Dataset, Fit};
use ndarray::{Array1, Array2};

use crate::RomError;

/// The fitted model type stored in surrogate files.
pub type Gp = GaussianProcess<f64, ConstantMean, Matern52Corr>;

/// Nugget (relative to the process variance) added to the correlation diagonal. Near the
/// knee's onset settled full-order slips scatter from run to run more than the trend between
/// neighbours (e.g. 0.97 % and 0.69 % at points 0.03 mm and 14 N apart), so an exact
/// interpolant oscillates; 1e-4 smooths that scatter (knee means within tolerance 12 of
/// 12 with 1e-4 against 11 of 12 with 1e-6, on stored full-order truths;
/// `docs/validation/surrogate.md`, "Earlier models").
pub const NUGGET: f64 = 1e-4;

/// Fits one process to inputs `x` (n x d, already scaled) and outputs `y` (n).
pub fn fit(x: &Array2<f64>, y: &Array1<f64>) -> Result<Gp, RomError> {
    GaussianProcess::<f64, ConstantMean, Matern52Corr>::params(ConstantMean(), Matern52Corr())
        .nugget(NUGGET)
        .n_start(10)
        .fit(&Dataset::new(x.clone(), y.clone()))
        .map_err(|e| RomError::Fit(format!("Gaussian process fit failed: {e}")))
}

/// Refits with the length scales of `like` held fixed (for leave-one-out checks).
pub fn fit_fixed(x: &Array2<f64>, y: &Array1<f64>, like: &Gp) -> Result<Gp, RomError> {
    GaussianProcess::<f64, ConstantMean, Matern52Corr>::params(ConstantMean(), Matern52Corr())
        .nugget(NUGGET)
        .theta_tuning(ThetaTuning::Fixed(like.theta().clone()))
        .fit(&Dataset::new(x.clone(), y.clone()))
        .map_err(|e| RomError::Fit(format!("Gaussian process refit failed: {e}")))
}

/// The Kriging mean predictor of a fitted process, evaluated directly:
/// y(x) = m_y + s_y (beta + sum_i r(x, x_i) gamma_i), with the Matérn 5/2 correlation
/// r = prod_jl (1 + sqrt5 u + 5/3 u^2) exp(-sqrt5 sum u), u = theta_l |w_jl| |x_j - x_ij| on
/// normalised inputs (Rasmussen & Williams eq. 4.17; the same parameters egobox fitted).
///
/// Why our own: egobox's `predict` builds an (n_points x n_train x d) difference array per call;
/// for the 200 friction samples of `rom predict` that took ~0.55 ms per process, this loop
/// ~0.1 ms (criterion, `cargo bench -p beltwin-rom --features bench`). A test checks it against egobox to 1e-9.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "KrigingMeanFile", into = "KrigingMeanFile")]
pub struct KrigingMean {
    dim: usize,
    /// The non-zero theta_l |w_jl| with their input j (without KPLS, w is the identity and
    /// there is one per input).
    theta_w: Vec<(usize, f64)>,
    x_mean: Vec<f64>,
    x_std: Vec<f64>,
    /// Normalised training inputs, column-major (input j's values of all n points at
    /// j n .. (j + 1) n), so the correlation loop runs along the points and vectorises.
    xt_cols: Vec<f64>,
    beta: f64,
    gamma: Vec<f64>,
    y_mean: f64,
    y_std: f64,
}

/// `KrigingMean` as the model file stores it: the training inputs row-major (`xt`, n x dim).
#[derive(serde::Serialize, serde::Deserialize)]
struct KrigingMeanFile {
    dim: usize,
    theta_w: Vec<(usize, f64)>,
    x_mean: Vec<f64>,
    x_std: Vec<f64>,
    xt: Vec<f64>,
    beta: f64,
    gamma: Vec<f64>,
    y_mean: f64,
    y_std: f64,
}

/// Moves between row-major (n x cols) and column-major storage of `v`.
fn transpose(v: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    (0..v.len())
        .map(|k| v[(k % rows) * cols + k / rows])
        .collect()
}

impl From<KrigingMeanFile> for KrigingMean {
    fn from(f: KrigingMeanFile) -> Self {
        let n = f.gamma.len();
        Self {
            xt_cols: transpose(&f.xt, n, f.dim),
            dim: f.dim,
            theta_w: f.theta_w,
            x_mean: f.x_mean,
            x_std: f.x_std,
            beta: f.beta,
            gamma: f.gamma,
            y_mean: f.y_mean,
            y_std: f.y_std,
        }
    }
}

impl From<KrigingMean> for KrigingMeanFile {
    fn from(m: KrigingMean) -> Self {
        let n = m.gamma.len();
        Self {
            xt: transpose(&m.xt_cols, m.dim, n),
            dim: m.dim,
            theta_w: m.theta_w,
            x_mean: m.x_mean,
            x_std: m.x_std,
            beta: m.beta,
            gamma: m.gamma,
            y_mean: m.y_mean,
            y_std: m.y_std,
        }
    }
}

/// The fitted process in its serde form, the only public view of its parameters.
fn gp_value(gp: &Gp) -> Result<serde_json::Value, RomError> {
    serde_json::to_value(gp).map_err(|e| RomError::Fit(format!("reading the fitted process: {e}")))
}

/// The direct mean predictor of a fitted process and, with `variance`, its variance
/// predictor, from one read of its parameters.
pub fn direct_predictors(
    gp: &Gp,
    variance: bool,
) -> Result<(KrigingMean, Option<KrigingVariance>), RomError> {
    let v = gp_value(gp)?;
    let var = if variance {
        Some(KrigingVariance::from_value(&v)?)
    } else {
        None
    };
    Ok((KrigingMean::from_value(&v)?, var))
}

fn nd_data(v: &serde_json::Value, path: &[&str]) -> Result<Vec<f64>, RomError> {
    let mut node = v;
    for p in path {
        node = node
            .get(*p)
            .ok_or_else(|| RomError::Fit(format!("egobox GP has no `{}`", path.join("."))))?;
    }
    node.get("data")
        .and_then(|d| d.as_array())
        .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
        .ok_or_else(|| RomError::Fit(format!("egobox GP `{}` is not an array", path.join("."))))
}

impl KrigingMean {
    /// Reads the fitted parameters from the process (through its serde form, the only public
    /// view of them); only the constant mean is supported, which is what `fit` uses.
    pub fn from_gp(gp: &Gp) -> Result<Self, RomError> {
        Self::from_value(&gp_value(gp)?)
    }

    fn from_value(v: &serde_json::Value) -> Result<Self, RomError> {
        let theta = nd_data(v, &["theta"])?;
        let w = nd_data(v, &["w_star"])?;
        let x_mean = nd_data(v, &["xt_norm", "mean"])?;
        let x_std = nd_data(v, &["xt_norm", "std"])?;
        let xt = nd_data(v, &["xt_norm", "data"])?;
        let beta = nd_data(v, &["inner_params", "beta"])?;
        let gamma = nd_data(v, &["inner_params", "gamma"])?;
        let y_mean = nd_data(v, &["yt_norm", "mean"])?;
        let y_std = nd_data(v, &["yt_norm", "std"])?;
        let dim = x_mean.len();
        let h = theta.len();
        if dim == 0 || w.len() != dim * h || xt.len() != gamma.len() * dim || beta.len() != 1 {
            return Err(RomError::Fit(
                "unexpected shapes in the fitted process".into(),
            ));
        }
        let theta_w = (0..dim * h)
            .map(|k| (k / h, theta[k % h] * w[k].abs()))
            .filter(|&(_, tw)| tw != 0.0)
            .collect();
        let xt_cols = transpose(&xt, gamma.len(), dim);
        Ok(Self {
            dim,
            theta_w,
            x_mean,
            x_std,
            xt_cols,
            beta: beta[0],
            gamma,
            y_mean: y_mean[0],
            y_std: y_std[0],
        })
    }

    /// The Matérn 5/2 correlation of the (scaled) input point `x` with each training point,
    /// in training order (Rasmussen & Williams eq. 4.17, the parameters egobox fitted), into
    /// `r`. The exponentials are taken in one pass over the slice, which the compiler
    /// vectorises (`fom::fastmath::exp`).
    pub fn correlations_into(&self, x: &[f64], r: &mut Vec<f64>) {
        let xn: Vec<f64> = (0..self.dim)
            .map(|j| (x[j] - self.x_mean[j]) / self.x_std[j])
            .collect();
        let n = self.gamma.len();
        r.clear();
        r.resize(n, 0.0);
        let mut poly = vec![1.0; n];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2, checked just above.
            unsafe { matern_terms_avx2(&self.theta_w, &self.xt_cols, &xn, &mut poly, r) };
        } else {
            matern_terms(&self.theta_w, &self.xt_cols, &xn, &mut poly, r);
        }
        #[cfg(not(target_arch = "x86_64"))]
        matern_terms(&self.theta_w, &self.xt_cols, &xn, &mut poly, r);
        fom::fastmath::exp_in_place(r);
        r.iter_mut().zip(&poly).for_each(|(v, a)| *v *= a);
    }

    /// The predictor at one (scaled) input point.
    pub fn predict(&self, x: &[f64]) -> f64 {
        let mut r = Vec::new();
        self.correlations_into(x, &mut r);
        self.predict_from(&r)
    }

    /// The predictor from the correlations `r` of a point (`correlations_into`).
    pub fn predict_from(&self, r: &[f64]) -> f64 {
        self.y_mean + self.y_std * (self.beta + dot(r, &self.gamma))
    }
}

/// The Matérn 5/2 factors of every training point (Rasmussen & Williams eq. 4.17): into `poly`
/// (ones on entry) the product over inputs of 1 + sqrt5 u + 5/3 u^2, into `expo` (zeros on
/// entry) -sqrt5 sum u, with u = theta_l |w_jl| |x_j - x_ij| and `xt_cols` column-major.
#[inline(always)]
fn matern_terms(
    theta_w: &[(usize, f64)],
    xt_cols: &[f64],
    xn: &[f64],
    poly: &mut [f64],
    expo: &mut [f64],
) {
    const SQRT5: f64 = 2.236_067_977_499_79;
    let n = poly.len();
    for &(j, tw) in theta_w {
        let xj = xn[j];
        for ((a, b), &xi) in poly
            .iter_mut()
            .zip(expo.iter_mut())
            .zip(&xt_cols[j * n..(j + 1) * n])
        {
            let u = tw * (xj - xi).abs();
            *a *= 1.0 + SQRT5 * u + (5.0 / 3.0) * u * u;
            *b += u;
        }
    }
    expo.iter_mut().for_each(|b| *b *= -SQRT5);
}

/// `matern_terms` compiled for AVX2's four lanes (the same IEEE operations, so the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn matern_terms_avx2(
    theta_w: &[(usize, f64)],
    xt_cols: &[f64],
    xn: &[f64],
    poly: &mut [f64],
    expo: &mut [f64],
) {
    matern_terms(theta_w, xt_cols, xn, poly, expo);
}

/// The Kriging variance of a fitted process with a constant mean, from the factors egobox
/// computed at fit time: with L the Cholesky factor of the training correlation matrix
/// (nugget included), r_t = L^-1 r(x) and f_t = L^-1 1,
/// MSE(x) = sigma^2 (1 - |r_t|^2 + (f_t . r_t - 1)^2 / |f_t|^2)
/// (ordinary-Kriging mean squared error: Sacks, Welch, Mitchell & Wynn, Statistical Science
/// 4(4), 1989, eq. 7; egobox's `predict_var` in this form). Stored instead of the egobox state:
/// L packed and base64-encoded, so a model file loads without parsing n^2 decimal numbers.
/// A test checks it against egobox to 1e-9.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KrigingVariance {
    sigma2: f64,
    /// The lower-triangular Cholesky factor L, rows packed (n (n + 1) / 2 entries).
    #[serde(with = "packed_f64")]
    l_packed: Vec<f64>,
    /// f_t = L^-1 1.
    ft: Vec<f64>,
}

/// Little-endian f64 vectors as base64 text in a JSON file (exact round trip).
mod packed_f64 {
    use base64::Engine;

    pub fn serialize<S: serde::Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        s.serialize_str(&base64::engine::general_purpose::STANDARD.encode(bytes))
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        let text = <std::borrow::Cow<'de, str> as serde::Deserialize>::deserialize(d)?;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(text.as_bytes())
            .map_err(serde::de::Error::custom)?;
        if bytes.len() % 8 != 0 {
            return Err(serde::de::Error::custom(
                "packed f64 data of a length not divisible by 8",
            ));
        }
        Ok(bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect())
    }
}

impl KrigingVariance {
    /// Reads sigma^2, L and f_t from the fitted process (its serde form).
    pub fn from_gp(gp: &Gp) -> Result<Self, RomError> {
        Self::from_value(&gp_value(gp)?)
    }

    fn from_value(v: &serde_json::Value) -> Result<Self, RomError> {
        let l = nd_data(v, &["inner_params", "r_chol"])?;
        let ft = nd_data(v, &["inner_params", "ft"])?;
        let sigma2 = v
            .get("inner_params")
            .and_then(|p| p.get("sigma2"))
            .and_then(|s| s.as_f64().or_else(|| s.get("data")?.get(0)?.as_f64()))
            .ok_or_else(|| RomError::Fit("egobox GP has no `inner_params.sigma2`".into()))?;
        let n = ft.len();
        if n == 0 || l.len() != n * n {
            return Err(RomError::Fit(
                "unexpected shapes in the fitted process".into(),
            ));
        }
        let l_packed = (0..n)
            .flat_map(|i| l[i * n..i * n + i + 1].to_vec())
            .collect();
        Ok(Self {
            sigma2,
            l_packed,
            ft,
        })
    }

    /// The variance at one (scaled) input point of the process whose mean predictor is `mean`.
    pub fn variance(&self, mean: &KrigingMean, x: &[f64]) -> f64 {
        let mut corr = Vec::new();
        mean.correlations_into(x, &mut corr);
        self.variance_from(&corr)
    }

    /// The variance from the correlations `corr` of a point with the training points
    /// (`KrigingMean::correlations_into` of the process's mean predictor); compiled for
    /// AVX2's four lanes where the processor has them (the same IEEE operations in the same
    /// order, so the same bits: no fused multiply-add).
    pub fn variance_from(&self, corr: &[f64]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked on the line above).
            return unsafe { self.variance_from_avx2(corr) };
        }
        self.variance_from_any(corr)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn variance_from_avx2(&self, corr: &[f64]) -> f64 {
        self.variance_from_any(corr)
    }

    #[inline(always)]
    fn variance_from_any(&self, corr: &[f64]) -> f64 {
        let n = self.ft.len();
        // Forward substitution L r_t = r, row by row through the packed factor.
        let mut rt = Vec::with_capacity(n);
        let mut row = 0;
        for (i, &r) in corr.iter().enumerate() {
            let li = &self.l_packed[row..row + i + 1];
            let acc = dot(&li[..i], &rt);
            rt.push((r - acc) / li[i]);
            row += i + 1;
        }
        let rr = dot(&rt, &rt);
        let fr = dot(&self.ft, &rt);
        let ff = dot(&self.ft, &self.ft);
        (self.sigma2 * (1.0 - rr + (fr - 1.0).powi(2) / ff)).max(0.0)
    }
}

impl KrigingVariance {
    /// `variance_from` at several points at once, `corrs` holding each point's correlations:
    /// the same bits as one point at a time (each point's sums in the same order), the
    /// forward substitutions of the points interleaved row by row, so that their dot
    /// products overlap instead of each row waiting on the last one's sum (the calibration's
    /// likelihood predicts all its conditions at each draw).
    pub fn variances_from(&self, corrs: &[&[f64]]) -> Vec<f64> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked on the line above).
            return unsafe { self.variances_from_avx2(corrs) };
        }
        self.variances_from_any(corrs)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn variances_from_avx2(&self, corrs: &[&[f64]]) -> Vec<f64> {
        self.variances_from_any(corrs)
    }

    #[inline(always)]
    fn variances_from_any(&self, corrs: &[&[f64]]) -> Vec<f64> {
        let mut out = Vec::with_capacity(corrs.len());
        for group in corrs.chunks(LANES) {
            // A point alone takes the one-point substitution: the lanes would do four times
            // its arithmetic for the same bits.
            match group {
                [one] => out.push(self.variance_from_any(one)),
                _ => out.extend_from_slice(&self.variances_of_lanes(group)[..group.len()]),
            }
        }
        out
    }

    /// The variances of up to `LANES` points (the rest of the lanes read zero correlations
    /// and are dropped by the caller): each lane's sums are `dot`'s, term by term.
    #[inline(always)]
    fn variances_of_lanes(&self, group: &[&[f64]]) -> [f64; LANES] {
        let n = self.ft.len();
        // rt[j][lane]: the lane's r_t at row j; acc[k][lane]: its k-th partial sum (`dot`).
        let mut rt = vec![[0.0; LANES]; n];
        let mut row = 0;
        for i in 0..n {
            let li = &self.l_packed[row..row + i + 1];
            let mut acc = [[0.0; LANES]; 8];
            let full = i / 8 * 8;
            for (lc, rc) in li[..full].chunks_exact(8).zip(rt[..full].chunks_exact(8)) {
                for k in 0..8 {
                    for lane in 0..LANES {
                        acc[k][lane] += lc[k] * rc[k][lane];
                    }
                }
            }
            let mut next = [0.0; LANES];
            for (lane, value) in next.iter_mut().enumerate() {
                let partial: [f64; 8] = std::array::from_fn(|k| acc[k][lane]);
                let tail: f64 = (full..i).map(|j| li[j] * rt[j][lane]).sum();
                let dot_i = partial.iter().sum::<f64>() + tail;
                let corr = group.get(lane).map_or(0.0, |c| c[i]);
                *value = (corr - dot_i) / li[i];
            }
            rt[i] = next;
            row += i + 1;
        }
        let ff = dot(&self.ft, &self.ft);
        std::array::from_fn(|lane| {
            let rt_lane: Vec<f64> = rt.iter().map(|r| r[lane]).collect();
            let rr = dot(&rt_lane, &rt_lane);
            let fr = dot(&self.ft, &rt_lane);
            (self.sigma2 * (1.0 - rr + (fr - 1.0).powi(2) / ff)).max(0.0)
        })
    }
}

/// Points whose variances `KrigingVariance::variances_from` computes together: AVX2's four
/// lanes.
const LANES: usize = 4;

/// Dot product with eight independent partial sums, which the compiler keeps in vector
/// registers (a single running sum is a serial chain of dependent additions). The forward
/// substitution of `KrigingVariance::variance` is a dot product per row: with it 10,000
/// one-sample predictions took 0.28 s instead of 0.50 s (`python/examples/bench.py`); the sum's
/// rounding differs from a left-to-right sum by a few ulps.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f64>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A process fitted to a smooth function of three inputs on 40 scattered points, its
    /// training inputs, and 25 query points.
    fn example() -> (Gp, Array2<f64>, Array2<f64>) {
        let f = |x: &[f64]| (3.0 * x[0]).sin() + x[1] * x[1] - 2.0 * (x[2] - 0.3).abs();
        let x = Array2::from_shape_fn((40, 3), |(i, j)| {
            ((i * 7 + j * 13) % 40) as f64 / 39.0 + 0.001 * j as f64
        });
        let y: Array1<f64> = x
            .rows()
            .into_iter()
            .map(|r| f(r.as_slice().unwrap()))
            .collect();
        let xq = Array2::from_shape_fn((25, 3), |(i, j)| ((i * 3 + j * 5) % 25) as f64 / 24.0);
        (fit(&x, &y).unwrap(), x, xq)
    }

    #[test]
    fn direct_mean_predictor_matches_egobox() {
        let (gp, _, xq) = example();
        let fast = KrigingMean::from_gp(&gp).unwrap();
        let want = gp.predict(&xq).unwrap();
        for (i, w) in want.iter().enumerate() {
            let got = fast.predict(xq.row(i).as_slice().unwrap());
            assert!((got - w).abs() <= 1e-9 * w.abs().max(1.0), "{got} vs {w}");
        }
    }

    #[test]
    fn direct_variance_matches_egobox_and_survives_a_file_round_trip() {
        let (gp, x, xq) = example();
        let (mean, var) = direct_predictors(&gp, true).unwrap();
        let var = var.unwrap();
        let text = serde_json::to_string(&var).unwrap();
        let back: KrigingVariance = serde_json::from_str(&text).unwrap();
        assert_eq!(back, var);
        // Between and at training points (where the variance nearly vanishes).
        let want = gp.predict_var(&xq).unwrap();
        let scale = want.iter().copied().fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (i, w) in want.iter().enumerate() {
            let got = back.variance(&mean, xq.row(i).as_slice().unwrap());
            assert!((got - w).abs() <= 1e-9 * scale, "{got} vs {w}");
        }
        let at_training = back.variance(&mean, x.row(3).as_slice().unwrap());
        assert!(at_training <= 1e-3 * scale, "{at_training}");
    }

    /// The variance is the same to the last bit whichever path computes it: the portable
    /// code and the AVX2 build of it that the dispatch picks on a processor that has AVX2.
    #[test]
    fn variances_of_several_points_are_each_points_variance_bit_for_bit() {
        let (gp, x, xq) = example();
        let (mean, var) = direct_predictors(&gp, true).unwrap();
        let var = var.unwrap();
        // Query points and training points (variance near zero), in batches of 1 to 7.
        let points: Vec<Vec<f64>> = xq
            .rows()
            .into_iter()
            .chain(x.rows().into_iter().take(6))
            .map(|r| {
                let mut c = Vec::new();
                mean.correlations_into(r.as_slice().unwrap(), &mut c);
                c
            })
            .collect();
        for m in 1..=7 {
            for batch in points.chunks(m) {
                let refs: Vec<&[f64]> = batch.iter().map(|c| c.as_slice()).collect();
                let together = var.variances_from(&refs);
                let alone = var.variances_from_any(&refs);
                for ((c, t), a) in batch.iter().zip(&together).zip(&alone) {
                    let one = var.variance_from(c);
                    assert_eq!(t.to_bits(), one.to_bits(), "batch of {m}: {t} vs {one}");
                    assert_eq!(a.to_bits(), one.to_bits(), "batch of {m}: {a} vs {one}");
                }
            }
        }
    }

    #[test]
    fn variance_paths_agree_bit_for_bit() {
        let (gp, _, xq) = example();
        let (mean, var) = direct_predictors(&gp, true).unwrap();
        let var = var.unwrap();
        for row in xq.rows() {
            let mut r = Vec::new();
            mean.correlations_into(row.as_slice().unwrap(), &mut r);
            let dispatched = var.variance_from(&r);
            assert_eq!(dispatched.to_bits(), var.variance_from_any(&r).to_bits());
        }
    }
}
