//! Evaluating the slip surrogate: scaled inputs, the steady quantile function at a point and
//! over the friction samples of a prediction, and the start-up series.

use fom::params::Variable;
use fom::{DesignPoint, DriveConfig};
use ndarray::Array2;

use super::{rearranged_slip, PointPrediction, Surrogate, MIXTURE_NODES};
use crate::features::{capacity_feature_n, capacity_n};
use crate::snapshots::from_z;
use crate::RomError;

impl Surrogate {
    /// Brings a surrogate read from a format-1/2 file to the in-memory form of format 3.
    pub(crate) fn upgrade_from_processes(&mut self) -> Result<(), RomError> {
        self.steady.upgrade_from_processes()?;
        self.startup.gps.clear();
        Ok(())
    }

    /// Scaled inputs: d and mu on [0, 1] over their training ranges, the traction-capacity
    /// feature on [0, 1] over its training range, then every further design variable of the
    /// campaign (e.g. the stiffness EA) on [0, 1] over its range (the configuration's value
    /// where the point leaves it open).
    /// `extra` is [`Surrogate::extra_inputs`], computed once per batch; `row` has
    /// [`Surrogate::input_dim`] entries.
    pub(crate) fn features_into(
        &self,
        q: &DesignPoint,
        u_n: f64,
        cfg: &DriveConfig,
        extra: &[(Variable, [f64; 2])],
        row: &mut ndarray::ArrayViewMut1<f64>,
    ) {
        let st = &self.settings;
        let unit = |v: f64, [lo, hi]: [f64; 2]| (v - lo) / (hi - lo);
        row[0] = unit(q.center_distance_m, st.center_distance_m);
        row[1] = unit(q.friction, st.friction);
        row[2] = match self.aligned_capacity {
            Some(a) => self
                .capacity_scale
                .unit(u_n * q.friction.powf(a.friction_exponent), a.range),
            None => self.capacity_scale.unit(u_n, self.capacity_range_n),
        };
        for (k, (var, range)) in extra.iter().enumerate() {
            row[3 + k] = unit(q.value_or_config(*var, cfg), *range);
        }
    }

    /// The design variables beyond d, mu and T that are inputs, with their training ranges.
    pub(crate) fn extra_inputs(&self) -> Vec<(Variable, [f64; 2])> {
        self.settings.ranges().into_iter().skip(3).collect()
    }

    /// Number of GP inputs.
    pub(crate) fn input_dim(&self) -> usize {
        self.settings.ranges().len()
    }

    /// Scaled inputs of several queries (the geometry is computed once per d and tension).
    pub(crate) fn inputs(&self, cfg: &DriveConfig, qs: &[DesignPoint]) -> Array2<f64> {
        let mut x = Array2::zeros((qs.len(), self.input_dim()));
        let extra = self.extra_inputs();
        let mut cache: Option<(DesignPoint, (f64, f64))> = None;
        for (i, q) in qs.iter().enumerate() {
            let same = |c: &DesignPoint| {
                c.center_distance_m == q.center_distance_m
                    && c.installation_tension_n == q.installation_tension_n
                    && c.axial_stiffness_n == q.axial_stiffness_n
            };
            let (t0, alpha) = match cache {
                Some((c, tw)) if same(&c) => tw,
                _ => {
                    let tw = (q.static_tension_n(cfg), q.smaller_wrap_angle_rad(cfg));
                    cache = Some((*q, tw));
                    tw
                }
            };
            let u = capacity_n(t0, alpha, q.friction);
            self.features_into(q, u, cfg, &extra, &mut x.row_mut(i));
        }
        x
    }

    /// Scaled inputs of one query and its traction capacity, N (computed once for both).
    pub(crate) fn input_row(&self, cfg: &DriveConfig, q: &DesignPoint) -> (Vec<f64>, f64) {
        let u = capacity_feature_n(cfg, q);
        let mut row = ndarray::Array1::zeros(self.input_dim());
        self.features_into(q, u, cfg, &self.extra_inputs(), &mut row.view_mut());
        (row.to_vec(), u)
    }

    /// Steady slip quantile functions (%, sorted) at each query, means only.
    pub fn quantile_functions(
        &self,
        cfg: &DriveConfig,
        qs: &[DesignPoint],
    ) -> Result<Vec<Vec<f64>>, RomError> {
        let mut out = Vec::with_capacity(qs.len());
        self.transformed_levels_at(cfg, qs, |z| out.push(rearranged_slip(z)));
        Ok(out)
    }

    /// Calls `visit` with the transformed slip at every probability level (unsorted) of each
    /// query, in order, each evaluated directly.
    pub(crate) fn transformed_levels_at(
        &self,
        cfg: &DriveConfig,
        qs: &[DesignPoint],
        mut visit: impl FnMut(&[f64]),
    ) {
        let x = self.inputs(cfg, qs);
        let mut z = vec![0.0; self.probability_levels.len()];
        for i in 0..qs.len() {
            let coef = self.mode_coefficients(&x.row(i).to_vec());
            self.steady.basis.reconstruct_into(&coef, &mut z);
            visit(&z);
        }
    }

