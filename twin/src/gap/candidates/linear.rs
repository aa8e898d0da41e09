//! The linear model every candidate is scored through: the cells of label l = twin +
//! sum_k m_k S_k + the slip-level nuisance, with S_k an effect's sensitivity per unit magnitude
//! (m_k in [0, max_k]) and the nuisance the calibration's slip offset (free) plus, where
//! enabled, a smooth discrepancy of the slip level across labels (`Nuisance`): what
//! calibration, or a belt whose creep differs from the twin's, absorbs is not credited to an
//! effect. Fitted robustly (Huber) by iteratively reweighted least squares; every candidate of
//! the catalogue, "none", and the joint fit of several effects (`selection`) go through it.

use faer::linalg::solvers::Solve;
use faer::Mat;
use fom::stats::{huber_loss, huber_weight};

use crate::gap::features::CELLS;

/// |z| beyond which a cell's residual weighs linearly, not quadratically, in the effects' fits
/// and scores (Huber's loss; three standard deviations: a noise-level cell keeps the
/// chi-square's weight).
pub(in crate::gap) const HUBER_Z: f64 = 3.0;

/// Huber's loss of a standardised residual on the chi-square's scale: z^2 within `HUBER_Z`,
/// 2 c |z| - c^2 beyond (Huber 1964, Ann. Math. Stat. 35, 73, eq. 2.2, doubled).
pub(in crate::gap) fn huber(z: f64) -> f64 {
    huber_loss(z, HUBER_Z)
}

/// The slip-level nuisance every fit shares: the calibration's slip offset a (free) and, when
/// `prior_sd_pp` is positive, a discrepancy b x + c x^2 of the slip level across labels with
/// x the label's standardised centre distance and a Gaussian prior N(0, prior_sd_pp^2) on b
/// and c (Kennedy & O'Hagan 2001, J. R. Stat. Soc. B 63, 425, section 4.3: a model
/// discrepancy term with a prior; here a quadratic, docs/decisions/gap-model-form.md).
#[derive(Debug, Clone)]
pub(in crate::gap) struct Nuisance {
    /// Per label, per cell: what 1 pp of slip offset does to the cell (`cells::nuisance`).
    pub offset: Vec<Vec<f64>>,
    /// Per label: the discrepancy's covariate, in [-1, 1].
    pub x: Vec<f64>,
    /// Prior sd of the discrepancy's slope and curvature, pp (0: the offset alone).
    pub prior_sd_pp: f64,
}

impl Nuisance {
    /// The slip offset alone.
    pub fn offset_only(offset: Vec<Vec<f64>>) -> Self {
        let x = vec![0.0; offset.len()];
        Nuisance {
            offset,
            x,
            prior_sd_pp: 0.0,
        }
    }

    /// Number of nuisance parameters: the offset, and slope and curvature if enabled.
    fn terms(&self) -> usize {
        if self.prior_sd_pp > 0.0 {
            3
        } else {
            1
        }
    }

    /// The column of nuisance parameter k at label l, cell i.
    fn column(&self, l: usize, i: usize, k: usize) -> f64 {
        self.offset[l][i] * self.x[l].powi(k as i32)
    }

    /// Whether the slip level's nuisance moves cell i at label l.
    pub fn moves(&self, l: usize, i: usize) -> bool {
        self.offset[l][i] != 0.0
    }

    /// Whether the discrepancy term is on.
    pub fn has_discrepancy(&self) -> bool {
        self.terms() > 1
    }

    /// The slip level the discrepancy (slope and curvature `shape`) adds at label l beyond the
    /// constant offset, pp.
    pub fn discrepancy_pp(&self, l: usize, shape: [f64; 2]) -> f64 {
        if self.has_discrepancy() {
            shape[0] * self.x[l] + shape[1] * self.x[l] * self.x[l]
        } else {
            0.0
        }
    }

