//! Stage "load levels": what a belt setting recorded at two loads tells. A belt's creep slip is
//! the tension difference over its effective axial stiffness (Johnson, Contact Mechanics,
//! 1985, sec. 8.7), so the slip's rise from one load to another measures that stiffness, while
//! a slip offset (what the calibration's nuisance takes: pulley diameters, a creep curve of
//! another level) cancels in it. Labels at another load than the diagnosis's reference load
//! are set apart from the calibration and the ranking, paired with the reference-load label at
//! the same known centre distance, and the twin runs at both loads, without and with belt
//! hysteresis at its reference magnitude; the measured rises are fitted by the hysteresis's
//! stiffness ratio g and by a factor on the twin's rise (docs/decisions/gap-load-levels.md).
//! Two load levels do not tell hysteresis from an axial stiffness below the model's: the
//! finding names both and the verdict's named effects are not changed.

use fom::stats::{slope_through_origin, Z90};
use fom::DriveConfig;
use rayon::prelude::*;
use serde::Serialize;

use super::baseline::{LabelTwin, KNEE_ELASTICITY};
use super::twin_runs::{run, run_config, twin_recording, Resolution, Variant};
use super::verdict::{a_gap, STRONG_EVIDENCE};
use super::Diagnosis;
use crate::error::{Result, TwinError};
use crate::measured::{DataSet, LOAD_TORQUE_KEY};
use crate::signal::{measured_slip, Unsettled};

/// What the load levels showed (JSON `load_levels`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadLevels {
    /// The load of the labels the diagnosis calibrates on and ranks, N m (null: the drive
    /// configuration's load).
    pub reference_load_torque_nm: Option<f64>,
    /// Each label at another load with the reference-load label it is compared with.
    pub pairs: Vec<LoadPair>,
    /// Labels at another load that are not compared, with the reason.
    pub not_compared: Vec<[String; 2]>,
    /// The fit over the pairs (absent without a pair).
    pub fit: Option<StiffnessFit>,
    /// The finding in words.
    pub finding: String,
}

/// One label at another load and its reference-load partner at the same centre distance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadPair {
    pub label: String,
    pub partner: String,
    /// The driven load's torque in steady running at the partner's and the label's load, N m,
    /// as the twin ran them.
    pub load_torque_nm: [f64; 2],
    /// Steady slip at the label minus at the partner, measured, pp.
    pub measured_rise_pct: f64,
    /// The sd of the measured rise minus the twin's, pp: the four levels' standard errors and
    /// the twin's resolution (`RESOLUTION_SHARE`).
    pub rise_sd_pct: f64,
    /// The same rise in the twin's runs, without hysteresis and its change per unit of the
    /// hysteresis's stiffness ratio g, pp.
    pub twin_rise_pct: f64,
    pub twin_rise_per_g_pct: f64,
    /// (measured - twin) / sd of the rise, before and after the fitted g.
    pub z_before: f64,
    pub z_after: f64,
}

/// The fit of the measured rises over the pairs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StiffnessFit {
    /// Belt hysteresis's stiffness ratio g (relaxation 10 ms) that the rises ask for, with its
    /// 90 % interval; negative: a belt stiffer under load than the twin's.
    pub stiffness_ratio: f64,
    pub stiffness_ratio_interval90: [f64; 2],
    /// The measured rise over the twin's, with its 90 % interval.
    pub rise_ratio: f64,
    pub rise_ratio_interval90: [f64; 2],
    /// The axial stiffness that gives the measured rise without hysteresis, EA over the rise
    /// ratio (creep slip ~ tension difference / EA), N, with its 90 % interval.
    pub equivalent_axial_stiffness_n: f64,
    pub equivalent_axial_stiffness_interval90_n: [f64; 2],
    /// Chi-square with g minus without, plus the Schwarz penalty ln n (n pairs): below
    /// `STRONG_EVIDENCE` the rises differ from the twin's.
    pub score: f64,
    pub rms_z_before: f64,
    pub rms_z_after: f64,
    /// The rises left after the fit fail the data-set test for a gap (`verdict::a_gap`): no
    /// one stiffness explains them, the rise varies across belt settings otherwise.
    pub residual_beyond_noise: bool,
}

/// Labels at the same centre distance within this, m, are one belt setting.
const SAME_DISTANCE_M: f64 = 1.0e-4;

