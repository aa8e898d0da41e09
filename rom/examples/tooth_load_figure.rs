//! The side-gap study of seed paper "arc-tooth-synchronous-belt-recurdyn" (section IV, Figure 8)
//! on the shipped toothed drive `fom/configs/synchronous-arc.toml`: one 0.3 s run per side gap
//! (0.1, 0.2, 0.3 mm), the maximum tooth (flank) load against the paper's, the typical maximum
//! of steady running (the mean of every pass's peak), and the loaded flank's load through each
//! pulley's wrap against the angle turned since entering it, averaged over the passes.
//!
//! `cargo run --release -p beltwin-rom --example tooth_load_figure [OUT_DIR [SEGMENTS [CONFIG]]]`
//! (another toothed drive as CONFIG; SEGMENTS 0 keeps its own) writes
//! `OUT_DIR/tooth-load-vs-side-gap.csv` and `OUT_DIR/tooth-load-vs-angle.svg` (default
//! `studies/tooth-load/`, the study's folder: `studies/tooth-load/README.md`).

use fom::model::{DRIVEN, DRIVER};
use fom::{DriveConfig, RunOptions};
use rom::plot::{line_plot_svg, LineSpec};
use std::path::{Path, PathBuf};

/// Output steps of the paper's 0.3 s run ("the step is 100", section IV).
const PAPER_OUTPUT_STEPS: usize = 100;

/// The paper's maximum root loads, N, at side gaps 0.1, 0.2, 0.3 mm
/// (`shared/data/paper-tooth-load-vs-side-gap.csv`, from the seed paper's section IV).
const PAPER: [(f64, f64); 3] = [(0.1, 38.2), (0.2, 43.5), (0.3, 49.8)];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("studies/tooth-load"));
    let config = std::env::args()
        .nth(3)
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("fom/configs/synchronous-arc.toml"));
    let mut base = DriveConfig::from_file(&config)?.into_inner();
    match std::env::args()
        .nth(2)
        .map(|n| n.parse::<usize>())
        .transpose()?
    {
        Some(0) | None => {}
        Some(n) => base.belt.segments = n, // a resolution study
    }
    if base.contact.tooth.is_none() {
        return Err(format!(
            "{}: not a toothed drive (belt.kind = \"toothed\")",
            config.display()
        )
        .into());
    }
    let runs: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = PAPER
            .iter()
            .map(|&(gap_mm, _)| {
                let mut cfg = base.clone();
                cfg.contact
                    .tooth
                    .as_mut()
                    .expect("checked above")
                    .side_gap_m = gap_mm * 1e-3;
                s.spawn(move || fom::simulate(&cfg.check()?, RunOptions::default()))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("run thread"))
            .collect()
    });
    let mut csv = String::from(
        "side_gap_mm,max_flank_load_n,ratio_to_first,paper_max_tooth_load_n,paper_ratio,\
         pass_peak_mean_n,pass_peak_ratio_to_first,pass_peak_sd_n,passes,\
         sampled_max_mean_n,sampled_max_sd_n,sampled_max_largest_n,wall_s\n",
    );
    let mut lines = Vec::new();
    let mut first = None;
    let mut first_peak = None;
    for (k, (run, &(gap_mm, paper_n))) in runs.into_iter().zip(&PAPER).enumerate() {
        let run = run?;
        let rec = run
            .record::<fom::belt_kind::tooth_record::ToothRecord>()
            .expect("a toothed run records its teeth");
        let max_n = rec.max_flank_load_n();
        let first_n = *first.get_or_insert(max_n);
        // Steady running: the tooth-root load's peak of every tooth pass through either wrap
        // in the tooth-load window (after 0.2 s here; the surrogate's snapshot samples).
        let window_s = rec.window_start_s;
        let peaks = rec.window_pass_peaks_n();
        let (mean, var) = fom::stats::mean_and_variance(&peaks);
        let sampled = rec.sampled_max_per_tooth_n(PAPER_OUTPUT_STEPS);
        let (s_mean, s_var) = fom::stats::mean_and_variance(&sampled);
        let s_max = sampled.iter().copied().fold(0.0, f64::max);
        println!(
            "side gap {gap_mm} mm, the paper's statistic ({PAPER_OUTPUT_STEPS} output steps, per \
             tooth): mean over teeth \
             {s_mean:.2} +- {:.2} N, largest {s_max:.2} N",
            s_var.sqrt()
        );
        let first_pass = *first_peak.get_or_insert(mean);
        csv += &format!(
            "{gap_mm},{max_n:.3},{:.4},{paper_n},{:.4},{mean:.3},{:.4},{:.3},{},{s_mean:.3},{:.3},\
             {s_max:.3},{:.2}\n",
            max_n / first_n,
            paper_n / PAPER[0].1,
            mean / first_pass,
            var.sqrt(),
            peaks.len(),
            s_var.sqrt(),
            run.summary.wall_time_s
        );
        println!(
            "side gap {gap_mm} mm: max flank load {max_n:.2} N (ratio {:.3}; paper {paper_n} N, \
             ratio {:.3}); pass peaks after {window_s} s {mean:.2} +- {:.2} N over {} passes (ratio \
             {:.3}); wall {:.2} s",
            max_n / first_n,
            paper_n / PAPER[0].1,
            var.sqrt(),
            peaks.len(),
            mean / first_pass,
            run.summary.wall_time_s
        );
        // Each wrap begins where its tight or slack span arrives: the driver's at the upper
        // tangent point, the driven pulley's at the lower one. Loads of the loaded flank
        // (driver b, driven a) averaged over every pass in the window, in 2-degree bins.
        for (pulley, tangent, flank, name, dashed) in [
            (DRIVER, 3, 1, "driver, flank b", false),
            (DRIVEN, 1, 0, "driven, flank a", true),
        ] {
            let entry = run.model.path.tangent_points()[tangent];
            let c = run.model.pulleys[pulley].center_m;
            let entry_angle = (entry[1] - c[1]).atan2(entry[0] - c[0]);
            let profile = rec.mean_pass_profile(pulley, entry_angle, window_s, 2.0);
            lines.push(LineSpec {
                label: format!("{gap_mm} mm, {name}"),
                colour: k,
                dashed,
                points: profile.iter().map(|(a, l)| (*a, l[flank])).collect(),
            });
        }
    }
    std::fs::create_dir_all(&out)?;
    let csv_path = out.join("tooth-load-vs-side-gap.csv");
    fom::output::write_atomic(&csv_path, |w| w.write_all(csv.as_bytes()))?;
    let svg_path = out.join("tooth-load-vs-angle.svg");
    line_plot_svg(
        &svg_path,
        "Tooth load through the wrap, mean of the passes after 0.2 s (synchronous-arc.toml)",
        (
            "angle turned since entering the wrap (deg)",
            "tooth load (N)",
        ),
        &lines,
    )?;
    println!("wrote {} and {}", csv_path.display(), svg_path.display());
    Ok(())
}
