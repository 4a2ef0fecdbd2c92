//! Figures as SVG text, drawn with `plotters` (no system fonts needed):
//! one look for every figure — white background, round tick values,
//! side-by-side panels, legends in a corner that keeps clear of the data.
//!
//! ```
//! use tandem::figures::{Panel, Series, render_panels};
//! let path: Vec<(f64, f64)> = (0..20).map(|i| (0.01 * i as f64, 0.3 + 0.005 * i as f64)).collect();
//! let top = Panel::new("top view", "x (m)", "y (m)").with(Series::line("gripper", &path, 0));
//! let svg = render_panels("an episode", &[top], 480, 400).unwrap();
//! assert!(svg.contains("<svg") && svg.contains("gripper"));
//! ```

use plotters::coord::Shift;
use plotters::prelude::*;

/// The colour cycle of every figure (Tableau 10).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// What a series draws.
#[derive(Debug, Clone, PartialEq)]
pub enum SeriesKind {
    /// A solid polyline.
    Line,
    /// A dashed polyline.
    Dashed,
    /// Markers.
    Points,
    /// Circles of the given radius (data units) at the points.
    Circles(f64),
    /// Ellipses: each point carries a 2 × 2 symmetric matrix (column-major)
    /// whose eigenvectors scaled by the eigenvalues are the half-axes.
    Ellipses(Vec<[f64; 4]>),
}

/// One labelled series of points in data coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (none when `None`).
    pub label: Option<String>,
    /// Points in data coordinates.
    pub points: Vec<(f64, f64)>,
    /// Index into [`PALETTE`].
    pub color: usize,
    /// How the points are drawn.
    pub kind: SeriesKind,
}

impl Series {
    /// A solid polyline.
    pub fn line(label: &str, points: &[(f64, f64)], color: usize) -> Series {
        Series { label: Some(label.into()), points: points.to_vec(), color, kind: SeriesKind::Line }
    }

    /// A dashed polyline.
    pub fn dashed(label: &str, points: &[(f64, f64)], color: usize) -> Series {
        Series { label: Some(label.into()), points: points.to_vec(), color, kind: SeriesKind::Dashed }
    }

    /// Markers.
    pub fn points(label: &str, points: &[(f64, f64)], color: usize) -> Series {
        Series { label: Some(label.into()), points: points.to_vec(), color, kind: SeriesKind::Points }
    }

    /// Unlabelled series (no legend entry).
    pub fn unlabelled(mut self) -> Series {
        self.label = None;
        self
    }
}

/// One panel: a title, axis labels, series, and optionally fixed ranges
/// and equal axis scales.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Panel title.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// What the panel shows.
    pub series: Vec<Series>,
    /// Fixed x range (data bounds when `None`).
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (data bounds when `None`).
    pub y_range: Option<(f64, f64)>,
    /// Same metres per pixel on both axes (workspace views).
    pub equal_axes: bool,
}

impl Panel {
    /// An empty panel.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Panel {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: vec![],
            x_range: None,
            y_range: None,
            equal_axes: false,
        }
    }

    /// Adds a series.
    pub fn with(mut self, series: Series) -> Panel {
        self.series.push(series);
        self
    }

    /// Fixes the axis ranges.
    pub fn ranges(mut self, x: (f64, f64), y: (f64, f64)) -> Panel {
        self.x_range = Some(x);
        self.y_range = Some(y);
        self
    }

    /// Equal scales on both axes.
    pub fn equal(mut self) -> Panel {
        self.equal_axes = true;
        self
    }

    /// Data bounds of every series, padded by 5 % (a unit box when empty).
    fn bounds(&self) -> ((f64, f64), (f64, f64)) {
        let mut b = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            let reach = match &s.kind {
                SeriesKind::Circles(r) => *r,
                _ => 0.0,
            };
            for (k, &(x, y)) in s.points.iter().enumerate() {
                let r = match &s.kind {
                    SeriesKind::Ellipses(m) => m.get(k).map_or(0.0, |m| m[0].abs().max(m[3].abs()) + m[1].abs()),
                    _ => reach,
                };
                if x.is_finite() && y.is_finite() {
                    b = (b.0.min(x - r), b.1.max(x + r), b.2.min(y - r), b.3.max(y + r));
                }
            }
        }
        if !b.0.is_finite() {
            return ((0.0, 1.0), (0.0, 1.0));
        }
        let pad = |lo: f64, hi: f64| {
            let span = (hi - lo).max(1e-6);
            (lo - 0.05 * span, hi + 0.05 * span)
        };
        (self.x_range.unwrap_or_else(|| pad(b.0, b.1)), self.y_range.unwrap_or_else(|| pad(b.2, b.3)))
    }
}

/// Why a figure could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the figure: {0}")]
pub struct FigureError(String);

