//! Goals from the ROS 2 system: a `geometry_msgs/PoseArray` of the
//! graspable objects' poses (from a perception node, say) places the
//! problem's graspable objects, and each gets a new reference and tracking
//! policy from the arm's measured configuration. The preparation runs on a
//! thread of its own (hundreds of milliseconds for the Panda); the loop
//! keeps ticking with the goals it has until the new arbiter is ready.
//! Poses equal to those the goals are planned for (within
//! [`POSITION_TOLERANCE`] and [`ANGLE_TOLERANCE`]) are not re-planned: a
//! perception node republishing the same poses at 30 Hz re-planned every
//! goal each time and reset the intent estimate ([`GoalPoses`]).

use super::log::Echo;
use super::messages::{Point, Pose, PoseArray, Quaternion as RosQuaternion};
use crate::arbitration::{Arbiter, ArbiterSettings, ArbitrationPolicy, GoalObjects, GoalSettings, problem_goals};
use crate::problem::{Goal, Problem};
use nalgebra::{IsometryMatrix3, Quaternion, Translation3, UnitQuaternion};
use std::sync::Arc;

/// Makes arbiters for new object poses: the problem, the planner's seed,
/// the arbiter's settings and the learned arbitration actor, if any.
#[derive(Clone)]
pub struct GoalPreparer {
    problem: Problem,
    seed: u64,
    settings: ArbiterSettings,
    actor: Option<Arc<dyn ArbitrationPolicy>>,
}

impl GoalPreparer {
    /// A preparer for `problem`'s graspable objects.
    pub fn new(
        problem: Problem,
        seed: u64,
        settings: ArbiterSettings,
        actor: Option<Arc<dyn ArbitrationPolicy>>,
    ) -> GoalPreparer {
        GoalPreparer { problem, seed, settings, actor }
    }

    /// The problem the goals are prepared in (objects at the problem's poses).
    pub fn problem(&self) -> &Problem {
        &self.problem
    }

    /// The objects a PoseArray places, in order: the problem's objects
    /// with its goal's grasp frame (the goal alone when it is not a grasp).
    pub fn graspable(&self) -> Vec<String> {
        graspable(&self.problem)
    }

    /// The graspable objects' poses in the problem (root frame), in order:
    /// what the goals are planned for before any PoseArray.
    pub fn problem_poses(&self) -> Vec<Pose> {
        self.graspable()
            .iter()
            .filter_map(|name| self.problem.scene.object(name))
            .map(|o| {
                let t = o.pose.translation.vector;
                let q = UnitQuaternion::from_rotation_matrix(&o.pose.rotation);
                Pose {
                    position: Point { x: t.x, y: t.y, z: t.z },
                    orientation: RosQuaternion { x: q.i, y: q.j, z: q.k, w: q.w },
                }
            })
            .collect()
    }

    /// An arbiter whose goals are the graspable objects at `poses` (in the
    /// robot's root frame: `frame` empty or the root link), the references
    /// planned from `start`.
    ///
    /// # Errors
    /// Another frame, a count other than the graspable objects', a pose
    /// that is not finite or whose quaternion is not unit (within 1e-3), a
    /// start or goal without a solution (the reason), arbiter errors.
    pub fn prepare(&self, poses: &PoseArray, start: &[f64]) -> Result<Arbiter, String> {
        self.prepare_around(poses, start, None).map(|(arbiter, _)| arbiter)
    }