/// Relative sd of the twin's rise from its resolution: at the drive configuration's own
/// resolution (240 segments) the rise differed from 360 segments' by at most 0.5 % on the
/// default drive (healthy, d 0.424, 0.421 and 0.418 m, fan law at 1 and 0.6 of its
/// coefficient), taken twice (docs/decisions/gap-load-levels.md).
const RESOLUTION_SHARE: f64 = 0.01;

/// `cfg` with its driven load's speed-dependent part (viscous and fan law) scaled so that the
/// load takes `torque_nm` at the driven speed `driven_rpm`; the fan law T = c + b w + k w^2
/// (fom/src/drive.rs, `Load::torque_nm`).
fn at_load(cfg: &DriveConfig, torque_nm: f64, driven_rpm: f64) -> Result<DriveConfig> {
    let mut c = cfg.clone();
    let w = driven_rpm * std::f64::consts::PI / 30.0;
    let Some(load) = c.driven.load.as_mut() else {
        return Err(TwinError::Gap(
            "the drive configuration's driven pulley has no load ([driven.load]) to set a \
             load level on"
                .into(),
        ));
    };
    let moving = load.viscous_nm_s * w + load.fan_nm_s2 * w * w;
    let scale = (torque_nm - load.constant_nm) / moving;
    if load.profile.is_some() || !(moving > 0.0 && scale.is_finite() && scale > 0.0) {
        return Err(TwinError::Gap(format!(
            "{LOAD_TORQUE_KEY} = {torque_nm} N m at {driven_rpm:.1} rpm: a load level is set \
             on a speed-dependent load (viscous or fan law, no torque profile) above its \
             constant torque {} N m",
            load.constant_nm
        )));
    }
    load.viscous_nm_s *= scale;
    load.fan_nm_s2 *= scale;
    Ok(c)
}

/// The steady driven speed of `label`'s first run, rpm (`features::steady_speeds`).
fn steady_driven_rpm(set: &DataSet, label: &str, ratio: f64) -> Result<f64> {
    let i = set.runs_of(label)[0];
    let s = super::features::steady_speeds(&set.recordings[i], ratio, super::features::Read::Own)?;
    if s.unsettled {
        return Err(TwinError::Unusable(format!(
            "{}: still drifting at its end",
            set.manifest.runs[i].file
        )));
    }
    Ok(fom::stats::mean(&s.driven_rpm))
}

/// The driven load's torque of the drive configuration in steady running at `driven_rpm`,
/// N m: the model's load law (`fom::drive::Load`) once its torque profile has ended.
fn model_torque_nm(cfg: &DriveConfig, driven_rpm: f64) -> f64 {
    let w = driven_rpm * std::f64::consts::PI / 30.0;
    cfg.driven.load.as_ref().map_or(0.0, |l| {
        let end_s = l.profile.as_ref().map_or(0.0, |p| p.end_s());
        fom::drive::Load::new(l).brake_torque_nm(end_s, w)
    })
}

/// The torque of a label's load and the configuration the twin runs it at: the given torque
/// (`at_load`), or the configuration's own load at the label's fan speed.
fn load_of(
    cfg: &DriveConfig,
    given_nm: Option<f64>,
    driven_rpm: f64,
) -> std::result::Result<(f64, DriveConfig), String> {
    match given_nm {
        Some(t) => Ok((t, at_load(cfg, t, driven_rpm).map_err(|e| e.to_string())?)),
        None => Ok((model_torque_nm(cfg, driven_rpm), cfg.clone())),
    }
}

/// A pair's rise difference (measured minus twin, with the hysteresis at `g`) over its sd.
fn z_at(p: &LoadPair, g: f64) -> f64 {
    (p.measured_rise_pct - p.twin_rise_pct - g * p.twin_rise_per_g_pct) / p.rise_sd_pct
}

/// How a reference load reads in the reports: its torque, or the configuration's.
pub fn reference_load_text(reference_nm: Option<f64>) -> String {
    reference_nm.map_or("the drive configuration's".to_string(), |t| {
        format!("{t} N m")
    })
}

/// A given reference load farther than this share from the drive configuration's load at the
/// same fan speed is said in the verdict: creep slip goes with the transmitted torque
/// (Johnson, Contact Mechanics, 1985, sec. 8.7), so 5 % of it is 0.035 pp of the default
/// drive's 0.69 % slip, several times a steady level's standard error.
const REFERENCE_LOAD_SHARE: f64 = 0.05;

