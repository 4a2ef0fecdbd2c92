//! Marks drawn the same in a panel and in the legend's swatches: markers
//! and the fills of patches.

use super::{Color, FigureError, Marker, err};
use plotters::prelude::*;
// `Color` names tandem's colour choice; plotters' trait stays usable.
use plotters::style::Color as _;

/// The fill of a patch: scene objects light grey, series a tint.
pub(super) fn fill(color: Color) -> ShapeStyle {
    match color {
        Color::Scene => RGBColor(205, 205, 205).filled(),
        c => c.rgb().mix(0.35).filled(),
    }
}

/// Draws a marker of `shape`, `size` pixels in half-width, at `at` (in
/// the area's coordinates: data in a panel, pixels in the legend).
pub(super) fn draw_marker<C: CoordTranslate>(
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
