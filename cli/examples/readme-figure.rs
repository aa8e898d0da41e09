//! The README's figure: the shipped surrogate's steady slip distributions from a healthy belt to
//! a loose one. The centre distance is swept from 0.424 m down to 0.415 m in 1 mm steps at the
//! default friction, for the belt installed at the default 250 N and for one that has lost
//! tension (180 N, as the sample data set `examples/data/loose`). Each prediction is a box
//! (p25-p75, median, whiskers p05-p95) with its mean and the surrogate's 90 % interval of the
//! mean, over bands of `rom diagnose`'s looseness classes.
//!
//! `cargo run --release -p beltwin-cli --example readme-figure -- docs/img/slip-healthy-to-loose.svg`

use fom::DesignPoint;
use rom::plot::{box_chart_svg, BandSpec, BoxChart, BoxSpec, MeanSpec};
use rom::predict::{mean_interval90_pct, DEFAULT_SAMPLES};
use twin::diagnose::{healthy_slip_pct, CLASSES, CLASS_THRESHOLDS};

/// Installation tensions, N, and their legend entries: the default drive's, and a belt that has
/// lost tension (the sample data set `examples/data/loose`).
const TENSIONS: [(f64, &str); 2] = [
    (250.0, "installed at 250 N (as shipped)"),
    (180.0, "installed at 180 N (lost tension)"),
];
/// Band colours of the looseness classes, healthy to critical.
const BAND_RGB: [[u8; 3]; 5] = [
    [44, 140, 44],
    [170, 140, 0],
    [220, 110, 0],
    [200, 50, 30],
    [140, 0, 60],
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .ok_or("usage: readme-figure OUT.svg")?;
    let file = rom::shipped::slip_model()?;
    let s = &file.surrogate;
    let cfg = s.config()?;
    let (mut boxes, mut means) = (Vec::new(), Vec::new());
    for k in 0..10 {
        let d_m = 0.424 - 0.001 * k as f64;
        let category = format!("{d_m:.3}");
        for (tension_n, series) in TENSIONS {
            let q = DesignPoint::nominal_with(&cfg, Some(d_m), None, Some(tension_n));
            let p = rom::predict_distribution(s, &cfg, &q, DEFAULT_SAMPLES, false)?;
            let qs = p.quantiles_pct;
            println!(
                "d {category} m, {tension_n} N: mean {:.4} %, p05-p95 {:.4}-{:.4} %",
                p.mean_slip_pct, qs.p05, qs.p95
            );
            boxes.push(BoxSpec {
                category: category.clone(),
                series: series.into(),
                quantiles: [qs.p05, qs.p25, qs.p50, qs.p75, qs.p95],
            });
            means.push(MeanSpec {
                category: category.clone(),
                series: series.into(),
                mean: p.mean_slip_pct,
                interval90: mean_interval90_pct(p.mean_slip_pct, p.surrogate_std_pct),
            });
        }
    }
    // The classes are ratios to the slip of the belt as installed (twin::diagnose).
    let healthy = healthy_slip_pct(s, &cfg)?;
    let mut edges = vec![0.0];
    edges.extend(CLASS_THRESHOLDS.iter().map(|t| t * healthy));
    edges.push(f64::INFINITY);
    let bands: Vec<BandSpec> = (0..CLASSES.len())
        .map(|i| BandSpec {
            label: match i {
                0 => "healthy".to_string(),
                _ => format!("loose: {}", CLASSES[i]),
            },
            y: [edges[i], edges[i + 1]],
            rgb: BAND_RGB[i],
        })
        .collect();
    box_chart_svg(
        std::path::Path::new(&out),
        &BoxChart {
            title:
                "Steady slip from a healthy belt to a loose one (surrogate, friction 0.70 +-1 %)",
            x_desc: "centre distance (m): the motor moves towards the fan, the belt loosens",
            y_desc: "steady slip (%)",
            boxes: &boxes,
            means: &means,
            bands: &bands,
            means_label: "mean and its 90 % interval (surrogate)",
            size: Some((1000, 560)),
            label_font_px: Some(14),
        },
    )?;
    println!("wrote {out}");
    Ok(())
}