    /// Posterior variance of the slip level the nuisance predicts at label l (pp^2), from
    /// the fit's covariance of the offset, slope and curvature: g' C g, g = (1, x_l, x_l^2).
    fn level_var(&self, l: usize, cov: &LevelCov) -> f64 {
        let (x, n) = (self.x[l], self.terms());
        let g = [1.0, x, x * x];
        (0..n)
            .map(|r| (0..n).map(|c| g[r] * cov[r][c] * g[c]).sum::<f64>())
            .sum::<f64>()
            .max(0.0)
    }

    /// A withheld label's z whitened against the uncertainty of the slip level predicted
    /// there: its cells' residuals r_i share the level's error e ~ N(0, v) along the offset's
    /// column u_i, so their covariance is D + v u u' (D the cells' variances), and
    /// z = (I - a w w') z0 with z0 = r / sd, w = u / sd normalised and
    /// (1 - a)^2 = 1 / (1 + v |u / sd|^2) gives sum z^2 = r' (D + v u u')^-1 r
    /// (Sherman & Morrison 1950, Ann. Math. Stat. 21, 124; the discrepancy's predictive
    /// uncertainty, Kennedy & O'Hagan 2001, J. R. Stat. Soc. B 63, 425, section 4.3). Cells the
    /// level does not move keep their z. `cells`: (cell index, z0, sd); returned: (cell
    /// index, z).
    fn whiten_held(
        &self,
        l: usize,
        cov: &LevelCov,
        cells: impl Iterator<Item = (usize, f64, f64)>,
    ) -> Vec<(usize, f64)> {
        // Per cell: (index, z0, w = u / sd).
        let cells: Vec<(usize, f64, f64)> = cells
            .map(|(i, z, sd)| (i, z, self.offset[l][i] / sd))
            .collect();
        let v = self.level_var(l, cov);
        let w2: f64 = cells.iter().map(|c| c.2 * c.2).sum();
        if v <= 0.0 || w2 <= 0.0 {
            return cells.into_iter().map(|(i, z, _)| (i, z)).collect();
        }
        let a = 1.0 - 1.0 / (1.0 + v * w2).sqrt();
        let proj: f64 = cells.iter().map(|c| c.1 * c.2).sum::<f64>() / w2;
        cells
            .into_iter()
            .map(|(i, z, w)| (i, z - a * w * proj))
            .collect()
    }

    fn shift(&self, l: usize, i: usize, level: &[f64; 3]) -> f64 {
        (0..self.terms())
            .map(|k| level[k] * self.column(l, i, k))
            .sum()
    }
}

/// Posterior covariance of the nuisance's offset, slope and curvature (pp^2; the unused
/// terms 0).
pub(in crate::gap) type LevelCov = [[f64; 3]; 3];

/// A fitted linear candidate: the magnitude, its sd, and the nuisance (slip offset, and the
/// discrepancy's slope and curvature) with its covariance.
#[derive(Debug, Clone, Copy)]
pub(in crate::gap) struct Fit {
    pub m: f64,
    pub sd: f64,
    pub offset: f64,
    pub shape: [f64; 2],
    pub level_cov: LevelCov,
}

impl Fit {
    fn level(&self) -> [f64; 3] {
        [self.offset, self.shape[0], self.shape[1]]
    }
}

/// One candidate's linear model: cells of label l = twin + m S + the nuisance.
pub(in crate::gap) struct LinearCandidate {
    /// Per label, per cell: (residual before = measured - twin, sensitivity per unit magnitude,
    /// sd, usable).
    pub rows: Vec<Vec<(f64, f64, f64, bool)>>,
    pub max: f64,
    pub nuis: Nuisance,
    /// Relative sd of the magnitude mapping from label to label (0: the twin's sensitivity
    /// holds at every label; `LINE_FORM_SD` for an effect mapped by its own line).
    pub form_sd: f64,
}

