//! Stage "which": the candidates scored out of sample against "none". The labels are cut into
//! folds (with a holdout, one fold: fit on the rest, evaluate on it; otherwise
//! leave-one-label-out), each candidate's linear model is fitted on a fold's fitted labels and
//! its withheld labels' z are scored by Huber's loss, plus the Schwarz penalty k ln n. The
//! pipeline: [`RankContext::new`] (cells, folds, "none"), the mechanical candidates and the
//! tachometer (`candidates`), then the verdict (`verdict`).

use fom::stats::bonferroni_z;

use super::baseline::{LabelTwin, KNEE_ELASTICITY};
use super::candidates::linear::{huber, Fit, Joint, LinearCandidate, Nuisance, LINE_FORM_SD};
use super::candidates::selection::Folds;
use super::candidates::{fit_bound, mechanical, tachometer, Scored, SENSITIVITY_SD};
use super::cells::{fit_cell, label_cells, nuisance, CellRow};
use super::features::{Features, CELLS};
use super::report::{Absorbed, FailedRun, GapReport};
use super::twin_runs::Variant;
use super::verdict::STRONG_EVIDENCE;
use super::{verdict, Diagnosis};
use crate::error::Result;

/// Family-wise level of the where-table's cell threshold (two-sided, Bonferroni).
const CELL_LEVEL: f64 = 0.05;

/// Ranks the candidates and reaches the verdict: the diagnosis's "which" and "how far".
pub(super) fn rank(
    d: &Diagnosis,
    twins: &[LabelTwin],
    vars: &[Variant],
    failed: &[FailedRun],
) -> Result<GapReport> {
    let (r, ranking) = scored(d, twins, vars)?;
    verdict::report(d, &r, vars, ranking, failed.to_vec())
}

/// The candidates ranked (best first), without the verdict and its confirmation runs.
pub(super) fn scored<'a>(
    d: &Diagnosis,
    twins: &'a [LabelTwin],
    vars: &[Variant],
) -> Result<(RankContext<'a>, Vec<Scored>)> {
    let mut r = RankContext::new(twins, &d.labels, &d.opts.holdout);
    r.line_only = line_mappings(&r, vars);
    let mut ranking: Vec<Scored> = mechanical::score(&r, vars);
    ranking.push(tachometer::score(&r, d)?);
    ranking.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    Ok((r, ranking))
}

/// Per variant, whether it is mapped onto the plant by its own line only
/// (`RankContext::line_only`): for a variant with a line of its own
/// (`Variant::line_cells`), when the line-only candidate's out-of-sample loss is below the
/// full candidate's.
fn line_mappings(r: &RankContext, vars: &[Variant]) -> Vec<bool> {
    vars.iter()
        .enumerate()
        .map(|(v, var)| {
            let line = var.line_cells();
            if line.is_empty() {
                return false;
            }
            let full = loss(&r.oos(&r.variant_on(v, var, None, 0.0), true));
            let own = loss(&r.oos(&r.variant_on(v, var, Some(&line), 0.0), true));
            own < full
        })
        .collect()
}

/// What every scoring step shares: the label twins' baseline cells, the nuisance column, the
/// folds and the out-of-sample scores of "none".
pub(super) struct RankContext<'a> {
    pub twins: &'a [LabelTwin],
    pub n: usize,
    /// Per label, the baseline twin's cells.
    pub base_cells: Vec<Vec<CellRow>>,
    /// Family-wise 5 % |z| threshold over the usable cells.
    pub threshold: f64,
    /// The slip-level nuisance: per label, per cell the slip offset's column
    /// (`cells::nuisance`), and the discrepancy across labels.
    pub nuis: Nuisance,
    /// Labels in the ranking (the knee labels left out, `KNEE_ELASTICITY`).
    pub active: Vec<usize>,
    /// Per label, whether it is withheld from calibration and fits (`--holdout`).
    pub held_out: Vec<bool>,
    /// (fitted labels, evaluated labels) of each fold.
    pub folds: Vec<(Vec<usize>, Vec<usize>)>,
    /// The evaluated labels in fold order, and their names.
    pub eval_labels: Vec<usize>,
    pub eval_names: Vec<String>,
    /// The active labels not withheld: the in-sample fit of a candidate's magnitude.
    pub fitted: Vec<usize>,
    /// ln of the usable cells' count over all labels (the Schwarz penalty per parameter).
    pub ln_n: f64,
    /// "none": the withheld z, their Huber loss, and the loss beyond the slip level.
    pub z_before: Vec<Vec<f64>>,
    pub loss_none: f64,
    pub level_free_none: f64,
    /// Per mechanical variant, whether its candidate keeps only its own line's sensitivity
    /// (`line_mappings`): the plant answers the effect with that line, and in its other cells
    /// with another shape than the twin's (docs/decisions/gap-signature-line.md). Empty: none.
    pub line_only: Vec<bool>,
}

