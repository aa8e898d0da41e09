//! More than one effect: forward selection over the mechanical candidates
//! (docs/decisions/gap-forward-selection.md). From the effects already named, the candidate
//! whose joint fit with them most lowers the out-of-sample score is added while it lowers it by
//! more than [`SELECTION_MARGIN`], on all cells and on the cells the slip level's nuisance
//! does not move; the selected effects are then fitted jointly (`linear::Joint`: weighted least
//! squares over the union of their columns, the slip-level nuisance refitted alongside).

use super::linear::{huber, Joint};
use crate::gap::ranking::loss;

/// Score improvement an added effect must bring, on the scale of the ranking's score (Huber
/// loss of the withheld z plus ln n per effect): 10, the "very strong" evidence a first effect
/// needs against "none" (Kass & Raftery 1995, J. Am. Stat. Assoc. 90, 773, section 3.2).
pub(in crate::gap) const SELECTION_MARGIN: f64 = 10.0;

/// The out-of-sample design: each fold's fitted and evaluated labels, the evaluated labels in
/// fold order, and the Schwarz penalty per parameter.
pub(in crate::gap) struct Folds<'a> {
    pub folds: &'a [(Vec<usize>, Vec<usize>)],
    pub eval_labels: &'a [usize],
    pub ln_n: f64,
}

/// One step of the selection: the effect added, the score it gained, and the evaluated labels'
/// z with every effect selected so far.
#[derive(Debug, Clone)]
pub(in crate::gap) struct Step {
    pub effect: usize,
    pub gain: f64,
    pub z: Vec<Vec<f64>>,
}

/// The evaluated labels' z with `effects`, each label's from its fold's fit, and their Huber
/// loss on the cells the slip level's nuisance does not move.
pub(in crate::gap) fn oos(j: &Joint, effects: &[usize], f: &Folds) -> (Vec<Vec<f64>>, f64) {
    let mut per = vec![Vec::new(); j.rows.len()];
    let mut level_free = 0.0;
    for (fit, held) in f.folds {
        let jf = j.fit(fit, effects);
        for &h in held {
            let z = j.held_z_cells(h, effects, &jf);
            per[h] = z.iter().map(|&(_, z)| z).collect();
            level_free += z
                .into_iter()
                .filter(|&(i, _)| !j.nuis.moves(h, i))
                .map(|(_, z)| huber(z))
                .sum::<f64>();
        }
    }
    let z = f.eval_labels.iter().map(|&l| per[l].clone()).collect();
    (z, level_free)
}

/// What forward selection did: the evaluated labels' z with the start's effects alone (the base
/// the first step gains on), and the steps taken, in order.
#[derive(Debug, Clone)]
pub(in crate::gap) struct Selection {
    pub start_z: Vec<Vec<f64>>,
    pub steps: Vec<Step>,
}