/// Relative sd, from one belt setting to the next, of the plant's answer to an effect mapped
/// by its own line against the twin's sensitivity there: the line's cell at label l is
/// m S_l (1 + delta_l), delta_l ~ N(0, 0.5^2), a multiplicative model discrepancy with a prior
/// (Kennedy & O'Hagan 2001, J. R. Stat. Soc. B 63, 425, section 4.3). The twin's span
/// resonance sits at one setting and another drive's elsewhere, so the twin's line per unit
/// runout can quadruple at one label where the plant's falls (docs/decisions/gap-line-mapping.md).
pub(in crate::gap) const LINE_FORM_SD: f64 = 0.5;

/// A cell's sd with the model-form sd of an effect's shift there: the shift m S times the
/// relative sd `form_sd` of its mapping, in quadrature with the cell's own sd `sd` (the
/// multiplicative discrepancy of [`LINE_FORM_SD`]).
fn with_form_sd(sd: f64, form_sd: f64, shift: f64) -> f64 {
    sd.hypot(form_sd * shift)
}

impl LinearCandidate {
    /// Per label, per cell: (residual before, sd, usable), the rows of a [`Joint`].
    pub fn residuals(&self) -> Vec<Vec<(f64, f64, bool)>> {
        self.rows
            .iter()
            .map(|r| r.iter().map(|&(g, _, sd, ok)| (g, sd, ok)).collect())
            .collect()
    }

    /// The candidate as a joint model of one effect.
    fn joint(&self) -> Joint {
        Joint {
            rows: self.residuals(),
            cols: vec![self
                .rows
                .iter()
                .map(|r| r.iter().map(|x| x.1).collect())
                .collect()],
            max: vec![self.max],
            nuis: self.nuis.clone(),
            form_sd: vec![self.form_sd],
        }
    }

    /// Robust weighted least squares of the magnitude (in [0, max]) and the nuisance on
    /// `labels` ([`Joint::fit`]). Without the effect, the nuisance alone.
    pub fn fit(&self, labels: &[usize], with_effect: bool) -> Fit {
        let f = self
            .joint()
            .fit(labels, if with_effect { &[0] } else { &[] });
        Fit {
            m: f.m.first().copied().unwrap_or(0.0),
            sd: f.sd.first().copied().unwrap_or(0.0),
            offset: f.level[0],
            shape: [f.level[1], f.level[2]],
            level_cov: f.level_cov,
        }
    }

    /// z of every usable cell of label l under `fit`.
    pub fn z(&self, l: usize, fit: &Fit) -> Vec<f64> {
        self.z_cells(l, fit).map(|(_, z)| z).collect()
    }

    /// (cell index, z) of every usable cell of label l under `fit`.
    pub fn z_cells<'a>(
        &'a self,
        l: usize,
        fit: &'a Fit,
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        self.z_sd(l, fit).map(|(i, z, _)| (i, z))
    }

    /// (cell index, z, sd) of every usable cell of label l under `fit`.
    fn z_sd<'a>(&'a self, l: usize, fit: &'a Fit) -> impl Iterator<Item = (usize, f64, f64)> + 'a {
        let level = fit.level();
        self.rows[l]
            .iter()
            .enumerate()
            .filter(|(_, r)| r.3)
            .map(move |(i, &(g, s, sd, _))| {
                let sd = with_form_sd(sd, self.form_sd, fit.m * s);
                (i, (g - fit.m * s - self.nuis.shift(l, i, &level)) / sd, sd)
            })
    }

    /// (cell index, z) of every usable cell of a label withheld from `fit`: the slip level
    /// predicted there carries the fit's uncertainty of the nuisance (`Nuisance::whiten_held`).
    pub fn held_z_cells(&self, l: usize, fit: &Fit) -> Vec<(usize, f64)> {
        self.nuis.whiten_held(l, &fit.level_cov, self.z_sd(l, fit))
    }

    /// z of every usable cell of a label withheld from `fit` ([`Self::held_z_cells`]).
    pub fn held_z(&self, l: usize, fit: &Fit) -> Vec<f64> {
        self.held_z_cells(l, fit)
            .into_iter()
            .map(|(_, z)| z)
            .collect()
    }
}

