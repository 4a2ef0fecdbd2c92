//! The figure's one legend, below its panels: each labelled series once,
//! its swatch drawing what the series draws, packed into centred rows.

use super::marks::{draw_marker, fill};
use super::{Color, FigureError, Panel, SeriesKind, err};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One legend entry: its label, colour and what its swatch draws.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Entry {
    label: String,
    color: Color,
    kind: SeriesKind,
}

/// The labelled series of `panels`, each (label, colour, kind) once, in order.
pub(super) fn legend_entries<'a>(panels: impl Iterator<Item = &'a Panel>) -> Vec<Entry> {
    let mut entries: Vec<Entry> = Vec::new();
    for panel in panels {
        for s in &panel.series {
            let Some(label) = &s.label else { continue };
            let kind = swatch_kind(&s.kind);
            if !entries.iter().any(|e| &e.label == label && e.color == s.color && e.kind == kind) {
                entries.push(Entry { label: label.clone(), color: s.color, kind });
            }
        }
    }
    entries
}

/// What a swatch needs of a series' kind (not its data).
pub(super) fn swatch_kind(kind: &SeriesKind) -> SeriesKind {
    match kind {
        SeriesKind::Circles(_) => SeriesKind::Circles(0.0),
        SeriesKind::Rectangles(_) => SeriesKind::Rectangles(vec![]),
        SeriesKind::Ellipses(_) => SeriesKind::Ellipses(vec![]),
        SeriesKind::Arrows(_) => SeriesKind::Arrows(vec![]),
        other => other.clone(),
    }
}

const SWATCH: i32 = 26;

/// An entry's width (px): swatch, gap, label at about 6.6 px per character
/// of 13 px sans-serif, and the space to the next entry.
pub(super) fn legend_width(e: &Entry) -> i32 {
    SWATCH + 8 + (6.6 * e.label.chars().count() as f64).ceil() as i32 + 18
}

/// The entries' widths packed into rows of at most `width` pixels:
/// `(first entry, entries, row width)` per row.
pub(super) fn legend_layout(entries: &[Entry], width: u32) -> Vec<(usize, usize, i32)> {
    let mut rows: Vec<(usize, usize, i32)> = Vec::new();
    let mut current = (0usize, 0usize, 0i32);
    for (k, e) in entries.iter().enumerate() {
        let w = legend_width(e);
        if current.1 > 0 && current.2 + w > width as i32 - 20 {
            rows.push(current);
            current = (k, 0, 0);
        }
        current.1 += 1;
        current.2 += w;
    }
    if current.1 > 0 {
        rows.push(current);
    }
    rows
}

pub(super) fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[Entry],
    width: u32,
) -> Result<(), FigureError> {
    let font = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (row, &(first, count, row_width)) in legend_layout(entries, width).iter().enumerate() {
        let y = 12 + 20 * row as i32;
        let mut x = (width as i32 - row_width) / 2;
        for e in &entries[first..first + count] {
            let color = e.color.rgb();
            let line = ShapeStyle::from(&color).stroke_width(2);
            let mid = (x + SWATCH / 2, y);
            match &e.kind {
                SeriesKind::Line | SeriesKind::Arrows(_) | SeriesKind::Ellipses(_) => {
                    area.draw(&PathElement::new(vec![(x, y), (x + SWATCH, y)], line)).map_err(err)?;
                }
                SeriesKind::Dashed => {
                    for k in 0..3 {
                        let a = x + k * 10;
                        area.draw(&PathElement::new(vec![(a, y), (a + 6, y)], line)).map_err(err)?;
                    }
                }
                SeriesKind::Points(marker) => draw_marker(area, mid, *marker, color, 5)?,
                SeriesKind::Circles(_) => {
                    area.draw(&Circle::new(mid, 7, fill(e.color))).map_err(err)?;
                }
                SeriesKind::Rectangles(_) | SeriesKind::Polygon => {
                    area.draw(&Rectangle::new([(x + 4, y - 6), (x + SWATCH - 4, y + 6)], fill(e.color)))
                        .map_err(err)?;
                }
            }
            area.draw(&Text::new(e.label.clone(), (x + SWATCH + 8, y), font.clone())).map_err(err)?;
            x += legend_width(e);
        }
    }
    Ok(())
}
