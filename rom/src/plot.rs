//! Box plots of slip distributions as SVG (plotters), like the seed paper's Figure 6: boxes
//! from the 25th to the 75th percentile, a line at the median, whiskers to the 5th and 95th.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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

/// A mean with its 90 % interval, drawn as a black dot and bar on the box of the same category
/// and series.
#[derive(Debug, Clone, PartialEq)]
pub struct MeanSpec {
    pub category: String,
    pub series: String,
    pub mean: f64,
    pub interval90: [f64; 2],
}

/// A horizontal band of the y axis, shaded in `rgb` and labelled at the plot's right edge.
#[derive(Debug, Clone, PartialEq)]
pub struct BandSpec {
    pub label: String,
    pub y: [f64; 2],
    pub rgb: [u8; 3],
}

/// A box chart: boxes by category and series, optionally the means with their intervals and
/// shaded bands behind them. The y range is the boxes' whiskers and means' intervals, padded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxChart<'a> {
    pub title: &'a str,
    /// The x axis's description; empty for none.
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub boxes: &'a [BoxSpec],
    pub means: &'a [MeanSpec],
    pub bands: &'a [BandSpec],
    /// The legend's entry for the means.
    pub means_label: &'a str,
    /// Width and height in pixels; `None`: 110 pixels per category and 480.
    pub size: Option<(u32, u32)>,
    /// The axis labels' font size in pixels; `None`: plotters' default.
    pub label_font_px: Option<u32>,
}

/// Draws the boxes and writes the SVG atomically.
pub fn box_plot_svg(path: &Path, title: &str, boxes: &[BoxSpec]) -> Result<(), RomError> {
    box_chart_svg(
        path,
        &BoxChart {
            title,
            x_desc: "",
            y_desc: "slip (%)",
            boxes,
            means: &[],
            bands: &[],
            means_label: "",
            size: None,
            label_font_px: None,
        },
    )
}

/// Draws a box chart and writes the SVG atomically.
pub fn box_chart_svg(path: &Path, c: &BoxChart) -> Result<(), RomError> {
    let err = |e: String| RomError::Data(format!("drawing {}: {e}", path.display()));
    let svg = box_chart_string(c).map_err(err)?;
    fom::output::write_atomic(path, |w| w.write_all(svg.as_bytes()))?;
    Ok(())
}

/// The distinct values of `key` over `boxes`, in order of first appearance.
fn distinct<'a>(boxes: &'a [BoxSpec], key: impl Fn(&'a BoxSpec) -> &'a str) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for b in boxes {
        if !out.contains(&key(b)) {
            out.push(key(b));
        }
    }
    out
}

