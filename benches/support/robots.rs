//! MotionBenchMaker-style problems for robots unlike the Panda: a 6-DOF UR5,
//! a TIAGo whose planning group includes its prismatic torso lift, and a
//! Baxter planning both arms at once (sphere models and SRDFs in
//! problems/robots/, made by scripts/spherize_robot.py).
//!
//! Each problem is written as MoveIt files (a planning scene YAML and a
//! motion plan request YAML) and loaded with `Problem::from_moveit`, as
//! MotionBenchMaker's are. Families, as MotionBenchMaker's: `table` (a
//! table with clutter, the goal just above it), `shelf` (a bookshelf, the
//! goal inside a bin) and `cage` (a box cage open at the front, the goal
//! inside). Obstacle placement is jittered per problem. Start and goal are
//! seeded samples, 1 mm clear of everything, every frame above the robot's
//! mount. The start lies within 0.4 rad per joint of the robot's home pose
//! (as MotionBenchMaker starts from a ready pose) with its tool(s) outside
//! the goal region. The goal is a grasp, as MotionBenchMaker's are: a tool
//! position drawn in the region (for the dual arm, the left tool in the
//! left half and the right tool in the right half), the tool's approach
//! axis within 0.5 rad of pointing down onto the table or forward into the
//! shelf and cage, any roll, solved by IK from a seed near home (one
//! descent per grasp, as a MotionBenchMaker goal is solved from its ready
//! pose). A grasp is kept when its solution lies within a half-turn of
//! its seed in every joint (MoveIt's consistency limits) and its tool can
//! be withdrawn along its approach axis out of the region (an approachable
//! grasp, its goal reachable from outside the furniture). The straight
//! line between start and goal is in collision when one of 50 starts
//! gives that. [`Goals::Joint`] draws goals in joint
//! space instead (the first generator, kept for comparison).
//! Everything follows from (robot, family, index): same problems on every
//! machine.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tandem::collision::CollisionWorkspace;
use tandem::plan::{IkSettings, IkTarget, solve_ik};
use tandem::problem::Problem;
use tandem::robot::{KinematicsWorkspace, RobotModel};

/// The problem families.
pub const FAMILIES: [&str; 3] = ["table", "shelf", "cage"];

/// A robot of the benchmark.
pub struct BenchRobot {
    /// Short name (also the folder under problems/robots/).
    pub name: &'static str,
    /// The SRDF planning group.
    pub group: &'static str,
    /// Tool frames whose position the goal region constrains, with the side
    /// (y sign) each must be on: 0 for either.
    pub tools: &'static [(&'static str, f64)],
    /// The tool frames' approach axis (0 = x, 1 = y, 2 = z): the one a
    /// grasp points at the object.
    pub tool_axis: usize,
    /// Joints outside the group, held at these values (rad or m).
    held: &'static [(&'static str, f64)],
    /// The work point in front of the robot (m, URDF root frame) and the
    /// scale of the furniture (1 for a Panda-sized reach).
    work: [f64; 3],
    scale: f64,
    /// What the robot stands on (a pedestal, the floor): a box of this size
    /// and centre (m) in every scene, allowed to touch the named link.
    mount: Option<([f64; 3], [f64; 3], &'static str)>,
    /// The home pose (joint name, value), near which starts are drawn, as
    /// MotionBenchMaker starts from a fixed ready pose.
    home: &'static [(&'static str, f64)],
    /// Lowest height (m) any frame may take in a start or goal: the arm
    /// works above its mount, as a real cell's would.
    min_height: f64,
}