    /// [`prepare`](Self::prepare) with `cloud` (a camera's points as an
    /// obstacle) in the scene: the references are planned around it and
    /// the arbiter's constraints keep it. Also returns the problem with
    /// the objects at their new poses, without the cloud.
    ///
    /// # Errors
    /// As [`prepare`](Self::prepare).
    pub fn prepare_around(
        &self,
        poses: &PoseArray,
        start: &[f64],
        cloud: Option<&crate::scene::Obstacle>,
    ) -> Result<(Arbiter, Problem), String> {
        let root = self.problem.robot.description().root_link();
        let frame = poses.header.frame_id.as_str();
        if !(frame.is_empty() || frame == root) {
            return Err(format!("poses in frame '{}': give them in the robot's root frame '{root}'", Echo(frame)));
        }
        let objects = self.graspable();
        if poses.poses.len() != objects.len() {
            return Err(format!(
                "{} pose(s) for {} graspable object(s) ({})",
                poses.poses.len(),
                objects.len(),
                objects.join(", ")
            ));
        }
        let mut problem = self.problem.clone();
        for (k, (name, pose)) in objects.iter().zip(&poses.poses).enumerate() {
            let o = pose.orientation;
            let norm = (o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w).sqrt();
            if !(norm - 1.0).abs().le(&1e-3) {
                return Err(format!("pose {k}: the quaternion's norm is {norm}, not 1"));
            }
            let p = pose.position;
            let rotation = UnitQuaternion::from_quaternion(Quaternion::new(o.w, o.x, o.y, o.z)).to_rotation_matrix();
            let placed = IsometryMatrix3::from_parts(Translation3::new(p.x, p.y, p.z), rotation);
            problem.scene.set_object_pose(name, placed).map_err(|e| format!("pose {k} ({name}): {e}"))?;
        }
        problem.start = start.to_vec();
        let placed = problem.clone();
        if let Some(cloud) = cloud {
            problem.scene.add_obstacle(cloud.clone()).map_err(|e| e.to_string())?;
        }
        let options =
            GoalSettings { seed: Some(self.seed), objects: GoalObjects::AllGraspable, ..GoalSettings::default() };
        let goals = problem_goals(&problem, &options).map_err(|e| e.to_string())?;
        let mut arbiter = Arbiter::for_problem(&problem, &goals, self.settings).map_err(|e| e.to_string())?;
        if let Some(actor) = &self.actor {
            arbiter = arbiter.with_arbitration_policy(actor.clone()).map_err(|e| e.to_string())?;
        }
        Ok((arbiter, placed))
    }
}

/// Largest distance between two positions of an object that count as the
/// same pose (m): well under the grasp's tolerance and a perception node's
/// noise floor is not re-planned for.
pub const POSITION_TOLERANCE: f64 = 1e-3;
/// Largest rotation between two orientations of an object that count as
/// the same pose (rad; 0.5°).
pub const ANGLE_TOLERANCE: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// Whether `a` and `b` place every object at the same pose, within the
/// tolerances (NaN is never the same; quaternions of any norm compared by
/// their directions, `q` and `−q` alike).
pub fn same_poses(a: &[Pose], b: &[Pose]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(p, q)| {
            let (u, v) = (p.position, q.position);
            let d = ((u.x - v.x).powi(2) + (u.y - v.y).powi(2) + (u.z - v.z).powi(2)).sqrt();
            let (r, s) = (p.orientation, q.orientation);
            let norms = ((r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w)
                * (s.x * s.x + s.y * s.y + s.z * s.z + s.w * s.w))
                .sqrt();
            let cos_half = ((r.x * s.x + r.y * s.y + r.z * s.z + r.w * s.w) / norms).abs().min(1.0);
            d <= POSITION_TOLERANCE && 2.0 * cos_half.acos() <= ANGLE_TOLERANCE
        })
}

/// The poses the goals are planned for, the ones being planned for (at
/// most one preparation in flight) and the latest waiting: a PoseArray
/// equal to what the goals will be once the preparation in flight is done
/// is dropped (the goals and the beliefs stay); others replace the waiting
/// one, the latest wins.
#[derive(Debug, Clone)]
pub struct GoalPoses {
    root: String,
    applied: Vec<Pose>,
    in_flight: Option<Vec<Pose>>,
    waiting: Option<PoseArray>,
    /// Arrays dropped as unchanged.
    pub unchanged: u64,
    /// Preparations started.
    pub started: u64,
}