/// Where the data set's labels at its reference load give their torque (`load_torque_nm`)
/// and it differs from the drive configuration's load at their mean steady fan speed by more
/// than `REFERENCE_LOAD_SHARE`, a sentence for the verdict: the twin's calibration runs at the
/// configuration's load (`None` otherwise, or where no label's fan speed reads).
pub fn reference_note(cfg: &DriveConfig, set: &DataSet, ratio: f64) -> Option<String> {
    let given = set.reference_load_torque_nm()?;
    let others = set.other_load_labels();
    let rpm: Vec<f64> = set
        .labels()
        .iter()
        .filter(|l| !others.contains(l))
        .filter_map(|l| steady_driven_rpm(set, l, ratio).ok())
        .collect();
    if rpm.is_empty() {
        return None;
    }
    let rpm = fom::stats::mean(&rpm);
    let model = model_torque_nm(cfg, rpm);
    let share = given / model - 1.0;
    (share.abs() > REFERENCE_LOAD_SHARE).then(|| {
        format!(
            " The labels give a load of {given} N m, {:+.0} % from the drive configuration's \
             {model:.2} N m at their fan speed ({rpm:.0} rpm): the twin is calibrated at the \
             configuration's load, so part of a slip-level gap may be the load (a model \
             trained on a configuration with that load reads it; \
             docs/decisions/gap-load-levels.md).",
            100.0 * share
        )
    })
}

/// Compares the labels `others` of `full` (at another load) with their partners among the
/// label twins, and fits the rises (module doc).
pub(super) fn compare(
    d: &Diagnosis,
    full: &DataSet,
    others: &[String],
    twins: &[LabelTwin],
    hysteresis: &Variant,
) -> LoadLevels {
    let reference = full.reference_load_torque_nm();
    let mut not_compared = Vec::new();
    let mut jobs = Vec::new();
    for l in others {
        match pair_job(d, full, l, twins, reference) {
            Ok(j) => jobs.push(j),
            Err(why) => not_compared.push([l.clone(), why]),
        }
    }
    // Four runs a pair: the partner's load and the label's, without and with hysteresis.
    let tasks: Vec<(usize, usize, bool)> = (0..jobs.len())
        .flat_map(|j| [(j, 0, false), (j, 0, true), (j, 1, false), (j, 1, true)])
        .collect();
    let levels: Vec<Result<(f64, f64)>> = tasks
        .par_iter()
        .map(|&(j, load, with)| {
            twin_level(
                d,
                &jobs[j],
                &twins[jobs[j].partner],
                load,
                with.then_some(hysteresis),
            )
        })
        .collect();
    let mut levels = levels.into_iter();
    let mut pairs = Vec::new();
    for job in &jobs {
        let got: Result<Vec<(f64, f64)>> = levels.by_ref().take(4).collect();
        let partner = &twins[job.partner].label;
        match got.and_then(|t| pair_of(full, d.ratio, job, partner, &t, hysteresis.reference)) {
            Ok(p) => pairs.push(p),
            Err(e) => not_compared.push([job.label.clone(), e.to_string()]),
        }
    }
    let fit = fit(&pairs, d.cfg.belt.axial_stiffness_n);
    if let Some(f) = &fit {
        for p in &mut pairs {
            p.z_after = z_at(p, f.stiffness_ratio);
        }
    }
    let finding = finding(fit.as_ref(), &pairs, &not_compared);
    LoadLevels {
        reference_load_torque_nm: reference,
        pairs,
        not_compared,
        fit,
        finding,
    }
}

/// A pair to run: the label at another load, its partner's twin, both loads' configurations.
struct PairJob {
    label: String,
    partner: usize,
    loads_nm: [f64; 2],
    cfgs: [DriveConfig; 2],
}

/// The partner of `label` and the configurations at both loads, or why it is not compared.
fn pair_job(
    d: &Diagnosis,
    full: &DataSet,
    label: &str,
    twins: &[LabelTwin],
    reference: Option<f64>,
) -> std::result::Result<PairJob, String> {
    let Some(dist) = full.known_center_distance_m(label) else {
        return Err(
            "no center_distance_m: a label at another load is compared with the \
                    reference load's label at the same known centre distance"
                .into(),
        );
    };
    let partner = twins
        .iter()
        .position(|t| {
            full.known_center_distance_m(&t.label)
                .is_some_and(|x| (x - dist).abs() <= SAME_DISTANCE_M)
        })
        .ok_or_else(|| format!("no label at the reference load at its centre distance {dist} m"))?;
    let p = &twins[partner];
    if d.unsettled.iter().any(|u| u.label == p.label) {
        return Err(format!("its partner {} still drifts at its end", p.label));
    }
    if p.tension_elasticity.abs() > KNEE_ELASTICITY {
        return Err(format!(
            "its partner {} sits in the twin's looseness knee, where the slip's rise with \
             the load follows friction and tension, not the belt's stiffness",
            p.label
        ));
    }
    let rpm = |l: &str| steady_driven_rpm(full, l, d.ratio).map_err(|e| e.to_string());
    let (rpm_p, rpm_l) = (rpm(&p.label)?, rpm(label)?);
    let (t_p, cfg_p) = load_of(d.cfg, reference, rpm_p)?;
    let (t_l, cfg_l) = load_of(d.cfg, full.load_torque_nm(label), rpm_l)?;
    Ok(PairJob {
        label: label.to_string(),
        partner,
        loads_nm: [t_p, t_l],
        cfgs: [cfg_p, cfg_l],
    })
}