/// Renders `panels` side by side under `title` into SVG text, each panel
/// `panel_width × height` pixels.
///
/// # Errors
/// A drawing error of the backend (none expected for finite data).
pub fn render_panels(title: &str, panels: &[Panel], panel_width: u32, height: u32) -> Result<String, FigureError> {
    let mut svg = String::new();
    {
        let width = panel_width * panels.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 18)).map_err(err)?;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (panel, area) in panels.iter().zip(areas) {
            draw_panel(panel, &area)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn err(e: impl std::fmt::Display) -> FigureError {
    FigureError(e.to_string())
}

fn draw_panel(panel: &Panel, area: &DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), FigureError> {
    let ((mut x0, mut x1), (mut y0, mut y1)) = panel.bounds();
    if panel.equal_axes {
        // Widen the shorter span so both axes have the same scale.
        let (w, h) = area.dim_in_pixel();
        let (pw, ph) = (f64::from(w.saturating_sub(70)).max(1.0), f64::from(h.saturating_sub(80)).max(1.0));
        let scale = ((x1 - x0) / pw).max((y1 - y0) / ph);
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        (x0, x1, y0, y1) = (cx - scale * pw / 2.0, cx + scale * pw / 2.0, cy - scale * ph / 2.0, cy + scale * ph / 2.0);
    }
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_labels(6)
        .y_labels(6)
        .light_line_style(WHITE.mix(0.0))
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(err)?;
    let mut labelled = false;
    for s in &panel.series {
        let color = PALETTE[s.color % PALETTE.len()];
        let style = ShapeStyle::from(&color).stroke_width(2);
        let anno = match &s.kind {
            SeriesKind::Line => chart.draw_series(LineSeries::new(s.points.iter().copied(), style)).map_err(err)?,
            SeriesKind::Dashed => {
                chart.draw_series(DashedLineSeries::new(s.points.iter().copied(), 6, 4, style)).map_err(err)?
            }
            SeriesKind::Points => {
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 4, color.filled()))).map_err(err)?
            }
            SeriesKind::Circles(r) => chart
                .draw_series(
                    s.points
                        .iter()
                        .map(|&(x, y)| Polygon::new(circle_points(x, y, *r, *r, 0.0), color.mix(0.35).filled())),
                )
                .map_err(err)?,
            SeriesKind::Ellipses(matrices) => chart
                .draw_series(s.points.iter().zip(matrices).map(|(&(x, y), m)| {
                    let (a, b, angle) = ellipse_axes(m);
                    PathElement::new(closed(circle_points(x, y, a, b, angle)), style)
                }))
                .map_err(err)?,
        };
        if let Some(label) = &s.label {
            labelled = true;
            anno.label(label.as_str()).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .position(emptiest_corner(panel, (x0, x1), (y0, y1)))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

/// The legend corner whose quarter of the panel holds the fewest points.
fn emptiest_corner(panel: &Panel, (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> SeriesLabelPosition {
    let (xm, ym) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let mut counts = [0usize; 4]; // upper right, upper left, lower right, lower left
    for s in &panel.series {
        for &(x, y) in &s.points {
            counts[usize::from(x < xm) + 2 * usize::from(y < ym)] += 1;
        }
    }
    match (0..4).min_by_key(|&k| counts[k]).unwrap_or(0) {
        0 => SeriesLabelPosition::UpperRight,
        1 => SeriesLabelPosition::UpperLeft,
        2 => SeriesLabelPosition::LowerRight,
        _ => SeriesLabelPosition::LowerLeft,
    }
}

fn closed(mut points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if let Some(&first) = points.first() {
        points.push(first);
    }
    points
}

/// Points of the ellipse with half-axes `a` (along `angle`) and `b`.
fn circle_points(x: f64, y: f64, a: f64, b: f64, angle: f64) -> Vec<(f64, f64)> {
    let (s, c) = angle.sin_cos();
    (0..32)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / 32.0;
            let (u, v) = (a * t.cos(), b * t.sin());
            (x + c * u - s * v, y + s * u + c * v)
        })
        .collect()
}

/// Half-axes and angle of the ellipse of a symmetric 2 × 2 matrix
/// (eigenvalues as lengths along the eigenvectors).
fn ellipse_axes(m: &[f64; 4]) -> (f64, f64, f64) {
    let (p, q, r) = (m[0], 0.5 * (m[1] + m[2]), m[3]);
    let mean = 0.5 * (p + r);
    let spread = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    let angle = 0.5 * (2.0 * q).atan2(p - r);
    ((mean + spread).max(0.0), (mean - spread).max(0.0), angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_axes_of_rotated_matrices() {
        let (a, b, angle) = ellipse_axes(&[2.0, 0.0, 0.0, 1.0]);
        assert!((a - 2.0).abs() < 1e-12 && (b - 1.0).abs() < 1e-12 && angle.abs() < 1e-12);
        // R diag(3, 1) Rᵀ with R a rotation by 30°.
        let t = 30f64.to_radians();
        let (c, s) = (t.cos(), t.sin());
        let m = [3.0 * c * c + s * s, 2.0 * c * s, 2.0 * c * s, 3.0 * s * s + c * c];
        let (a, b, angle) = ellipse_axes(&m);
        assert!((a - 3.0).abs() < 1e-12 && (b - 1.0).abs() < 1e-12 && (angle - t).abs() < 1e-12);
    }

    #[test]
    fn panels_render_with_legends_and_equal_axes() {
        let line = Series::line("path", &[(0.0, 0.0), (1.0, 0.5)], 0);
        let e = Series {
            label: Some("metric".into()),
            points: vec![(0.5, 0.25)],
            color: 1,
            kind: SeriesKind::Ellipses(vec![[0.1, 0.0, 0.0, 0.05]]),
        };
        let svg = render_panels(
            "t",
            &[Panel::new("a", "x", "y").with(line).equal(), Panel::new("b", "x", "y").with(e)],
            400,
            300,
        )
        .unwrap();
        assert!(svg.contains("path") && svg.contains("metric") && svg.matches("<svg").count() == 1);
    }
}