/// The three robots.
pub const ROBOTS: [BenchRobot; 3] = [
    BenchRobot {
        name: "ur5",
        group: "manipulator",
        tools: &[("tool0", 0.0)],
        tool_axis: 2,
        held: &[],
        work: [0.5, 0.0, 0.0],
        scale: 1.0,
        mount: Some(([0.2, 0.2, 1.0], [0.0, 0.0, -0.505], "base_link")),
        home: &[
            ("shoulder_pan_joint", 0.0),
            ("shoulder_lift_joint", -1.57),
            ("elbow_joint", 1.57),
            ("wrist_1_joint", -1.57),
            ("wrist_2_joint", -1.57),
            ("wrist_3_joint", 0.0),
        ],
        min_height: -0.05,
    },
    BenchRobot {
        name: "tiago",
        group: "arm_torso",
        tools: &[("arm_tool_link", 0.0)],
        tool_axis: 0,
        held: &[("head_1_joint", 0.0), ("head_2_joint", 0.0)],
        work: [0.6, -0.15, 0.8],
        scale: 1.0,
        mount: Some(([3.0, 3.0, 0.02], [0.0, 0.0, -0.011], "base_link")),
        home: &[
            ("torso_lift_joint", 0.15),
            ("arm_1_joint", 0.2),
            ("arm_2_joint", -1.34),
            ("arm_3_joint", -0.2),
            ("arm_4_joint", 1.94),
            ("arm_5_joint", -1.57),
            ("arm_6_joint", 1.37),
            ("arm_7_joint", 0.0),
        ],
        min_height: 0.0,
    },
    BenchRobot {
        name: "baxter",
        group: "both_arms",
        tools: &[("left_gripper", 1.0), ("right_gripper", -1.0)],
        tool_axis: 2,
        held: &[],
        work: [0.65, 0.0, 0.0],
        scale: 1.3,
        mount: None,
        home: &[
            ("left_s0", 0.0),
            ("left_s1", -0.55),
            ("left_e0", 0.0),
            ("left_e1", 0.75),
            ("left_w0", 0.0),
            ("left_w1", 1.26),
            ("left_w2", 0.0),
            ("right_s0", 0.0),
            ("right_s1", -0.55),
            ("right_e0", 0.0),
            ("right_e1", 0.75),
            ("right_w0", 0.0),
            ("right_w1", 1.26),
            ("right_w2", 0.0),
        ],
        min_height: -1.0,
    },
];

impl BenchRobot {
    fn folder(&self) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/robots").join(self.name)
    }

    /// The sphere-model URDF.
    pub fn urdf(&self) -> PathBuf {
        self.folder().join(format!("{}_spheres.urdf", self.name))
    }

    /// The ready pose's value of joint `name` (rad or m).
    pub fn home_value(&self, name: &str) -> Option<f64> {
        self.home.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }

    /// The SRDF.
    pub fn srdf(&self) -> PathBuf {
        self.folder().join(format!("{}.srdf", self.name))
    }
}

/// An axis-aligned box obstacle: name, size and centre (m).
struct Block {
    name: String,
    size: [f64; 3],
    center: [f64; 3],
}

/// Axis-aligned region (m): lower and upper corners.
type Region = ([f64; 3], [f64; 3]);

fn block(name: &str, size: [f64; 3], center: [f64; 3]) -> Block {
    Block { name: name.to_string(), size, center }
}

