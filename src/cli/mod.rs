//! The `tandem` command line: argument types and the subcommands.
//!
//! Kept in the library so integration tests and later front ends share it;
//! `src/bin/tandem.rs` only parses arguments and maps errors to exit codes.
//!
//! ```
//! use clap::Parser;
//! use tandem::cli::Cli;
//! let cli = Cli::try_parse_from(["tandem", "fk", "robot.urdf", "--frame", "tool0", "--q", "0,0.5"]).unwrap();
//! # let _ = cli;
//! ```

mod arbiter_args;
mod arbitrate;
mod check;
mod demo;
mod experiment;
mod experiment_policy;
mod experiment_traded;
mod generate;
mod harness;
mod inspect;
mod kinematics;
mod learn;
mod learned_arbitration;
mod plan;
mod policy;
mod problem_args;
mod refusal;
#[cfg(feature = "ros2")]
mod ros2;
mod serve;
mod solve;

pub use problem_args::{MoveItArgs, PointCloudArgs, ProblemArgs};

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// What a command that ran to its end found, beside the output it printed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It succeeded: exit status [`EXIT_SUCCESS`].
    Success,
    /// It ran, but the answer is "no" (a collision, no path, no converged
    /// trajectory, a rollout that missed the goal): exit status
    /// [`EXIT_UNSUCCESSFUL`].
    Unsuccessful,
}

/// Exit status of a command that succeeded.
pub const EXIT_SUCCESS: u8 = 0;
/// Exit status of an error: an input file or argument value that is
/// invalid (the message names the file, key, line or value), or I/O that failed.
pub const EXIT_ERROR: u8 = 1;
/// Exit status of a command line that does not parse: an unknown option,
/// a missing argument, a value of the wrong type or outside its documented
/// range (clap's usage errors).
pub const EXIT_USAGE: u8 = 2;
/// Exit status of a command that ran but did not succeed: `check` found a
/// collision (at the configuration, or at a joint goal); `plan` found no
/// path (start or goal invalid, time or iteration limit); `solve` did not
/// converge to a collision-free trajectory within limits; `policy` had a
/// rollout end farther from the goal than its tolerance.
pub const EXIT_UNSUCCESSFUL: u8 = 3;

/// tandem — motion for human-robot shared control.
///
/// Loads robots from URDF and computes exact kinematics (frame placements
/// and Jacobians cross-checked against Pinocchio to 3e-13), LQR tracking
/// policies, collision checks, plans and optimized trajectories of problem
/// files (signed distances cross-checked against coal). Every command
/// prints human-readable text by default and one JSON object with --json
/// where offered. Errors go to stderr with the file, element, line and
/// value at fault.
///
/// Exit status: 0 success; 1 an invalid input file or argument value, or
/// failed I/O; 2 a command line that does not parse (unknown option,
/// missing argument, value outside its range); 3 the command ran but did
/// not succeed (check: a collision; plan: no path; solve: not converged,
/// colliding or outside limits; policy: a rollout missed the goal).
#[derive(Debug, Parser)]
#[command(name = "tandem", version, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand to run.
    pub command: Command,
}

