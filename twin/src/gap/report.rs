//! What `rom gap` found: the report's types (serialised as `rom gap --format json`), a text
//! summary, JSON, and an HTML page with the where-table as a heat map and the slip
//! distributions before and after (inline SVG), written atomically.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;
use serde::Serialize;

use crate::error::{Result, TwinError};

/// One cell of the where-table.
#[derive(Debug, Clone, Serialize)]
pub struct CellGap {
    pub label: String,
    pub cell: String,
    pub measured: f64,
    pub twin: f64,
    /// What noise and friction uncertainty explain (1 sd).
    pub sd: f64,
    pub z: f64,
    /// |z| beyond the family-wise 5 % threshold over all cells.
    pub significant: bool,
}

/// A fitted parameter with its 90 % interval.
#[derive(Debug, Clone, Serialize)]
pub struct Param {
    pub name: String,
    pub value: f64,
    pub interval90: [f64; 2],
}

/// One candidate's result.
#[derive(Debug, Clone, Serialize)]
pub struct Ranked {
    pub effect: String,
    /// Out-of-sample chi-square minus that of "none", plus k ln n (lower is better; "none" 0).
    pub score: f64,
    pub params: Vec<Param>,
    /// Withheld-label RMS z with the candidate (linearised about the sensitivity run).
    pub gap_after: f64,
    /// Slip offset refitted alongside the candidate on all fitted labels, pp (what the
    /// calibration's offset becomes once the effect is modelled).
    pub slip_offset_pct: f64,
    /// The cells that moved most towards the measurement (the signature supporting it).
    pub signature: Vec<String>,
    /// The score on the cells the slip offset does not move (all but the steady slip levels
    /// and the driven speed's level): an effect is named only if it is strong here too.
    pub score_beyond_slip_level: f64,
    /// The candidate keeps only its own line's sensitivity: the plant answers the effect with
    /// that line and with another shape elsewhere (docs/decisions/gap-signature-line.md).
    pub line_only: bool,
    /// Index of the mechanical variant (None: the tachometer).
    #[serde(skip)]
    pub variant: Option<usize>,
}

/// An effect named as (part of) the gap's cause, in the order the forward selection added it.
#[derive(Debug, Clone, Serialize)]
pub struct NamedEffect {
    pub effect: String,
    /// Its magnitude with a 90 % interval (with more than one named: from their joint fit).
    pub params: Vec<Param>,
    /// Withheld labels' RMS z with this effect and those named before it.
    pub gap_after: f64,
    /// How much this step lowered the out-of-sample score (the first: against "none").
    pub score_gain: f64,
}

/// What the slip level's smooth discrepancy across labels absorbed (see `GapReport::absorbed`).
#[derive(Debug, Clone, Serialize)]
pub struct Absorbed {
    /// Per label, the slip level the discrepancy adds beyond the constant offset, pp (fitted
    /// with no effect on the fitted labels).
    pub slip_level_pp: BTreeMap<String, f64>,
    /// Prior sd of the discrepancy's slope and curvature, pp.
    pub prior_sd_pp: f64,
    /// How much the discrepancy lowers the out-of-sample score of "none" against the slip
    /// offset alone (Huber loss, less 2 ln n for its two parameters).
    pub score_gain: f64,
    /// Whether that gain is very strong (above 10): a model-form difference in the slip level.
    pub model_form_difference: bool,
}

/// A strong candidate that does not explain the gap (see `GapReport::partial_effect`).
#[derive(Debug, Clone, Serialize)]
pub struct PartialEffect {
    pub effect: String,
    /// Share of the withheld gap's excess over noise it removes.
    pub reduction: f64,
    /// Whether its full-order runs at the fitted magnitude fell short (its linearised fit
    /// promised at least half).
    pub by_runs: bool,
}