/// The obstacles of problem `rng`'s draw of `family` and its goal region.
fn furniture(robot: &BenchRobot, family: &str, rng: &mut ChaCha8Rng) -> (Vec<Block>, Region) {
    let s = robot.scale;
    let mut jitter = |w: f64| rng.random_range(-w..=w);
    let [wx, wy, wz] = robot.work;
    let (x, y, z) = (wx + jitter(0.05 * s), wy + jitter(0.05 * s), wz + jitter(0.05 * s));
    match family {
        "table" => {
            let top = z - 0.15 * s;
            let mut blocks = vec![block("table", [0.6 * s, 1.2 * s, 0.04], [x, y, top - 0.02])];
            for k in 0..3 {
                let h = 0.08 + jitter(0.04);
                let at = [x + jitter(0.22 * s), y + jitter(0.5 * s), top + h / 2.0];
                blocks.push(block(&format!("clutter{k}"), [0.06 + jitter(0.02), 0.06 + jitter(0.02), h], at));
            }
            (blocks, ([x - 0.25 * s, y - 0.5 * s, top + 0.05], [x + 0.25 * s, y + 0.5 * s, top + 0.25 * s]))
        }
        "shelf" => {
            let (depth, width, front) = (0.35 * s, 1.1 * s, x);
            let cx = front + depth / 2.0;
            let mut blocks = vec![
                block("back", [0.02, width, 1.0 * s], [front + depth, y, z]),
                block("side_left", [depth, 0.02, 1.0 * s], [cx, y + width / 2.0, z]),
                block("side_right", [depth, 0.02, 1.0 * s], [cx, y - width / 2.0, z]),
            ];
            for (k, dz) in [-0.5, -0.15, 0.2, 0.5].iter().enumerate() {
                blocks.push(block(&format!("board{k}"), [depth, width, 0.02], [cx, y, z + dz * s]));
            }
            // The middle bin, between boards 1 and 2.
            let lo = [front + 0.02, y - width / 2.0 + 0.06, z - 0.15 * s + 0.05];
            let hi = [front + depth - 0.08, y + width / 2.0 - 0.06, z + 0.2 * s - 0.06];
            (blocks, (lo, hi))
        }
        _ => {
            let (half, height) = (0.3 * s, 0.45 * s);
            let (floor, roof) = (z - height / 2.0, z + height / 2.0);
            let blocks = vec![
                block("floor", [2.0 * half, 2.0 * half, 0.02], [x + half, y, floor]),
                block("roof", [2.0 * half, 2.0 * half, 0.02], [x + half, y, roof]),
                block("back", [0.02, 2.0 * half, height], [x + 2.0 * half, y, z]),
                block("wall_left", [2.0 * half, 0.02, height], [x + half, y + half, z]),
                block("wall_right", [2.0 * half, 0.02, height], [x + half, y - half, z]),
                block("bar_left", [0.03, 0.03, height], [x, y + 0.55 * half, z]),
                block("bar_right", [0.03, 0.03, height], [x, y - 0.55 * half, z]),
            ];
            let lo = [x + 0.1 * s, y - half + 0.08, floor + 0.06];
            let hi = [x + 2.0 * half - 0.1, y + half - 0.08, roof - 0.06];
            (blocks, (lo, hi))
        }
    }
}

fn scene_yaml(blocks: &[Block], robot: &BenchRobot) -> String {
    let mut out = String::from("name: generated\n");
    if let Some((_, _, link)) = robot.mount {
        out += &format!(
            "allowed_collision_matrix:\n  entry_names: [{link}, mount]\n  entry_values:\n    - enabled: [false, true]\n    - enabled: [true, false]\n"
        );
    }
    out += "world:\n  collision_objects:\n";
    for b in blocks {
        let [sx, sy, sz] = b.size;
        let [x, y, z] = b.center;
        out += &format!(
            "    - id: {}\n      header: {{frame_id: ''}}\n      primitives: [{{type: box, dimensions: [{sx}, {sy}, {sz}]}}]\n      primitive_poses: [{{position: [{x}, {y}, {z}], orientation: [0, 0, 0, 1]}}]\n",
            b.name
        );
    }
    out
}

fn request_yaml(group: &str, start: &[(String, f64)], goal: &[(String, f64)]) -> String {
    let names: Vec<&str> = start.iter().map(|(n, _)| n.as_str()).collect();
    let values: Vec<String> = start.iter().map(|(_, v)| format!("{v}")).collect();
    let mut out = format!(
        "group_name: {group}\nstart_state:\n  joint_state:\n    name: [{}]\n    position: [{}]\ngoal_constraints:\n  - joint_constraints:\n",
        names.join(", "),
        values.join(", ")
    );
    for (n, v) in goal {
        out += &format!(
            "      - {{joint_name: {n}, position: {v}, tolerance_above: 0.0001, tolerance_below: 0.0001, weight: 1.0}}\n"
        );
    }
    out
}

/// How far (rad or m per joint) starts may lie from the home pose, and
/// joint-space goals (one IK branch, as the ready pose would seed).
const START_SPREAD: f64 = 0.4;
const GOAL_SPREAD: f64 = 1.6;

/// How goals are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Goals {
    /// A grasp solved by IK, as MotionBenchMaker's are (the default).
    Grasp,
    /// Uniform within 1.6 rad per joint of home with the tool(s) in the
    /// region: any orientation, so often a contorted pose in a pocket
    /// (the benchmark's first generator, kept for comparison).
    Joint,
}

