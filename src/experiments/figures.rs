//! Figures of learning: loss curves, the training data's joint values
//! against the limits (the dissertation's Fig. 3.8), and success against the
//! start's distance from the data; and how episodes end on their paths.

use crate::figures::{Color, FigureError, Marker, Panel, Series, render_panels};
use crate::robot::JointLimits;
use crate::sim::Outcome;

/// Adds the outlines of `scene`'s objects and obstacles (but a table,
/// which would fill the view) seen along the axis that is neither `a` nor
/// `b` (0 = x, 1 = y, 2 = z).
pub fn with_scene(mut panel: Panel, scene: &crate::scene::Scene, (a, b): (usize, usize)) -> Panel {
    let obstacles = scene.obstacles().iter().filter(|o| o.name != "table").map(|o| o.silhouette_points());
    for points in obstacles.chain(scene.objects().iter().map(|o| o.silhouette_points())) {
        let projected: Vec<(f64, f64)> = points.iter().map(|p| (p[a], p[b])).collect();
        panel = panel.with(Series::outline("obstacles and objects", &projected));
    }
    panel
}

/// The marker at the end of an episode's path: none for a success (the
/// path ends at its target), a triangle for a collision, a square at the
/// time limit, a cross where the operator stopped and the judge declined.
pub fn outcome_marker(outcome: Outcome) -> Option<Marker> {
    match outcome {
        Outcome::Success => None,
        Outcome::Collision => Some(Marker::Triangle),
        Outcome::Timeout => Some(Marker::Square),
        Outcome::Failed => Some(Marker::Cross),
    }
}

/// Adds an episode's path to `panel` as a line in `color` labelled `label`,
/// its last point marked by [`outcome_marker`] in the same colour.
pub fn episode_path(panel: Panel, label: &str, path: &[(f64, f64)], color: usize, outcome: Outcome) -> Panel {
    let panel = panel.with(Series::line(label, path, color));
    match (outcome_marker(outcome), path.last()) {
        (Some(marker), Some(&end)) => panel.with(Series::markers("", &[end], color, marker).unlabelled()),
        _ => panel,
    }
}

/// Adds legend entries (in black, without points) for the end markers of
/// `outcomes` (each once, successes need none).
pub fn outcome_legend(mut panel: Panel, outcomes: impl IntoIterator<Item = Outcome>) -> Panel {
    let mut seen: Vec<Outcome> = Vec::new();
    for outcome in outcomes {
        if seen.contains(&outcome) {
            continue;
        }
        seen.push(outcome);
        if let Some(marker) = outcome_marker(outcome) {
            let label = match outcome {
                Outcome::Collision => "ends in a collision",
                Outcome::Timeout => "ends at the time limit",
                _ => "stopped, grasp judged failed",
            };
            panel = panel.with(Series::markers(label, &[], Color::Reference, marker));
        }
    }
    panel
}

#[cfg(feature = "learn")]
/// Training and validation loss per epoch (log10), one panel.
///
/// # Errors
/// Plotting errors.
pub fn loss_curves(report: &crate::learn::TrainReport, title: &str) -> Result<String, FigureError> {
    let log = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let train: Vec<(f64, f64)> = report.losses.iter().map(|l| (l.epoch as f64, log(l.train))).collect();
    let validation: Vec<(f64, f64)> = report
        .losses
        .iter()
        .filter(|l| l.validation.is_finite())
        .map(|l| (l.epoch as f64, log(l.validation)))
        .collect();
    let direction: Vec<(f64, f64)> = report
        .losses
        .iter()
        .filter(|l| l.validation_direction.is_finite())
        .map(|l| (l.epoch as f64, log(l.validation_direction)))
        .collect();
    let speed: Vec<(f64, f64)> = report
        .losses
        .iter()
        .filter(|l| l.validation_speed.is_finite())
        .map(|l| (l.epoch as f64, log(l.validation_speed)))
        .collect();
    let mut panel = Panel::new("loss (direction MSE + speed MSE)", "epoch", "log10 loss")
        .integer_x()
        .with(Series::line("train", &train, 0));
    if !validation.is_empty() {
        panel = panel
            .with(Series::line("validation", &validation, 1))
            .with(Series::dashed("validation: direction", &direction, 2))
            .with(Series::dashed("validation: speed", &speed, 4));
    }
    render_panels(title, &[panel], 640, 420)
}