impl<'a> RankContext<'a> {
    pub fn new(twins: &'a [LabelTwin], labels: &[String], holdout: &[String]) -> Self {
        let n = twins.len();
        let base_cells: Vec<Vec<CellRow>> = twins
            .iter()
            .map(|lt| label_cells(lt, &lt.baseline))
            .collect();
        let n_cells: usize = base_cells
            .iter()
            .map(|c| {
                c.iter()
                    .enumerate()
                    .filter(|(i, x)| fit_cell(*i, **x))
                    .count()
            })
            .sum();
        let nuis = slip_nuisance(twins);
        // An unsettled label is never fitted, only evaluated (`UnsettledLabel`).
        let held_out: Vec<bool> = (0..n)
            .map(|j| holdout.contains(&labels[j]) || twins[j].measured.unsettled)
            .collect();
        let active = active_labels(twins, &held_out, holdout.is_empty());
        let folds = folds(&active, &held_out, holdout.is_empty());
        let eval_labels: Vec<usize> = folds.iter().flat_map(|f| f.1.clone()).collect();
        let mut r = RankContext {
            twins,
            n,
            base_cells,
            threshold: bonferroni_z(CELL_LEVEL, n_cells),
            nuis,
            eval_names: eval_labels.iter().map(|&l| labels[l].clone()).collect(),
            eval_labels,
            fitted: active.iter().copied().filter(|&j| !held_out[j]).collect(),
            active,
            held_out,
            folds,
            ln_n: (n_cells as f64).ln(),
            z_before: Vec::new(),
            loss_none: 0.0,
            level_free_none: 0.0,
            line_only: Vec::new(),
        };
        let none = r.none();
        r.z_before = r.oos(&none, false);
        r.loss_none = loss(&r.z_before);
        r.level_free_none = r.oos_level_free(&none, false);
        r
    }

    /// What the slip level's discrepancy absorbed (None when it is off: every label at one
    /// distance): per label the level it adds in the fit of "none" on the fitted labels, and
    /// how much it lowers the out-of-sample score of "none" against the offset alone.
    pub fn absorbed(&self, labels: &[String]) -> Option<Absorbed> {
        if !self.nuis.has_discrepancy() {
            return None;
        }
        let none = self.none();
        let shape = none.fit(&self.fitted, false).shape;
        let offset_only = LinearCandidate {
            nuis: Nuisance::offset_only(self.nuis.offset.clone()),
            ..none
        };
        let score_gain = loss(&self.oos(&offset_only, false)) - self.loss_none - 2.0 * self.ln_n;
        Some(Absorbed {
            slip_level_pp: (0..self.n)
                .map(|l| (labels[l].clone(), self.nuis.discrepancy_pp(l, shape)))
                .collect(),
            prior_sd_pp: self.nuis.prior_sd_pp,
            score_gain,
            model_form_difference: score_gain > -STRONG_EVIDENCE,
        })
    }

    /// A linear candidate from per-label twin features at the reference magnitude (the two
    /// runs read with the same sensor noise, so their difference is the effect's).
    pub fn linear(
        &self,
        at_ref: Vec<Option<&Features>>,
        reference: f64,
        max: f64,
    ) -> LinearCandidate {
        self.linear_on(at_ref, reference, max, (None, &[]), 0.0)
    }

