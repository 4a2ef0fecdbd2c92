//! Minimal SVG line plots: axes with ticks, polylines, arrows, a legend.
//!
//! Enough for the pictures tandem writes (policy fields, joint trajectories,
//! end-effector paths) without a plotting dependency; the output opens in
//! any browser and converts to PNG with standard tools.
//!
//! ```
//! use tandem::plot::SvgPlot;
//! let mut plot = SvgPlot::new("sine", "t (s)", "y");
//! let xs: Vec<(f64, f64)> = (0..50).map(|i| (i as f64 * 0.1, (i as f64 * 0.1).sin())).collect();
//! plot.line(&xs, "#1f77b4", 2.0, Some("sin t"));
//! let svg = plot.render(640.0, 480.0);
//! assert!(svg.starts_with("<svg"));
//! ```

use std::fmt::Write;

enum Item {
    Line { points: Vec<(f64, f64)>, color: String, width: f64, dashed: bool },
    Arrow { from: (f64, f64), to: (f64, f64), color: String },
    Marker { at: (f64, f64), color: String, radius: f64 },
}

/// A 2-D plot in data coordinates, rendered to SVG text.
pub struct SvgPlot {
    title: String,
    x_label: String,
    y_label: String,
    items: Vec<Item>,
    legend: Vec<(String, String)>,
}

impl SvgPlot {
    /// An empty plot with a title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        SvgPlot {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            items: Vec::new(),
            legend: Vec::new(),
        }
    }

    /// A polyline through `points`, with an optional legend entry.
    pub fn line(&mut self, points: &[(f64, f64)], color: &str, width: f64, label: Option<&str>) {
        self.push_line(points, color, width, false, label);
    }

    /// A dashed polyline.
    pub fn dashed_line(&mut self, points: &[(f64, f64)], color: &str, width: f64, label: Option<&str>) {
        self.push_line(points, color, width, true, label);
    }

    fn push_line(&mut self, points: &[(f64, f64)], color: &str, width: f64, dashed: bool, label: Option<&str>) {
        let points: Vec<(f64, f64)> = points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
        self.items.push(Item::Line { points, color: color.to_string(), width, dashed });
        if let Some(l) = label {
            self.legend.push((l.to_string(), color.to_string()));
        }
    }

    /// An arrow from `from` to `to` (data coordinates).
    pub fn arrow(&mut self, from: (f64, f64), to: (f64, f64), color: &str) {
        self.items.push(Item::Arrow { from, to, color: color.to_string() });
    }

    /// A filled circle of `radius` pixels at `at`.
    pub fn marker(&mut self, at: (f64, f64), color: &str, radius: f64) {
        self.items.push(Item::Marker { at, color: color.to_string(), radius });
    }

    fn bounds(&self) -> (f64, f64, f64, f64) {
        let mut b = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        let mut add = |(x, y): (f64, f64)| {
            if x.is_finite() && y.is_finite() {
                b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
            }
        };
        for item in &self.items {
            match item {
                Item::Line { points, .. } => points.iter().for_each(|p| add(*p)),
                Item::Arrow { from, to, .. } => {
                    add(*from);
                    add(*to);
                }
                Item::Marker { at, .. } => add(*at),
            }
        }
        if !b.0.is_finite() {
            return (0.0, 1.0, 0.0, 1.0);
        }
        let pad = |lo: f64, hi: f64| {
            let d = (hi - lo).max(1e-9) * 0.05;
            (lo - d, hi + d)
        };
        let (x0, x1) = pad(b.0, b.1);
        let (y0, y1) = pad(b.2, b.3);
        (x0, x1, y0, y1)
    }

    /// The SVG document, `width` × `height` pixels.
    pub fn render(&self, width: f64, height: f64) -> String {
        let (x0, x1, y0, y1) = self.bounds();
        let (left, right, top, bottom) = (70.0, 20.0, 40.0, 55.0);
        let sx = |x: f64| left + (x - x0) / (x1 - x0) * (width - left - right);
        let sy = |y: f64| height - bottom - (y - y0) / (y1 - y0) * (height - top - bottom);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(
            s,
            r##"<rect width="100%" height="100%" fill="white"/><defs><marker id="head" markerWidth="8" markerHeight="8" refX="6" refY="3" orient="auto"><path d="M0,0 L6,3 L0,6 z" fill="context-stroke"/></marker></defs>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            width / 2.0,
            escape(&self.title)
        );
        for i in 0..=5 {
            let (fx, fy) = (x0 + (x1 - x0) * i as f64 / 5.0, y0 + (y1 - y0) * i as f64 / 5.0);
            let _ = writeln!(
                s,
                r##"<line x1="{0:.1}" y1="{1}" x2="{0:.1}" y2="{2}" stroke="#eee"/><text x="{0:.1}" y="{3}" text-anchor="middle">{4:.3}</text>"##,
                sx(fx),
                top,
                height - bottom,
                height - bottom + 16.0,
                fx
            );
            let _ = writeln!(
                s,
                r##"<line x1="{1}" y1="{0:.1}" x2="{2}" y2="{0:.1}" stroke="#eee"/><text x="{3}" y="{0:.1}" text-anchor="end" dominant-baseline="middle">{4:.3}</text>"##,
                sy(fy),
                left,
                width - right,
                left - 6.0,
                fy
            );
        }
        let _ = writeln!(
            s,
            r##"<rect x="{left}" y="{top}" width="{}" height="{}" fill="none" stroke="#444"/>"##,
            width - left - right,
            height - top - bottom
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            (left + width - right) / 2.0,
            height - 12.0,
            escape(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(16,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
            (top + height - bottom) / 2.0,
            escape(&self.y_label)
        );
        for item in &self.items {
            match item {
                Item::Line { points, color, width, dashed } => {
                    let pts: Vec<String> = points.iter().map(|&(x, y)| format!("{:.2},{:.2}", sx(x), sy(y))).collect();
                    let dash = if *dashed { r#" stroke-dasharray="6 4""# } else { "" };
                    let _ = writeln!(
                        s,
                        r#"<polyline points="{}" fill="none" stroke="{color}" stroke-width="{width}"{dash}/>"#,
                        pts.join(" ")
                    );
                }
                Item::Arrow { from, to, color } => {
                    let _ = writeln!(
                        s,
                        r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{color}" stroke-width="1.2" marker-end="url(#head)"/>"#,
                        sx(from.0),
                        sy(from.1),
                        sx(to.0),
                        sy(to.1)
                    );
                }
                Item::Marker { at, color, radius } => {
                    let _ = writeln!(
                        s,
                        r#"<circle cx="{:.2}" cy="{:.2}" r="{radius}" fill="{color}"/>"#,
                        sx(at.0),
                        sy(at.1)
                    );
                }
            }
        }
        for (i, (label, color)) in self.legend.iter().enumerate() {
            let y = top + 16.0 + 18.0 * i as f64;
            let _ = writeln!(
                s,
                r#"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{color}" stroke-width="3"/><text x="{}" y="{y}" dominant-baseline="middle">{}</text>"#,
                width - right - 230.0,
                width - right - 205.0,
                width - right - 200.0,
                escape(label)
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