/// The twin's steady slip and its standard error, %, at `job`'s load `load` (0: the partner's,
/// 1: the label's), at the partner's calibrated point, read through its sensor.
fn twin_level(
    d: &Diagnosis,
    job: &PairJob,
    p: &LabelTwin,
    load: usize,
    effect: Option<&Variant>,
) -> Result<(f64, f64)> {
    let spec = effect.map(|v| v.spec(v.reference));
    let c = run_config(
        &job.cfgs[load],
        &p.q,
        &full_resolution(d.cfg, &d.opts.resolution),
        p.sample_interval_s,
        p.run_s,
        spec.as_deref(),
    )?;
    let rows = run(&c)?;
    let rec = twin_recording(&rows, d.model_ratio, d.ratio, 0.0, &p.sensor);
    let s = measured_slip(&[("twin run", &rec)], d.ratio, Unsettled::Refuse)?;
    Ok((s.mean_pct, s.mean_se_pct))
}

/// The drive configuration's own resolution, with `res`'s run lengths: the rise is a
/// difference of 0.1-0.3 pp whose change with hysteresis is a fifth of it, and the gap's
/// reduced resolution moves the rise by up to 10 % (docs/decisions/gap-load-levels.md). An
/// automatic step is taken as `res`'s scaled with the segment length (the explicit limit is
/// the axial wave's transit of one segment, fom/configs/hvac.toml).
fn full_resolution(cfg: &DriveConfig, res: &Resolution) -> Resolution {
    let segments = cfg.belt.segments;
    let step_s = match cfg.simulation.step_s {
        fom::config::StepSize::Seconds(s) => s,
        fom::config::StepSize::Auto => res.step_s * res.segments as f64 / segments as f64,
    };
    Resolution {
        segments,
        step_s,
        ..*res
    }
}

/// A pair's rises from the measurements and the twin's four levels (`twin_level`'s order:
/// partner's load without and with hysteresis at `g_ref`, the label's likewise).
fn pair_of(
    full: &DataSet,
    ratio: f64,
    job: &PairJob,
    partner: &str,
    t: &[(f64, f64)],
    g_ref: f64,
) -> Result<LoadPair> {
    let m_p = measured_slip(&full.recordings_of(partner), ratio, Unsettled::Refuse)?;
    let m_l = measured_slip(&full.recordings_of(&job.label), ratio, Unsettled::Refuse)?;
    let twin_rise = t[2].0 - t[0].0;
    let twin_rise_g = t[3].0 - t[1].0;
    let mut p = LoadPair {
        label: job.label.clone(),
        partner: partner.to_string(),
        load_torque_nm: job.loads_nm,
        measured_rise_pct: m_l.mean_pct - m_p.mean_pct,
        rise_sd_pct: 0.0,
        twin_rise_pct: twin_rise,
        twin_rise_per_g_pct: (twin_rise_g - twin_rise) / g_ref,
        z_before: 0.0,
        z_after: 0.0,
    };
    // Measured and twin levels are independent; the resolution's share on the twin's rise.
    p.rise_sd_pct = (m_l.mean_se_pct.powi(2)
        + m_p.mean_se_pct.powi(2)
        + t[0].1.powi(2)
        + t[2].1.powi(2)
        + (RESOLUTION_SHARE * twin_rise).powi(2))
    .sqrt();
    p.z_before = z_at(&p, 0.0);
    p.z_after = p.z_before;
    Ok(p)
}