/// The SVG text of a box chart.
fn box_chart_string(c: &BoxChart) -> Result<String, String> {
    let categories = distinct(c.boxes, |b| b.category.as_str());
    let series = distinct(c.boxes, |b| b.series.as_str());
    let values = c
        .boxes
        .iter()
        .flat_map(|b| b.quantiles)
        .chain(c.means.iter().flat_map(|m| m.interval90));
    if c.boxes.is_empty() || values.clone().any(|v| !v.is_finite()) {
        return Err("nothing finite to plot".into());
    }
    let lo = values.clone().fold(f64::INFINITY, f64::min);
    let hi = values.fold(f64::NEG_INFINITY, f64::max);
    let pad = 0.1 * (hi - lo).max(0.05);
    let (y0, y1) = (lo - pad, hi + pad);
    let size = c.size.unwrap_or((200 + 110 * categories.len() as u32, 480));
    let slot = |category: &str, series_name: &str| {
        let ci = categories.iter().position(|x| *x == category).unwrap_or(0) as f64;
        let si = series.iter().position(|x| *x == series_name).unwrap_or(0) as f64;
        let width = 0.7 / series.len() as f64;
        let x0 = ci - 0.35 + si * width + 0.1 * width;
        (x0, x0 + 0.8 * width, width)
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = builder(&root, c.title)
            .build_cartesian_2d(-0.5..categories.len() as f64 - 0.5, y0..y1)
            .map_err(|e| e.to_string())?;
        let cats = categories.clone();
        let label = move |x: &f64| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < cats.len() {
                cats[i as usize].to_string()
            } else {
                String::new()
            }
        };
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh()
            .x_labels(categories.len() + 1)
            .x_label_formatter(&label)
            .y_desc(c.y_desc);
        if !c.x_desc.is_empty() {
            mesh.x_desc(c.x_desc);
        }
        if !c.bands.is_empty() {
            // The bands mark the y values; the fine grid lines would stripe them.
            mesh.light_line_style(TRANSPARENT);
        }
        if let Some(px) = c.label_font_px {
            mesh.label_style(("sans-serif", px))
                .axis_desc_style(("sans-serif", px + 1));
        }
        mesh.draw().map_err(|e| e.to_string())?;
        draw_bands(&mut chart, c.bands, (categories.len() as f64 - 0.5, y0, y1))?;
        for (si, sname) in series.iter().enumerate() {
            let colour = COLOURS[si % COLOURS.len()];
            let mine = c.boxes.iter().filter(|b| b.series == *sname);
            let shapes = mine.flat_map(|b| box_shapes(b, slot(&b.category, sname), colour));
            chart
                .draw_series(shapes.collect::<Vec<_>>())
                .map_err(|e| e.to_string())?
                .label(*sname)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled())
                });
        }
        if !c.means.is_empty() {
            let mut bars = Vec::new();
            let mut dots = Vec::new();
            for m in c.means {
                let (x0, x1, _) = slot(&m.category, &m.series);
                let (x, cap) = (0.5 * (x0 + x1), 0.15 * (x1 - x0));
                let [lo, hi] = m.interval90;
                let style = BLACK.stroke_width(2);
                bars.push(PathElement::new(vec![(x, lo), (x, hi)], style));
                bars.push(PathElement::new(vec![(x - cap, lo), (x + cap, lo)], style));
                bars.push(PathElement::new(vec![(x - cap, hi), (x + cap, hi)], style));
                dots.push(Circle::new((x, m.mean), 3, BLACK.filled()));
            }
            chart.draw_series(bars).map_err(|e| e.to_string())?;
            chart
                .draw_series(dots)
                .map_err(|e| e.to_string())?
                .label(c.means_label)
                .legend(|(x, y)| Circle::new((x + 6, y), 4, BLACK.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// The lines of one box (p25-p75 box, median, whiskers to p05 and p95 with caps) in the slot
/// (x0, x1, slot width) of its category and series.
fn box_shapes(
    b: &BoxSpec,
    (x0, x1, width): (f64, f64, f64),
    colour: RGBColor,
) -> Vec<PathElement<(f64, f64)>> {
    let xm = 0.5 * (x0 + x1);
    let [p05, p25, p50, p75, p95] = b.quantiles;
    let style = colour.stroke_width(2);
    let (w0, w1) = (xm - 0.2 * width, xm + 0.2 * width);
    vec![
        PathElement::new(
            vec![(x0, p25), (x1, p25), (x1, p75), (x0, p75), (x0, p25)],
            style,
        ),
        PathElement::new(vec![(x0, p50), (x1, p50)], style),
        PathElement::new(vec![(xm, p75), (xm, p95)], style),
        PathElement::new(vec![(xm, p25), (xm, p05)], style),
        PathElement::new(vec![(w0, p95), (w1, p95)], style),
        PathElement::new(vec![(w0, p05), (w1, p05)], style),
    ]
}

/// Shades each band of y (clipped to y0..y1) over the plot's width up to `x_end`, and writes its
/// label at the left edge, centred in the visible part.
fn draw_bands<'a>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    bands: &[BandSpec],
    (x_end, y0, y1): (f64, f64, f64),
) -> Result<(), String> {
    for b in bands {
        let (lo, hi) = (b.y[0].max(y0), b.y[1].min(y1));
        if lo >= hi {
            continue;
        }
        let [r, g, bl] = b.rgb;
        let colour = RGBColor(r, g, bl);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(-0.5, lo), (x_end, hi)],
                colour.mix(0.25).filled(),
            )))
            .map_err(|e| e.to_string())?;
        let style = TextStyle::from(("sans-serif", 14).into_font())
            .color(&colour)
            .pos(Pos::new(HPos::Left, VPos::Center));
        chart
            .draw_series(std::iter::once(Text::new(
                b.label.clone(),
                (-0.45, 0.5 * (lo + hi)),
                style,
            )))
            .map_err(|e| e.to_string())?;
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn chart<'a>(
        boxes: &'a [BoxSpec],
        means: &'a [MeanSpec],
        bands: &'a [BandSpec],
    ) -> BoxChart<'a> {
        BoxChart {
            title: "t",
            x_desc: "centre distance (m)",
            y_desc: "slip (%)",
            boxes,
            means,
            bands,
            means_label: "mean and its 90 % interval",
            size: None,
            label_font_px: Some(14),
        }
    }

    #[test]
    fn a_chart_draws_its_bands_means_and_axis_descriptions() {
        let boxes = [BoxSpec {
            category: "0.420".into(),
            series: "250 N".into(),
            quantiles: [0.68, 0.685, 0.69, 0.70, 0.71],
        }];
        let means = [MeanSpec {
            category: "0.420".into(),
            series: "250 N".into(),
            mean: 0.692,
            interval90: [0.685, 0.699],
        }];
        let bands = [
            BandSpec {
                label: "healthy".into(),
                y: [0.0, 0.7],
                rgb: [0, 128, 0],
            },
            BandSpec {
                label: "out of view".into(),
                y: [5.0, 6.0],
                rgb: [128, 0, 0],
            },
        ];
        let svg = box_chart_string(&chart(&boxes, &means, &bands)).unwrap();
        for text in [
            "healthy",
            "mean and its 90 % interval",
            "250 N",
            "centre distance (m)",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert!(
            !svg.contains("out of view"),
            "a band outside the y range is drawn"
        );
        assert!(svg.contains("<circle"), "no mean drawn");
    }

    #[test]
    fn a_chart_without_boxes_or_with_a_non_finite_interval_is_refused() {
        assert!(box_chart_string(&chart(&[], &[], &[])).is_err());
        let boxes = [BoxSpec {
            category: "a".into(),
            series: "s".into(),
            quantiles: [1.0, 2.0, 3.0, 4.0, 5.0],
        }];
        let means = [MeanSpec {
            category: "a".into(),
            series: "s".into(),
            mean: 3.0,
            interval90: [f64::NAN, 4.0],
        }];
        assert!(box_chart_string(&chart(&boxes, &means, &[])).is_err());
        assert!(box_chart_string(&chart(&boxes, &[], &[])).is_ok());
    }
}