impl GoalPoses {
    /// The goals planned for `applied` (root frame `root`).
    pub fn new(root: &str, applied: Vec<Pose>) -> GoalPoses {
        GoalPoses { root: root.to_string(), applied, in_flight: None, waiting: None, unchanged: 0, started: 0 }
    }

    /// A PoseArray arrived; returns whether it waits to be planned for.
    pub fn arrived(&mut self, poses: PoseArray) -> bool {
        let frame = poses.header.frame_id.as_str();
        let target = self.in_flight.as_ref().unwrap_or(&self.applied);
        if (frame.is_empty() || frame == self.root) && same_poses(&poses.poses, target) {
            self.unchanged += 1;
            self.waiting = None;
            return false;
        }
        self.waiting = Some(poses);
        true
    }

    /// The poses to prepare now: the waiting ones, when none are in flight.
    pub fn start(&mut self) -> Option<PoseArray> {
        if self.in_flight.is_some() {
            return None;
        }
        let poses = self.waiting.take()?;
        self.in_flight = Some(poses.poses.clone());
        self.started += 1;
        Some(poses)
    }

    /// The preparation in flight ended: its poses are the goals' when `applied`.
    pub fn finished(&mut self, applied: bool) {
        if let Some(poses) = self.in_flight.take()
            && applied
        {
            self.applied = poses;
        }
    }

    /// Whether a preparation is in flight.
    pub fn preparing(&self) -> bool {
        self.in_flight.is_some()
    }
}

