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
/// interpolant oscillates; 1e-4 smooths that scatter (issue 10's note: knee means within
/// tolerance 12 of 12 with 1e-4 against 11 of 12 with 1e-6, on stored full-order truths).
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

/// Per process: means, then variances, each over the query points.
pub type MeansAndVariances = (Vec<Array1<f64>>, Vec<Array1<f64>>);

/// Mean and variance of each process at the rows of `x`: (n_gp x n_points) each.
pub fn predict_all(gps: &[Gp], x: &Array2<f64>) -> Result<MeansAndVariances, RomError> {
    let mut means = Vec::with_capacity(gps.len());
    let mut vars = Vec::with_capacity(gps.len());
    for gp in gps {
        let (m, v) = gp
            .predict_valvar(x)
            .map_err(|e| RomError::Predict(format!("Gaussian process prediction failed: {e}")))?;
        means.push(m);
        vars.push(v);
    }
    Ok((means, vars))
}

/// Means only, through egobox's `predict`: the baseline the benchmark compares
/// [`KrigingMean`] with (`gp_means_200`).
pub fn predict_means(gps: &[Gp], x: &Array2<f64>) -> Result<Vec<Array1<f64>>, RomError> {
    gps.iter()
        .map(|gp| {
            gp.predict(x)
                .map_err(|e| RomError::Predict(format!("Gaussian process prediction failed: {e}")))
        })
        .collect()
}

/// The Kriging mean predictor of a fitted process, evaluated directly:
/// y(x) = m_y + s_y (beta + sum_i r(x, x_i) gamma_i), with the Matérn 5/2 correlation
/// r = prod_jl (1 + sqrt5 u + 5/3 u^2) exp(-sqrt5 sum u), u = theta_l |w_jl| |x_j - x_ij| on
/// normalised inputs (Rasmussen & Williams eq. 4.17; the same parameters egobox fitted).
///
/// Why our own: egobox's `predict` builds an (n_points x n_train x d) difference array per call;
/// for the 200 friction samples of `rom predict` that took ~0.55 ms per process, this loop
/// ~0.1 ms (criterion, `cargo bench -p beltwin-rom`). A test checks it against egobox to 1e-9.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KrigingMean {
    dim: usize,
    /// The non-zero theta_l |w_jl| with their input j (without KPLS, w is the identity and
    /// there is one per input).
    theta_w: Vec<(usize, f64)>,
    x_mean: Vec<f64>,
    x_std: Vec<f64>,
    /// Normalised training inputs, row-major (n x dim).
    xt: Vec<f64>,
    beta: f64,
    gamma: Vec<f64>,
    y_mean: f64,
    y_std: f64,
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
        let v = serde_json::to_value(gp)
            .map_err(|e| RomError::Fit(format!("reading the fitted process: {e}")))?;
        let theta = nd_data(&v, &["theta"])?;
        let w = nd_data(&v, &["w_star"])?;
        let x_mean = nd_data(&v, &["xt_norm", "mean"])?;
        let x_std = nd_data(&v, &["xt_norm", "std"])?;
        let xt = nd_data(&v, &["xt_norm", "data"])?;
        let beta = nd_data(&v, &["inner_params", "beta"])?;
        let gamma = nd_data(&v, &["inner_params", "gamma"])?;
        let y_mean = nd_data(&v, &["yt_norm", "mean"])?;
        let y_std = nd_data(&v, &["yt_norm", "std"])?;
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
        Ok(Self {
            dim,
            theta_w,
            x_mean,
            x_std,
            xt,
            beta: beta[0],
            gamma,
            y_mean: y_mean[0],
            y_std: y_std[0],
        })
    }

    /// The predictor at one (scaled) input point.
    pub fn predict(&self, x: &[f64]) -> f64 {
        const SQRT5: f64 = 2.236_067_977_499_79;
        let xn: Vec<f64> = (0..self.dim)
            .map(|j| (x[j] - self.x_mean[j]) / self.x_std[j])
            .collect();
        let mut acc = 0.0;
        for (xi, g) in self.xt.chunks_exact(self.dim).zip(&self.gamma) {
            let mut a = 1.0;
            let mut b = 0.0;
            for &(j, tw) in &self.theta_w {
                let u = tw * (xn[j] - xi[j]).abs();
                a *= 1.0 + SQRT5 * u + (5.0 / 3.0) * u * u;
                b += u;
            }
            acc += a * (-SQRT5 * b).exp() * g;
        }
        self.y_mean + self.y_std * (self.beta + acc)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direct_mean_predictor_matches_egobox() {
        // A smooth function of three inputs on 40 scattered points.
        let f = |x: &[f64]| (3.0 * x[0]).sin() + x[1] * x[1] - 2.0 * (x[2] - 0.3).abs();
        let x = Array2::from_shape_fn((40, 3), |(i, j)| {
            ((i * 7 + j * 13) % 40) as f64 / 39.0 + 0.001 * j as f64
        });
        let y: Array1<f64> = x
            .rows()
            .into_iter()
            .map(|r| f(r.as_slice().unwrap()))
            .collect();
        let gp = fit(&x, &y).unwrap();
        let fast = KrigingMean::from_gp(&gp).unwrap();
        let xq = Array2::from_shape_fn((25, 3), |(i, j)| ((i * 3 + j * 5) % 25) as f64 / 24.0);
        let want = gp.predict(&xq).unwrap();
        for (i, w) in want.iter().enumerate() {
            let got = fast.predict(xq.row(i).as_slice().unwrap());
            assert!((got - w).abs() <= 1e-9 * w.abs().max(1.0), "{got} vs {w}");
        }
    }
}