    /// The steady modes' coefficients (the processes' means) at the scaled input row `xi`.
    pub(crate) fn mode_coefficients(&self, xi: &[f64]) -> Vec<f64> {
        self.steady.means.iter().map(|m| m.predict(xi)).collect()
    }

    /// The quantile functions at `q` with its friction replaced by each of `mus` (the friction
    /// samples of a prediction), as `quantile_functions` gives them, but with the steady
    /// modes' coefficients evaluated at `MIXTURE_NODES` Chebyshev points over the span of
    /// `mus` and interpolated (barycentric Lagrange: Berrut & Trefethen, SIAM Review 46(3),
    /// 2004, eq. 5.2 with the weights of sec. 5) when there are more samples than nodes. The
    /// samples span mu +- 1 %, where the coefficients are smooth (Matern 5/2 processes are
    /// twice differentiable, so convergence is algebraic): on the five-round surrogate the
    /// interpolated quantiles differed from direct evaluation by at most 4.0e-8 pp with 12
    /// nodes, 7.5e-7 pp with 8 and 1.7e-8 pp with 16; on the shipped 421-run model, by at most
    /// 2.1e-6 of the point's own sd with 8 nodes and 2.0e-5 with 6 (test
    /// `mixture_interpolation_matches_direct_evaluation`, bound 1e-3). 8 nodes since that
    /// model, whose processes have 421 training runs against 240: 8 process evaluations per
    /// prediction instead of 100.
    pub fn friction_quantile_functions(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
        mus: &[f64],
    ) -> Result<Vec<Vec<f64>>, RomError> {
        let mut out = Vec::with_capacity(mus.len());
        self.friction_transformed_levels(cfg, q, mus, |z| out.push(rearranged_slip(z)))?;
        Ok(out)
    }

    /// The friction mixture's pool in the transformed space: every probability level's
    /// transformed slip (`to_z`) of every sample in `mus`, unordered (`friction_quantile_functions`
    /// before `from_z` and the per-sample rearrangement, which leave the pooled order statistics
    /// unchanged because `from_z` is increasing). Sorting and mapping through `from_z` gives the
    /// pooled slip values in order.
    pub fn friction_pool_z(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
        mus: &[f64],
    ) -> Result<Vec<f64>, RomError> {
        let mut pool = Vec::with_capacity(mus.len() * self.probability_levels.len());
        self.friction_transformed_levels(cfg, q, mus, |z| pool.extend_from_slice(z))?;
        Ok(pool)
    }