/// Forward selection from the effects `start` (already named; may be empty) over the effects
/// with `allowed` set.
pub(in crate::gap) fn forward_select(
    j: &Joint,
    start: &[usize],
    allowed: &[bool],
    f: &Folds,
) -> Selection {
    // (score, score beyond the slip level, z) of a set of effects.
    let score = |set: &[usize]| {
        let (z, level_free) = oos(j, set, f);
        let penalty = set.len() as f64 * f.ln_n;
        (loss(&z) + penalty, level_free + penalty, z)
    };
    let mut set = start.to_vec();
    let mut current = score(&set);
    let start_z = current.2.clone();
    let mut steps = Vec::new();
    loop {
        let best = (0..j.cols.len())
            .filter(|e| allowed[*e] && !set.contains(e))
            .map(|e| {
                let mut with = set.clone();
                with.push(e);
                (e, score(&with))
            })
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
        let Some((e, next)) = best else { break };
        let (gain, gain_level) = (current.0 - next.0, current.1 - next.1);
        if gain <= SELECTION_MARGIN || gain_level <= SELECTION_MARGIN {
            break;
        }
        set.push(e);
        steps.push(Step {
            effect: e,
            gain,
            z: next.2.clone(),
        });
        current = next;
    }
    Selection { start_z, steps }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::candidates::fit_bound;
    use crate::gap::candidates::linear::Nuisance;
    use fom::stats::rms;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    const LABELS: usize = 4;
    const CELLS_USED: usize = 12;
    const SD: f64 = 0.1;

    /// Four candidates' linear sensitivities over four labels and twelve cells (cells 0-2 the
    /// slip level): 0 moves the slip level and cells 3-4, 1 cells 6-8, 2 cells 9-10, 3 cells
    /// 3 and 5 (shares cell 3 with 0).
    fn columns() -> Vec<Vec<Vec<f64>>> {
        let col = |cells: &[(usize, f64)]| -> Vec<Vec<f64>> {
            (0..LABELS)
                .map(|l| {
                    let mut c = vec![0.0; CELLS_USED];
                    for &(i, s) in cells {
                        c[i] = s * (1.0 + 0.3 * l as f64);
                    }
                    c
                })
                .collect()
        };
        vec![
            col(&[(0, 0.2), (1, 0.2), (3, 1.0), (4, -0.6)]),
            col(&[(6, 0.8), (7, 1.0), (8, -0.5)]),
            col(&[(9, 1.0), (10, 0.7)]),
            col(&[(3, 0.8), (5, 1.0)]),
        ]
    }

    /// The joint model of residuals `sum_k m_k S_k` plus white noise of sd `SD` (fixed seed).
    fn joint(truth: &[(usize, f64)], max: f64) -> Joint {
        let cols = columns();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let rows = (0..LABELS)
            .map(|l| {
                (0..CELLS_USED)
                    .map(|i| {
                        let e: f64 = StandardNormal.sample(&mut rng);
                        let g: f64 = truth.iter().map(|&(k, m)| m * cols[k][l][i]).sum();
                        (g + SD * e, SD, true)
                    })
                    .collect()
            })
            .collect();
        let offset = (0..LABELS)
            .map(|_| (0..CELLS_USED).map(|i| f64::from(i < 3)).collect())
            .collect();
        Joint {
            rows,
            max: vec![max; cols.len()],
            form_sd: vec![0.0; cols.len()],
            cols,
            nuis: Nuisance::offset_only(offset),
        }
    }

    fn select(j: &Joint) -> Vec<usize> {
        select_from(j, &[])
    }

    /// The selection from the effects `start` over the others, each label withheld in turn.
    fn selection_from(j: &Joint, start: &[usize]) -> Selection {
        let folds: Vec<(Vec<usize>, Vec<usize>)> = (0..LABELS)
            .map(|k| ((0..LABELS).filter(|&l| l != k).collect(), vec![k]))
            .collect();
        let eval: Vec<usize> = (0..LABELS).collect();
        let f = Folds {
            folds: &folds,
            eval_labels: &eval,
            ln_n: ((LABELS * CELLS_USED) as f64).ln(),
        };
        let allowed: Vec<bool> = (0..4).map(|e| !start.contains(&e)).collect();
        let selection = forward_select(j, start, &allowed, &f);
        // The base it starts from is the start's own withheld z, the one definition (`oos`).
        assert_eq!(selection.start_z, oos(j, start, &f).0);
        selection
    }

    /// The effects `start` and those the forward selection adds to them.
    fn select_from(j: &Joint, start: &[usize]) -> Vec<usize> {
        let steps = selection_from(j, start).steps;
        start
            .iter()
            .copied()
            .chain(steps.iter().map(|s| s.effect))
            .collect()
    }

    /// From what a first effect's runs leave with a true second effect in it, the selection
    /// starts from that gap (beyond noise: RMS z 3.0 here) and its step brings it to noise; from runs that
    /// leave noise, the start is noise and there is no step.
    #[test]
    fn the_selection_starts_from_the_gap_the_first_effects_runs_leave() {
        let ran = |truth: &[(usize, f64)]| {
            let mut j = joint(truth, 3.0);
            for (l, row) in j.rows.iter_mut().enumerate() {
                for (i, c) in row.iter_mut().enumerate() {
                    c.0 -= 2.0 * j.cols[0][l][i];
                }
            }
            j
        };
        let with_second = selection_from(&ran(&[(0, 2.0), (1, 0.5)]), &[]);
        let start = rms(&with_second.start_z.concat());
        let after = rms(&with_second.steps[0].z.concat());
        // Noise alone is RMS z about 1; the second effect's cells are 4-10 sd off.
        assert!(start > 2.0 && after < 1.5, "{start} -> {after}");
        let noise = selection_from(&ran(&[(0, 2.0)]), &[]);
        assert!(noise.steps.is_empty());
        assert!(rms(&noise.start_z.concat()) < 1.5);
    }

    #[test]
    fn two_effects_at_once_are_both_named_and_fitted_jointly() {
        let j = joint(&[(0, 0.8), (1, 0.5)], 2.0);
        let mut named = select(&j);
        named.sort_unstable();
        assert_eq!(named, vec![0, 1]);
        let all: Vec<usize> = (0..LABELS).collect();
        let f = j.fit(&all, &[0, 1]);
        for (k, truth) in [0.8, 0.5].into_iter().enumerate() {
            assert!(
                (f.m[k] - truth).abs() < 3.0 * f.sd[k],
                "effect {k}: {} +- {} against {truth}",
                f.m[k],
                f.sd[k]
            );
        }
    }

    /// The plant's effect moves the cells three times as much per unit as the twin's: at 0.8
    /// of the physical bound (1) it acts as the twin's 2.4. Its twin-equivalent magnitude is
    /// fitted within `fit_bound` (beyond the physical bound) and the gap left is noise; clamped
    /// at the physical bound, cells 3 and 4 would stay 14 and 8 sd off.
    #[test]
    fn an_effect_three_times_the_twins_per_unit_is_still_named() {
        let j = joint(&[(0, 3.0 * 0.8)], fit_bound(1.0));
        assert_eq!(select(&j), vec![0]);
        let all: Vec<usize> = (0..LABELS).collect();
        let f = j.fit(&all, &[0]);
        assert!((f.m[0] - 2.4).abs() < 3.0 * f.sd[0], "{f:?}");
        let z: Vec<f64> = all.iter().flat_map(|&l| j.z(l, &[0], &f)).collect();
        assert!(rms(&z) < 1.5, "RMS z {}", rms(&z));
    }

    /// Effect 0 at 2.0 with a response its linear column misses: 0.5 (5 sd) in cell 5
    /// (an eccentric pulley's second harmonic, quadratic in the runout), a cell effect 3 moves
    /// too. Selected onwards from the linearised first effect, that response is taken for
    /// effect 3; selected from what the first effect's run leaves (its whole response taken
    /// off), nothing is added, and a true second effect still is.
    #[test]
    fn a_response_the_linearisation_misses_is_not_a_second_effect() {
        let harmonic = |l: usize| 0.5 * (1.0 + 0.3 * l as f64);
        // The residuals against the baseline twin, with the harmonic.
        let mut linearised = joint(&[(0, 2.0)], 3.0);
        for (l, row) in linearised.rows.iter_mut().enumerate() {
            row[5].0 += harmonic(l);
        }
        assert_eq!(select_from(&linearised, &[0]), vec![0, 3]);
        // What the run with effect 0 at 2.0 leaves: noise, and a true second effect.
        let ran = |truth: &[(usize, f64)]| {
            let mut j = joint(truth, 3.0);
            for (l, row) in j.rows.iter_mut().enumerate() {
                for (i, c) in row.iter_mut().enumerate() {
                    c.0 -= 2.0 * j.cols[0][l][i];
                }
            }
            j
        };
        assert!(select_from(&ran(&[(0, 2.0)]), &[]).is_empty());
        assert_eq!(select_from(&ran(&[(0, 2.0), (1, 0.5)]), &[]), vec![1]);
    }

    #[test]
    fn one_effect_alone_is_named_alone() {
        assert_eq!(select(&joint(&[(0, 0.8)], 2.0)), vec![0]);
        // No effect: none is named.
        assert!(select(&joint(&[], 2.0)).is_empty());
    }
}
