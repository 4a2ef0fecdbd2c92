//! `tandem ros2`: the shared-control node on a ROS 2 system.

use super::refusal::{or_goal_refusal, start_refusal};
use crate::arbitration::{Arbiter, ArbiterSettings, GoalObjects, GoalSettings, problem_goals};
use crate::ros2::{GoalPreparer, NodeSettings, run_node};
use serde_json::json;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Arguments of `tandem ros2`.
#[derive(Debug, clap::Args)]
pub struct Ros2Args {
    /// Problem file, or builtin:NAME: the robot, the scene it keeps clear
    /// of, and the goals (each object with the goal's grasp frame gets an
    /// optimized reference and an LQR tracking policy before the node starts).
    #[arg(default_value = "builtin:panda_grasp_box")]
    pub problem: PathBuf,
    /// The node's parameters file (YAML; `docs/ros2.md` lists every key).
    /// Without it, the defaults: 100 Hz, mode sos, MoveIt Servo's topics.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Point clouds added to the problem's scene.
    #[command(flatten)]
    pub clouds: super::PointCloudArgs,
    /// The trained arbitration actor for mode `learned` (`tandem learn arbitration`).
    #[arg(long, value_name = "FILE")]
    pub arbiter: Option<PathBuf>,
    /// Seed of the planner that seeds each goal's reference.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Stop after this many seconds (0.1 to 1e6; by default the node runs
    /// until SIGINT or SIGTERM).
    #[arg(long, value_name = "S", value_parser = |s: &str| super::number_in(s, 0.1..=1e6))]
    pub duration: Option<f64>,
    /// Print the start line and the final report as JSON objects (one per
    /// line): {"ready": true, "node", "joints", "gripper_frame",
    /// "root_frame", "start", "graspable": [{"name", "position", "orientation" (x, y, z,
    /// w)}] (what a PoseArray on the goals topic places, in order), "goals": [{"name", "position"}], "mode", "rate_hz"}
    /// once every topic exists, then {"ticks", "late_ticks", "published",
    /// "unreadable", "tick_us": {"median", "p99", "max"}, "dropped_log_lines",
    /// "suppressed_log_lines", "stalls", "longest_stall_s", "mode_messages",
    /// "poses_unchanged", "replans", "point_clouds", "point_clouds_refused",
    /// "stopped_before_start"} at the end (also
    /// when stopped before the loop started: no start line then).
    #[arg(long)]
    pub json: bool,
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn request_stop(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

/// Runs the node until stopped; [`Outcome::Unsuccessful`](super::Outcome)
/// (exit 3) when the problem has no solution (start or goal invalid).
pub(super) fn run(args: &Ros2Args) -> Result<super::Outcome, Box<dyn std::error::Error>> {
    // First of all: a stop while the goals are planned, or while the node
    // waits for /robot_description, is a stop like any other (exit 0 and
    // the report), not the default action's death by signal.
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, request_stop as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, request_stop as *const () as libc::sighandler_t);
    }
    let settings = match &args.config {
        Some(path) => NodeSettings::from_file(path)?,
        None => NodeSettings::default(),
    };
    let mut problem = super::problem_args::load(&args.problem, &args.clouds)?;
    if let Some(limits) = &settings.joint_limits {
        // The node's parameter over the problem's `[robot] joint_limits`.
        let mut robot = (*problem.robot).clone();
        crate::problem::apply_joint_limits(&mut robot, limits, |f| crate::problem::JointLimitsFile::read(f)).map_err(
            |e| {
                let config = args.config.as_deref().unwrap_or(std::path::Path::new("")).display();
                format!("{config}: joint_limits: {e}")
            },
        )?;
        problem.robot = std::sync::Arc::new(robot);
        problem.robot_spec.joint_limits = Some(limits.clone());
    }
    if let Some(refusal) = start_refusal(&problem)? {
        eprintln!("{}: no node ({}): {}", problem.name, refusal.status, refusal.reason);
        return Ok(super::Outcome::Unsuccessful);
    }
    let options = GoalSettings { seed: Some(args.seed), objects: GoalObjects::AllGraspable, ..GoalSettings::default() };
    let goals = match or_goal_refusal(problem_goals(&problem, &options))? {
        Ok(goals) => goals,
        Err(refusal) => {
            eprintln!("{}: no node ({}): {}", problem.name, refusal.status, refusal.reason);
            return Ok(super::Outcome::Unsuccessful);
        }
    };
    let arbiter_settings = settings.arbiter_settings(&ArbiterSettings::default());
    let mut arbiter = Arbiter::for_problem(&problem, &goals, arbiter_settings)?;
    let mut actor: Option<std::sync::Arc<dyn crate::arbitration::ArbitrationPolicy>> = None;
    if let Some(path) = &args.arbiter {
        let loaded = std::sync::Arc::new(crate::learn::ArbitrationActor::load(path)?);
        arbiter = arbiter.with_arbitration_policy(loaded.clone())?;
        actor = Some(loaded);
    }
    let preparer = GoalPreparer::new(problem.clone(), args.seed, arbiter_settings, actor);
    let mut control = crate::ros2::ControlLoop::new(&arbiter, &settings)?;
    let robot = arbiter.robot();
    let ready = json!({
        "ready": true,
        "node": format!("{}/{}", settings.namespace.trim_end_matches('/'), settings.node_name),
        "joints": robot.joint_names(),
        "gripper_frame": robot.frame_name(arbiter.gripper_frame()),
        "root_frame": robot.description().root_link(),
        "start": problem.start,
        "graspable": preparer.graspable().iter().filter_map(|name| problem.scene.object(name)).map(|o| {
            let q = nalgebra::UnitQuaternion::from_rotation_matrix(&o.pose.rotation);
            json!({"name": o.name, "position": o.pose.translation.vector.as_slice(), "orientation": [q.i, q.j, q.k, q.w]})
        }).collect::<Vec<_>>(),
        "goals": goals.iter().map(|g| json!({"name": g.name, "position": g.position})).collect::<Vec<_>>(),
        "mode": settings.mode.as_str(),
        "rate_hz": settings.rate_hz,
    });
    let json = args.json;
    let duration = args.duration.map(Duration::from_secs_f64);
    let report = run_node(&mut control, &settings, &STOP, duration, Some(preparer), || {
        if json {
            println!("{ready}");
        } else {
            println!(
                "tandem ros2: node {} on domain {} at {} Hz, mode {}, {} goal(s); reading {} and {}, writing {}",
                ready["node"].as_str().unwrap_or_default(),
                settings.domain_id,
                settings.rate_hz,
                settings.mode,
                goals.len(),
                settings.joint_topic,
                settings.cartesian_command_in_topic,
                settings.command_out_topic
            );
        }
    })?;
    let [median, p99, max] = report.tick_us;
    if json {
        println!(
            "{}",
            json!({
                "ticks": report.ticks,
                "late_ticks": report.late_ticks,
                "published": report.published,
                "unreadable": report.unreadable,
                "tick_us": {"median": median, "p99": p99, "max": max},
                "dropped_log_lines": report.dropped_log_lines,
                "suppressed_log_lines": report.suppressed_log_lines,
                "stalls": report.stalls,
                "longest_stall_s": report.longest_stall_s,
                "mode_messages": report.mode_messages,
                "poses_unchanged": report.poses_unchanged,
                "replans": report.replans,
                "point_clouds": report.point_clouds,
                "point_clouds_refused": report.point_clouds_refused,
                "stopped_before_start": report.stopped_before_start,
            })
        );
    } else {
        println!(
            "tandem ros2: {} ticks ({} late), {} commands published, {} unreadable messages; tick median {median:.1} µs, p99 {p99:.1} µs; \
             log lines {} dropped, {} suppressed; {} stall(s){}",
            report.ticks,
            report.late_ticks,
            report.published,
            report.unreadable,
            report.dropped_log_lines,
            report.suppressed_log_lines,
            report.stalls,
            if report.stopped_before_start { "; stopped before the loop started" } else { "" }
        );
    }
    Ok(super::Outcome::Success)
}
