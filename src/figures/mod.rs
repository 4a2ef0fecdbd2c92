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

use plotters::prelude::*;

mod legend;
mod marks;
mod render;
mod shapes;

pub use render::{render_grid, render_panels};
use shapes::convex_hull;

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

/// A drawing backend's error `e` as a [`FigureError`].
fn err(e: impl std::fmt::Display) -> FigureError {
    FigureError(e.to_string())
}

#[cfg(test)]
mod tests;