/// The weighted least-squares fits of the rises (module doc): g from y = measured - twin =
/// g s, and the rise ratio from measured = r twin (`fom::stats::slope_through_origin`);
/// `None` without a pair whose twin rises.
fn fit(pairs: &[LoadPair], axial_stiffness_n: f64) -> Option<StiffnessFit> {
    let w = |p: &LoadPair| p.rise_sd_pct.powi(-2);
    let y = |p: &LoadPair| p.measured_rise_pct - p.twin_rise_pct;
    let sum = |f: &dyn Fn(&LoadPair) -> f64| pairs.iter().map(f).sum::<f64>();
    // g: one parameter by weighted least squares.
    let (g, g_sd) = slope_through_origin(
        pairs
            .iter()
            .map(|p| [y(p), p.twin_rise_per_g_pct, p.rise_sd_pct]),
    )?;
    // The rise ratio: measured = r twin.
    let (r, r_sd) = slope_through_origin(
        pairs
            .iter()
            .map(|p| [p.measured_rise_pct, p.twin_rise_pct, p.rise_sd_pct]),
    )?;
    let chi0 = sum(&|p| w(p) * y(p).powi(2));
    let chi1 = sum(&|p| w(p) * (y(p) - g * p.twin_rise_per_g_pct).powi(2));
    let n = pairs.len() as f64;
    let rms = |chi: f64| (chi / n).sqrt();
    let r_lo = (r - Z90 * r_sd).max(f64::MIN_POSITIVE);
    Some(StiffnessFit {
        stiffness_ratio: g,
        stiffness_ratio_interval90: [g - Z90 * g_sd, g + Z90 * g_sd],
        rise_ratio: r,
        rise_ratio_interval90: [r - Z90 * r_sd, r + Z90 * r_sd],
        equivalent_axial_stiffness_n: axial_stiffness_n / r,
        equivalent_axial_stiffness_interval90_n: [
            axial_stiffness_n / (r + Z90 * r_sd),
            axial_stiffness_n / r_lo,
        ],
        score: chi1 - chi0 + n.ln(),
        rms_z_before: rms(chi0),
        rms_z_after: rms(chi1),
        residual_beyond_noise: a_gap(&[pairs.iter().map(|p| z_at(p, g)).collect()]),
    })
}

/// The finding in words (`LoadLevels::finding`).
fn finding(fit: Option<&StiffnessFit>, pairs: &[LoadPair], not_compared: &[[String; 2]]) -> String {
    let left = if not_compared.is_empty() {
        String::new()
    } else {
        format!(
            " Not compared: {}.",
            not_compared
                .iter()
                .map(|[l, why]| format!("{l} ({why})"))
                .collect::<Vec<_>>()
                .join("; ")
        )
    };
    let Some(f) = fit else {
        return match pairs.is_empty() {
            true => format!("Two load levels: no label at another load was compared.{left}"),
            false => format!(
                "Two load levels ({} pair{}): the twin's slip does not rise with the load, so \
                 the belt's stiffness is not read.{left}",
                pairs.len(),
                if pairs.len() == 1 { "" } else { "s" }
            ),
        };
    };
    let [g_lo, g_hi] = f.stiffness_ratio_interval90;
    let [r_lo, r_hi] = f.rise_ratio_interval90;
    let [ea_lo, ea_hi] = f.equivalent_axial_stiffness_interval90_n;
    let head = format!(
        "Two load levels ({} pair{}: {}): the slip rises with the load {:.2} [{r_lo:.2}, \
         {r_hi:.2}] times as much as in the twin (score {:.1})",
        pairs.len(),
        if pairs.len() == 1 { "" } else { "s" },
        pairs
            .iter()
            .map(|p| format!("{} against {}", p.label, p.partner))
            .collect::<Vec<_>>()
            .join(", "),
        f.rise_ratio,
        f.score
    );
    let body = if f.score < STRONG_EVIDENCE && f.residual_beyond_noise {
        format!(
            ", and no one stiffness explains the rises (RMS z {:.2} after the best, belt \
             hysteresis of stiffness_ratio {:.3} or an axial stiffness of {:.0} N): the rise \
             varies across belt settings otherwise than a belt softer or stiffer under load \
             makes it, a creep curve of another shape under load \
             (docs/decisions/gap-load-levels.md).",
            f.rms_z_after, f.stiffness_ratio, f.equivalent_axial_stiffness_n
        )
    } else if f.score < STRONG_EVIDENCE && f.stiffness_ratio > 0.0 {
        format!(
            ": the belt is softer under load than the twin's. Belt hysteresis of stiffness_ratio \
             {:.3} [{g_lo:.3}, {g_hi:.3}], or without it an axial stiffness of {:.0} N [{ea_lo:.0}, \
             {ea_hi:.0}], gives that rise; two load levels do not tell those two apart \
             (docs/decisions/gap-load-levels.md).",
            f.stiffness_ratio, f.equivalent_axial_stiffness_n
        )
    } else if f.score < STRONG_EVIDENCE {
        format!(
            ": the belt is stiffer under load than the twin's, as an axial stiffness of {:.0} N \
             [{ea_lo:.0}, {ea_hi:.0}] would make it (docs/decisions/gap-load-levels.md).",
            f.equivalent_axial_stiffness_n
        )
    } else {
        format!(
            ": as in the twin. Belt hysteresis above stiffness_ratio {:.3} is ruled out, and \
             what the slip level differs by does not grow with the load \
             (docs/decisions/gap-load-levels.md).",
            g_hi.max(0.0)
        )
    };
    format!("{head}{body}{left}")
}

