//! Figures as SVG text, drawn with `plotters` (no system fonts needed), in
//! one style for every figure tandem writes:
//!
//! - one colour per series ([`PALETTE`], ten), never reused for scene
//!   objects, which are drawn in [`Color::Scene`] grey, nor for references
//!   ([`Color::Reference`], black);
//! - one legend for the whole figure, below the panels, never over the
//!   data; its swatches draw what the series draws (a solid or a dashed
//!   line, the marker, a patch);
//! - axes fitted to the data (equal scales only where that does not leave
//!   most of a panel empty); round tick values without `-0` or a needless
//!   `.0`; tick label areas sized to their labels, so axis titles never
//!   cover them;
//! - panels meant for comparison share their axes ([`share_x`], [`share_y`]);
//! - categorical axes name their categories ([`Panel::categories`]).
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
// `Color` below names tandem's colour choice; plotters' trait stays usable.
use plotters::style::Color as _;
use plotters::style::text_anchor::{HPos, Pos, VPos};

mod legend;
mod shapes;

use legend::{draw_legend, legend_entries, legend_layout};
use shapes::{arrow, circle_points, closed, convex_hull, ellipse_axes};

/// The colour cycle of every figure's series (Tableau 10).
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(188, 189, 34),
    RGBColor(127, 127, 127),
];

/// Grey of scene objects (obstacles, tables, boxes): no series uses it.
const SCENE: RGBColor = RGBColor(150, 150, 150);

/// A series' colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Color {
    /// [`PALETTE`]`[i % 10]`.
    Palette(usize),
    /// Scene objects: grey.
    Scene,
    /// References and targets: black.
    Reference,
}

impl From<usize> for Color {
    fn from(i: usize) -> Color {
        Color::Palette(i)
    }
}

impl Color {
    fn rgb(self) -> RGBColor {
        match self {
            Color::Palette(i) => PALETTE[i % PALETTE.len()],
            Color::Scene => SCENE,
            Color::Reference => BLACK,
        }
    }
}

/// A marker's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// A filled disc.
    Dot,
    /// A hollow ring.
    Ring,
    /// An upright cross (×).
    Cross,
    /// A filled square.
    Square,
    /// A filled upward triangle.
    Triangle,
    /// A filled diamond.
    Diamond,
}

/// What a series draws.
#[derive(Debug, Clone, PartialEq)]
pub enum SeriesKind {
    /// A solid polyline.
    Line,
    /// A dashed polyline.
    Dashed,
    /// Markers.
    Points(Marker),
    /// Filled discs of the given radius (data units) at the points.
    Circles(f64),
    /// Filled axis-aligned rectangles: each point is a corner, the vector
    /// at its index the opposite corner minus it (data units).
    Rectangles(Vec<(f64, f64)>),
    /// One filled polygon through the points (a scene object's outline).
    Polygon,
    /// Ellipses: each point carries a 2 × 2 symmetric matrix (column-major)
    /// whose eigenvectors scaled by the eigenvalues are the half-axes.
    Ellipses(Vec<[f64; 4]>),
    /// Arrows from each point by the vector (data units) at its index.
    Arrows(Vec<(f64, f64)>),
}

/// One labelled series of points in data coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (none when `None`).
    pub label: Option<String>,
    /// Points in data coordinates.
    pub points: Vec<(f64, f64)>,
    /// Its colour.
    pub color: Color,
    /// How the points are drawn.
    pub kind: SeriesKind,
}

impl Series {
    /// A solid polyline in palette colour `color`.
    pub fn line(label: &str, points: &[(f64, f64)], color: impl Into<Color>) -> Series {
        Series { label: Some(label.into()), points: points.to_vec(), color: color.into(), kind: SeriesKind::Line }
    }

    /// A dashed polyline.
    pub fn dashed(label: &str, points: &[(f64, f64)], color: impl Into<Color>) -> Series {
        Series { label: Some(label.into()), points: points.to_vec(), color: color.into(), kind: SeriesKind::Dashed }
    }