/// A fit of several effects at once: per effect its magnitude and sd, and the nuisance.
#[derive(Debug, Clone)]
pub(in crate::gap) struct JointFit {
    pub m: Vec<f64>,
    pub sd: Vec<f64>,
    /// Slip offset, the discrepancy's slope and curvature, pp.
    pub level: [f64; 3],
    /// Their posterior covariance.
    pub level_cov: LevelCov,
}

/// Several effects' linear model: cells of label l = twin + sum_k m_k S_k + the nuisance.
pub(in crate::gap) struct Joint {
    /// Per label, per cell: (residual before = measured - twin, sd, usable).
    pub rows: Vec<Vec<(f64, f64, bool)>>,
    /// Per effect, per label, per cell: the sensitivity per unit magnitude.
    pub cols: Vec<Vec<Vec<f64>>>,
    /// Per effect, the upper bound of its magnitude.
    pub max: Vec<f64>,
    pub nuis: Nuisance,
    /// Per effect, the relative sd of its magnitude mapping from label to label
    /// (`LinearCandidate::form_sd`).
    pub form_sd: Vec<f64>,
}

impl Joint {
    /// Robust weighted least squares of the magnitudes of `effects` (each in [0, max]) and
    /// the nuisance on `labels` (Huber's M-estimate by iteratively reweighted least squares,
    /// Huber 1964, Ann. Math. Stat. 35, 73: a cell whose residual lies beyond `HUBER_Z`
    /// standard deviations is down-weighted to `HUBER_Z / |z|`, so that one label's model-form
    /// miss cannot steer the fit of an effect that all labels show).
    pub fn fit(&self, labels: &[usize], effects: &[usize]) -> JointFit {
        let mut robust = vec![vec![1.0; CELLS.len()]; self.rows.len()];
        let mut out = self.weighted_fit(labels, effects, &robust, &vec![0.0; effects.len()]);
        // Only a model-form sd moves the weights with the magnitudes.
        let form = effects.iter().any(|&e| self.form_sd[e] > 0.0);
        for _ in 0..40 {
            let mut changed = false;
            for &l in labels {
                for (i, z) in self.z_cells(l, effects, &out).collect::<Vec<_>>() {
                    let w = huber_weight(z, HUBER_Z);
                    changed |= (w - robust[l][i]).abs() > 1e-6;
                    robust[l][i] = w;
                }
            }
            if !changed && !form {
                break;
            }
            // The model-form sd moves the cells' weights with the magnitudes (iteratively
            // reweighted, as for Huber's weights).
            let next = self.weighted_fit(labels, effects, &robust, &out.m);
            let settled = next
                .m
                .iter()
                .zip(&out.m)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()));
            out = next;
            if !changed && settled {
                break;
            }
        }
        out
    }

    /// The sd of label l's cell i, with the model-form sd of the magnitudes `m` of `effects`.
    fn cell_sd(&self, l: usize, i: usize, effects: &[usize], m: &[f64]) -> f64 {
        effects
            .iter()
            .zip(m)
            .fold(self.rows[l][i].1, |sd, (&e, m)| {
                with_form_sd(sd, self.form_sd[e], m * self.cols[e][l][i])
            })
    }

    /// (cell index, z) of every usable cell of label l under `fit` of `effects`.
    pub fn z_cells<'a>(
        &'a self,
        l: usize,
        effects: &'a [usize],
        fit: &'a JointFit,
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        self.z_sd(l, effects, fit).map(|(i, z, _)| (i, z))
    }

    /// (cell index, z, sd) of every usable cell of label l under `fit` of `effects`.
    fn z_sd<'a>(
        &'a self,
        l: usize,
        effects: &'a [usize],
        fit: &'a JointFit,
    ) -> impl Iterator<Item = (usize, f64, f64)> + 'a {
        self.rows[l]
            .iter()
            .enumerate()
            .filter(|(_, r)| r.2)
            .map(move |(i, &(g, _, _))| {
                let moved: f64 = effects
                    .iter()
                    .zip(&fit.m)
                    .map(|(&e, m)| m * self.cols[e][l][i])
                    .sum();
                let sd = self.cell_sd(l, i, effects, &fit.m);
                (i, (g - moved - self.nuis.shift(l, i, &fit.level)) / sd, sd)
            })
    }

    /// z of every usable cell of label l under `fit` of `effects`.
    #[cfg(test)]
    pub fn z(&self, l: usize, effects: &[usize], fit: &JointFit) -> Vec<f64> {
        self.z_cells(l, effects, fit).map(|(_, z)| z).collect()
    }

    /// (cell index, z) of every usable cell of a label withheld from `fit` of `effects`: the
    /// slip level predicted there carries the fit's uncertainty (`Nuisance::whiten_held`).
    pub fn held_z_cells(&self, l: usize, effects: &[usize], fit: &JointFit) -> Vec<(usize, f64)> {
        self.nuis
            .whiten_held(l, &fit.level_cov, self.z_sd(l, effects, fit))
    }

    /// Weighted least squares of [`Self::fit`] with the robust weight factors `robust`
    /// (weights `robust / sd^2`, sd with the model-form sd at the magnitudes `m_prev`,
    /// [`Self::cell_sd`]; the discrepancy's prior added to the normal equations). A
    /// magnitude outside its bounds is clamped and the others refitted with it fixed (an
    /// active set, one effect at a time, the worst violation first); the sds are those of the
    /// unconstrained fit. An effect that moves no usable cell has magnitude 0 and sd infinity.
    fn weighted_fit(
        &self,
        labels: &[usize],
        effects: &[usize],
        robust: &[Vec<f64>],
        m_prev: &[f64],
    ) -> JointFit {
        let ne = effects.len();
        let nn = self.nuis.terms();
        let mut fixed: Vec<Option<f64>> = effects
            .iter()
            .map(|&e| {
                let moves = labels.iter().any(|&l| {
                    self.rows[l]
                        .iter()
                        .zip(&self.cols[e][l])
                        .any(|(r, &s)| r.2 && s != 0.0)
                });
                (!moves).then_some(0.0)
            })
            .collect();
        let mut sd = vec![f64::INFINITY; ne];
        let mut first = true;
        loop {
            let free: Vec<usize> = (0..ne).filter(|&k| fixed[k].is_none()).collect();
            let Some((x, var, level_cov)) =
                self.solve(labels, effects, (robust, m_prev), &free, &fixed)
            else {
                return JointFit {
                    m: vec![0.0; ne],
                    sd,
                    level: [0.0; 3],
                    level_cov: [[0.0; 3]; 3],
                };
            };
            if first {
                for (j, &k) in free.iter().enumerate() {
                    sd[k] = var[j].sqrt();
                }
                first = false;
            }
            // The worst bound violation among the free magnitudes.
            let worst = free
                .iter()
                .enumerate()
                .map(|(j, &k)| {
                    let c = x[j].clamp(0.0, self.max[effects[k]]);
                    (k, c, (x[j] - c).abs())
                })
                .filter(|v| v.2 > 0.0)
                .max_by(|a, b| a.2.total_cmp(&b.2));
            if let Some((k, c, _)) = worst {
                fixed[k] = Some(c);
                continue;
            }
            let mut m = vec![0.0; ne];
            for k in 0..ne {
                m[k] = fixed[k].unwrap_or(0.0);
            }
            for (j, &k) in free.iter().enumerate() {
                m[k] = x[j];
            }
            let mut level = [0.0; 3];
            level[..nn].copy_from_slice(&x[free.len()..]);
            return JointFit {
                m,
                sd,
                level,
                level_cov,
            };
        }
    }

    /// The normal equations of the free magnitudes and the nuisance, the fixed magnitudes
    /// moved to the right-hand side: the solution, its variances and the nuisance's
    /// covariance (None if singular). A
    /// parameter no usable cell informs (an offset column that is zero everywhere) is 0.
    /// `(robust, m_prev)`: the robust weight factors and the magnitudes the cells' sds are
    /// taken at ([`Self::cell_sd`]).
    fn solve(
        &self,
        labels: &[usize],
        effects: &[usize],
        (robust, m_prev): (&[Vec<f64>], &[f64]),
        free: &[usize],
        fixed: &[Option<f64>],
    ) -> Option<(Vec<f64>, Vec<f64>, LevelCov)> {
        let nn = self.nuis.terms();
        let p = free.len() + nn;
        let mut a = Mat::<f64>::zeros(p, p);
        let mut b = Mat::<f64>::zeros(p, 1);
        let mut phi = vec![0.0; p];
        for &l in labels {
            for (i, &(g, _, ok)) in self.rows[l].iter().enumerate() {
                if !ok {
                    continue;
                }
                let sd = self.cell_sd(l, i, effects, m_prev);
                let w = robust[l][i] / (sd * sd);
                let y = g - effects
                    .iter()
                    .zip(fixed)
                    .filter_map(|(&e, f)| f.map(|m| m * self.cols[e][l][i]))
                    .sum::<f64>();
                for (j, &k) in free.iter().enumerate() {
                    phi[j] = self.cols[effects[k]][l][i];
                }
                for k in 0..nn {
                    phi[free.len() + k] = self.nuis.column(l, i, k);
                }
                for r in 0..p {
                    b[(r, 0)] += w * phi[r] * y;
                    for c in 0..p {
                        a[(r, c)] += w * phi[r] * phi[c];
                    }
                }
            }
        }
        for k in 1..nn {
            let j = free.len() + k;
            a[(j, j)] += self.nuis.prior_sd_pp.powi(-2);
        }
        for j in 0..p {
            // A parameter without information is held at 0; a tiny ridge keeps the system
            // positive definite where an effect's column is collinear with the offset's.
            if a[(j, j)] <= 0.0 {
                a[(j, j)] = 1.0;
            } else {
                a[(j, j)] *= 1.0 + 1e-12;
            }
        }
        let llt = a.llt(faer::Side::Lower).ok()?;
        let x = llt.solve(&b);
        let inv = llt.solve(Mat::<f64>::identity(p, p));
        let mut level_cov = [[0.0; 3]; 3];
        let n0 = free.len();
        for r in 0..nn {
            for c in 0..nn {
                level_cov[r][c] = inv[(n0 + r, n0 + c)];
            }
        }
        Some((
            (0..p).map(|j| x[(j, 0)]).collect(),
            (0..p).map(|j| inv[(j, j)]).collect(),
            level_cov,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_linear_fit_recovers_a_magnitude_and_an_offset_and_respects_its_bounds() {
        // Two labels, three cells each: residual = 0.7 S + 0.2 N exactly (N the offset column).
        let s = [[1.0, 0.0, 2.0], [0.5, 1.0, 0.0]];
        let n = [[1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        let rows: Vec<Vec<(f64, f64, f64, bool)>> = (0..2)
            .map(|l| {
                (0..3)
                    .map(|i| (0.7 * s[l][i] + 0.2 * n[l][i], s[l][i], 0.1, true))
                    .collect()
            })
            .collect();
        let nuis: Vec<Vec<f64>> = n.iter().map(|r| r.to_vec()).collect();
        let c = LinearCandidate {
            rows: rows.clone(),
            max: 5.0,
            nuis: Nuisance::offset_only(nuis.clone()),
            form_sd: 0.0,
        };
        let f = c.fit(&[0, 1], true);
        assert!(
            (f.m - 0.7).abs() < 1e-9 && (f.offset - 0.2).abs() < 1e-9,
            "{f:?}"
        );
        assert!(f.sd > 0.0 && f.sd < 0.1);
        assert!(c.z(0, &f).iter().all(|z| z.abs() < 1e-6));
        // A bound below the truth clamps the magnitude; no effect fits the offset alone.
        let c = LinearCandidate {
            rows,
            max: 0.5,
            nuis: Nuisance::offset_only(nuis),
            form_sd: 0.0,
        };
        assert_eq!(c.fit(&[0, 1], true).m, 0.5);
        assert_eq!(c.fit(&[0, 1], false).m, 0.0);
    }

    #[test]
    fn one_cell_far_off_does_not_steer_the_fit() {
        // Ten cells follow residual = 0.7 S exactly; one more, with the same sensitivity, sits
        // 50 sd off (a label's model-form miss). Least squares would move the magnitude by
        // 50 x 0.1 / 11 = 0.45; the Huber fit moves it by less than 0.1 (one cell at its
        // 3-sd weight).
        let mut cells: Vec<(f64, f64, f64, bool)> =
            (0..10).map(|_| (0.7, 1.0, 0.1, true)).collect();
        cells.push((0.7 + 5.0, 1.0, 0.1, true));
        let c = LinearCandidate {
            nuis: Nuisance::offset_only(vec![vec![0.0; cells.len()]]),
            rows: vec![cells],
            max: 10.0,
            form_sd: 0.0,
        };
        let m = c.fit(&[0], true).m;
        assert!((m - 0.7).abs() < 0.1, "{m}");
        // The loss charges the far cell linearly: 2 x 3 x 50 - 9, not 50^2.
        assert_eq!(huber(50.0), 291.0);
        assert_eq!(huber(-2.0), 4.0);
    }

    /// Four labels, one line cell each, sd 0.05: the plant's line is the twin's sensitivity
    /// times a magnitude that changes from label to label (`plant`); each label withheld in
    /// turn, fitted on the others.
    fn withheld_line_z(plant: [f64; 4], form_sd: f64) -> Vec<f64> {
        let s = [2500.0, 2700.0, 2900.0, 10700.0];
        let c = LinearCandidate {
            rows: (0..4)
                .map(|l| vec![(plant[l] * s[l], s[l], 0.05, true)])
                .collect(),
            max: 1.0,
            nuis: Nuisance::offset_only(vec![vec![0.0]; 4]),
            form_sd,
        };
        (0..4)
            .map(|k| {
                let fitted: Vec<usize> = (0..4).filter(|&l| l != k).collect();
                c.z(k, &c.fit(&fitted, true))[0]
            })
            .collect()
    }

    #[test]
    fn a_line_whose_magnitude_mapping_changes_from_label_to_label_is_explained_within_its_form_sd()
    {
        // The twin's line per unit runout quadruples at the loosest label (its span resonance
        // there) where the plant's falls: the plant's twin-equivalent runout 1.4, 1.0, 0.7 and
        // 0.25 times 0.4 mm, within 1.5 prior sd of one magnitude. With one magnitude for all
        // labels the withheld loosest label misses by tens of sd; with the mapping free within
        // `LINE_FORM_SD`, every withheld label is within `HUBER_Z` (weighed as noise).
        let plant = [1.4, 1.0, 0.7, 0.25].map(|k| k * 4.0e-4);
        let fixed = withheld_line_z(plant, 0.0);
        assert!(fixed.iter().any(|z| z.abs() > 20.0), "{fixed:?}");
        let free = withheld_line_z(plant, LINE_FORM_SD);
        assert!(free.iter().all(|z| z.abs() < HUBER_Z), "{free:?}");
        // The mapping's freedom is relative: a plant without the line is not explained by a
        // magnitude (it fits 0, and leaves the labels' noise as it was), and one line 40 sd
        // out at one label only, none at the others, is still left beyond 3 sd there.
        let none = withheld_line_z([0.0; 4], LINE_FORM_SD);
        assert!(none.iter().all(|z| z.abs() < 1e-9), "{none:?}");
        let one = withheld_line_z([8.0e-4, 0.0, 0.0, 0.0], LINE_FORM_SD);
        assert!(one[0] > 3.0, "{one:?}");
    }

    /// Three labels at x = 1, 0.25, -0.5, each with five slip-level cells (offset column 1,
    /// sd 0.025 pp) and five cells the level does not move; the level cells sit `level[l]` pp
    /// off the twin, the others on it. The discrepancy's prior sd is 0.077 pp.
    fn level_plant(level: [f64; 3]) -> LinearCandidate {
        let u: Vec<f64> = (0..10).map(|i| if i < 5 { 1.0 } else { 0.0 }).collect();
        LinearCandidate {
            rows: level
                .iter()
                .map(|&d| u.iter().map(|&u| (u * d, 0.0, 0.025, true)).collect())
                .collect(),
            max: 0.0,
            nuis: Nuisance {
                offset: vec![u; 3],
                x: vec![1.0, 0.25, -0.5],
                prior_sd_pp: 0.077,
            },
            form_sd: 0.0,
        }
    }

    #[test]
    fn a_withheld_labels_slip_level_carries_the_discrepancys_predictive_uncertainty() {
        // Another drive's creep curve bends up at the loosest label where the twin's stays
        // flat (the lumped simulator's healthy belt: -0.048, -0.004, +0.095 pp). Fitted on the
        // two tighter labels, the point prediction of the third misses by over 3 sd in each
        // level cell; with the slope and curvature's posterior carried into the withheld
        // label, the miss is within noise.
        let c = level_plant([-0.048, -0.004, 0.095]);
        let f = c.fit(&[0, 1], false);
        let point = c.z(2, &f);
        assert!(point[..5].iter().all(|z| *z > 3.0), "{point:?}");
        let held = c.held_z(2, &f);
        let rms = (held.iter().map(|z| z * z).sum::<f64>() / held.len() as f64).sqrt();
        assert!(rms < 1.0, "{held:?}");
        // Cells the level does not move keep their z.
        assert_eq!(held[5..], point[5..]);
        // The sum of squares is the residuals' chi-square under the covariance
        // D + v u u' (v the level's predictive variance), computed directly.
        let v = c.nuis.level_var(2, &f.level_cov);
        let r: Vec<f64> = point.iter().map(|z| z * 0.025).collect();
        let mut cov = Mat::<f64>::zeros(10, 10);
        for i in 0..10 {
            for j in 0..10 {
                let uu = c.nuis.offset[2][i] * c.nuis.offset[2][j];
                cov[(i, j)] = v * uu + if i == j { 0.025 * 0.025 } else { 0.0 };
            }
        }
        let rv = Mat::<f64>::from_fn(10, 1, |i, _| r[i]);
        let sol = cov.llt(faer::Side::Lower).unwrap().solve(&rv);
        let chi2: f64 = (0..10).map(|i| r[i] * sol[(i, 0)]).sum();
        let sum: f64 = held.iter().map(|z| z * z).sum();
        assert!((sum - chi2).abs() < 1e-9 * chi2, "{sum} against {chi2}");
        // The uncertainty is the prior's, not a free level: a jump of 0.5 pp (6.5 prior sd)
        // at the withheld label stays beyond `HUBER_Z` in every level cell, and the label's
        // level as a whole (the cells' chi-square) more than 8 sd off.
        let jump = level_plant([-0.048, -0.004, 0.5]);
        let f = jump.fit(&[0, 1], false);
        let z = jump.held_z(2, &f);
        assert!(z[..5].iter().all(|z| *z > HUBER_Z), "{z:?}");
        assert!(z.iter().map(|z| z * z).sum::<f64>() > 64.0, "{z:?}");
    }
}
