//! What `diagnose` found, as text, JSON and box plots, written atomically into a report
//! directory.

use std::path::Path;

use crate::diagnose::LabelVerdict;
use crate::error::{Result, TwinError};

/// The table's column heads after "label  runs".
const HEADS: [&str; 5] = [
    "measured slip % (mean, p05-p95)",
    "d estimate (m) [90 %]",
    "known d",
    "tension (N) [90 %]",
    "class (probability)",
];

/// Readable table of the verdicts, each column as wide as its head or its widest cell.
pub fn to_text(verdicts: &[LabelVerdict]) -> String {
    // Per label: its cells (none where it cannot be diagnosed), then the lines under it.
    let mut rows: Vec<(String, Option<[String; 5]>, Vec<String>)> = Vec::new();
    for v in verdicts {
        let first = format!("{:<6} {:>4}", v.label, v.runs);
        let mut under = Vec::new();
        let cells = match (&v.measured, &v.estimate, &v.cannot_diagnose) {
            (Some(m), Some(e), _) => {
                let p = e.class_probability;
                Some([
                    format!(
                        "{:7.4} ({:.4}-{:.4})",
                        m.mean_pct, m.quantiles_pct[0], m.quantiles_pct[4]
                    ),
                    format!(
                        "{:.4} [{:.4}, {:.4}]",
                        e.center_distance_m, e.center_distance_90_m[0], e.center_distance_90_m[1]
                    ),
                    v.known_center_distance_m
                        .map_or("-".to_string(), |d| format!("{d:.4}")),
                    format!(
                        "{:5.1} [{:5.1}, {:5.1}]",
                        e.installation_tension_n,
                        e.installation_tension_90_n[0],
                        e.installation_tension_90_n[1]
                    ),
                    format!(
                        "{} ({:.0} %; h {:.0} w {:.0} m {:.0} s {:.0} c {:.0})",
                        e.class,
                        100.0 * p.iter().copied().fold(0.0, f64::max),
                        100.0 * p[0],
                        100.0 * p[1],
                        100.0 * p[2],
                        100.0 * p[3],
                        100.0 * p[4],
                    ),
                ])
            }
            (_, _, Some(why)) => {
                under.push(format!("{first} | cannot diagnose: {why}"));
                None
            }
            _ => None,
        };
        for f in v.measured.iter().flat_map(|m| &m.settling) {
            under.push(format!(
                "       {} still settling: {} extrapolated from {:.2}-{:.2} s (time constant \
                 {:.2} s) to {:.3} % [{:.3}, {:.3}]; {:.3} % over its last second",
                v.label,
                f.file,
                f.fit_from_s,
                f.fit_to_s,
                f.time_constant_s,
                f.steady_pct,
                f.steady_90_pct[0],
                f.steady_90_pct[1],
                f.last_window_pct
            ));
        }
        for f in v.measured.iter().flat_map(|m| &m.drifting) {
            under.push(format!(
                "       {} still drifting: {} changed {:+.3} pp between the halves of {:.2}-{:.2} \
                 s, less than the finest class step ({:.3} pp); the mean's standard error \
                 includes {:.3} pp for where a settle as slow as the window would end",
                v.label, f.file, f.drift_pp, f.from_s, f.to_s, f.small_drift_pp, f.offset_pp
            ));
        }
        for f in &v.misfit {
            under.push(format!("       {} misfit: {f}", v.label));
        }
        rows.push((first, cells, under));
    }
    let mut widths = HEADS.map(str::len);
    for cells in rows.iter().filter_map(|r| r.1.as_ref()) {
        for (w, c) in widths.iter_mut().zip(cells) {
            *w = (*w).max(c.len());
        }
    }
    let line = |first: &str, cells: [&str; 5]| {
        let [slip, d, known, tension, class] = cells;
        let [ws, wd, wk, wt, _] = widths;
        format!("{first} | {slip:<ws$} | {d:<wd$} {known:>wk$} | {tension:<wt$} | {class}\n")
    };
    let mut t = line("label  runs", HEADS);
    for (first, cells, under) in &rows {
        if let Some(c) = cells {
            t += &line(first, c.each_ref().map(String::as_str));
        }
        for u in under {
            t += u;
            t += "\n";
        }
    }
    if verdicts.iter().any(|v| !v.misfit.is_empty()) {
        t += "what the model misses: `rom gap --measured DIR`\n";
    }
    t
}

/// Writes `diagnosis.txt`, `diagnosis.json` and (when any label was diagnosed)
/// `slip-boxplots.svg` (measured and twin distributions per label) into `dir`.
pub fn write_diagnosis_report(dir: &Path, verdicts: &[LabelVerdict]) -> Result<()> {
    let text = to_text(verdicts);
    let json = serde_json::to_string_pretty(verdicts).expect("verdicts serialise");
    let mut boxes = Vec::new();
    for v in verdicts {
        if let (Some(m), Some(e)) = (&v.measured, &v.estimate) {
            boxes.push(rom::plot::BoxSpec {
                category: v.label.clone(),
                series: "measured".into(),
                quantiles: m.quantiles_pct,
            });
            boxes.push(rom::plot::BoxSpec {
                category: v.label.clone(),
                series: "twin".into(),
                quantiles: e.twin_quantiles_pct,
            });
        }
    }
    std::fs::create_dir_all(dir).map_err(|source| TwinError::Io {
        context: format!("creating {}", dir.display()),
        source,
    })?;
    if !boxes.is_empty() {
        rom::plot::box_plot_svg(
            &dir.join("slip-boxplots.svg"),
            "Steady slip: measured and twin",
            &boxes,
        )?;
    }
    fom::output::write_atomic(&dir.join("diagnosis.json"), |w| {
        w.write_all(json.as_bytes())
    })?;
    fom::output::write_atomic(&dir.join("diagnosis.txt"), |w| w.write_all(text.as_bytes()))?;
    Ok(())
}