/// An effect named by its own line (`Variant::line_cells`) though it removes less than half
/// of the whole withheld gap: the plant answers it with another magnitude or shape than the
/// twin, and the rest of the gap is that model-form difference
/// (docs/decisions/gap-signature-line.md).
#[derive(Debug, Clone, Serialize)]
pub struct SignatureLine {
    /// The line's cells.
    pub cells: Vec<String>,
    /// The withheld labels' RMS z over the line's cells before, after the fit, and in the
    /// confirmation runs.
    pub rms_z_before: f64,
    pub rms_z_after: f64,
    pub confirmed_rms_z_after: Option<f64>,
    /// Share of the whole withheld gap's excess over noise the effect removes (below half):
    /// in its fit, or, where the fit promised half and its confirmation runs fell short
    /// (`whole_gap_by_runs`), in those runs.
    pub whole_gap_reduction: f64,
    pub whole_gap_by_runs: bool,
    /// Whether the whole withheld gap is larger with the effect than without (its share
    /// removed is then 0): the twin's effect moves other cells than the plant's does.
    #[serde(skip)]
    pub whole_gap_grows: bool,
}

/// The withheld labels' gap: RMS of z over their cells (1 = noise level).
#[derive(Debug, Clone, Serialize)]
pub struct GapSummary {
    pub labels: Vec<String>,
    pub rms_z: f64,
    /// 90 % bootstrap interval over labels.
    pub interval90: [f64; 2],
    pub cells_beyond_noise: usize,
}

/// What `rom gap` reports.
#[derive(Debug, Clone, Serialize)]
pub struct GapReport {
    /// A catalogue effect, "none", or "unexplained"; with several effects named, the first.
    pub top_effect: String,
    /// Every effect named, in the order of the forward selection (empty for "none" and
    /// "unexplained").
    pub named: Vec<NamedEffect>,
    /// What the slip level's smooth discrepancy across labels absorbed (a creep curve of
    /// another shape than the twin's; null when the labels share one distance).
    pub absorbed: Option<Absorbed>,
    /// A candidate whose score is within the strong-evidence margin of the named effect's: the
    /// data do not tell the two apart (both are shown; the top one is named).
    pub not_told_apart_from: Option<String>,
    /// A candidate with very strong evidence that removes less than half of the gap: the gap is
    /// unexplained, and this effect is at most part of it.
    pub partial_effect: Option<PartialEffect>,
    /// The named effect was named by its own line, not by the whole gap (null otherwise).
    pub named_by_line: Option<SignatureLine>,
    pub verdict: String,
    pub ranking: Vec<Ranked>,
    pub gap_before: GapSummary,
    /// The withheld gap after the named effects: what the first one's confirmation runs leave
    /// (`confirmed_gap_after`), then each added effect's joint fit; a tachometer's from its
    /// grid's fit; where nothing is named, the gap before.
    pub gap_after: GapSummary,
    /// Share of the withheld gap's excess over noise (RMS z above 1) removed, at most 100 %,
    /// with a 90 % bootstrap interval over labels.
    pub reduction: f64,
    pub reduction_interval90: [f64; 2],
    /// Full-order confirmation of the best candidate at its fitted magnitude (withheld labels'
    /// RMS z), when a mechanical candidate had very strong evidence and its fit explained the
    /// gap.
    pub confirmed_gap_after: Option<f64>,
    /// The installation tension of the confirmation runs, N, where the runs at the calibrated
    /// tension fell short and a tension within its 90 % posterior interval fits the fitted
    /// labels better (docs/decisions/gap-confirmation-tension.md); null otherwise.
    pub confirmation_tension_n: Option<f64>,
    /// The named effect's magnitude searched with full-order runs at the labels no fold fits,
    /// where its runs at the linearised fit's magnitude fell short there: `labels`, `search`
    /// (magnitude, chi-square), `magnitude`, `interval90`, `fitted` (the fit's magnitude); the
    /// runs and the named magnitude are then the search's
    /// (docs/decisions/gap-unfitted-labels.md); null otherwise.
    pub confirmation_magnitude: Option<super::unfitted::MagnitudeSearch>,
    /// Where the confirmation runs are made at a re-fitted installation tension: the named
    /// effect's magnitude those runs ask for in its own line on the fitted labels, no run
    /// added (`tension_n`, `cells`, `labels`, `magnitude`, `interval90`, `fitted`: the
    /// linearised fit's magnitude at the calibrated tension, at which the runs and the gap
    /// after are made); the named magnitude is then this one
    /// (docs/decisions/gap-confirmation-tension.md); null otherwise.
    pub magnitude_at_confirmation_tension: Option<super::confirmation::MagnitudeAtTension>,
    /// Share of the withheld gap's excess over noise that the confirmation runs remove, at
    /// most 100 %: how far the gap shrinks with the effect run, not linearised.
    pub confirmed_reduction: Option<f64>,
    #[serde(rename = "where")]
    pub where_cells: Vec<CellGap>,
    pub calibration: BaselineSummary,
    pub blades: u32,
    pub z_threshold: f64,
    pub unusable: Vec<[String; 2]>,
    /// Labels whose recordings still drift at their end (`UnsettledLabel`).
    pub unsettled_labels: Vec<UnsettledLabel>,
    /// Full-order runs with an effect that stopped with an error (a numerical failure or a
    /// physical-plausibility stop at that magnitude): the effect is not evaluated at that label
    /// (sensitivity runs), or not confirmed (confirmation runs), and the reason is kept here.
    pub failed_runs: Vec<FailedRun>,
    /// The second pass's runs: each of the two best candidates run again at its first fit's
    /// magnitude, and whether that run was kept (docs/decisions/gap-second-pass.md). Empty:
    /// no second pass.
    pub second_pass: Vec<SecondPassRun>,
    pub elapsed_s: f64,
    /// Labels where the calibrated twin sits in its looseness knee (`baseline::KNEE_ELASTICITY`):
    /// left out of the effects' ranking and gap figures, their cells still in `where`, with the
    /// installation tension's spread through two more twin runs in their sd.
    pub knee_labels: Vec<KneeLabel>,
    /// Where the gap lies in unsettled labels alone, which no fold fits: the candidates fitted
    /// in sample there, the best one's magnitude searched with full-order runs, and whether it
    /// was named (docs/decisions/gap-unfitted-labels.md). Absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unfitted_labels: Option<super::unfitted::UnfittedEvidence>,
    /// What labels recorded at another load than the reference one tell about the belt's
    /// stiffness under load (docs/decisions/gap-load-levels.md). Absent when every label is at
    /// one load.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load_levels: Option<super::load_levels::LoadLevels>,
    /// The sensor identified from the recordings, through which the twin is read
    /// (`sensor_id`).
    pub sensor: super::sensor_id::IdentifiedSensor,
    #[serde(skip)]
    pub plots: Vec<LabelPlot>,
}

