//! What `diagnose` found, as text, JSON and box plots, written atomically into a report
//! directory.

use std::path::Path;

use crate::diagnose::LabelVerdict;
use crate::error::{Result, TwinError};

/// Readable table of the verdicts.
pub fn to_text(verdicts: &[LabelVerdict]) -> String {
    let mut t = String::from(
        "label  runs | measured slip % (mean, p05-p95) | d estimate (m) [90 %]          known d | \
         tension (N) [90 %]        | class (probability)\n",
    );
    for v in verdicts {
        match (&v.measured, &v.estimate, &v.cannot_diagnose) {
            (Some(m), Some(e), _) => {
                let p = e.class_probability;
                let known = v
                    .known_center_distance_m
                    .map_or("   -   ".to_string(), |d| format!("{d:.4}"));
                t += &format!(
                    "{:<6} {:>4} | {:7.4} ({:.4}-{:.4})        | {:.4} [{:.4}, {:.4}]  {known} | \
                     {:5.1} [{:5.1}, {:5.1}] | {} ({:.0} %; h {:.0} w {:.0} m {:.0} s {:.0} c {:.0})\n",
                    v.label,
                    v.runs,
                    m.mean_pct,
                    m.quantiles_pct[0],
                    m.quantiles_pct[4],
                    e.center_distance_m,
                    e.center_distance_90_m[0],
                    e.center_distance_90_m[1],
                    e.installation_tension_n,
                    e.installation_tension_90_n[0],
                    e.installation_tension_90_n[1],
                    e.class,
                    100.0 * p.iter().copied().fold(0.0, f64::max),
                    100.0 * p[0],
                    100.0 * p[1],
                    100.0 * p[2],
                    100.0 * p[3],
                    100.0 * p[4],
                );
            }
            (_, _, Some(why)) => {
                t += &format!("{:<6} {:>4} | cannot diagnose: {why}\n", v.label, v.runs)
            }
            _ => {}
        }
        for f in &v.misfit {
            t += &format!("       {} misfit: {f}\n", v.label);
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