/// Histograms of each joint's values in `states` (one panel per joint,
/// `bins` bins across the joint's range) with the limits as vertical lines.
///
/// # Errors
/// Plotting errors.
pub fn joint_histograms(
    states: &[Vec<f64>],
    joints: &[String],
    limits: &[JointLimits],
    bins: usize,
) -> Result<String, FigureError> {
    let bins = bins.max(1);
    let panels: Vec<Panel> = joints
        .iter()
        .zip(limits)
        .enumerate()
        .map(|(j, (name, l))| {
            let width = (l.upper - l.lower) / bins as f64;
            let mut counts = vec![0usize; bins];
            for q in states {
                let b = ((q[j] - l.lower) / width).floor();
                if b >= 0.0 {
                    counts[(b as usize).min(bins - 1)] += 1;
                }
            }
            let total = states.len().max(1) as f64;
            let mut steps = Vec::with_capacity(2 * bins + 2);
            steps.push((l.lower, 0.0));
            for (b, c) in counts.iter().enumerate() {
                let share = *c as f64 / total;
                steps.push((l.lower + b as f64 * width, share));
                steps.push((l.lower + (b + 1) as f64 * width, share));
            }
            steps.push((l.upper, 0.0));
            let top = steps.iter().map(|p| p.1).fold(0.0, f64::max).max(1e-3) * 1.1;
            let margin = 0.05 * (l.upper - l.lower);
            Panel::new(name, "joint value (rad)", "share of states")
                .with(Series::line("training states", &steps, 0))
                .with(Series::line("limits", &[(l.lower, 0.0), (l.lower, top)], 3))
                .with(Series::line("", &[(l.upper, 0.0), (l.upper, top)], 3).unlabelled())
                .ranges((l.lower - margin, l.upper + margin), (0.0, top))
        })
        .collect();
    render_panels("Joint values of the training data against the joint limits (Fig. 3.8)", &panels, 300, 260)
}

/// Success rate per bin of the start's distance from the data, one
/// series per policy: `outcomes[k] = (name, [(distance, success)])`.
/// Bins hold equal numbers of starts (quantiles of the first series).
///
/// # Errors
/// Plotting errors.
pub fn success_by_distance(outcomes: &[(String, Vec<(f64, bool)>)], bins: usize) -> Result<String, FigureError> {
    let mut distances: Vec<f64> = outcomes.first().map(|o| o.1.iter().map(|p| p.0).collect()).unwrap_or_default();
    distances.retain(|d| d.is_finite());
    distances.sort_by(f64::total_cmp);
    let bins = bins.max(1).min(distances.len().max(1));
    let edges: Vec<f64> = (0..=bins)
        .map(|b| if distances.is_empty() { 0.0 } else { distances[(b * (distances.len() - 1)) / bins] })
        .collect();
    let mut panel = Panel::new(
        "success by the start's distance from the data",
        "distance to the nearest training state (rad)",
        "success rate",
    );
    for (k, (name, points)) in outcomes.iter().enumerate() {
        let series: Vec<(f64, f64)> = edges
            .windows(2)
            .enumerate()
            .filter_map(|(b, w)| {
                let inside: Vec<bool> = points
                    .iter()
                    .filter(|(d, _)| *d >= w[0] && (*d < w[1] || (b == bins - 1 && *d <= w[1])))
                    .map(|p| p.1)
                    .collect();
                (!inside.is_empty()).then(|| {
                    let rate = inside.iter().filter(|s| **s).count() as f64 / inside.len() as f64;
                    (0.5 * (w[0] + w[1]), rate)
                })
            })
            .collect();
        panel = panel.with(Series::line(name, &series, k)).with(Series::points("", &series, k).unlabelled());
    }
    render_panels(
        "Following the policy alone",
        &[panel.ranges((edges[0], edges[bins].max(edges[0] + 1e-3)), (0.0, 1.05))],
        640,
        420,
    )
}

#[cfg(feature = "learn")]
/// Fig. 6.4: success rate and return per training episode, one line per
/// reward (each the mean over its seeds' runs, smoothed by a moving
/// average over `window` episodes).
///
/// # Errors
/// Plotting errors.
pub fn training_curves(
    runs: &[(String, Vec<Vec<crate::learn::TrainingEpisode>>)],
    window: usize,
) -> Result<String, FigureError> {
    let window = window.max(1);
    let smoothed = |values: &[f64]| -> Vec<(f64, f64)> {
        (0..values.len())
            .map(|i| {
                let from = (i + 1).saturating_sub(window);
                let part = &values[from..=i];
                (i as f64 + 1.0, part.iter().sum::<f64>() / part.len() as f64)
            })
            .collect()
    };
    let mean_over = |seeds: &[Vec<crate::learn::TrainingEpisode>],
                     f: &dyn Fn(&crate::learn::TrainingEpisode) -> f64| {
        let len = seeds.iter().map(Vec::len).min().unwrap_or(0);
        (0..len).map(|i| seeds.iter().map(|s| f(&s[i])).sum::<f64>() / seeds.len() as f64).collect::<Vec<f64>>()
    };
    let mut success = Panel::new("success rate", "training episode", "share of episodes (moving average)").integer_x();
    let mut returns = Panel::new("return", "training episode", "episode return (moving average)").integer_x();
    for (color, (name, seeds)) in runs.iter().enumerate() {
        let s = mean_over(seeds, &|e| f64::from(u8::from(e.outcome == "success")));
        let r = mean_over(seeds, &|e| e.episode_return);
        success = success.with(Series::line(name, &smoothed(&s), color));
        returns = returns.with(Series::line(name, &smoothed(&r), color));
    }
    let seeds = runs.first().map_or(0, |r| r.1.len());
    let of = if seeds == 1 { "one seed".to_string() } else { format!("mean of {seeds} seeds") };
    render_panels(&format!("Training the arbiter with DDPG ({of})"), &[success, returns], 560, 400)
}