/// A label whose recordings still drift at their end (the one steady-state definition finds no
/// settled window): compared with the twin over its last minimum window, the twin's run read
/// over the same window, and never a calibration target; in the ranking it is always withheld
/// (docs/decisions/gap-unsettled-labels.md).
#[derive(Debug, Clone, Serialize)]
pub struct UnsettledLabel {
    pub label: String,
    /// The window compared, s after the first running sample.
    pub window_s: [f64; 2],
    /// Mean slip over the window and its standard error (about the drift), %.
    pub mean_slip_pct: f64,
    pub mean_slip_se_pct: f64,
}

/// A label whose calibrated twin sits in its looseness knee (see `GapReport::knee_labels`).
#[derive(Debug, Clone, Serialize)]
pub struct KneeLabel {
    pub label: String,
    /// d ln(slip) / d ln(installation tension) of the calibrated surrogate at the label.
    pub tension_elasticity: f64,
    /// The installation tension's 90 % posterior interval, N: the twin's two extra runs.
    pub tension_interval_n: [f64; 2],
    /// Share of the label's cells' variance that the tension's spread is (mean over the cells
    /// that enter fits; `cells::tension_term`).
    pub tension_variance_share: f64,
    /// RMS z of the label's cells against the baseline twin (1 = noise).
    pub rms_z: f64,
}

/// A candidate run again at its first fit's magnitude (see `GapReport::second_pass`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SecondPassRun {
    /// The `rom simulate --effect` specification of the run.
    pub effect: String,
    /// The candidate's score with its reference run (first pass), also on the cells beyond
    /// the slip level, and with this run.
    pub score_first: f64,
    pub score_first_beyond_slip_level: f64,
    pub score_rerun: f64,
    /// False: the run cost the candidate very strong evidence and was set aside; the reference
    /// run is kept.
    pub kept: bool,
}