    /// Arrows from `points` by `vectors` (data units), unlabelled.
    pub fn arrows(points: &[(f64, f64)], vectors: &[(f64, f64)], color: impl Into<Color>) -> Series {
        let kind = SeriesKind::Arrows(vectors.to_vec());
        Series { label: None, points: points.to_vec(), color: color.into(), kind }
    }

    /// Dots.
    pub fn points(label: &str, points: &[(f64, f64)], color: impl Into<Color>) -> Series {
        Series::markers(label, points, color, Marker::Dot)
    }

    /// Markers of shape `marker`.
    pub fn markers(label: &str, points: &[(f64, f64)], color: impl Into<Color>, marker: Marker) -> Series {
        Series {
            label: Some(label.into()),
            points: points.to_vec(),
            color: color.into(),
            kind: SeriesKind::Points(marker),
        }
    }

    /// Scene discs (obstacles seen from above) of `radius` (m), grey.
    pub fn discs(label: &str, centres: &[(f64, f64)], radius: f64) -> Series {
        let kind = SeriesKind::Circles(radius);
        Series { label: Some(label.into()), points: centres.to_vec(), color: Color::Scene, kind }
    }

    /// Scene rectangles (a table, a box seen from above), grey: each from
    /// its lower-left corner `(x, y)` with size `(w, h)`.
    pub fn boxes(label: &str, corners: &[(f64, f64)], sizes: &[(f64, f64)]) -> Series {
        let kind = SeriesKind::Rectangles(sizes.to_vec());
        Series { label: Some(label.into()), points: corners.to_vec(), color: Color::Scene, kind }
    }

    /// A scene object's outline seen along an axis, grey: the convex hull
    /// of `corners` (its corners projected onto the view).
    pub fn outline(label: &str, corners: &[(f64, f64)]) -> Series {
        Series {
            label: Some(label.into()),
            points: convex_hull(corners),
            color: Color::Scene,
            kind: SeriesKind::Polygon,
        }
    }

    /// The same series in another colour.
    pub fn colored(mut self, color: impl Into<Color>) -> Series {
        self.color = color.into();
        self
    }

    /// Unlabelled series (no legend entry).
    pub fn unlabelled(mut self) -> Series {
        self.label = None;
        self
    }
}

/// One panel: a title, axis labels, series, and optionally fixed ranges,
/// equal axis scales and category names on x.
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
    /// Same metres per pixel on both axes (workspace views), unless that
    /// would leave most of the panel empty.
    pub equal_axes: bool,
    /// Names of x = 0, 1, 2, …: a categorical x axis.
    pub categories: Vec<String>,
    /// x counts something (epochs, episodes): ticks on whole numbers only.
    pub integer_x: bool,
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
            categories: vec![],
            integer_x: false,
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

    /// Fixes the y range only.
    pub fn y_range(mut self, y: (f64, f64)) -> Panel {
        self.y_range = Some(y);
        self
    }

    /// Equal scales on both axes (when the data's shape allows it).
    pub fn equal(mut self) -> Panel {
        self.equal_axes = true;
        self
    }

    /// Ticks x on whole numbers only (x counts epochs, episodes, …).
    pub fn integer_x(mut self) -> Panel {
        self.integer_x = true;
        self
    }

    /// Names the x positions 0, 1, 2, … (the points' x are category indices).
    pub fn categories(mut self, names: &[&str]) -> Panel {
        self.categories = names.iter().map(|s| s.to_string()).collect();
        self
    }

    /// Data bounds of every series (unpadded), `None` without finite data.
    fn data_bounds(&self) -> Option<((f64, f64), (f64, f64))> {
        let mut b = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        let mut add = |x: f64, y: f64| {
            if x.is_finite() && y.is_finite() {
                b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
            }
        };
        for s in &self.series {
            for (k, &(x, y)) in s.points.iter().enumerate() {
                match &s.kind {
                    SeriesKind::Circles(r) => {
                        add(x - r, y - r);
                        add(x + r, y + r);
                    }
                    SeriesKind::Ellipses(m) => {
                        let r = m.get(k).map_or(0.0, |m| m[0].abs().max(m[3].abs()) + m[1].abs());
                        add(x - r, y - r);
                        add(x + r, y + r);
                    }
                    SeriesKind::Arrows(v) | SeriesKind::Rectangles(v) => {
                        add(x, y);
                        if let Some(v) = v.get(k) {
                            add(x + v.0, y + v.1);
                        }
                    }
                    _ => add(x, y),
                }
            }
        }
        b.0.is_finite().then_some(((b.0, b.1), (b.2, b.3)))
    }

    /// The ranges drawn: fixed ones, else the data's padded by 5 % (a unit
    /// box without data); a categorical x spans half a slot past its ends.
    fn bounds(&self) -> ((f64, f64), (f64, f64)) {
        let pad = |(lo, hi): (f64, f64)| {
            let span = (hi - lo).max(1e-6 * hi.abs().max(lo.abs()).max(1e-3));
            (lo - 0.05 * span, hi + 0.05 * span)
        };
        let data = self.data_bounds();
        let x = if !self.categories.is_empty() {
            (-0.5, self.categories.len() as f64 - 0.5)
        } else {
            self.x_range.unwrap_or_else(|| data.map_or((0.0, 1.0), |d| pad(d.0)))
        };
        let y = self.y_range.unwrap_or_else(|| data.map_or((0.0, 1.0), |d| pad(d.1)));
        (x, y)
    }
}