    /// Calls `visit` with the transformed slip at every probability level (unsorted) of each
    /// friction sample in `mus`, in order; the interpolation is described at
    /// `friction_quantile_functions`.
    pub(crate) fn friction_transformed_levels(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
        mus: &[f64],
        mut visit: impl FnMut(&[f64]),
    ) -> Result<(), RomError> {
        let with_mu = |mu: f64| DesignPoint { friction: mu, ..*q };
        let (lo, hi) = mus
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| {
                (a.min(m), b.max(m))
            });
        if mus.len() <= MIXTURE_NODES || hi <= lo {
            let qs: Vec<DesignPoint> = mus.iter().map(|&m| with_mu(m)).collect();
            self.transformed_levels_at(cfg, &qs, visit);
            return Ok(());
        }
        // Chebyshev points of the second kind on [lo, hi] and their barycentric weights.
        let k = MIXTURE_NODES - 1;
        let nodes: Vec<f64> = (0..=k)
            .map(|j| {
                let c = (std::f64::consts::PI * j as f64 / k as f64).cos();
                0.5 * (lo + hi) + 0.5 * (hi - lo) * c
            })
            .collect();
        let weights: Vec<f64> = (0..=k)
            .map(|j| {
                let w = if j % 2 == 0 { 1.0 } else { -1.0 };
                if j == 0 || j == k {
                    0.5 * w
                } else {
                    w
                }
            })
            .collect();
        let node_qs: Vec<DesignPoint> = nodes.iter().map(|&m| with_mu(m)).collect();
        let x = self.inputs(cfg, &node_qs);
        // coef[j][m]: mode m's coefficient at node j.
        let coef: Vec<Vec<f64>> = (0..=k)
            .map(|j| self.mode_coefficients(&x.row(j).to_vec()))
            .collect();
        let mut c = vec![0.0; self.steady.means.len()];
        let mut z = vec![0.0; self.probability_levels.len()];
        for &mu in mus {
            match nodes.iter().position(|&t| t == mu) {
                Some(j) => c.copy_from_slice(&coef[j]),
                None => {
                    c.fill(0.0);
                    let mut denom = 0.0;
                    for j in 0..=k {
                        let f = weights[j] / (mu - nodes[j]);
                        denom += f;
                        for (cm, &v) in c.iter_mut().zip(&coef[j]) {
                            *cm += f * v;
                        }
                    }
                    c.iter_mut().for_each(|v| *v /= denom);
                }
            }
            self.steady.basis.reconstruct_into(&c, &mut z);
            visit(&z);
        }
        Ok(())
    }

    /// Prediction at one point with the surrogate's own uncertainty of the mean slip.
    pub fn predict_point(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
    ) -> Result<PointPrediction, RomError> {
        let mut p = self.predict_points(cfg, std::slice::from_ref(q))?;
        Ok(p.pop().expect("one point in, one out"))
    }

    /// `predict_point` at several points, the same bits as one at a time: each mode's
    /// variances of all the points in one pass (`gp::KrigingVariance::variances_from`).
    pub fn predict_points(
        &self,
        cfg: &DriveConfig,
        qs: &[DesignPoint],
    ) -> Result<Vec<PointPrediction>, RomError> {
        let rows: Vec<(Vec<f64>, f64)> = qs.iter().map(|q| self.input_row(cfg, q)).collect();
        let modes = self.steady.means.len();
        // coef[point][mode] and coef_var[point][mode].
        let mut coef = vec![Vec::with_capacity(modes); qs.len()];
        let mut coef_var = vec![Vec::with_capacity(modes); qs.len()];
        // Each mode's correlations once per point, for its mean and its variance.
        let mut r: Vec<Vec<f64>> = vec![Vec::new(); qs.len()];
        for (m, v) in self.steady.means.iter().zip(&self.steady.variances) {
            for ((xi, _), (rc, c)) in rows.iter().zip(r.iter_mut().zip(coef.iter_mut())) {
                m.correlations_into(xi, rc);
                c.push(m.predict_from(rc));
            }
            let refs: Vec<&[f64]> = r.iter().map(|c| c.as_slice()).collect();
            for (cv, var) in coef_var.iter_mut().zip(v.variances_from(&refs)) {
                cv.push(var);
            }
        }
        Ok(rows
            .iter()
            .zip(coef.iter().zip(&coef_var))
            .map(|((_, u), (c, cv))| {
                let (s, mean, var) = self.steady.steady_moments(c, cv);
                let raw = (var + self.truncation_var_pct2).sqrt();
                PointPrediction {
                    quantiles_pct: s,
                    mean_slip_pct: mean,
                    surrogate_std_pct: self.interval_factor(*u, mean) * raw,
                    likelihood_std_pct: self.std_factor(*u) * raw,
                }
            })
            .collect())
    }

    /// The mean slip at one point, % (`predict_point`'s `mean_slip_pct`, the same number
    /// without the modes' variances, which are most of a point's cost: callers that need only
    /// the mean, such as the posterior predictive over thousands of draws, call this).
    pub fn predict_mean_slip_pct(&self, cfg: &DriveConfig, q: &DesignPoint) -> f64 {
        let (xi, _) = self.input_row(cfg, q);
        let mut r = Vec::new();
        let coef: Vec<f64> = self
            .steady
            .means
            .iter()
            .map(|m| {
                m.correlations_into(&xi, &mut r);
                m.predict_from(&r)
            })
            .collect();
        self.steady.steady_mean(&coef)
    }

    /// Start-up slip series at one point, % on `startup_time_s`.
    pub fn predict_startup(&self, cfg: &DriveConfig, q: &DesignPoint) -> Vec<f64> {
        let (xi, _) = self.input_row(cfg, q);
        let coef: Vec<f64> = self.startup.means.iter().map(|m| m.predict(&xi)).collect();
        let mut z = vec![0.0; self.startup_time_s.len()];
        self.startup.basis.reconstruct_into(&coef, &mut z);
        z.into_iter().map(from_z).collect()
    }

    /// Mean start-up slip at one point over the start-up grid's times up to `until_s` (the
    /// driven speed's 90 % time, as a recording's start-up cell is read), %; the series' first
    /// value where `until_s` is before the grid's first time.
    pub fn predict_startup_mean_pct(
        &self,
        cfg: &DriveConfig,
        q: &DesignPoint,
        until_s: f64,
    ) -> f64 {
        let series = self.predict_startup(cfg, q);
        let w: Vec<f64> = self
            .startup_time_s
            .iter()
            .zip(&series)
            .filter(|(t, _)| **t <= until_s)
            .map(|(_, v)| *v)
            .collect();
        if w.is_empty() {
            return series.first().copied().unwrap_or(f64::NAN);
        }
        w.iter().sum::<f64>() / w.len() as f64
    }
}