/// A full-order run with an effect that failed (see `GapReport::failed_runs`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailedRun {
    pub label: String,
    /// The `rom simulate --effect` specification of the run.
    pub effect: String,
    /// "sensitivity" (the effect at its reference magnitude), "second pass" (at a first fit's
    /// magnitude) or "confirmation" (the named candidate at its fitted magnitude).
    pub purpose: &'static str,
    pub reason: String,
}

/// The baseline calibration the diagnosis compares against.
#[derive(Debug, Clone, Serialize)]
pub struct BaselineSummary {
    pub fitted_on: Vec<String>,
    pub friction: f64,
    pub installation_tension_n: f64,
    pub slip_offset_pct: f64,
    pub center_distances_m: BTreeMap<String, f64>,
    /// The calibration's own signs that the twin cannot reproduce the fitted labels' slip (a
    /// parameter at the trained box's bound, a slip beyond every training run, a residual
    /// beyond three sd: `rom calibrate`'s "misfit"); empty when none. A bound reached means the
    /// baseline the gap is measured against is forced: the knee labels and the slip level then
    /// carry a model-form difference the calibration could not take.
    pub misfit: Vec<String>,
    /// Where the fitted labels' start-up slips decided the calibration (the steady slips
    /// alone left the tension free, and their run-up lay beyond noise of that point); null
    /// where the steady slips alone made it.
    pub startup_fit: Option<StartupFit>,
    /// Where the tension readings were taken in as the installation tension's prior (the
    /// speeds alone agreed with them); null otherwise.
    pub tension_prior: Option<crate::calibrate::TensionPrior>,
}

/// A baseline calibration that matched the fitted labels' start-up slips as well
/// (docs/decisions/gap-startup-calibration.md).
#[derive(Debug, Clone, Serialize)]
pub struct StartupFit {
    /// The labels whose start-up slip was matched.
    pub labels: Vec<String>,
    /// What the steady slips alone gave.
    pub steady_only_friction: f64,
    pub steady_only_tension_n: f64,
    /// The start-up slips' chi-square at the steady slips' point and at the one kept.
    pub startup_chi2: [f64; 2],
    /// How much the steady slips' chi-square rose at the point kept (below 3.84, the 95 %
    /// quantile for one parameter, or the steady slips' point is kept).
    pub steady_chi2_rise: f64,
}

/// Steady slip samples of one label (sorted) for the distribution plots.
#[derive(Debug, Clone)]
pub struct LabelPlot {
    pub label: String,
    pub index: usize,
    pub measured: Vec<f64>,
    pub before: Vec<f64>,
    pub after: Vec<f64>,
}

/// The text report's line on the best candidate's full-order runs, where there are any: how
/// they were made and what they leave.
fn confirmation_line(r: &GapReport) -> String {
    let Some(g) = r.confirmed_gap_after else {
        return String::new();
    };
    let mut how = String::new();
    if let Some(t) = r.confirmation_tension_n {
        how += &format!(", installation tension re-fitted to {t:.1} N");
    }
    if let Some(s) = &r.confirmation_magnitude {
        how += &format!(
            ", magnitude searched at {}: {}",
            s.labels.join(", "),
            num(s.magnitude)
        );
    }
    if let Some(a) = &r.magnitude_at_confirmation_tension {
        how += &format!(
            " at {}; its line there asks for {} [{}, {}]",
            num(a.fitted),
            num(a.magnitude),
            num(a.interval90[0]),
            num(a.interval90[1])
        );
    }
    format!(
        "\n  the best candidate run at its fitted magnitude (full-order{how}): RMS z {g:.2}, \
         reduction {:.0} %",
        100.0 * r.confirmed_reduction.unwrap_or(0.0)
    )
}

/// A number for the text report: five decimals, or four significant digits in scientific
/// notation below 1e-3 (a tachometer's P tau of ~2e-4 s read 0.0002 before).
pub(super) fn num(x: f64) -> String {
    if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        format!("{x:.5}")
    }
}

