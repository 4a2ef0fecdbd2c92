//! `tandem policy`: an LQR tracking policy for the embedded Panda, its
//! closed-loop behaviour, and a Fig. 3.9-style picture of it.

use super::Outcome;
use crate::control::{
    ControlError, GainSchedule, MAX_TIME_STEP, MIN_TIME_STEP, TrackingPolicy, TrackingWeights, WEIGHT_RANGE,
};
use crate::figures::{Color, Marker, Panel, Series, render_panels};
use crate::robot::{MeshSearchPath, RobotDescription, RobotModel};
use crate::trajectory::JointTrajectory;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use super::demo::PANDA_READY;

/// A goal configuration of the embedded Panda reached from the ready pose.
const PANDA_GOAL: [f64; 7] = [0.6, -0.2, -0.3, -1.9, 0.2, 1.8, 0.4];

/// Arguments of `tandem policy`.
#[derive(Debug, clap::Args)]
pub struct PolicyArgs {
    /// Reference trajectory CSV as `tandem solve --out` writes it: header
    /// `time,<joint>,…`, one row per waypoint, the start first, evenly
    /// spaced times (their spacing is the time step). Default: a 3 s
    /// minimum-jerk motion of the Panda from its ready pose.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// The robot whose joints the reference names (its joints must exist
    /// and its values lie within their limits). Default: the embedded Panda.
    #[arg(long, value_name = "URDF")]
    pub urdf: Option<PathBuf>,
    /// Time step between waypoints and control ticks (s), 0.0001 to 1.
    /// Default: 0.01 for the built-in reference; a --reference file sets
    /// its own (give --dt only to confirm it).
    #[arg(long, value_parser = |s: &str| super::number_in(s, MIN_TIME_STEP..=MAX_TIME_STEP))]
    pub dt: Option<f64>,
    /// Weight on position error (1/rad²), 1e-4 to 1e4.
    #[arg(long, default_value_t = 100.0, value_parser = weight)]
    pub q_weight: f64,
    /// Weight on velocity error (s²/rad²), 1e-4 to 1e4.
    #[arg(long, default_value_t = 1.0, value_parser = weight)]
    pub v_weight: f64,
    /// Weight on acceleration, the control (s⁴/rad²), 1e-4 to 1e4.
    #[arg(long, default_value_t = 0.1, value_parser = weight)]
    pub r_weight: f64,
    /// Use time-varying gains from the finite-horizon Riccati recursion.
    #[arg(long)]
    pub time_varying: bool,
    /// Largest distance (rad, joint space) from the goal at which a
    /// rollout counts as arrived; any rollout ending farther gives exit
    /// status 3.
    #[arg(long, default_value_t = 1e-3, value_parser = |s: &str| super::number_in(s, 1e-12..=10.0))]
    pub goal_tolerance: f64,
    /// With --plot: the two joints (1-based) spanning the plotted slice.
    #[arg(long, value_name = "A,B", default_value = "1,2", requires = "plot")]
    pub slice: String,
    /// Write a Fig. 3.9-style SVG: reference, rollouts from nearby starts,
    /// policy velocity arrows, in the slice of two joints.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

fn weight(text: &str) -> Result<f64, String> {
    super::number_in(text, WEIGHT_RANGE)
}

/// The reference the arguments ask for, its joints checked against the robot.
fn reference(args: &PolicyArgs) -> Result<JointTrajectory, Box<dyn std::error::Error>> {
    let robot = match &args.urdf {
        Some(path) => {
            let desc = RobotDescription::from_urdf_file(path, &MeshSearchPath::default().with_ros_package_path())?;
            RobotModel::builder(Arc::new(desc)).build()?
        }
        None => RobotModel::panda(),
    };
    let Some(path) = &args.reference else {
        let joints = RobotModel::panda().joint_names().to_vec();
        if args.urdf.is_some() {
            return Err("--urdf needs a --reference naming its joints (the built-in reference is the Panda's)".into());
        }
        return Ok(JointTrajectory::minimum_jerk(joints, &PANDA_READY, &PANDA_GOAL, 3.0, args.dt.unwrap_or(0.01))?);
    };
    let table = JointTrajectory::read_csv(path)?;
    if let Some(dt) = args.dt.filter(|dt| (dt - table.dt()).abs() > 1e-9 * dt) {
        let msg = format!(
            "--dt {dt} disagrees with the time column of {} ({} s apart): omit --dt",
            path.display(),
            table.dt()
        );
        return Err(msg.into());
    }
    let description = robot.description();
    for (k, name) in table.joints().iter().enumerate() {
        let joint = description.joint(name).filter(|j| j.kind.is_movable()).ok_or_else(|| {
            let names = description.joints().iter().filter(|j| j.kind.is_movable()).map(|j| j.name.as_str());
            let hint = crate::robot::did_you_mean(&crate::robot::suggest_names(name, names));
            format!(
                "{}: column {} names joint '{name}', which {} has no movable joint of{hint}",
                path.display(),
                k + 2,
                description.name()
            )
        })?;
        let limits = joint.limits;
        if let Some(row) = table.positions().position(|q| !limits.contains(q[k])) {
            let v = table.position(row)[k];
            let (lo, hi) = (limits.lower, limits.upper);
            return Err(format!(
                "{}: row {row} (line {}): joint '{name}' = {v} is outside its limits [{lo}, {hi}]",
                path.display(),
                row + 2
            )
            .into());
        }
    }
    Ok(table)
}

pub(super) fn run(args: &PolicyArgs) -> Result<Outcome, Box<dyn std::error::Error>> {
    let reference = reference(args)?;
    let weights = TrackingWeights { position: args.q_weight, velocity: args.v_weight, control: args.r_weight };
    let schedule = if args.time_varying { GainSchedule::TimeVarying } else { GainSchedule::Constant };
    let slice = match args.plot {
        Some(_) => Some(parse_slice(&args.slice, reference.dof())?),
        None => None,
    };
    let policy = TrackingPolicy::new(reference, weights, schedule)?;
    let r = policy.reference();
    let k = policy.gain(0);
    println!(
        "reference: {} waypoints of {} joints, dt = {} s; gains {:?}: K(0) position {:.3}, velocity {:.3}",
        r.len(),
        r.dof(),
        r.dt(),
        schedule,
        k[(0, 0)],
        k[(0, r.dof())]
    );
    let starts = nearby_starts(r.position(0), 8);
    let steps = r.len() + (3.0 / r.dt()) as usize;
    let mut rollouts = Vec::new();
    let mut missed = 0;
    for start in &starts {
        let path = policy.rollout(start, steps)?;
        let miss = distance(path.last().map_or(start.as_slice(), Vec::as_slice), r.goal());
        let verdict = if miss <= args.goal_tolerance { "" } else { " — MISSED the goal" };
        missed += usize::from(miss > args.goal_tolerance || !miss.is_finite());
        println!(
            "  rollout from a start {:.3} rad off: ends {miss:.2e} rad from the goal{verdict}",
            distance(start, r.position(0))
        );
        rollouts.push(path);
    }
    report_query_time(&policy)?;
    if let (Some(file), Some((a, b))) = (&args.plot, slice) {
        std::fs::write(file, field_plot(&policy, &rollouts, a, b)?)
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        println!("wrote {}", file.display());
    }
    if missed > 0 {
        println!("{missed} of {} rollouts ended more than {} rad from the goal", starts.len(), args.goal_tolerance);
        return Ok(Outcome::Unsuccessful);
    }
    Ok(Outcome::Success)
}

/// Starts displaced from `q0` in a ring, in every joint, by up to 0.2 rad.
fn nearby_starts(q0: &[f64], count: usize) -> Vec<Vec<f64>> {
    (0..count)
        .map(|i| {
            let phase = std::f64::consts::TAU * i as f64 / count as f64;
            q0.iter().enumerate().map(|(j, q)| q + 0.2 * (phase + j as f64).sin()).collect()
        })
        .collect()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

fn report_query_time(policy: &TrackingPolicy) -> Result<(), ControlError> {
    let r = policy.reference();
    let mut ws = policy.workspace();
    let mut command = vec![0.0; r.dof()];
    let start = Instant::now();
    let n = 200_000;
    for i in 0..n {
        policy.query(&mut ws, r.position(i % r.len()), None, &mut command)?;
    }
    let ns = start.elapsed().as_secs_f64() * 1e9 / n as f64;
    println!("policy query: {ns:.0} ns per call over {n} calls (see `cargo bench --bench control` for medians)");
    Ok(())
}

fn parse_slice(text: &str, dof: usize) -> Result<(usize, usize), String> {
    let parts: Vec<usize> = text
        .split(',')
        .map(|s| s.trim().parse::<usize>().map_err(|_| format!("--slice: '{}' is not a joint number", s.trim())))
        .collect::<Result<_, _>>()?;
    match parts.as_slice() {
        [a, b] if *a >= 1 && *b >= 1 && *a <= dof && *b <= dof && a != b => Ok((a - 1, b - 1)),
        _ => Err(format!("--slice needs two different joint numbers between 1 and {dof}, got '{text}'")),
    }
}

/// Reference (dashed black), rollouts (one colour), starts and goal, and
/// the policy's commands as arrows around the path.
fn field_plot(
    policy: &TrackingPolicy,
    rollouts: &[Vec<Vec<f64>>],
    a: usize,
    b: usize,
) -> Result<String, Box<dyn std::error::Error>> {
    let r = policy.reference();
    let names = r.joints();
    let mut panel = Panel::new(
        "reference, rollouts, velocity field",
        &format!("{} (rad)", names[a]),
        &format!("{} (rad)", names[b]),
    );
    let project = |q: &[f64]| (q[a], q[b]);
    let mut starts = vec![];
    for (i, path) in rollouts.iter().enumerate() {
        let pts: Vec<(f64, f64)> = path.iter().map(|q| project(q)).collect();
        starts.extend(pts.first().copied());
        let rollout = Series::line("rollouts from nearby starts", &pts, 0);
        panel = panel.with(if i == 0 { rollout } else { rollout.unlabelled() });
    }
    let reference: Vec<(f64, f64)> = (0..r.len()).map(|i| project(r.position(i))).collect();
    panel = panel
        .with(Series::dashed("reference", &reference, Color::Reference))
        .with(Series::points("starts", &starts, Color::Reference))
        .with(Series::markers("goal", &[project(r.goal())], Color::Reference, Marker::Ring));
    // Policy commands on a lattice around the reference, arrows scaled so the
    // longest spans 6% of the reference's extent.
    let mut command = vec![0.0; r.dof()];
    let mut arrows = Vec::new();
    for i in (0..r.len()).step_by((r.len() / 12).max(1)) {
        for (da, db) in [(-0.15, -0.15), (-0.15, 0.15), (0.15, -0.15), (0.15, 0.15), (0.0, 0.0)] {
            let mut q = r.position(i).to_vec();
            q[a] += da;
            q[b] += db;
            // A fresh workspace per point: the field of an arm placed there.
            policy.query(&mut policy.workspace(), &q, None, &mut command)?;
            arrows.push((project(&q), (command[a], command[b])));
        }
    }
    let extent = reference.iter().fold(0.0f64, |m, p| m.max(distance(&[p.0, p.1], &[reference[0].0, reference[0].1])));
    let longest = arrows.iter().fold(0.0f64, |m, (_, v)| m.max(v.0.hypot(v.1))).max(1e-12);
    let scale = 0.06 * extent.max(0.1) / longest;
    let (from, by): (Vec<_>, Vec<_>) = arrows.into_iter().map(|(p, v)| (p, (scale * v.0, scale * v.1))).unzip();
    let field = Series { label: Some("policy command (scaled)".into()), ..Series::arrows(&from, &by, 1) };
    panel = panel.with(field);
    Ok(render_panels("LQR tracking policy", &[panel], 800, 600)?)
}
