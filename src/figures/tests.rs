use super::shapes::ellipse_axes;
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
fn axes_get_about_five_round_ticks() {
    let panel = Panel::new("t", "x", "y").with(Series::line("a", &[(-0.245, -1.03), (0.795, -0.18)], 0));
    let svg = render_panels("ticks", &[panel], 800, 600).unwrap();
    let labels: Vec<&str> = svg
        .split("</text>")
        .filter_map(|t| t.rsplit('>').next())
        .map(str::trim)
        .filter(|t| t.parse::<f64>().is_ok())
        .collect();
    for tick in ["-0.2", "0", "0.2", "0.4", "0.6", "-1", "-0.8", "-0.6", "-0.4"] {
        assert!(labels.contains(&tick), "{tick} missing from {labels:?}");
    }
}

#[test]
fn one_legend_below_the_panels_with_each_entry_once() {
    let line = Series::line("path", &[(0.0, 0.0), (1.0, 0.5)], 0);
    let e = Series {
        label: Some("metric".into()),
        points: vec![(0.5, 0.25)],
        color: Color::Palette(1),
        kind: SeriesKind::Ellipses(vec![[0.1, 0.0, 0.0, 0.05]]),
    };
    let a = Panel::new("a", "x", "y").with(line.clone()).equal();
    let b = Panel::new("b", "x", "y").with(line).with(e);
    let svg = render_panels("t", &[a, b], 400, 300).unwrap();
    assert_eq!(svg.matches(">\npath\n<").count(), 1, "the legend names a series once");
    assert!(svg.contains("metric") && svg.matches("<svg").count() == 1);
}

#[test]
fn hull_of_a_square_with_inner_points() {
    let pts = [(0.0, 0.0), (1.0, 0.0), (0.5, 0.5), (1.0, 1.0), (0.0, 1.0), (0.2, 0.7)];
    assert_eq!(convex_hull(&pts), vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
}

#[test]
fn shared_axes_hold_every_panel() {
    let mut panels = vec![
        Panel::new("a", "x", "y").with(Series::line("p", &[(0.0, 0.0), (1.0, 1.0)], 0)),
        Panel::new("b", "x", "y").with(Series::line("p", &[(0.0, -2.0), (1.0, 3.0)], 0)),
    ];
    share_y(&mut panels);
    assert_eq!(panels[0].y_range, panels[1].y_range);
    let (lo, hi) = panels[0].y_range.unwrap();
    assert!(lo <= -2.0 && hi >= 3.0);
}