/// How far (rad or m per joint) from home a goal's IK starts.
pub const IK_SEED_SPREAD: f64 = 0.3;

/// Largest angle (rad) between a grasp's approach and its family's direction.
pub const APPROACH_TILT: f64 = 0.5;

/// A grasp's withdrawal (see `Sampler::withdraws`): step along the
/// approach axis (m), largest joint motion per step (rad or m), and how
/// far outside the goal region the tool must get (m).
const RETREAT_STEP: f64 = 0.01;
const RETREAT_JOINT_STEP: f64 = 0.2;
const RETREAT_MARGIN: f64 = 0.05;

/// Draws of a problem's scene before it is given up.
pub const SCENE_DRAWS: usize = 200;

/// Grasps tried for a goal before the scene is drawn again.
const GOAL_DRAWS: usize = 400;

/// A random offset perpendicular to the unit `approach`, at most
/// tan([`APPROACH_TILT`]) long (uniform in that disc): added to the
/// approach, it tilts it by at most [`APPROACH_TILT`].
fn tilt(rng: &mut ChaCha8Rng, approach: &Vector3<f64>) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.random_range(-1.0..=1.0));
        let across = v - approach * approach.dot(&v);
        if across.norm() <= 1.0 {
            return across * APPROACH_TILT.tan();
        }
    }
}

/// The direction a grasp approaches its object in `family`: from above on
/// the table, from the front into the shelf and the cage.
pub fn approach(family: &str) -> Vector3<f64> {
    if family == "table" { -Vector3::z() } else { Vector3::x() }
}

/// Whether every joint of `a` is within `limit` (rad or m) of `b`'s.
fn within(a: &[f64], b: &[f64], limit: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= limit)
}

/// IK settings of one damped least-squares descent from the given seed.
fn one_descent() -> IkSettings {
    IkSettings { restarts: 1, ..IkSettings::default() }
}

/// Rejection sampler of start and goal configurations.
struct Sampler<'a> {
    problem: &'a Problem,
    robot: &'a RobotModel,
    model: tandem::collision::CollisionModel,
    ws: CollisionWorkspace,
    kin: KinematicsWorkspace,
    tools: Vec<(tandem::robot::FrameId, f64)>,
    tool_axis: usize,
    home: Vec<f64>,
    min_height: f64,
}