    /// [`Self::linear`] with the sensitivity kept in the cells `only` alone (None: in all);
    /// `own_line`: the variant's own line's cells, whose features hold the change between two
    /// quiet reads of the twin (`reading::variant_features`); `form_sd`: the relative sd of
    /// the magnitude mapping from label to label (`LinearCandidate::form_sd`).
    fn linear_on(
        &self,
        at_ref: Vec<Option<&Features>>,
        reference: f64,
        max: f64,
        (only, own_line): (Option<&[usize]>, &[usize]),
        form_sd: f64,
    ) -> LinearCandidate {
        let rows = (0..self.n)
            .map(|l| {
                let at = at_ref[l];
                self.base_cells[l]
                    .iter()
                    .enumerate()
                    .map(|(i, &(m, t, sd))| {
                        let ok = fit_cell(i, (m, t, sd));
                        // A cell moves with the effect only where the two runs differ by
                        // more than twice the difference's standard error (with the twin's
                        // spread under the friction uncertainty): within it, the difference is
                        // the runs' own scatter, and crediting it to the effect would move
                        // cells the effect does not move.
                        let kept = only.is_none_or(|c| c.contains(&i));
                        let s = at.filter(|_| kept).map_or(0.0, |f| {
                            let (a, b) = (f.cells[i], self.twins[l].baseline.cells[i]);
                            let d = a.value - b.value;
                            let spread = self.twins[l].run_spread[i];
                            // A variant's own line holds the change between two quiet reads,
                            // with its standard error (`reading::variant_features`).
                            let se = match own_line.contains(&i) {
                                true => a.se.hypot(spread),
                                false => a.se.hypot(b.se).hypot(spread),
                            };
                            if d.is_finite() && d.abs() > SENSITIVITY_SD * se {
                                d / reference
                            } else {
                                0.0
                            }
                        });
                        (m - t, s, sd, ok)
                    })
                    .collect()
            })
            .collect();
        LinearCandidate {
            rows,
            max,
            nuis: self.nuis.clone(),
            form_sd,
        }
    }

    /// "None": the baseline twin's residuals, no effect.
    pub fn none(&self) -> LinearCandidate {
        self.linear(vec![None; self.n], 1.0, 0.0)
    }

    /// Variant `v`'s candidate: its sensitivity runs at the reference magnitude, the
    /// twin-equivalent magnitude free up to `fit_bound`; on its own line's cells only where
    /// `line_only` says so, and then with the line's magnitude free from label to label within
    /// `LINE_FORM_SD`.
    pub fn variant(&self, v: usize, var: &Variant) -> LinearCandidate {
        let line = var.line_cells();
        let only = self.line_only.get(v).copied().unwrap_or(false);
        self.variant_on(v, var, only.then_some(line.as_slice()), self.form_sd(v))
    }

    /// The relative sd of variant `v`'s magnitude mapping from label to label: `LINE_FORM_SD`
    /// where it is mapped by its own line (`line_only`), else 0.
    pub fn form_sd(&self, v: usize) -> f64 {
        match self.line_only.get(v).copied().unwrap_or(false) {
            true => LINE_FORM_SD,
            false => 0.0,
        }
    }

    /// Variant `v`'s candidate with its sensitivity in the cells `only` alone (None: all) and
    /// the magnitude mapping's relative sd `form_sd` from label to label.
    pub fn variant_on(
        &self,
        v: usize,
        var: &Variant,
        only: Option<&[usize]>,
        form_sd: f64,
    ) -> LinearCandidate {
        self.linear_on(
            self.twins.iter().map(|t| t.variant[v].as_ref()).collect(),
            var.reference,
            fit_bound(var.max),
            (only, &var.line_cells()),
            form_sd,
        )
    }

    /// Every mechanical variant's sensitivity as one column of a joint model (the forward
    /// selection's, `candidates::selection`), over the baseline's residuals.
    pub fn joint(&self, vars: &[Variant]) -> Joint {
        let cands: Vec<LinearCandidate> = vars
            .iter()
            .enumerate()
            .map(|(v, var)| self.variant(v, var))
            .collect();
        let none = self.none();
        Joint {
            rows: none.residuals(),
            cols: cands
                .iter()
                .map(|c| {
                    c.rows
                        .iter()
                        .map(|r| r.iter().map(|x| x.1).collect())
                        .collect()
                })
                .collect(),
            max: vars.iter().map(|v| fit_bound(v.max)).collect(),
            nuis: self.nuis.clone(),
            form_sd: cands.iter().map(|c| c.form_sd).collect(),
        }
    }

