//! What the page draws, as JSON: the scene once per episode ([`SceneView`]:
//! the robot's collision shapes per link, obstacles, objects, goals and
//! their reference paths), then the state at up to 60 Hz ([`StateView`]:
//! link poses, commands, beliefs, status, timing, the metric's ellipsoid).
//! Poses are `[x, y, z, qx, qy, qz, qw]` (m, unit quaternion), world frame.

use crate::arbitration::{Arbiter, ArbiterWorkspace, ArbitrationMode, ProblemGoal};
use crate::problem::Problem;
use crate::robot::{FrameId, Geometry, KinematicsWorkspace, RobotModel};
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, Matrix3, SymmetricEigen, UnitQuaternion};
use serde::Serialize;

/// One collision shape and its pose (in its link's frame for robot links,
/// in the world for obstacles and objects).
#[derive(Debug, Clone, Serialize)]
pub struct ShapeView {
    /// The geometry.
    #[serde(flatten)]
    pub geometry: GeometryView,
    /// `[x, y, z, qx, qy, qz, qw]`.
    pub pose: [f64; 7],
}

/// A shape's geometry (m); cylinders and capsules along their z axis.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum GeometryView {
    /// Full side lengths.
    Box {
        /// Full side lengths along x, y, z (m).
        size: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A cylinder along its z axis.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Full length (m).
        length: f64,
    },
    /// A capsule along its z axis (the cylinder part's length).
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Full length of the cylinder part (m).
        length: f64,
    },
    /// A triangle mesh: xyz triples and index triples.
    Mesh {
        /// Vertex coordinates (m, shape frame).
        vertices: Vec<f32>,
        /// Triangle vertex indices.
        indices: Vec<u32>,
    },
    /// A convex hull, by its points (the page builds the hull).
    Hull {
        /// xyz triples.
        points: Vec<f32>,
    },
    /// A point cloud's balls: their centres and one radius.
    Points {
        /// xyz triples (m, shape frame).
        points: Vec<f32>,
        /// Radius of every ball (m).
        radius: f64,
    },
}

/// A robot link's shapes.
#[derive(Debug, Clone, Serialize)]
pub struct LinkView {
    /// The link's name.
    pub name: String,
    /// Its collision shapes, posed in the link frame.
    pub shapes: Vec<ShapeView>,
}

/// A named world shape (obstacle or object).
#[derive(Debug, Clone, Serialize)]
pub struct BodyView {
    /// Its name.
    pub name: String,
    /// Its shape and world pose.
    pub shape: ShapeView,
}

/// A goal: its name, its point (m, world) and the gripper's path along its
/// optimized reference.
#[derive(Debug, Clone, Serialize)]
pub struct GoalView {
    /// The goal's name.
    pub name: String,
    /// The goal point.
    pub position: [f64; 3],
    /// Gripper positions along the reference.
    pub reference: Vec<[f64; 3]>,
}

/// The scene of one episode.
#[derive(Debug, Clone, Serialize)]
pub struct SceneView {
    /// The task (`reach-grasp`, `planar`).
    pub task: &'static str,
    /// The problem's name.
    pub problem: String,
    /// The task's seed.
    pub seed: u64,
    /// The modes this episode can run (their command-line names).
    pub modes: Vec<&'static str>,
    /// The current mode.
    pub mode: &'static str,
    /// The active joints, the order of [`StateView::q`].
    pub joints: Vec<String>,
    /// Control rate (Hz).
    pub rate_hz: f64,
    /// Whether the arm moves in the horizontal plane only (a top view suits it).
    pub planar: bool,
    /// The robot's links with collision shapes, in the order of
    /// [`StateView::links`].
    pub links: Vec<LinkView>,
    /// Fixed obstacles.
    pub obstacles: Vec<BodyView>,
    /// Objects (grasp targets).
    pub objects: Vec<BodyView>,
    /// The goals.
    pub goals: Vec<GoalView>,
}