/// Gives every panel the x range that holds all of them.
pub fn share_x(panels: &mut [Panel]) {
    let ranges: Vec<(f64, f64)> = panels.iter().map(|p| p.bounds().0).collect();
    if let Some(range) = union(&ranges) {
        panels.iter_mut().for_each(|p| p.x_range = Some(range));
    }
}

/// Gives every panel the y range that holds all of them.
pub fn share_y(panels: &mut [Panel]) {
    let ranges: Vec<(f64, f64)> = panels.iter().map(|p| p.bounds().1).collect();
    if let Some(range) = union(&ranges) {
        panels.iter_mut().for_each(|p| p.y_range = Some(range));
    }
}

fn union(ranges: &[(f64, f64)]) -> Option<(f64, f64)> {
    let lo = ranges.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
    let hi = ranges.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// Why a figure could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the figure: {0}")]
pub struct FigureError(String);

/// Renders `panels` side by side under `title` into SVG text, each panel
/// `panel_width × height` pixels, with one legend below them.
///
/// # Errors
/// A drawing error of the backend (none expected for finite data).
pub fn render_panels(title: &str, panels: &[Panel], panel_width: u32, height: u32) -> Result<String, FigureError> {
    render_grid(title, &[panels.to_vec()], panel_width, height)
}

/// Renders rows of panels under `title` into SVG text, each panel
/// `panel_width × panel_height` pixels, with one legend below them (the
/// entries of every panel, each once).
///
/// # Errors
/// A drawing error of the backend (none expected for finite data).
pub fn render_grid(
    title: &str,
    rows: &[Vec<Panel>],
    panel_width: u32,
    panel_height: u32,
) -> Result<String, FigureError> {
    let columns = rows.iter().map(Vec::len).max().unwrap_or(1).max(1) as u32;
    let width = panel_width * columns;
    let entries = legend_entries(rows.iter().flatten());
    let legend_rows = legend_layout(&entries, width).len() as u32;
    let legend_height = if entries.is_empty() { 0 } else { 14 + 20 * legend_rows };
    let title_height = 34;
    let height = title_height + panel_height * rows.len().max(1) as u32 + legend_height;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (top, rest) = root.split_vertically(title_height);
        top.draw(&Text::new(
            title.to_string(),
            (width as i32 / 2, 10),
            TextStyle::from(("sans-serif", 18).into_font()).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(err)?;
        let (body, legend) = rest.split_vertically(panel_height * rows.len().max(1) as u32);
        let row_areas = body.split_evenly((rows.len().max(1), 1));
        for (row, row_area) in rows.iter().zip(row_areas) {
            let cells = row_area.split_by_breakpoints(
                (1..row.len()).map(|k| k as u32 * panel_width).collect::<Vec<_>>(),
                [] as [u32; 0],
            );
            for (panel, area) in row.iter().zip(cells) {
                draw_panel(panel, &area)?;
            }
        }
        if !entries.is_empty() {
            draw_legend(&legend, &entries, width)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn err(e: impl std::fmt::Display) -> FigureError {
    FigureError(e.to_string())
}

/// A tick value with as many decimals as the tick step needs: no `-0`, no
/// needless `.0`.
fn tick(value: f64, step: f64) -> String {
    let decimals = if step > 0.0 && step.is_finite() { (-step.log10().floor()).max(0.0) as usize } else { 3 };
    let text = format!("{value:.decimals$}");
    let text = if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text };
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') { "0".into() } else { text }
}

/// How many multiples of `step` lie within `range` (at least 2, at most 50).
fn ticks((lo, hi): (f64, f64), step: f64) -> usize {
    if !(step > 0.0 && lo.is_finite() && hi.is_finite()) {
        return 2;
    }
    (((hi / step + 1e-9).floor() - (lo / step - 1e-9).ceil()) as i64 + 1).clamp(2, 50) as usize
}

/// The 1-2-5 step nearest to `range / count`: about `count` round ticks.
fn tick_step((lo, hi): (f64, f64), count: usize) -> f64 {
    let raw = (hi - lo).abs() / count.max(1) as f64;
    if !(raw > 0.0 && raw.is_finite()) {
        return 1.0;
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    let f = raw / magnitude;
    magnitude
        * if f < 1.5 {
            1.0
        } else if f < 3.5 {
            2.0
        } else if f < 7.5 {
            5.0
        } else {
            10.0
        }
}

fn draw_panel(panel: &Panel, area: &DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), FigureError> {
    let ((mut x0, mut x1), (mut y0, mut y1)) = panel.bounds();
    let (w, h) = area.dim_in_pixel();
    // Tick labels decide the label areas (an axis title beside them).
    let y_step = tick_step((y0, y1), 5);
    let y_chars = [y0, y1, 0.5 * (y0 + y1)].iter().map(|v| tick(*v, y_step).len()).max().unwrap_or(1);
    let y_area = 30 + 7 * y_chars as u32;
    let x_area = if panel.categories.is_empty() { 40 } else { 52 };
    if panel.equal_axes && panel.categories.is_empty() {
        let (pw, ph) =
            (f64::from(w.saturating_sub(y_area + 20)).max(1.0), f64::from(h.saturating_sub(x_area + 40)).max(1.0));
        let scale = ((x1 - x0) / pw).max((y1 - y0) / ph);
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        // Equal scales only while the data fills at least a quarter of the
        // panel's width and height: a path in a 2 cm band over 30 cm is
        // better read fitted.
        if (x1 - x0) / (scale * pw) >= 0.25 && (y1 - y0) / (scale * ph) >= 0.25 {
            (x0, x1, y0, y1) =
                (cx - scale * pw / 2.0, cx + scale * pw / 2.0, cy - scale * ph / 2.0, cy + scale * ph / 2.0);
        }
    }
    // Steps from the final (equal-scaled) ranges. Plotters takes the finest
    // 1-2-5 step with at most the given count of ticks, so the count of our
    // step's multiples in range makes it pick exactly our step.
    let (x_step, y_step) = (tick_step((x0, x1), 5), tick_step((y0, y1), 5));
    let x_step = if panel.integer_x { x_step.max(1.0) } else { x_step };
    let x_labels = if panel.categories.is_empty() { ticks((x0, x1), x_step) } else { panel.categories.len() * 2 + 1 };
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 15))
        .margin(10)
        .margin_right(18)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    let categories = panel.categories.clone();
    let x_format = move |v: &f64| {
        if categories.is_empty() {
            tick(*v, x_step)
        } else {
            let k = v.round();
            if (v - k).abs() < 1e-6 && k >= 0.0 {
                categories.get(k as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        }
    };
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_labels(x_labels)
        .y_labels(ticks((y0, y1), y_step))
        .x_label_formatter(&x_format)
        .y_label_formatter(&|v| tick(*v, y_step))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    // Scene first, data over it.
    let mut order: Vec<&Series> = panel.series.iter().filter(|s| s.color == Color::Scene).collect();
    order.extend(panel.series.iter().filter(|s| s.color != Color::Scene));
    for s in order {
        let color = s.color.rgb();
        let style = ShapeStyle::from(&color).stroke_width(2);
        match &s.kind {
            SeriesKind::Line => {
                chart.draw_series(LineSeries::new(s.points.iter().copied(), style)).map_err(err)?;
            }
            SeriesKind::Dashed => {
                chart.draw_series(DashedLineSeries::new(s.points.iter().copied(), 7, 5, style)).map_err(err)?;
            }
            SeriesKind::Points(marker) => {
                for &p in &s.points {
                    draw_marker(chart.plotting_area(), p, *marker, color, 5)?;
                }
            }
            SeriesKind::Circles(r) => {
                chart
                    .draw_series(
                        s.points.iter().map(|&(x, y)| Polygon::new(circle_points(x, y, *r, *r, 0.0), fill(s.color))),
                    )
                    .map_err(err)?;
            }
            SeriesKind::Rectangles(sizes) => {
                chart
                    .draw_series(
                        s.points
                            .iter()
                            .zip(sizes)
                            .map(|(&(x, y), &(w, h))| Rectangle::new([(x, y), (x + w, y + h)], fill(s.color))),
                    )
                    .map_err(err)?;
            }
            SeriesKind::Polygon => {
                chart.draw_series(std::iter::once(Polygon::new(s.points.clone(), fill(s.color)))).map_err(err)?;
            }
            SeriesKind::Ellipses(matrices) => {
                chart
                    .draw_series(s.points.iter().zip(matrices).map(|(&(x, y), m)| {
                        let (a, b, angle) = ellipse_axes(m);
                        PathElement::new(closed(circle_points(x, y, a, b, angle)), style)
                    }))
                    .map_err(err)?;
            }
            SeriesKind::Arrows(vectors) => {
                let thin = ShapeStyle::from(&color).stroke_width(1);
                chart
                    .draw_series(s.points.iter().zip(vectors).map(|(&p, &v)| PathElement::new(arrow(p, v), thin)))
                    .map_err(err)?;
            }
        }
    }
    Ok(())
}

/// The fill of a patch: scene objects light grey, series a tint.
fn fill(color: Color) -> ShapeStyle {
    match color {
        Color::Scene => RGBColor(205, 205, 205).filled(),
        c => c.rgb().mix(0.35).filled(),
    }
}

/// Draws a marker of `shape`, `size` pixels in half-width, at `at` (in
/// the area's coordinates: data in a panel, pixels in the legend).
fn draw_marker<C: CoordTranslate>(
    area: &DrawingArea<SVGBackend<'_>, C>,
    at: C::From,
    shape: Marker,
    color: RGBColor,
    size: i32,
) -> Result<(), FigureError> {
    let line = ShapeStyle::from(&color).stroke_width(2);
    let here = EmptyElement::at(at);
    match shape {
        Marker::Dot => area.draw(&(here + Circle::new((0, 0), size, color.filled()))),
        Marker::Ring => area.draw(&(here + Circle::new((0, 0), size + 2, line))),
        Marker::Cross => area.draw(
            &(here + PathElement::new(vec![(-size, -size), (size, size), (0, 0), (-size, size), (size, -size)], line)),
        ),
        Marker::Square => {
            area.draw(&(here + Rectangle::new([(1 - size, 1 - size), (size - 1, size - 1)], color.filled())))
        }
        Marker::Triangle => {
            area.draw(&(here + Polygon::new(vec![(0, -size), (size, size - 1), (-size, size - 1)], color.filled())))
        }
        Marker::Diamond => {
            area.draw(&(here + Polygon::new(vec![(0, -size), (size, 0), (0, size), (-size, 0)], color.filled())))
        }
    }
    .map_err(err)
}

#[cfg(test)]
mod tests;