impl Sampler<'_> {
    /// Uniform within `spread` of the home pose and within the limits.
    fn random(&self, rng: &mut ChaCha8Rng, spread: f64) -> Vec<f64> {
        let limits = self.problem.robot.limits().iter().zip(&self.home);
        limits.map(|(l, h)| rng.random_range((h - spread).max(l.lower)..=(h + spread).min(l.upper))).collect()
    }

    /// Whether every tool is inside `region` (on its side), or none is.
    fn tools_in(&mut self, q: &[f64], region: &Region) -> (bool, bool) {
        self.robot.forward_kinematics(&mut self.kin, q).expect("fk");
        self.robot.update_frame_placements(&mut self.kin);
        let low = self.robot.frame_ids().any(|f| self.robot.frame_pose(&self.kin, f).translation.z < self.min_height);
        if low {
            return (false, true);
        }
        let (mut all, mut any) = (true, false);
        for &(frame, side) in &self.tools {
            let p = self.robot.frame_pose(&self.kin, frame).translation.vector;
            let mid = 0.5 * (region.0[1] + region.1[1]);
            let on_side = side == 0.0 || (p.y - mid) * side > 0.05;
            let inside = (0..3).all(|i| p[i] >= region.0[i] && p[i] <= region.1[i]) && on_side;
            all &= inside;
            any |= (0..3).all(|i| p[i] >= region.0[i] && p[i] <= region.1[i]);
        }
        (all, any)
    }

    /// Collision-free with the planner's clearance to spare (1 mm: the
    /// planner certifies with half a millimetre).
    fn free(&mut self, q: &[f64]) -> bool {
        self.model.collision_free(&mut self.ws, q).expect("check")
            && self.model.min_distance(&mut self.ws, q).expect("distance").is_none_or(|d| d.signed.distance >= 1e-3)
    }

    /// A free configuration within `spread` of home with every tool inside
    /// `region` (`inside`: a joint-space goal, see [`Goals::Joint`]) or
    /// none inside (a start).
    fn sample(&mut self, rng: &mut ChaCha8Rng, region: &Region, spread: f64, inside: bool) -> Option<Vec<f64>> {
        for _ in 0..200_000 {
            let q = self.random(rng, spread);
            let (all, any) = self.tools_in(&q, region);
            if (inside && all || !inside && !any) && self.free(&q) {
                return Some(q);
            }
        }
        None
    }

    /// A free goal as MotionBenchMaker makes one: each tool's grasp (a
    /// point of its side of `region`, the tool's approach axis along
    /// `approach`, any roll) solved by IK from a seed near home, tools one
    /// after the other.
    fn goal(&mut self, rng: &mut ChaCha8Rng, region: &Region, approach: Vector3<f64>) -> Option<Vec<f64>> {
        let mid = 0.5 * (region.0[1] + region.1[1]);
        'draw: for _ in 0..GOAL_DRAWS {
            let mut q = self.random(rng, IK_SEED_SPREAD);
            for (frame, side) in self.tools.clone() {
                let (lo_y, hi_y) = match side {
                    s if s > 0.0 => (mid + 0.05, region.1[1]),
                    s if s < 0.0 => (region.0[1], mid - 0.05),
                    _ => (region.0[1], region.1[1]),
                };
                let y = rng.random_range(lo_y..=hi_y);
                let [x, z] = [0, 2].map(|i| rng.random_range(region.0[i]..=region.1[i]));
                // Grasps vary around an object: the approach tilts up to
                // APPROACH_TILT off the family's direction.
                let direction = (approach + tilt(rng, &approach)).normalize();
                let target = IkTarget {
                    frame,
                    position: Vector3::new(x, y, z),
                    orientation: None,
                    axis_alignment: Some((self.tool_axis, direction)),
                };
                // MoveIt's consistency limits: a solution more than a
                // half-turn from its seed in some joint lies on a branch
                // the ready pose does not pick.
                match solve_ik(&self.model, &mut self.ws, &target, &q, 1, &one_descent()) {
                    Ok(mut solutions) if within(&solutions[0], &q, std::f64::consts::PI) => {
                        q = solutions.swap_remove(0)
                    }
                    _ => continue 'draw,
                }
                if !self.withdraws(target, &q, region) {
                    continue 'draw;
                }
            }
            if self.tools_in(&q, region).0 && self.free(&q) {
                return Some(q);
            }
        }
        None
    }

    /// Whether the tool of `grasp`, solved as `q`, can be withdrawn along
    /// its approach axis until it is [`RETREAT_MARGIN`] outside `region`:
    /// IK steps of [`RETREAT_STEP`] from the previous solution, each
    /// collision-free and none moving a joint more than
    /// [`RETREAT_JOINT_STEP`] (a continuous motion, not a jump to another
    /// branch). A grasp that cannot be approached is not one a robot can
    /// take, and a goal whose tool cannot leave its pocket without a joint
    /// passing its limit is not reachable from outside at all.
    fn withdraws(&mut self, grasp: IkTarget, q: &[f64], region: &Region) -> bool {
        let Some((_, direction)) = grasp.axis_alignment else { return true };
        let (mut target, mut q) = (grasp, q.to_vec());
        let outside = |p: &Vector3<f64>| {
            (0..3).any(|i| p[i] < region.0[i] - RETREAT_MARGIN || p[i] > region.1[i] + RETREAT_MARGIN)
        };
        while !outside(&target.position) {
            target.position -= direction * RETREAT_STEP;
            let Ok(mut solutions) = solve_ik(&self.model, &mut self.ws, &target, &q, 1, &one_descent()) else {
                return false;
            };
            let next = solutions.swap_remove(0);
            if !within(&next, &q, RETREAT_JOINT_STEP) {
                return false;
            }
            q = next;
        }
        true
    }
}