/// The state after a tick.
#[derive(Debug, Clone, Default, Serialize)]
pub struct StateView {
    /// Simulated time since the episode started (s).
    pub time: f64,
    /// Ticks run.
    pub steps: usize,
    /// The configuration (rad or m, [`SceneView::joints`] order).
    pub q: Vec<f64>,
    /// World poses of [`SceneView::links`].
    pub links: Vec<[f64; 7]>,
    /// Gripper position (m).
    pub gripper: [f64; 3],
    /// The gripper frame's pose: the page draws the gripper's outline
    /// there (the robot's own geometry is collision spheres only).
    pub gripper_pose: [f64; 7],
    /// The operator's last command (m/s; after the speed clamp).
    pub human: [f64; 3],
    /// The executed gripper velocity `J q̇` (m/s).
    pub executed: [f64; 3],
    /// Beliefs over the goals.
    pub beliefs: Vec<f64>,
    /// The tick's status (`nominal`, `constrained`, `invalid_command`, …),
    /// or `waiting` before the operator's first command (the episode's
    /// clock has not started).
    pub status: &'static str,
    /// The mode that ran the tick; while `waiting`, the one that will.
    pub mode: &'static str,
    /// Wall-clock time of the arbiter's tick (µs).
    pub tick_us: f64,
    /// Signed distance to the nearest obstacle (m; `null` without obstacles).
    pub clearance: f64,
    /// The pair at that distance: the robot link, then the obstacle or
    /// object (`null` without obstacles).
    pub nearest: Option<[String; 2]>,
    /// Smallest clearance of the episode so far (m).
    pub min_clearance: f64,
    /// The metric's ellipsoid at the gripper: its three semi-axes (m/s per
    /// unit of metric norm, world axes), from `J W⁻¹ Jᵀ` of the gripper's
    /// linear Jacobian `J` and the tick's joint metric `W`.
    pub ellipsoid: [[f64; 3]; 3],
    /// How the episode ended (`success`, `collision`, `timeout`, `failed`),
    /// or `null` while it runs.
    pub outcome: Option<&'static str>,
    /// Why it ended, by name ([`Reason::as_str`](crate::sim::Reason::as_str):
    /// `success`, `collision`, `timeout`, `stopped_short`,
    /// `orientation_off`, …), or `null` while it runs.
    pub reason: Option<&'static str>,
    /// Why it ended, in words ([`Reason`](crate::sim::Reason)'s `Display`:
    /// `panda_hand touched table`, `time ran out 4.2 cm from the goal`), or
    /// `null` while it runs.
    pub reason_detail: Option<String>,
    /// Whether the operator's commands stopped arriving (the arm holds).
    pub stale_command: bool,
    /// Commands received and messages rejected in this session.
    pub commands: u64,
    /// Messages rejected (malformed or unknown).
    pub rejected: u64,
    /// Time from receiving the command this tick used to queueing this state (µs).
    pub latency_us: f64,
}

/// `[x, y, z, qx, qy, qz, qw]` of a pose.
pub fn pose7(pose: &IsometryMatrix3<f64>) -> [f64; 7] {
    let q = UnitQuaternion::from_rotation_matrix(&pose.rotation);
    let t = pose.translation.vector;
    [t.x, t.y, t.z, q.i, q.j, q.k, q.w]
}

fn robot_geometry(geometry: &Geometry) -> Option<GeometryView> {
    Some(match geometry {
        Geometry::Box { half_extents } => GeometryView::Box { size: (half_extents * 2.0).into() },
        Geometry::Sphere { radius } => GeometryView::Sphere { radius: *radius },
        Geometry::Cylinder { radius, length } => GeometryView::Cylinder { radius: *radius, length: *length },
        Geometry::Capsule { radius, length } => GeometryView::Capsule { radius: *radius, length: *length },
        Geometry::Mesh { mesh, .. } => GeometryView::Mesh {
            vertices: mesh.vertices.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
            indices: mesh.triangles.iter().flatten().copied().collect(),
        },
        Geometry::UnreadableMesh { .. } => return None,
    })
}

