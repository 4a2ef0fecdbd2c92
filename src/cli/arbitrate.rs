//! `tandem arbitrate`: one shared-control episode on a problem.

use super::refusal::{Refusal, or_goal_refusal, start_refusal};
use crate::arbitration::{Arbiter, ArbiterSettings, ArbitrationMode, GoalSettings, ProblemGoal, problem_goals};
use crate::experiments::figures::{episode_path, outcome_legend, with_scene};
use crate::figures::{Color, Marker, Panel, Series, render_panels};
use crate::problem::Problem;
use crate::sim::{
    Approach, Episode, EpisodeRecord, EpisodeSettings, Operator, Pace, Straightline, TaskJudge, percentiles,
};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `tandem arbitrate`.
#[derive(Debug, clap::Args)]
pub struct ArbitrateArgs {
    /// Problem file, or builtin:NAME. Its goal object (for a grasp, every
    /// object with the goal's grasp frame) gets an optimized reference and
    /// an LQR tracking policy; the simulated operator aims at the problem's
    /// own goal.
    #[arg(default_value = "builtin:panda_grasp_box")]
    pub problem: PathBuf,
    /// Arbitration mode: direct, blend-timid, blend-aggressive, avoid,
    /// natural-gradient, natural-gradient-joint, constrained, sos, or
    /// learned (with --arbiter).
    #[arg(long, default_value = "sos")]
    pub mode: ArbitrationMode,
    /// The trained arbitration actor of `--mode learned` (`tandem learn
    /// arbitration`; trained for the problem's number of goals). Required
    /// with `--mode learned`.
    #[arg(long, value_name = "FILE", required_if_eq("mode", "learned"))]
    pub arbiter: Option<PathBuf>,
    /// The centres of sum-of-squares and of the constrained mode.
    #[command(flatten)]
    pub centers: super::arbiter_args::CenterArgs,
    #[command(flatten)]
    pub motion: super::arbiter_args::MotionLimitArgs,
    /// Point clouds added to the problem's scene.
    #[command(flatten)]
    pub clouds: super::PointCloudArgs,
    /// Simulated operator: straightline (straight at the grasp point) or
    /// approach (to a point 10 cm above it, then down).
    #[arg(long, default_value = "approach", value_parser = ["straightline", "approach"])]
    pub operator: String,
    /// Seed of the planner that seeds each goal's reference.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Operator speed (m/s), 0.001 to 2.
    #[arg(long, default_value_t = 0.1, value_parser = |s: &str| super::number_in(s, 0.001..=2.0))]
    pub speed: f64,
    /// Control rate (Hz; the dissertation's 15 Hz by default), 1 to 1000
    /// as `tandem serve` takes.
    #[arg(long, default_value_t = 15.0, value_parser = |s: &str| super::number_in(s, 1.0..=1000.0))]
    pub rate: f64,
    /// Write the gripper path (top and side views, with the reference) as SVG.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Write the Fig. 4.2-style metric field as SVG: ellipses of F⁻¹ (the
    /// natural gradient's metric) over the first two joints — the workspace
    /// of a planar problem such as problems/planar_pick.toml — for the goal
    /// alone, for every goal with distance-based beliefs, and for a policy
    /// that only avoids obstacles.
    #[arg(long, value_name = "FILE")]
    pub field: Option<PathBuf>,
    /// Write the executed commands' largest joint acceleration and jerk per
    /// tick as ratios to the robot's limits (finite differences at the
    /// period, from rest; 1 is the limit) as SVG: with and without
    /// `--no-motion-limits`, what the limits change.
    #[arg(long, value_name = "FILE")]
    pub motion_plot: Option<PathBuf>,
    /// Print one JSON object: {"problem", "mode", "operator", "seed",
    /// "outcome" (success, collision, timeout or failed), "reason" (the
    /// simulator's, or start_invalid / goal_invalid when the start is
    /// outside the limits or in collision, or no configuration within
    /// limits reaches the goal without collision: no episode ran),
    /// "reason_detail", "steps", "tick_us": {"median", "p99", "max"},
    /// "hard_violations", "limit_violations" (commands past an
    /// acceleration, deceleration or jerk limit), "peak_acceleration_ratio",
    /// "peak_jerk_ratio" (the largest |q̈| and |q⃛| over their limits),
    /// "min_clearance_m" (null when no pair can collide), "fallbacks"}.
    /// Exit status 3 unless the outcome is success.
    #[arg(long)]
    pub json: bool,
}