/// Parameters with their 90 % intervals where they have one.
fn params_text(params: &[Param]) -> String {
    params
        .iter()
        .map(|p| {
            if p.interval90[0].is_finite() {
                format!(
                    "{} {} [{}, {}]",
                    p.name,
                    num(p.value),
                    num(p.interval90[0]),
                    num(p.interval90[1])
                )
            } else {
                format!("{} {}", p.name, p.value)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The text's lines on the baseline calibration: its point, where the run-ups decided it, and
/// its signs of misfit.
fn calibration_text(t: &mut String, r: &GapReport) {
    let c = &r.calibration;
    let _ = writeln!(
        t,
        "\nbaseline calibration on {}: friction {:.4}, installation tension {:.1} N, slip offset \
         {:+.3} pp; blade-pass band at {} x fan speed",
        c.fitted_on.join(", "),
        c.friction,
        c.installation_tension_n,
        c.slip_offset_pct,
        r.blades
    );
    if let Some(u) = &c.startup_fit {
        let _ = writeln!(
            t,
            "  matched to the start-up slip of {} as well: the steady slips alone barely pin \
             the installation tension (nor, where it is fitted, the distance), and gave \
             friction {:.4}, installation tension {:.1} N, where the run-up is off (chi-square \
             {:.1}; {:.1} here, the steady slips' chi-square {:+.2})",
            u.labels.join(", "),
            u.steady_only_friction,
            u.steady_only_tension_n,
            u.startup_chi2[0],
            u.startup_chi2[1],
            u.steady_chi2_rise
        );
    }
    if let Some(tp) = &c.tension_prior {
        let _ = writeln!(t, "  {}", tp.to_text());
    }
    for f in &c.misfit {
        let _ = writeln!(t, "  calibration misfit: {f}");
    }
}

/// The text summary: verdict, named effects, ranking, before/after, the cells beyond noise.
pub fn to_text(r: &GapReport) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "top effect: {}", r.top_effect);
    let _ = writeln!(t, "{}", r.verdict);
    if !r.named.is_empty() {
        let _ = writeln!(
            t,
            "\nnamed (in order of selection; withheld RMS z after each step):"
        );
        for (k, e) in r.named.iter().enumerate() {
            let _ = writeln!(
                t,
                "  {}. {:<40} RMS z after {:>6.2}  score gain {:>8.1}  {}",
                k + 1,
                e.effect,
                e.gap_after,
                e.score_gain,
                params_text(&e.params)
            );
        }
    }
    if let Some(a) = &r.absorbed {
        let _ = writeln!(
            t,
            "\nabsorbed by the slip level's discrepancy across labels (prior sd {:.3} pp; score \
             gain {:.1}{}): {}",
            a.prior_sd_pp,
            a.score_gain,
            if a.model_form_difference {
                ", a model-form difference in the slip level"
            } else {
                ""
            },
            a.slip_level_pp
                .iter()
                .map(|(l, v)| format!("{l} {v:+.3} pp"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if let Some(ll) = &r.load_levels {
        super::load_levels::text(&mut t, ll);
    }
    calibration_text(&mut t, r);
    let c = &r.calibration;
    let _ = writeln!(t, "\nsensor from the recordings: {}", r.sensor.summary());
    // Leave one label out: every withheld label is also a calibration label, in turn.
    let in_turn = if r.gap_before.labels.iter().all(|l| c.fitted_on.contains(l)) {
        ", each left out of the calibration in turn"
    } else {
        ""
    };
    let _ = writeln!(
        t,
        "\ngap on withheld labels ({}{in_turn}), RMS z (1 = noise):\n  before {:.2} [{:.2}, {:.2}] \
         ({} cells beyond |z| {:.2})\n  after  {:.2} [{:.2}, {:.2}] ({} cells)\n  reduction of \
         the excess over noise {:.0} % [{:.0}, {:.0}]{}",
        r.gap_before.labels.join(", "),
        r.gap_before.rms_z,
        r.gap_before.interval90[0],
        r.gap_before.interval90[1],
        r.gap_before.cells_beyond_noise,
        r.z_threshold,
        r.gap_after.rms_z,
        r.gap_after.interval90[0],
        r.gap_after.interval90[1],
        r.gap_after.cells_beyond_noise,
        100.0 * r.reduction,
        100.0 * r.reduction_interval90[0],
        100.0 * r.reduction_interval90[1],
        confirmation_line(r)
    );
    let _ = writeln!(
        t,
        "\nranking (score: out-of-sample chi-square vs none + k ln n):"
    );
    for k in &r.ranking {
        let params = params_text(&k.params);
        let line = if k.line_only {
            "  (by its line only)"
        } else {
            ""
        };
        let _ = writeln!(
            t,
            "  {:<42} score {:>10.1}  RMS z after {:>6.2}  {params}{line}",
            k.effect, k.score, k.gap_after
        );
    }
    let mut worst: Vec<_> = r.where_cells.iter().filter(|c| c.significant).collect();
    worst.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let _ = writeln!(t, "\nwhere (cells beyond noise, largest first):");
    if worst.is_empty() {
        let _ = writeln!(t, "  none");
    }
    for c in worst.iter().take(15) {
        let _ = writeln!(
            t,
            "  {:<8} {:<44} measured {:>12} twin {:>12} sd {:>11} z {:>+7.1}",
            c.label,
            c.cell,
            num(c.measured),
            num(c.twin),
            num(c.sd),
            c.z
        );
    }
    for [l, why] in &r.unusable {
        let _ = writeln!(t, "label {l} left out: {why}");
    }
    for u in &r.unsettled_labels {
        let _ = writeln!(
            t,
            "label {} still drifting: compared over {:.2}-{:.2} s after its start (mean slip {:.3} %), withheld from calibration and fits",
            u.label, u.window_s[0], u.window_s[1], u.mean_slip_pct
        );
    }
    for f in &r.failed_runs {
        let _ = writeln!(
            t,
            "{} run `{}` at label {} failed: {}",
            f.purpose, f.effect, f.label, f.reason
        );
    }
    for p in r.second_pass.iter().filter(|p| !p.kept) {
        let _ = writeln!(
            t,
            "second pass run `{}` set aside: score {:.1} with it, {:.1} with the reference run",
            p.effect, p.score_rerun, p.score_first
        );
    }
    let _ = writeln!(t, "\n({:.1} s wall time)", r.elapsed_s);
    t
}

/// Cell style of a z value: background white at 0, red at +threshold x 2, blue at
/// -threshold x 2; white text on the darker half of the scale.
fn heat(z: f64, threshold: f64) -> String {
    let a = (z.abs() / (2.0 * threshold)).min(1.0);
    let (r, g, b) = if z >= 0.0 {
        (255.0, 255.0 * (1.0 - a), 255.0 * (1.0 - a))
    } else {
        (255.0 * (1.0 - a), 255.0 * (1.0 - a), 255.0)
    };
    let text = if a > 0.6 { "#fff" } else { "#000" };
    format!("background:rgb({r:.0},{g:.0},{b:.0});color:{text}")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Quantile-function plot (slip against probability) of one label: measured, twin before and
/// after, as an SVG string.
fn distribution_svg(p: &LabelPlot) -> Result<String> {
    let q = |v: &[f64]| -> Vec<(f64, f64)> {
        (0..100)
            .map(|i| {
                let pr = (i as f64 + 0.5) / 100.0;
                (pr, fom::stats::quantile(v, pr))
            })
            .collect()
    };
    let series = [
        ("measured", q(&p.measured), RGBColor(0, 0, 0)),
        ("twin before", q(&p.before), RGBColor(31, 119, 180)),
        ("twin after", q(&p.after), RGBColor(214, 39, 40)),
    ];
    let all: Vec<f64> = series
        .iter()
        .flat_map(|s| s.1.iter().map(|x| x.1))
        .filter(|x| x.is_finite())
        .collect();
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(lo.is_finite() && hi.is_finite()) {
        return Ok(String::new());
    }
    let pad = 0.05 * (hi - lo).max(1e-3);
    let err = |e: String| TwinError::Gap(format!("drawing the distributions: {e}"));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (360, 260)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("label {}", p.label), ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, (lo - pad)..(hi + pad))
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("probability")
            .y_desc("steady slip, %")
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for (name, pts, colour) in series {
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                .map_err(|e| err(e.to_string()))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    Ok(svg)
}

/// The HTML page.
pub fn to_html(r: &GapReport) -> Result<String> {
    let mut h = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>beltwin gap diagnosis\
         </title><style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}\
         td,th{border:1px solid #ccc;padding:2px 6px;font-size:12px;text-align:right}\
         th{background:#eee}</style></head><body>\n",
    );
    let _ = writeln!(
        h,
        "<h1>Sim-to-real gap</h1>\n<p id=\"top-effect\"><b>Top effect: {}</b></p>\n<p>{}</p>",
        escape(&r.top_effect),
        escape(&r.verdict)
    );
    let _ = writeln!(
        h,
        "<p>Withheld labels {}: RMS z {:.2} before, {:.2} after (reduction {:.0} %, 90 % \
         interval {:.0}-{:.0} %).</p>",
        escape(&r.gap_before.labels.join(", ")),
        r.gap_before.rms_z,
        r.gap_after.rms_z,
        100.0 * r.reduction,
        100.0 * r.reduction_interval90[0],
        100.0 * r.reduction_interval90[1]
    );
    h += "<h2>Ranking</h2>\n<table><tr><th>effect</th><th>score</th><th>RMS z after</th>\
          <th>parameters</th><th>signature</th></tr>\n";
    for k in &r.ranking {
        let params = k
            .params
            .iter()
            .map(|p| format!("{} = {:.4}", p.name, p.value))
            .collect::<Vec<_>>()
            .join("; ");
        let _ = writeln!(
            h,
            "<tr><td style=\"text-align:left\">{}</td><td>{:.1}</td><td>{:.2}</td><td>{}</td>\
             <td style=\"text-align:left\">{}</td></tr>",
            escape(&k.effect),
            k.score,
            k.gap_after,
            escape(&params),
            escape(&k.signature.join(", "))
        );
    }
    h += "</table>\n<h2>Where: z = (measured - twin) / sd per label and cell</h2>\n";
    let mut labels: Vec<&str> = Vec::new();
    let mut cells: Vec<&str> = Vec::new();
    for c in &r.where_cells {
        if !labels.contains(&c.label.as_str()) {
            labels.push(&c.label);
        }
        if !cells.contains(&c.cell.as_str()) {
            cells.push(&c.cell);
        }
    }
    h += "<table id=\"where\"><tr><th>cell</th>";
    for l in &labels {
        let _ = write!(h, "<th>{}</th>", escape(l));
    }
    h += "</tr>\n";
    for cell in &cells {
        let _ = write!(h, "<tr><td style=\"text-align:left\">{}</td>", escape(cell));
        for l in &labels {
            match r
                .where_cells
                .iter()
                .find(|c| c.cell == *cell && c.label == *l)
            {
                Some(c) => {
                    let _ = write!(
                        h,
                        "<td style=\"{}\" title=\"measured {:.5}, twin {:.5}, sd {:.5}\">{}</td>",
                        heat(c.z, r.z_threshold),
                        c.measured,
                        c.twin,
                        c.sd,
                        if c.significant {
                            format!("<b>{:+.1}</b>", c.z)
                        } else {
                            format!("{:+.1}", c.z)
                        }
                    );
                }
                None => h += "<td>-</td>",
            }
        }
        h += "</tr>\n";
    }
    h += "</table>\n<h2>Steady slip distributions (quantile functions)</h2>\n<div>\n";
    for p in &r.plots {
        h += &distribution_svg(p)?;
        h += "\n";
    }
    h += "</div>\n</body></html>\n";
    Ok(h)
}

/// Writes `gap.txt`, `gap.json` and `gap.html` into `dir`.
pub fn write_gap_report(dir: &Path, r: &GapReport) -> Result<()> {
    let text = to_text(r);
    let json = serde_json::to_string_pretty(r).expect("the report serialises");
    let html = to_html(r)?;
    std::fs::create_dir_all(dir).map_err(|source| TwinError::Io {
        context: format!("creating {}", dir.display()),
        source,
    })?;
    for (name, body) in [("gap.json", &json), ("gap.txt", &text), ("gap.html", &html)] {
        fom::output::write_atomic(&dir.join(name), |w| w.write_all(body.as_bytes()))?;
    }
    Ok(())
}