/// Problem `k` of `family` for `robot` with `goals`, written into `dir` and loaded;
/// `None` when [`SCENE_DRAWS`] draws of the scene gave no start and goal.
pub fn problem(robot: &BenchRobot, family: &str, k: u64, goals: Goals, dir: &Path) -> Option<Problem> {
    let family_index = FAMILIES.iter().position(|f| *f == family).expect("family") as u64;
    let robot_index = ROBOTS.iter().position(|r| r.name == robot.name).expect("robot") as u64;
    let mut rng = ChaCha8Rng::seed_from_u64(0x7a6d_0000 + robot_index * 1_000_000 + family_index * 10_000 + k);
    let base = dir.join(format!("{}_{family}_{k:04}", robot.name));
    let (scene, request) = (base.with_extension("scene.yaml"), base.with_extension("request.yaml"));
    for _draw in 0..SCENE_DRAWS {
        let (mut blocks, region) = furniture(robot, family, &mut rng);
        if let Some((size, center, _)) = robot.mount {
            blocks.push(block("mount", size, center));
        }
        std::fs::write(&scene, scene_yaml(&blocks, robot)).expect("write scene");
        // A placeholder request (the held joints and the group at 0) to build the checker.
        let desc = tandem::robot::RobotDescription::from_urdf_file(robot.urdf(), &Default::default()).expect("urdf");
        let srdf = tandem::robot::Srdf::from_srdf_file(robot.srdf()).expect("srdf");
        let selection = srdf.joint_selection(robot.group).expect("group");
        let model = RobotModel::builder(Arc::new(desc)).selection(selection).build().expect("model");
        let zero: Vec<(String, f64)> = model
            .joint_names()
            .iter()
            .zip(model.limits())
            .map(|(n, l)| (n.clone(), 0.0f64.clamp(l.lower, l.upper)))
            .chain(robot.held.iter().map(|(n, v)| (n.to_string(), *v)))
            .collect();
        let group: Vec<(String, f64)> = zero[..model.nq()].to_vec();
        std::fs::write(&request, request_yaml(robot.group, &zero, &group)).expect("write request");
        let placeholder = Problem::from_moveit(&robot.urdf(), &robot.srdf(), &scene, &request).expect("problem");
        let collision = placeholder.collision_model().expect("collision model");
        let tools = robot.tools.iter().map(|(f, side)| (model.frame_id(f).expect("tool frame"), *side)).collect();
        let mut sampler = Sampler {
            problem: &placeholder,
            robot: &model,
            ws: CollisionWorkspace::new(&collision),
            model: collision,
            kin: KinematicsWorkspace::new(&model),
            tools,
            tool_axis: robot.tool_axis,
            home: model.joint_names().iter().map(|n| robot.home_value(n).expect("home value")).collect(),
            min_height: robot.min_height,
        };
        let goal = match goals {
            Goals::Grasp => sampler.goal(&mut rng, &region, approach(family)),
            Goals::Joint => sampler.sample(&mut rng, &region, GOAL_SPREAD, true),
        };
        let Some(goal) = goal else { continue };
        // A start the straight line to the goal does not reach, if one of
        // 50 draws is; else the last (a direct problem, as some of
        // MotionBenchMaker's are).
        let mut found = None;
        for _ in 0..50 {
            let Some(start) = sampler.sample(&mut rng, &region, START_SPREAD, false) else { break };
            let mut ws = CollisionWorkspace::new(&sampler.model);
            let direct = sampler.model.motion_free(&mut ws, &start, &goal, 0.01).expect("motion check");
            found = Some(start);
            if !direct {
                break;
            }
        }
        let Some(start) = found else { continue };
        let named =
            |q: &[f64]| -> Vec<(String, f64)> { model.joint_names().iter().cloned().zip(q.iter().copied()).collect() };
        let mut start_state = named(&start);
        start_state.extend(robot.held.iter().map(|(n, v)| (n.to_string(), *v)));
        std::fs::write(&request, request_yaml(robot.group, &start_state, &named(&goal))).expect("write request");
        return Some(Problem::from_moveit(&robot.urdf(), &robot.srdf(), &scene, &request).expect("problem"));
    }
    None
}