    /// The folds as the forward selection reads them.
    pub fn folds_view(&self) -> Folds<'_> {
        Folds {
            folds: &self.folds,
            eval_labels: &self.eval_labels,
            ln_n: self.ln_n,
        }
    }

    /// The evaluated labels' z, each from the fit on its fold's fitted labels.
    pub fn oos(&self, c: &LinearCandidate, with: bool) -> Vec<Vec<f64>> {
        self.oos_where(c, with, |_| true)
    }

    /// The out-of-sample z of the evaluated labels' cells `cells` only, as [`Self::oos`] fits
    /// them (every usable cell in the fit).
    pub fn oos_cells(&self, c: &LinearCandidate, with: bool, cells: &[usize]) -> Vec<f64> {
        self.oos_where(c, with, |i| cells.contains(&i)).concat()
    }

    /// Per evaluated label, the out-of-sample z of its usable cells that `keep` selects
    /// ([`Self::oos_z_cells`]).
    fn oos_where(
        &self,
        c: &LinearCandidate,
        with: bool,
        keep: impl Fn(usize) -> bool,
    ) -> Vec<Vec<f64>> {
        self.oos_z_cells(c, with)
            .into_iter()
            .map(|cells| {
                cells
                    .into_iter()
                    .filter(|&(i, _)| keep(i))
                    .map(|(_, z)| z)
                    .collect()
            })
            .collect()
    }

    /// Per evaluated label, (cell index, out-of-sample z) of its usable cells: each fold fitted
    /// on its labels, its withheld labels' z under that fit.
    pub fn oos_z_cells(&self, c: &LinearCandidate, with: bool) -> Vec<Vec<(usize, f64)>> {
        let mut per = vec![Vec::new(); self.n];
        for (fit, held) in &self.folds {
            let f = c.fit(fit, with);
            for &h in held {
                per[h] = c.held_z_cells(h, &f);
            }
        }
        self.eval_labels.iter().map(|&l| per[l].clone()).collect()
    }

    /// The Huber loss of label h's cells the slip offset does not move: the slip level is what
    /// calibration, and any difference in the belt's creep between the twin and the measured
    /// drive (another simulator's healthy belt whose slip rises with looseness differently),
    /// move too; evidence for an effect only there names none.
    pub fn level_free_loss(&self, c: &LinearCandidate, f: &Fit, h: usize) -> f64 {
        c.z_cells(h, f)
            .filter(|&(i, _)| !self.nuis.moves(h, i))
            .map(|(_, z)| huber(z))
            .sum()
    }

    /// [`Self::level_free_loss`] out of sample, summed over the folds.
    pub fn oos_level_free(&self, c: &LinearCandidate, with: bool) -> f64 {
        self.folds
            .iter()
            .map(|(fit, held)| {
                let f = c.fit(fit, with);
                held.iter()
                    .map(|&h| self.level_free_loss(c, &f, h))
                    .sum::<f64>()
            })
            .sum()
    }
}

/// Share of the twin's slip level (the labels' median) that is the prior sd of the slip-level
/// discrepancy's slope and curvature (docs/decisions/gap-model-form.md).
const SLIP_DISCREPANCY_SHARE: f64 = 0.1;

/// The slip-level nuisance: the calibration's offset at every label (`cells::nuisance`) and a
/// smooth discrepancy across labels in their centre distance, scaled to [-1, 1] (off when the
/// labels share one distance).
fn slip_nuisance(twins: &[LabelTwin]) -> Nuisance {
    let offset = twins
        .iter()
        .map(|lt| (0..CELLS.len()).map(|i| nuisance(lt, i)).collect())
        .collect();
    let d: Vec<f64> = twins.iter().map(|lt| lt.q.center_distance_m).collect();
    let lo = d.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // Below a micrometre the labels share one distance.
    if hi - lo <= 1e-6 {
        return Nuisance::offset_only(offset);
    }
    let slip = fom::stats::median(twins.iter().map(|lt| lt.slip_pct.abs()).collect());
    Nuisance {
        offset,
        x: d.iter().map(|v| 2.0 * (v - lo) / (hi - lo) - 1.0).collect(),
        prior_sd_pp: SLIP_DISCREPANCY_SHARE * slip,
    }
}

/// Labels in the ranking: those in the twin's looseness knee are left out
/// (`KNEE_ELASTICITY`), unless that would leave no label to fit or none to withhold.
fn active_labels(twins: &[LabelTwin], held_out: &[bool], leave_one_out: bool) -> Vec<usize> {
    let n = twins.len();
    let knee: Vec<bool> = twins
        .iter()
        .map(|lt| lt.tension_elasticity.abs() > KNEE_ELASTICITY)
        .collect();
    let keep_knee = {
        let fit = (0..n).filter(|&j| !knee[j] && !held_out[j]).count();
        let held = (0..n).filter(|&j| !knee[j] && held_out[j]).count();
        if leave_one_out {
            fit < 2
        } else {
            fit < 1 || held < 1
        }
    };
    (0..n).filter(|&j| keep_knee || !knee[j]).collect()
}

