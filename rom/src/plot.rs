//! Box plots of slip distributions as SVG (plotters), like the seed paper's Figure 6: boxes
//! from the 25th to the 75th percentile, a line at the median, whiskers to the 5th and 95th.

use std::path::Path;

use plotters::prelude::*;

use crate::RomError;

/// One box: its category (x position), its series (colour, side by side within a category)
/// and the quantiles p05, p25, p50, p75, p95.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxSpec {
    pub category: String,
    pub series: String,
    pub quantiles: [f64; 5],
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
];

/// Draws the boxes and writes the SVG atomically.
pub fn box_plot_svg(path: &Path, title: &str, boxes: &[BoxSpec]) -> Result<(), RomError> {
    let err = |e: String| RomError::Data(format!("drawing {}: {e}", path.display()));
    let mut categories: Vec<&str> = Vec::new();
    let mut series: Vec<&str> = Vec::new();
    for b in boxes {
        if !categories.contains(&b.category.as_str()) {
            categories.push(&b.category);
        }
        if !series.contains(&b.series.as_str()) {
            series.push(&b.series);
        }
    }
    if boxes.is_empty()
        || boxes
            .iter()
            .any(|b| b.quantiles.iter().any(|v| !v.is_finite()))
    {
        return Err(err("nothing finite to plot".into()));
    }
    let lo = boxes
        .iter()
        .map(|b| b.quantiles[0])
        .fold(f64::INFINITY, f64::min);
    let hi = boxes
        .iter()
        .map(|b| b.quantiles[4])
        .fold(f64::NEG_INFINITY, f64::max);
    let pad = 0.1 * (hi - lo).max(0.05);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (200 + 110 * categories.len() as u32, 480))
            .into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = builder(&root, title)
            .build_cartesian_2d(-0.5..categories.len() as f64 - 0.5, (lo - pad)..(hi + pad))
            .map_err(|e| err(e.to_string()))?;
        let cats = categories.clone();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(categories.len() + 1)
            .x_label_formatter(&move |x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < cats.len() {
                    cats[i as usize].to_string()
                } else {
                    String::new()
                }
            })
            .y_desc("slip (%)")
            .draw()
            .map_err(|e| err(e.to_string()))?;
        let width = 0.7 / series.len() as f64;
        for (si, sname) in series.iter().enumerate() {
            let colour = COLOURS[si % COLOURS.len()];
            let mine: Vec<&BoxSpec> = boxes.iter().filter(|b| b.series == *sname).collect();
            let mut shapes: Vec<PathElement<(f64, f64)>> = Vec::new();
            for b in &mine {
                let ci = categories
                    .iter()
                    .position(|c| *c == b.category)
                    .unwrap_or(0) as f64;
                let x0 = ci - 0.35 + si as f64 * width + 0.1 * width;
                let x1 = x0 + 0.8 * width;
                let xm = 0.5 * (x0 + x1);
                let [p05, p25, p50, p75, p95] = b.quantiles;
                let style = colour.stroke_width(2);
                shapes.push(PathElement::new(
                    vec![(x0, p25), (x1, p25), (x1, p75), (x0, p75), (x0, p25)],
                    style,
                ));
                shapes.push(PathElement::new(vec![(x0, p50), (x1, p50)], style));
                shapes.push(PathElement::new(vec![(xm, p75), (xm, p95)], style));
                shapes.push(PathElement::new(vec![(xm, p25), (xm, p05)], style));
                let (w0, w1) = (xm - 0.2 * width, xm + 0.2 * width);
                shapes.push(PathElement::new(vec![(w0, p95), (w1, p95)], style));
                shapes.push(PathElement::new(vec![(w0, p05), (w1, p05)], style));
            }
            chart
                .draw_series(shapes)
                .map_err(|e| err(e.to_string()))?
                .label(*sname)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled())
                });
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(err)?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    fom::output::write_atomic(path, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}

/// A chart on `root` with the caption `title` and the margins and label areas of every plot
/// here.
fn builder<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    title: &str,
) -> ChartBuilder<'a, 'b, SVGBackend<'b>> {
    let mut b = ChartBuilder::on(root);
    b.caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60);
    b
}

/// Draws the series labels of `chart` in a white, framed box at `position`.
fn legend<'a, X: Ranged, Y: Ranged>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// One line of a line plot: its label, its colour index (series of one colour share it) and
/// whether it is dashed, and its points.
#[derive(Debug, Clone, PartialEq)]
pub struct LineSpec {
    pub label: String,
    pub colour: usize,
    pub dashed: bool,
    pub points: Vec<(f64, f64)>,
}

/// Draws lines against a common x axis and writes the SVG atomically.
pub fn line_plot_svg(
    path: &Path,
    title: &str,
    (x_desc, y_desc): (&str, &str),
    lines: &[LineSpec],
) -> Result<(), RomError> {
    let err = |e: String| RomError::Data(format!("drawing {}: {e}", path.display()));
    let finite = lines
        .iter()
        .flat_map(|l| &l.points)
        .filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for &(x, y) in finite {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
        return Err(err("nothing finite to plot".into()));
    }
    let y1 = 1.1 * y1.max(1e-9);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = builder(&root, title)
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for l in lines {
            let colour = COLOURS[l.colour % COLOURS.len()];
            let style = colour.stroke_width(2);
            let pts = l.points.iter().copied().filter(|p| p.1.is_finite());
            let series = if l.dashed {
                chart.draw_series(DashedLineSeries::new(pts, 6, 4, style))
            } else {
                chart.draw_series(LineSeries::new(pts, style))
            };
            let dashed = l.dashed;
            series
                .map_err(|e| err(e.to_string()))?
                .label(l.label.as_str())
                .legend(move |(x, y)| {
                    if dashed {
                        PathElement::new(vec![(x, y), (x + 6, y), (x + 9, y), (x + 14, y)], style)
                    } else {
                        PathElement::new(vec![(x, y), (x + 14, y)], style)
                    }
                });
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(err)?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    fom::output::write_atomic(path, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}