fn world_geometry(shape: &Shape) -> GeometryView {
    match shape {
        Shape::Box { half_extents } => GeometryView::Box { size: (half_extents * 2.0).into() },
        Shape::Sphere { radius } => GeometryView::Sphere { radius: *radius },
        Shape::Cylinder { radius, half_length } => {
            GeometryView::Cylinder { radius: *radius, length: 2.0 * half_length }
        }
        Shape::Capsule { radius, half_length } => GeometryView::Capsule { radius: *radius, length: 2.0 * half_length },
        Shape::Convex(hull) => {
            GeometryView::Hull { points: hull.points().into_iter().flat_map(|p| p.map(|v| v as f32)).collect() }
        }
        Shape::Points { points, radius } => GeometryView::Points {
            points: points.points().flat_map(|(p, _)| p.map(|v| v as f32)).collect(),
            radius: *radius,
        },
    }
}

/// The links with collision shapes (of the problem's collision geometry
/// when it has one) and their frames in `robot`.
pub(crate) fn robot_links(problem: &Problem) -> (Vec<LinkView>, Vec<FrameId>) {
    let description = problem.collision_geometry.as_ref().unwrap_or(problem.robot.description());
    let mut links = vec![];
    let mut frames = vec![];
    for link in description.links() {
        let Ok(frame) = problem.robot.frame_id(&link.name) else { continue };
        let shapes: Vec<ShapeView> = link
            .collisions
            .iter()
            .filter_map(|c| robot_geometry(&c.geometry).map(|geometry| ShapeView { geometry, pose: pose7(&c.origin) }))
            .collect();
        if !shapes.is_empty() {
            links.push(LinkView { name: link.name.clone(), shapes });
            frames.push(frame);
        }
    }
    (links, frames)
}

/// Gripper positions along a goal's reference.
fn reference_path(arbiter: &Arbiter, goal: &ProblemGoal) -> Vec<[f64; 3]> {
    let robot = arbiter.robot();
    let mut kin = KinematicsWorkspace::new(robot);
    goal.solution
        .trajectory
        .iter()
        .filter_map(|q| {
            robot.forward_kinematics(&mut kin, q).ok()?;
            Some(robot.frame_position(&kin, arbiter.gripper_frame()).into())
        })
        .collect()
}

/// Everything [`SceneView::new`] reads.
pub(crate) struct SceneParts<'a> {
    pub task: &'static str,
    pub seed: u64,
    pub problem: &'a Problem,
    pub goals: &'a [ProblemGoal],
    pub arbiter: &'a Arbiter,
    pub modes: &'a [ArbitrationMode],
    pub mode: ArbitrationMode,
    pub links: Vec<LinkView>,
}

impl SceneView {
    pub(crate) fn new(parts: SceneParts<'_>) -> SceneView {
        let body = |name: &str, shape: &Shape, pose: &IsometryMatrix3<f64>| BodyView {
            name: name.to_string(),
            shape: ShapeView { geometry: world_geometry(shape), pose: pose7(pose) },
        };
        let scene = &parts.problem.scene;
        SceneView {
            task: parts.task,
            problem: parts.problem.name.clone(),
            seed: parts.seed,
            modes: parts.modes.iter().map(ArbitrationMode::as_str).collect(),
            mode: parts.mode.as_str(),
            joints: parts.problem.robot.joint_names().to_vec(),
            rate_hz: 1.0 / parts.arbiter.settings().period,
            planar: parts.task == "planar",
            links: parts.links,
            obstacles: scene.obstacles().iter().map(|o| body(&o.name, &o.shape, &o.pose)).collect(),
            objects: scene.objects().iter().map(|o| body(&o.name, &o.shape, &o.pose)).collect(),
            goals: parts
                .goals
                .iter()
                .map(|g| GoalView {
                    name: g.name.clone(),
                    position: g.position,
                    reference: reference_path(parts.arbiter, g),
                })
                .collect(),
        }
    }
}