/// Folds: with a holdout, one fold (fit on the rest, evaluate on it); otherwise one per label.
fn folds(
    active: &[usize],
    held_out: &[bool],
    leave_one_out: bool,
) -> Vec<(Vec<usize>, Vec<usize>)> {
    if leave_one_out {
        active
            .iter()
            .map(|&k| {
                (
                    active
                        .iter()
                        .copied()
                        .filter(|&j| j != k && !held_out[j])
                        .collect(),
                    vec![k],
                )
            })
            .collect()
    } else {
        let (fit, held): (Vec<usize>, Vec<usize>) = active.iter().partition(|&&j| !held_out[j]);
        vec![(fit, held)]
    }
}

/// Sum of squared z (the chi-square of the cells).
pub(super) fn chi2(z: &[Vec<f64>]) -> f64 {
    z.iter().flatten().map(|x| x * x).sum::<f64>()
}

/// Candidates are scored on the Huber loss of the withheld z (the chi-square within
/// `HUBER_Z`, linear beyond), for the robustness the fit has.
pub(super) fn loss(z: &[Vec<f64>]) -> f64 {
    z.iter().flatten().map(|&x| huber(x)).sum::<f64>()
}

#[cfg(test)]
pub(in crate::gap) mod tests {
    use super::*;
    use crate::gap::baseline::tests::label_twin_of;
    use crate::gap::features::{cell_index, Band, Cell, Measure, Signal, Statistic, Window};
    use crate::gap::twin_runs::variants;

    pub(in crate::gap) fn features(cells: &[f64]) -> Features {
        Features {
            cells: cells
                .iter()
                .map(|&value| Measure { value, se: 0.05 })
                .collect(),
            slip_sorted: vec![1.0; 10],
            noise_rpm: [1.0; 2],
            scatter_ratio: [1.0; 2],
            scatter_rpm: [1.0; 2],
            scatter_acf: [[0.0; 8]; 2],
            frequencies_hz: [29.0, 14.5, 116.0, 5.0],
            running_s: 3.0,
            startup_s: 1.0,
            unsettled: false,
        }
    }

    /// Three labels whose twin moves the fan pulley's runout line by 0.2 and the slip's sd by
    /// 0.5 at the reference runout; the measurement moves the line by `line` and the slip's
    /// sd by `spread` from the baseline. Whether the runout is mapped by its line only.
    fn line_only_for(line: f64, spread: f64) -> bool {
        let vars = variants(8);
        let v = vars
            .iter()
            .position(|x| x.choice == "pulley=driven")
            .expect("the fan pulley's runout");
        let line_cell = vars[v].line_cells()[0];
        let spread_cell = cell_index(Cell::new(
            Window::Steady,
            Signal::Slip,
            Statistic::Std,
            Band::Level,
        ));
        let base = vec![1.0; CELLS.len()];
        let moved = |dl: f64, ds: f64| {
            let mut c = base.clone();
            c[line_cell] += dl;
            c[spread_cell] += ds;
            features(&c)
        };
        let twins: Vec<LabelTwin> = (0..3)
            .map(|_| {
                let mut lt = label_twin_of(moved(line, spread), false);
                lt.baseline = features(&base);
                lt.variant = (0..vars.len())
                    .map(|k| (k == v).then(|| moved(0.2, 0.5)))
                    .collect();
                lt
            })
            .collect();
        let labels: Vec<String> = ["d0", "d1", "d2"].map(String::from).to_vec();
        let r = RankContext::new(&twins, &labels, &[]);
        let mapped = line_mappings(&r, &vars);
        // Only an effect with a line of its own can be mapped by it.
        for (k, var) in vars.iter().enumerate() {
            assert!(!mapped[k] || !var.line_cells().is_empty(), "{}", var.effect);
        }
        mapped[v]
    }

    #[test]
    fn an_effect_answered_with_its_line_alone_is_mapped_by_its_line() {
        // The plant: a line five times the twin's at the reference, no slip spread.
        assert!(line_only_for(1.0, 0.0));
    }

    #[test]
    fn an_effect_answered_with_the_twins_shape_keeps_every_cell() {
        // The plant: the twin's own shape at five times the reference.
        assert!(!line_only_for(1.0, 2.5));
    }
}