/// Options shared by the commands that load a URDF.
#[derive(Debug, Clone, clap::Args)]
pub struct UrdfArgs {
    /// Path of the URDF file. Meshes referenced as package://PKG/… are looked
    /// up in each --package-dir, in $ROS_PACKAGE_PATH, and in the folders
    /// above the URDF named PKG; relative mesh paths are relative to the URDF.
    pub urdf: PathBuf,
    /// A folder containing packages (repeatable), e.g. the `share` folder of
    /// an install.
    #[arg(long = "package-dir", value_name = "DIR")]
    pub package_dirs: Vec<PathBuf>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the main job on the embedded default robot (the Franka Panda):
    /// shared control of a reach-and-grasp of a box on a table. A simulated
    /// operator drives the gripper under every arbitration mode, one
    /// episode each: outcome and reason, tick time, hard-limit violations,
    /// clearance. Then the robot's reference behind it (planned, optimized,
    /// checked) and the files in --out: shared_control.svg (the gripper's
    /// paths), path.svg and joints.svg (the reference), trajectory.csv and
    /// .parquet. --verbose adds a kinematics timing and a clearance sweep.
    ///
    /// Example: tandem demo
    Demo(demo::DemoArgs),
    /// Describe a URDF: the kinematic tree, joints with types, axes and
    /// limits, frames, collision geometry, whether it takes the sphere fast
    /// path (and what would), and problems found in the file. With --srdf,
    /// also the planning groups' joints and the SRDF entries naming what
    /// the URDF lacks (warnings: left out, as MoveIt does).
    ///
    /// Examples:
    ///   tandem inspect problems/robots/panda/panda.urdf
    ///   tandem inspect problems/motionbenchmaker/panda_spherized.urdf
    ///     --srdf problems/motionbenchmaker/panda.srdf
    #[command(verbatim_doc_comment)]
    Inspect(inspect::InspectArgs),
    /// Pose and geometric Jacobian of a frame at a configuration.
    ///
    /// The Jacobian is 6 × n, linear rows (m/s per unit joint velocity) then
    /// angular rows (rad/s), world-aligned by default: velocities of the
    /// frame origin expressed in the axes of the URDF root link.
    ///
    /// Example (the embedded Panda's 7 arm joints and finger joint 1):
    ///   tandem fk problems/robots/panda/panda.urdf --frame panda_hand_tcp
    ///     --q 0,-0.785,0,-2.356,0,1.571,0.785,0.04 --json
    #[command(verbatim_doc_comment)]
    Fk(kinematics::FkArgs),
    /// Build an LQR tracking policy (the dissertation's Algorithm 1) for a joint
    /// reference, roll it out from perturbed starts, time its queries and
    /// optionally plot it (Fig. 3.9 style).
    ///
    /// The reference defaults to a 3 s minimum-jerk motion of the embedded
    /// Panda; --reference takes a trajectory CSV as `tandem solve --out`
    /// writes it (header `time,<joint>,…`, the start first, evenly spaced
    /// times), whose joints must be joints of the robot (--urdf, default
    /// the embedded Panda), within their limits. Exit status 3 when a
    /// rollout ends farther than --goal-tolerance from the goal.
    ///
    /// Examples:
    ///   tandem policy --time-varying --plot policy.svg
    ///   tandem solve builtin:panda_reach_obstacle --out out/ && tandem policy --reference out/trajectory.csv
    #[command(verbatim_doc_comment)]
    Policy(policy::PolicyArgs),
    /// Validate a problem file and check a configuration for collisions.
    ///
    /// Loads the problem (robot, SRDF, scene, start, goal, settings; any
    /// error names the file, key and line), builds its collision model and
    /// reports, for the start configuration or --q (within the joint
    /// limits), whether it is collision-free, the minimum signed distance
    /// and the closest pair of bodies, and every colliding pair. Exit
    /// status 3 when the configuration (or a joint goal) collides.
    ///
    /// A family file (a `base` key; format in problems/README.md) is
    /// validated with its base problem, and its first --samples members
    /// are drawn and checked the same way.
    ///
    /// Examples:
    ///   tandem check problems/panda_grasp_box.toml
    ///   tandem check problems/panda_grasp_family.toml --samples 5
    ///   tandem check builtin:panda_reach_obstacle --q 0,0,0,-1.5,0,1.5,0 --json
    ///   tandem check --urdf panda_spherized.urdf --srdf panda.srdf
    ///     --scene scene0001.yaml --request request0001.yaml
    #[command(verbatim_doc_comment)]
    Check(check::CheckArgs),
    /// Plan a collision-free joint-space path with RRT-Connect, then
    /// shortcut it.
    ///
    /// Pose and grasp goals are solved by inverse kinematics first (several
    /// collision-free solutions form the goal set). Settings come from the
    /// problem file's planner table; the same seed gives the same path. Exit
    /// status 3 when no path is found (the reason is printed).
    ///
    /// Examples:
    ///   tandem plan problems/panda_reach_obstacle.toml --seed 3 --svg path.svg
    ///   tandem plan --urdf panda_spherized.urdf --srdf panda.srdf
    ///     --scene scene0001.yaml --request request0001.yaml --json
    #[command(verbatim_doc_comment)]
    Plan(plan::PlanArgs),
    /// Plan with RRT-Connect, then optimize a smooth, collision-free
    /// trajectory (KOMO-style: k-order sum of squares with constraints).
    ///
    /// The objectives come from the problem's [[optimizer.objectives]]
    /// (format: problems/README.md); without any (e.g. MoveIt inputs) the
    /// optimizer minimises acceleration subject to joint limits, collision
    /// avoidance and reaching the goal at rest. The result is validated by
    /// checking the motion between slices at fine resolution. Trajectories
    /// are printed and written with the start configuration first (time 0).
    /// Exit status 3 unless "status" is "converged".
    ///
    /// Examples:
    ///   tandem solve problems/panda_grasp_box.toml --out results/
    ///   tandem solve builtin:panda_reach_obstacle -T 20 --json
    ///   tandem solve --urdf panda_spherized.urdf --srdf panda.srdf
    ///     --scene scene0001.yaml --request request0001.yaml --json
    #[command(verbatim_doc_comment)]
    Solve(solve::SolveArgs),
    /// Generate a dataset of optimized trajectories from a problem family:
    /// sample problems 0 … N−1 (start, object pose, obstacles), then IK →
    /// RRT-Connect → optimizer → validation (collision-free between slices
    /// at 2 mrad, within limits, q_T within 1 mm / 10 mrad of the goal) on
    /// every core, and write the accepted trajectories to Parquet part
    /// files with a JSON manifest (layout and columns: src/data/schema.rs;
    /// read the folder with pyarrow.parquet.read_table(DIR)). Rejected
    /// samples are counted by reason; a failed grasp is retried with the
    /// grasp turned by π about its approach axis (the same grasp for a
    /// parallel gripper).
    ///
    /// The dataset depends on the family, --count, --seed, -T,
    /// --chunk-size, --attempts and --max-evaluations only: not on
    /// --threads or --shard, nor on machine load. A killed run loses
    /// nothing but its unfinished part files: re-run the same command to
    /// complete it. A bar (on a terminal) or a line every 10 s shows
    /// progress.
    ///
    /// Examples:
    ///   tandem generate --family problems/panda_grasp_family.toml --count 1000 --out grasps/
    ///   tandem generate --family problems/panda_grasp_family.toml --count 100000 -T 50
    ///     --seed 7 --out grasps/ --shard 0/4        (and 1/4, 2/4, 3/4 elsewhere)
    #[command(verbatim_doc_comment)]
    Generate(generate::GenerateArgs),
    /// Run one shared-control episode: a simulated operator drives the arm
    /// through the arbiter, which blends the operator's command with LQR
    /// tracking policies of optimized references (one per graspable object)
    /// under hard constraints (joint limits, velocity limits, distances),
    /// at 15 Hz in the kinematic simulator, with a collision check each step.
    ///
    /// The episode ends in success (a grasp: the box between the finger
    /// pads, the fingertip centre over it, the gripper within 0.2 rad of the
    /// grasp's approach axis, palm and fingers clear; a reach: within 1 cm),
    /// collision, timeout (30 s), or failed: the operator stopped where the
    /// task is not done. Every ending has a reason, printed and in --json
    /// ("reason"): success, collision (with the pair), timeout (with the
    /// distance left), stopped_short (with the distance), orientation_off
    /// (with the angle), not_between_pads, outside_footprint,
    /// touching_object, judge_declined. Exit status 3 unless it succeeds.
    /// Reports the tick time (median, p99, max), hard-constraint violations
    /// (should be 0), the smallest clearance and the fallbacks.
    ///
    /// Examples:
    ///   tandem arbitrate --mode constrained --operator straightline
    ///   tandem arbitrate problems/planar_pick.toml --mode natural-gradient-joint --plot episode.svg
    ///   tandem arbitrate builtin:panda_grasp_box --mode sos --json
    #[command(verbatim_doc_comment)]
    Arbitrate(arbitrate::ArbitrateArgs),
    /// Train networks: `tandem learn policy --data DIR --out
    /// policy.safetensors` fits the robot policy network to a dataset
    /// (§3.3.3 of the dissertation); `tandem learn arbitration --out
    /// arbiter.safetensors` trains an arbitration actor with DDPG (chapter
    /// 6). See `tandem learn <name> --help`.
    Learn(learn::LearnArgs),
    /// Run the dissertation's experiments with simulated operators:
    /// reach-grasp (Table 5.1), planar (Table 4.1), policy (the learned
    /// policy alone and under shared control, §3.3.3), learned (the learned
    /// arbiters, Table 6.1) and traded (traded control from predicted
    /// intent, Table 7.3). See `tandem experiment <name> --help`.
    Experiment(experiment::ExperimentArgs),
    /// Drive the arm yourself from a browser: a local web server with a
    /// live shared-control page (3-D view of the robot, the scene, the
    /// reference and the metric's ellipsoid; beliefs, tick time, status
    /// and clearance as you drive). Steer the gripper with a gamepad or the
    /// keyboard (W/S: ±x, A/D: ±y, R/F: ±z; arrow keys too), pick the task
    /// (reach-grasp, planar) and the arbitration mode, and reset. The
    /// simulator and the arbiter run in the server at --rate (30 Hz, the
    /// dissertation's joystick rate); each driven episode is saved as Parquet in
    /// the simulator's layout, to compare with the simulated operators'.
    ///
    /// A page that disconnects or stops sending holds the arm (after
    /// 0.5 s); malformed, binary or oversized (> 4 KiB) messages are
    /// refused with a message on the page; NaN commands make the arbiter
    /// hold. /stats reports tick and latency percentiles as JSON.
    ///
    /// Examples:
    ///   tandem serve                       (then open http://127.0.0.1:8080/)
    ///   tandem serve --task planar --mode natural-gradient-joint
    ///   tandem serve --rate 1000 --port 0
    ///   tandem serve --task planar --arbiter combined.safetensors --mode learned
    #[command(verbatim_doc_comment)]
    Serve(serve::ServeArgs),
    /// Run the shared-control node on a ROS 2 system, where MoveIt Servo
    /// runs: it reads Servo's twist and joint commands and /joint_states,
    /// blends them with the problem's goals under the arbitration mode, and
    /// writes a JointTrajectory (or a Float64MultiArray of positions or
    /// velocities) for ros2_control's controllers, a status code per tick
    /// (Servo's codes, and tandem's own), the beliefs and diagnostics. The
    /// mode is a ROS 2 parameter (`ros2 param set /tandem mode constrained`).
    /// No ROS installation is needed: the node speaks DDS itself. Parameters:
    /// docs/ros2.md. Runs until SIGINT or SIGTERM (or --duration); exit 3 when
    /// the problem's start or goal is invalid.
    ///
    /// Examples:
    ///   tandem ros2
    ///   tandem ros2 builtin:panda_grasp_box --config node.yaml
    #[cfg(feature = "ros2")]
    #[command(verbatim_doc_comment)]
    Ros2(ros2::Ros2Args),
}