/// The text report's table of the pairs (`report::to_text`).
pub fn text(t: &mut String, ll: &LoadLevels) {
    use std::fmt::Write;
    let reference = reference_load_text(ll.reference_load_torque_nm);
    let _ = writeln!(
        t,
        "\nload levels (reference load {reference}; slip rise from the partner's load, pp):"
    );
    for p in &ll.pairs {
        let _ = writeln!(
            t,
            "  {:<12} against {:<12} {:>6.2} -> {:>6.2} N m  measured {:+.4} (sd {:.4})  twin \
             {:+.4}  z {:+.1} -> {:+.1}",
            p.label,
            p.partner,
            p.load_torque_nm[0],
            p.load_torque_nm[1],
            p.measured_rise_pct,
            p.rise_sd_pct,
            p.twin_rise_pct,
            p.z_before,
            p.z_after
        );
    }
    for [l, why] in &ll.not_compared {
        let _ = writeln!(t, "  {l}: not compared ({why})");
    }
}

/// A sentence for the verdict where the load levels find the belt as stiff as the twin's and
/// the ranking's belt-hysteresis candidate beats "none" at a stiffness ratio above what they
/// allow (`None` otherwise).
pub fn ranking_note(ll: &LoadLevels, ranking: &[super::Ranked]) -> Option<String> {
    let f = ll.fit.as_ref()?;
    let h = ranking.iter().find(|r| r.effect == "belt-hysteresis")?;
    let g = h.params.first()?.value;
    rules_out(f, g, h.score).then(|| {
        format!(
            " The ranking's belt-hysteresis candidate (stiffness_ratio {g:.3}) is above the \
             {:.3} the load levels allow: what it fits at one load is not a belt softer under \
             load.",
            f.stiffness_ratio_interval90[1]
        )
    })
}