/// Runs the episode; [`Outcome::Unsuccessful`](super::Outcome) (exit 3) unless it succeeds.
pub(super) fn run(args: &ArbitrateArgs) -> Result<super::Outcome, Box<dyn std::error::Error>> {
    let problem = super::problem_args::load(&args.problem, &args.clouds)?;
    if let Some(refusal) = start_refusal(&problem)? {
        return Ok(refused(&problem, &refusal, args));
    }
    let began = Instant::now();
    let options = GoalSettings { seed: Some(args.seed), ..GoalSettings::default() };
    let goals = match or_goal_refusal(problem_goals(&problem, &options))? {
        Ok(goals) => goals,
        Err(refusal) => return Ok(refused(&problem, &refusal, args)),
    };
    let prepared = began.elapsed();
    let target = goals.iter().position(|g| g.problem.goal == problem.goal).unwrap_or(0);
    let settings = args.motion.apply(args.centers.arbiter_settings(1.0 / args.rate));
    let mut arbiter = Arbiter::for_problem(&problem, &goals, settings)?;
    if let Some(path) = &args.arbiter {
        let actor = crate::learn::ArbitrationActor::load(path)?;
        arbiter = arbiter.with_arbitration_policy(std::sync::Arc::new(actor))?;
    }
    let arbiter = arbiter.with_settings(ArbiterSettings { mode: args.mode, ..settings })?;
    let settings = *arbiter.settings();
    let mut operator: Box<dyn Operator> = match args.operator.as_str() {
        "straightline" => Box::new(Straightline { pace: Pace { speed: args.speed, ..Pace::default() } }),
        _ => Box::new(Approach::at_speed(args.speed)),
    };
    let mut judge = TaskJudge::new(&goals[target]);
    let episode = Episode {
        arbiter: &arbiter,
        start: &problem.start,
        target: goals[target].position,
        true_goal: target,
        settings: EpisodeSettings::default(),
    };
    let mut ws = arbiter.workspace();
    let record = episode.run(&mut ws, operator.as_mut(), &mut judge)?;
    if let Some(path) = &args.plot {
        let svg = episode_svg(&problem, &goals[target], &record, args)?;
        std::fs::write(path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    if let Some(path) = &args.field {
        let svg = field_svg(&problem, &goals, target, &settings)?;
        std::fs::write(path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    if let Some(path) = &args.motion_plot {
        let svg = motion_svg(&problem, &record, &settings, args)?;
        std::fs::write(path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    let (median, p99, max) = percentiles(&record.tick_us);
    if args.json {
        let json = serde_json::json!({
            "problem": problem.name,
            "mode": args.mode.as_str(),
            "operator": args.operator,
            "seed": args.seed,
            "outcome": record.outcome.as_str(),
            "reason": record.reason.as_str(),
            "reason_detail": record.reason.to_string(),
            "steps": record.steps,
            "tick_us": {"median": median, "p99": p99, "max": max},
            "hard_violations": record.hard_violations,
            "limit_violations": record.limit_violations,
            "peak_acceleration_ratio": record.peak_acceleration_ratio,
            "peak_jerk_ratio": record.peak_jerk_ratio,
            "min_clearance_m": record.min_clearance,
            "fallbacks": record.fallbacks,
        });
        println!("{}", crate::experiments::tidy_json(json));
        return Ok(outcome(&record));
    }
    println!(
        "{}: {} goal reference(s) planned and optimized in {:.1} ms ({})",
        problem.name,
        goals.len(),
        prepared.as_secs_f64() * 1e3,
        goals.iter().map(|g| g.name.as_str()).collect::<Vec<_>>().join(", ")
    );
    println!(
        "{} operator, mode {} at {} Hz: {} after {} ticks ({:.1} s): {}",
        args.operator,
        args.mode,
        args.rate,
        record.outcome.as_str(),
        record.steps,
        record.steps as f64 / args.rate,
        record.reason
    );
    println!("tick: median {median:.1} µs, p99 {p99:.1} µs, max {max:.1} µs");
    let clearance = match record.min_clearance {
        c if c.is_finite() => format!("smallest clearance {c:.4} m"),
        _ => "no collision pair to keep clear".to_string(),
    };
    println!("hard-constraint violations {}, {clearance}, fallbacks {}", record.hard_violations, record.fallbacks);
    println!(
        "motion-limit violations {} (largest acceleration {:.3} and jerk {:.3} of the limits)",
        record.limit_violations, record.peak_acceleration_ratio, record.peak_jerk_ratio
    );
    for path in args.plot.iter().chain(&args.field).chain(&args.motion_plot) {
        println!("wrote {}", path.display());
    }
    Ok(outcome(&record))
}

/// Reports an episode that cannot start (exit 3): outcome `failed`, the
/// refusal's status as the reason, the same JSON keys as an episode.
fn refused(problem: &Problem, refusal: &Refusal, args: &ArbitrateArgs) -> super::Outcome {
    if args.json {
        let json = serde_json::json!({
            "problem": problem.name,
            "mode": args.mode.as_str(),
            "operator": args.operator,
            "seed": args.seed,
            "outcome": "failed",
            "reason": refusal.status,
            "reason_detail": refusal.reason,
            "steps": 0,
            "tick_us": {"median": null, "p99": null, "max": null},
            "hard_violations": 0,
            "min_clearance_m": null,
            "fallbacks": 0,
        });
        println!("{json}");
    } else {
        println!("{}: no episode ({}): {}", problem.name, refusal.status, refusal.reason);
    }
    super::Outcome::Unsuccessful
}

fn outcome(record: &EpisodeRecord) -> super::Outcome {
    if record.outcome == crate::sim::Outcome::Success { super::Outcome::Success } else { super::Outcome::Unsuccessful }
}

/// Top and side views of the executed gripper path and the reference's.
fn episode_svg(
    problem: &Problem,
    goal: &ProblemGoal,
    record: &EpisodeRecord,
    args: &ArbitrateArgs,
) -> Result<String, Box<dyn std::error::Error>> {
    let robot = &problem.robot;
    let gripper = robot.frame_id(problem.robot_spec.gripper.as_deref().unwrap_or_default())?;
    let reference = goal.policy.reference();
    let planned = robot.frame_path(gripper, (0..reference.len()).map(|i| reference.position(i)))?;
    let view = |a: usize, b: usize, title: &str, y_label: &str| {
        let project = |p: &[f64; 3]| (p[a], p[b]);
        let executed: Vec<(f64, f64)> = record.gripper.iter().map(project).collect();
        let reference: Vec<(f64, f64)> = planned.iter().map(project).collect();
        let panel =
            Panel::new(title, "x (m)", y_label).with(Series::dashed("reference", &reference, Color::Reference)).equal();
        let panel = episode_path(
            with_scene(panel, &problem.scene, (a, b)),
            &format!("executed ({})", args.mode),
            &executed,
            0,
            record.outcome,
        );
        outcome_legend(panel, [record.outcome])
            .with(Series::markers("start", &executed[..executed.len().min(1)], Color::Reference, Marker::Dot))
            .with(Series::markers("goal", &[project(&goal.position)], Color::Reference, Marker::Ring))
    };
    let title =
        format!("{}: {} operator, {} ({})", problem.name, args.operator, record.outcome.as_str(), record.reason);
    Ok(render_panels(&title, &[view(0, 1, "from above", "y (m)"), view(0, 2, "from the side", "z (m)")], 480, 440)?)
}

/// The executed commands' largest acceleration and jerk ratio per tick
/// (finite differences at the period from rest, over each joint's limits:
/// [`MotionAudit`](crate::arbitration::MotionAudit)).
fn motion_svg(
    problem: &Problem,
    record: &EpisodeRecord,
    settings: &ArbiterSettings,
    args: &ArbitrateArgs,
) -> Result<String, Box<dyn std::error::Error>> {
    let (dt, limits) = (settings.period, problem.robot.motion_limits());
    // The episode's own audit, command by command (as a controller sees it).
    let mut audit = crate::arbitration::MotionAudit::new(limits.len());
    let (mut accelerations, mut jerks) = (Vec::new(), Vec::new());
    for (k, qdot) in record.qdot.iter().enumerate() {
        audit.observe(qdot, dt, limits);
        let t = (k + 1) as f64 * dt;
        accelerations.push((t, audit.last_ratios[0]));
        jerks.push((t, audit.last_ratios[1]));
    }
    let end = record.qdot.len() as f64 * dt;
    let limit = [(0.0, 1.0), (end, 1.0)];
    let panel = |title: &str, y: &str, points: &[(f64, f64)]| {
        Panel::new(title, "time (s)", y)
            .with(Series::line("executed, largest over the joints", points, Color::Palette(0)))
            .with(Series::dashed("limit", &limit, Color::Reference))
    };
    let on = if settings.safety.motion_limits { "motion limits on" } else { "motion limits off" };
    let title = format!(
        "{}: {} operator, {} at {} Hz, {on}: peak {:.2}× acceleration, {:.2}× jerk",
        problem.name, args.operator, args.mode, args.rate, record.peak_acceleration_ratio, record.peak_jerk_ratio
    );
    let panels = [panel("acceleration", "|q̈| / limit", &accelerations), panel("jerk", "|q⃛| / limit", &jerks)];
    Ok(render_panels(&title, &panels, 480, 360)?)
}

/// The dissertation's Fig. 4.2: F⁻¹ ellipses for (a) the goal, (b) every goal
/// with beliefs from distance (exp(−d / 10 cm)), (c) obstacle avoidance only.
fn field_svg(
    problem: &Problem,
    goals: &[ProblemGoal],
    target: usize,
    settings: &ArbiterSettings,
) -> Result<String, Box<dyn std::error::Error>> {
    use crate::arbitration::{ArbiterGoal, ObstacleRepulsion, metric_field};
    use crate::figures::SeriesKind;
    const GRID: usize = 11;
    if problem.robot.nq() < 2 {
        let n = problem.robot.nq();
        return Err(format!(
            "--field draws the metric over the first two joints; {} has {n} active joint",
            problem.name
        )
        .into());
    }
    let single = Arbiter::for_problem(problem, &goals[target..=target], *settings)?;
    let all = Arbiter::for_problem(problem, goals, *settings)?;
    let model = all.collision_model().clone();
    let repulsion = ArbiterGoal {
        name: "obstacles".into(),
        position: goals[target].position,
        policy: std::sync::Arc::new(ObstacleRepulsion::new(model.clone(), 0.1, 1.0)),
    };
    let gripper = problem.robot_spec.gripper.as_deref().unwrap_or_default();
    let avoid = Arbiter::new(model, gripper, vec![repulsion], *settings)?;
    // Beliefs from the gripper's distance to each goal (exp(−d / 10 cm)) at
    // the grid point: the slice through the start with joints 1 and 2 set.
    let gripper_frame = problem.robot.frame_id(gripper)?;
    let by_distance = |at: [f64; 2]| {
        let mut q = problem.start.clone();
        q[0] = at[0];
        q[1] = at[1];
        let p = problem.robot.frame_path(gripper_frame, [q.as_slice()]).ok().and_then(|p| p.first().copied());
        let w: Vec<f64> = goals
            .iter()
            .map(|g| {
                p.map_or(1.0, |p| (-(0..3).map(|k| (p[k] - g.position[k]).powi(2)).sum::<f64>().sqrt() / 0.1).exp())
            })
            .collect();
        let total: f64 = w.iter().sum::<f64>().max(1e-300);
        w.iter().map(|x| x / total).collect::<Vec<_>>()
    };
    let fields = [
        ("(a) goal-directed", metric_field(&single, &problem.start, GRID, |_| vec![1.0])),
        ("(b) every goal, beliefs by distance", metric_field(&all, &problem.start, GRID, by_distance)),
        ("(c) obstacle avoidance only", metric_field(&avoid, &problem.start, GRID, |_| vec![1.0])),
    ];
    let limits = problem.robot.limits();
    let spacing = (limits[0].upper - limits[0].lower) * 0.9 / (GRID - 1) as f64;
    // Each goal's final configuration, in the same joint plane as the field.
    let goal_ends: Vec<(f64, f64)> =
        goals.iter().filter_map(|g| g.solution.trajectory.last()).map(|q| (q[0], q[1])).collect();
    let axis =
        |j: usize| format!("{} ({})", problem.robot.joint_names()[j], problem.robot.joint_unit(j).unwrap_or("rad"));
    let panels: Vec<Panel> = fields
        .iter()
        .map(|(title, samples)| {
            let largest = samples
                .iter()
                .map(|s| s.inverse[0].abs().max(s.inverse[3].abs()) + s.inverse[1].abs())
                .fold(1e-12, f64::max);
            let scale = 0.45 * spacing / largest;
            let ellipses = crate::figures::Series {
                label: Some("F⁻¹".into()),
                points: samples.iter().map(|s| (s.at[0], s.at[1])).collect(),
                color: 0.into(),
                kind: SeriesKind::Ellipses(samples.iter().map(|s| s.inverse.map(|v| v * scale)).collect()),
            };
            Panel::new(title, &axis(0), &axis(1))
                .with(ellipses)
                .with(Series::markers("goal configurations", &goal_ends, Color::Reference, Marker::Cross))
                .with(Series::markers("start", &[(problem.start[0], problem.start[1])], Color::Reference, Marker::Dot))
                .equal()
        })
        .collect();
    Ok(render_panels(&format!("{}: metric fields (F⁻¹ ellipses)", problem.name), &panels, 420, 440)?)
}