/// Runs a parsed command line, writing results to stdout.
///
/// # Errors
/// Any error of the command, ready to print (exit status [`EXIT_ERROR`]).
pub fn run(cli: Cli) -> Result<Outcome, Box<dyn std::error::Error>> {
    let done = |r: Result<(), Box<dyn std::error::Error>>| r.map(|()| Outcome::Success);
    match cli.command {
        Command::Demo(args) => done(demo::run(&args)),
        Command::Inspect(args) => done(inspect::run(&args)),
        Command::Fk(args) => done(kinematics::run(&args)),
        Command::Policy(args) => policy::run(&args),
        Command::Check(args) => check::run(&args),
        Command::Plan(args) => plan::run(&args),
        Command::Solve(args) => solve::run(&args),
        Command::Generate(args) => done(generate::run(&args)),
        Command::Arbitrate(args) => arbitrate::run(&args),
        Command::Learn(args) => done(learn::run(&args)),
        Command::Experiment(args) => done(experiment::run(&args)),
        Command::Serve(args) => done(serve::run(&args)),
        #[cfg(feature = "ros2")]
        Command::Ros2(args) => ros2::run(&args),
    }
}

/// Parses a number within `range` for an option, naming the range in the error.
pub(crate) fn number_in<T>(text: &str, range: std::ops::RangeInclusive<T>) -> Result<T, String>
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display,
{
    let value: T = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if range.contains(&value) {
        Ok(value)
    } else {
        // The value as typed: 1e300 printed back would be 301 digits.
        Err(format!("{} is outside the allowed range [{}, {}]", text.trim(), range.start(), range.end()))
    }
}

impl UrdfArgs {
    /// Loads the URDF with the requested search path.
    pub fn load(&self) -> Result<crate::robot::RobotDescription, crate::robot::RobotError> {
        let search = crate::robot::MeshSearchPath::new(self.package_dirs.clone()).with_ros_package_path();
        crate::robot::RobotDescription::from_urdf_file(&self.urdf, &search)
    }
}