/// Whether the load levels rule out a hysteresis candidate of stiffness ratio `g` that scored
/// `score` in the ranking: they find the belt as stiff as the twin's, the candidate beats
/// "none", and `g` lies above their interval, and one stiffness explains the rises.
fn rules_out(f: &StiffnessFit, g: f64, score: f64) -> bool {
    f.score >= STRONG_EVIDENCE
        && !f.residual_beyond_noise
        && score < 0.0
        && g > f.stiffness_ratio_interval90[1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measured::{Manifest, Recording, RunEntry};

    fn set(loads: &[(&str, Option<f64>)]) -> DataSet {
        let runs = loads
            .iter()
            .map(|(l, t)| RunEntry {
                file: format!("{l}.csv"),
                label: l.to_string(),
                center_distance_m: None,
                metadata: t
                    .map(|t| [(LOAD_TORQUE_KEY.to_string(), toml::Value::Float(t))].into())
                    .unwrap_or_default(),
            })
            .collect::<Vec<_>>();
        DataSet {
            dir: "x".into(),
            recordings: vec![Recording::default(); runs.len()],
            manifest: Manifest {
                runs,
                ..Manifest::default()
            },
        }
    }

    /// The reference load is the drive's own where a label gives none, else the one most labels
    /// give; the labels at another load leave the data set, and a data set at one load is not
    /// split.
    #[test]
    fn labels_at_another_load_than_the_reference_are_set_apart() {
        let s = set(&[
            ("d0", None),
            ("d1", None),
            ("d0-low", Some(8.8)),
            ("d1", None),
        ]);
        assert_eq!(s.reference_load_torque_nm(), None);
        let (main, others) = s.split_by_load().unwrap();
        assert_eq!(others, vec!["d0-low"]);
        assert_eq!(main.labels(), vec!["d0", "d1"]);
        assert_eq!(main.recordings.len(), 3);
        let fewer = set(&[("a", Some(8.8)), ("b", Some(8.8)), ("c", None)]);
        assert_eq!(
            fewer.reference_load_torque_nm(),
            None,
            "the surrogate's load"
        );
        assert_eq!(fewer.split_by_load().unwrap().1, vec!["a", "b"]);
        let given = set(&[("a", Some(14.2)), ("b", Some(8.8)), ("c", Some(14.2))]);
        assert_eq!(given.reference_load_torque_nm(), Some(14.2));
        assert_eq!(given.split_by_load().unwrap().1, vec!["b"]);
        let tie = set(&[("a", Some(8.8)), ("b", Some(14.2))]);
        assert_eq!(
            tie.reference_load_torque_nm(),
            Some(8.8),
            "a tie: the first label's"
        );
        assert!(set(&[("a", Some(8.8)), ("b", Some(8.8))])
            .split_by_load()
            .is_none());
        assert!(set(&[("a", None), ("b", None)]).split_by_load().is_none());
    }

    /// A steady recording at `driven_rpm` (driver at twice it, 1 kHz, 3 s), slip about 0.7 %.
    fn steady(driven_rpm: f64) -> Recording {
        let n = 3000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let wobble = |i: usize| 0.3 * ((i * 7919 % 101) as f64 / 101.0 - 0.5);
        Recording {
            driver_rpm: (0..n)
                .map(|i| 2.0 * driven_rpm / 0.993 + wobble(i))
                .collect(),
            driven_rpm: (0..n).map(|i| driven_rpm + wobble(i + 13)).collect(),
            time_s,
        }
    }

    /// A given reference load 5 % or more from the configuration's fan law at the labels' fan
    /// speed is said; one within it, or the configuration's own (no key), is not.
    #[test]
    fn a_given_reference_load_far_from_the_configurations_is_said() {
        let cfg = DriveConfig::default_hvac();
        let with = |t: Option<f64>| {
            let mut s = set(&[("d0", t), ("d1", t)]);
            s.recordings = vec![steady(870.0), steady(869.0)];
            s
        };
        let model = model_torque_nm(&cfg, 869.5);
        let note = reference_note(&cfg, &with(Some(0.8 * model)), 2.0).unwrap();
        assert!(
            note.contains("-20 %") && note.contains("calibrated at the"),
            "{note}"
        );
        assert!(reference_note(&cfg, &with(Some(1.02 * model)), 2.0).is_none());
        assert!(reference_note(&cfg, &with(None), 2.0).is_none());
    }

    /// A `--holdout` naming a label at another load is refused, naming it; one at the
    /// reference load is not.
    #[test]
    fn a_label_at_another_load_is_not_withheld() {
        let others = vec!["d0-low".to_string()];
        let opts = |h: &str| super::super::GapOptions {
            holdout: vec![h.to_string()],
            ..Default::default()
        };
        let e = super::super::check_load_holdout(Some(&others), &opts("d0-low"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`d0-low`") && e.contains("another load"), "{e}");
        assert!(super::super::check_load_holdout(Some(&others), &opts("d0")).is_ok());
        assert!(super::super::check_load_holdout(None, &opts("d0-low")).is_ok());
    }

    /// The fan law's speed-dependent part is scaled so that the load takes the given torque at
    /// the given speed; a torque at or below the constant part is refused.
    #[test]
    fn a_load_level_scales_the_fan_law_to_the_torque_at_the_measured_speed() {
        let cfg = DriveConfig::default_hvac();
        let c = at_load(&cfg, 8.8, 870.0).unwrap();
        assert!((model_torque_nm(&c, 870.0) - 8.8).abs() < 1e-9);
        let base = model_torque_nm(&cfg, 870.0);
        assert!(base > 13.0 && base < 15.0, "{base}");
        let k0 = cfg.driven.load.as_ref().unwrap().fan_nm_s2;
        let k = c.driven.load.as_ref().unwrap().fan_nm_s2;
        assert!((k / k0 - (8.8 - 0.2) / (base - 0.2)).abs() < 1e-12);
        let e = at_load(&cfg, 0.1, 870.0).unwrap_err().to_string();
        assert!(
            e.contains("load_torque_nm = 0.1") && e.contains("constant torque"),
            "{e}"
        );
    }

    fn pair(measured: f64, twin: f64, per_g: f64, sd: f64) -> LoadPair {
        LoadPair {
            label: "d0-low".into(),
            partner: "d0".into(),
            load_torque_nm: [14.2, 8.8],
            measured_rise_pct: measured,
            rise_sd_pct: sd,
            twin_rise_pct: twin,
            twin_rise_per_g_pct: per_g,
            z_before: 0.0,
            z_after: 0.0,
        }
    }

    /// Rises made with a known g are fitted back to it, and the finding says softer; rises as
    /// the twin's give g about 0 and rule out a hysteresis above the interval; a stiffer belt
    /// gives a negative g and an axial stiffness above the model's.
    #[test]
    fn the_rises_are_fitted_by_the_hysteresis_stiffness_ratio_and_the_rise_ratio() {
        // The twin's rise -0.26 pp from 14.2 to 8.8 N m; +0.35 pp per unit g.
        let (t, s, sd) = (-0.26, -0.35, 0.005);
        let softer = [
            pair(t + 0.2 * s, t, s, sd),
            pair(t * 1.02 + 0.2 * s, t * 1.02, s, sd),
        ];
        let f = fit(&softer, 20_000.0).unwrap();
        assert!((f.stiffness_ratio - 0.2).abs() < 1e-9, "{f:?}");
        let [lo, hi] = f.stiffness_ratio_interval90;
        assert!(lo > 0.15 && hi < 0.25 && lo < 0.2 && hi > 0.2, "{f:?}");
        assert!(f.score < STRONG_EVIDENCE && f.rms_z_after < 1e-6, "{f:?}");
        assert!((f.rise_ratio - 1.27).abs() < 0.01, "{f:?}");
        assert!((f.equivalent_axial_stiffness_n - 20_000.0 / f.rise_ratio).abs() < 1e-6);
        let text = finding(Some(&f), &softer, &[]);
        assert!(
            text.contains("softer under load") && text.contains("0.200"),
            "{text}"
        );

        let same = [pair(t + 0.004, t, s, sd), pair(t - 0.003, t, s, sd)];
        let f = fit(&same, 20_000.0).unwrap();
        assert!(
            f.stiffness_ratio.abs() < 0.02 && f.score > STRONG_EVIDENCE,
            "{f:?}"
        );
        let text = finding(Some(&f), &same, &[["d3-low".into(), "why".into()]]);
        assert!(
            text.contains("as in the twin")
                && text.contains("ruled out")
                && text.contains("Not compared: d3-low (why)"),
            "{text}"
        );

        // Rises 1.15 and 1.5 times the twin's: no one g explains both.
        let other = [pair(t * 1.15, t, s, sd), pair(t * 1.5, t, s, sd)];
        let f = fit(&other, 20_000.0).unwrap();
        assert!(
            f.residual_beyond_noise && f.score < STRONG_EVIDENCE,
            "{f:?}"
        );
        let text = finding(Some(&f), &other, &[]);
        assert!(
            text.contains("no one stiffness explains") && !text.contains("softer under load than"),
            "{text}"
        );
        assert!(!fit(&softer, 20_000.0).unwrap().residual_beyond_noise);

        let stiffer = [pair(t * 0.8, t, s, sd)];
        let f = fit(&stiffer, 20_000.0).unwrap();
        assert!(
            f.stiffness_ratio < 0.0 && f.equivalent_axial_stiffness_n > 24_000.0,
            "{f:?}"
        );
        assert!(finding(Some(&f), &stiffer, &[]).contains("stiffer under load"));
        assert!(fit(&[], 20_000.0).is_none());
        // A twin whose slip does not rise with the load reads no stiffness, and says why.
        let flat = [pair(0.1, 0.0, 0.0, sd)];
        assert!(fit(&flat, 20_000.0).is_none());
        assert!(finding(None, &flat, &[]).contains("does not rise with the load"));
        // A hysteresis the ranking fits at one load is ruled out only by a belt as stiff as
        // the twin's, never by one that is softer.
        let as_twin = fit(&same, 20_000.0).unwrap();
        assert!(rules_out(&as_twin, 0.2, -30.0));
        assert!(
            !rules_out(&as_twin, 0.2, 3.0),
            "a candidate worse than none"
        );
        assert!(!rules_out(&as_twin, 0.0, -30.0), "within the interval");
        let soft = fit(&softer, 20_000.0).unwrap();
        assert!(!rules_out(&soft, 0.3, -60.0));
        assert!(finding(None, &[], &[]).contains("no label at another load was compared"));
    }
}