/// The problem's objects with its goal's grasp frame, in scene order.
fn graspable(problem: &Problem) -> Vec<String> {
    match &problem.goal {
        Goal::Grasp { grasp, .. } => problem
            .scene
            .objects()
            .iter()
            .filter(|o| o.grasps.iter().any(|g| &g.name == grasp))
            .map(|o| o.name.clone())
            .collect(),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::messages::{Header, Point, Pose, Quaternion as RosQuaternion};

    #[test]
    fn poses_place_the_graspable_objects_and_bad_ones_are_named() {
        let problem = Problem::builtin("panda_grasp_box").unwrap();
        let start = problem.start.clone();
        let preparer = GoalPreparer::new(problem.clone(), 0, ArbiterSettings::default(), None);
        assert_eq!(preparer.graspable(), vec!["box".to_string()]);
        let box_pose = problem.scene.object("box").unwrap().pose;
        let t = box_pose.translation.vector;
        let q = UnitQuaternion::from_rotation_matrix(&box_pose.rotation);
        let moved = |dy: f64, frame: &str, count: usize| PoseArray {
            header: Header { frame_id: frame.into(), ..Header::default() },
            poses: vec![
                Pose {
                    position: Point { x: t.x, y: t.y + dy, z: t.z },
                    orientation: RosQuaternion { x: q.i, y: q.j, z: q.k, w: q.w },
                };
                count
            ],
        };
        let before = Arbiter::for_problem(
            &problem,
            &problem_goals(&problem, &GoalSettings { seed: Some(0), ..GoalSettings::default() }).unwrap(),
            ArbiterSettings::default(),
        )
        .unwrap()
        .goals()[0]
            .position;
        let arbiter = preparer.prepare(&moved(0.05, "panda_link0", 1), &start).unwrap();
        let after = arbiter.goals()[0].position;
        // The grasp point moves with the box (the optimizer reaches it to ~1e-4 m).
        assert!((after[1] - before[1] - 0.05).abs() < 2e-3, "{before:?} -> {after:?}");
        assert!((after[0] - before[0]).abs() < 2e-3 && (after[2] - before[2]).abs() < 2e-3);
        for (poses, says) in [
            (moved(0.0, "camera_link", 1), "give them in the robot's root frame 'panda_link0'"),
            (moved(0.0, "", 2), "2 pose(s) for 1 graspable object(s) (box)"),
        ] {
            let e = preparer.prepare(&poses, &start).err().unwrap();
            assert!(e.contains(says), "{e}");
        }
        let mut bad = moved(0.0, "", 1);
        bad.poses[0].orientation.w = 3.0;
        assert!(preparer.prepare(&bad, &start).err().unwrap().contains("norm"));
        bad.poses[0].orientation = RosQuaternion::default();
        bad.poses[0].position.x = f64::NAN;
        assert!(preparer.prepare(&bad, &start).is_err());
        // Out of reach: the reason comes back, nothing panics.
        let far = moved(5.0, "", 1);
        assert!(preparer.prepare(&far, &start).is_err());
        // A frame name of any length is echoed cut.
        let e = preparer.prepare(&moved(0.0, &"x".repeat(100_000), 1), &start).err().unwrap();
        assert!(e.len() < 300 && e.contains("(100000 bytes)"), "{e}");
    }

    /// Unchanged poses (within the tolerances, `q` or `−q`) are dropped;
    /// changed ones wait, the latest wins, one preparation at a time, and
    /// the goals take the poses only when it succeeded.
    #[test]
    fn unchanged_poses_are_not_re_planned_and_changed_ones_coalesce() {
        let problem = Problem::builtin("panda_grasp_box").unwrap();
        let preparer = GoalPreparer::new(problem, 0, ArbiterSettings::default(), None);
        let here = preparer.problem_poses();
        assert_eq!(here.len(), 1);
        let array = |poses: Vec<Pose>, frame: &str| PoseArray {
            header: Header { frame_id: frame.into(), ..Header::default() },
            poses,
        };
        let shifted = |dx: f64, angle: f64| {
            let mut p = here[0];
            p.position.x += dx;
            let q = UnitQuaternion::new(nalgebra::Vector3::new(0.0, 0.0, angle))
                * UnitQuaternion::from_quaternion(Quaternion::new(
                    p.orientation.w,
                    p.orientation.x,
                    p.orientation.y,
                    p.orientation.z,
                ));
            p.orientation = RosQuaternion { x: q.i, y: q.j, z: q.k, w: q.w };
            vec![p]
        };
        let mut goals = GoalPoses::new("panda_link0", here.clone());
        let mut negated = here.clone();
        let o = &mut negated[0].orientation;
        (o.x, o.y, o.z, o.w) = (-o.x, -o.y, -o.z, -o.w);
        for same in [here.clone(), negated, shifted(0.9e-3, 0.0), shifted(0.0, 0.4f64.to_radians())] {
            assert!(!goals.arrived(array(same, "panda_link0")));
        }
        assert!(!goals.arrived(array(here.clone(), "")));
        assert_eq!((goals.unchanged, goals.start().is_none()), (5, true));
        for changed in [shifted(1.1e-3, 0.0), shifted(0.0, 0.6f64.to_radians())] {
            assert!(goals.arrived(array(changed, "")));
        }
        assert!(goals.arrived(array(here.clone(), "camera_link")), "another frame is not the same poses");
        let mut nan = here.clone();
        nan[0].position.x = f64::NAN;
        assert!(goals.arrived(array(nan, "")));
        assert!(goals.arrived(array(shifted(0.05, 0.0), "")));
        // One in flight, the latest of the waiting ones.
        let first = goals.start().unwrap();
        assert!(same_poses(&first.poses, &shifted(0.05, 0.0)));
        assert!(goals.start().is_none());
        // While it is prepared: the same poses again are dropped, others wait.
        assert!(!goals.arrived(array(shifted(0.05, 0.0), "")));
        assert!(goals.arrived(array(shifted(0.1, 0.0), "")));
        assert!(goals.preparing() && goals.start().is_none());
        goals.finished(true);
        assert!(!goals.arrived(array(shifted(0.05, 0.0), "")), "the goals now have the prepared poses");
        assert!(goals.arrived(array(shifted(0.1, 0.0), "")));
        goals.start().unwrap();
        goals.finished(false);
        // A failed preparation leaves the goals' poses as they were.
        assert!(!goals.arrived(array(shifted(0.05, 0.0), "")));
        assert_eq!(goals.started, 2);
    }
}