/// The ellipsoid `{J u : uᵀ W u ≤ 1}` of gripper velocities a unit of the
/// metric `W` buys, as semi-axes (columns of `V √Λ` for `J W⁻¹ Jᵀ = V Λ Vᵀ`).
/// `w_inverse` is `W⁻¹` (n × n, row-major); `jacobian` the linear rows
/// (3 × n, row-major).
pub fn metric_ellipsoid(jacobian: &[f64], w_inverse: &[f64], n: usize) -> [[f64; 3]; 3] {
    let mut s = Matrix3::zeros();
    for r in 0..3 {
        for c in 0..3 {
            let mut v = 0.0;
            for i in 0..n {
                let row: f64 = (0..n).map(|j| w_inverse[i * n + j] * jacobian[c * n + j]).sum();
                v += jacobian[r * n + i] * row;
            }
            s[(r, c)] = v;
        }
    }
    if !s.iter().all(|v| v.is_finite()) {
        return [[0.0; 3]; 3];
    }
    let eig = SymmetricEigen::new(s);
    std::array::from_fn(|k| {
        let length = eig.eigenvalues[k].max(0.0).sqrt();
        [0, 1, 2].map(|r| eig.eigenvectors[(r, k)] * length)
    })
}

/// Link poses of `frames` at the last forward kinematics of `kin`.
pub(crate) fn link_poses(robot: &RobotModel, kin: &KinematicsWorkspace, frames: &[FrameId], out: &mut Vec<[f64; 7]>) {
    out.clear();
    out.extend(frames.iter().map(|&f| pose7(&robot.frame_pose(kin, f))));
}

/// The metric's ellipsoid after the last tick of `ws`: the task-space
/// Fisher metric in `NaturalGradient(Task)`, the joint metric otherwise.
pub(crate) fn tick_ellipsoid(ws: &ArbiterWorkspace, mode: ArbitrationMode) -> [[f64; 3]; 3] {
    let jac = ws.jacobian();
    let n = jac.ncols();
    if matches!(mode, ArbitrationMode::NaturalGradient(crate::arbitration::MetricSpace::Task))
        && ws.task_metric().dim() == 3
    {
        let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        return metric_ellipsoid(&identity, ws.task_metric().inverse(), 3);
    }
    let linear: Vec<f64> = (0..3).flat_map(|r| (0..n).map(move |c| (r, c))).map(|(r, c)| jac[(r, c)]).collect();
    if ws.metric().dim() != n {
        return [[0.0; 3]; 3];
    }
    metric_ellipsoid(&linear, ws.metric().inverse(), n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ellipsoid_of_the_identity_metric_is_the_manipulability_ellipsoid() {
        // J = diag(1, 2, 0) padded to 4 joints: semi-axes 1, 2, 0 along x, y, z.
        let n = 4;
        let mut j = vec![0.0; 3 * n];
        j[0] = 1.0;
        j[n + 1] = 2.0;
        let w_inv: Vec<f64> = (0..n * n).map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 }).collect();
        let axes = metric_ellipsoid(&j, &w_inv, n);
        let mut lengths: Vec<f64> = axes.iter().map(|a| a.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
        lengths.sort_by(f64::total_cmp);
        assert!((lengths[0]).abs() < 1e-12 && (lengths[1] - 1.0).abs() < 1e-12 && (lengths[2] - 2.0).abs() < 1e-12);
        // A metric twice as expensive along joint 1 shrinks that axis by √2.
        let mut w_inv2 = w_inv.clone();
        w_inv2[n + 1] = 0.5;
        let axes = metric_ellipsoid(&j, &w_inv2, n);
        let y = axes.iter().map(|a| a[1].abs()).fold(0.0, f64::max);
        assert!((y - 2.0 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(metric_ellipsoid(&[f64::NAN; 12], &w_inv, n), [[0.0; 3]; 3]);
    }
}
