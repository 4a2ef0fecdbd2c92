//! Drawing: panels and their legend laid out into SVG text, axes and
//! ticks fitted to the data, each series drawn as its kind says.

use super::legend::{draw_legend, legend_entries, legend_layout};
use super::marks::{draw_marker, fill};
use super::shapes::{arrow, circle_points, closed, ellipse_axes};
use super::{Color, FigureError, Panel, Series, SeriesKind, err};
use plotters::coord::Shift;
use plotters::prelude::*;
// `Color` names tandem's colour choice; plotters' trait stays usable.
use plotters::style::Color as _;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_without_minus_zero() {
        assert_eq!(tick(-0.0000001, 0.05), "0");
        assert_eq!(tick(-0.05, 0.05), "-0.05");
        assert_eq!(tick(0.1, 0.05), "0.1");
        assert_eq!(tick(2.0, 0.5), "2");
        assert_eq!(tick(300.0, 100.0), "300");
        assert_eq!(tick_step((0.0, 1.0), 5), 0.2);
        assert_eq!(tick_step((-0.14, -0.12), 5), 0.005);
        assert_eq!(ticks((-0.245, 0.795), 0.2), 5);
    }
}
