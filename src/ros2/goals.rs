//! Goals from the ROS 2 system: a `geometry_msgs/PoseArray` of the
//! graspable objects' poses (from a perception node, say) places the
//! problem's graspable objects, and each gets a new reference and tracking
//! policy from the arm's measured configuration. The preparation runs on a
//! thread of its own (hundreds of milliseconds for the Panda); the loop
//! keeps ticking with the goals it has until the new arbiter is ready.

use super::messages::PoseArray;
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

    /// The objects a PoseArray places, in order: the problem's objects
    /// with its goal's grasp frame (the goal alone when it is not a grasp).
    pub fn graspable(&self) -> Vec<String> {
        graspable(&self.problem)
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
        let root = self.problem.robot.description().root_link();
        let frame = poses.header.frame_id.as_str();
        if !(frame.is_empty() || frame == root) {
            return Err(format!("poses in frame '{frame}': give them in the robot's root frame '{root}'"));
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
        let options =
            GoalSettings { seed: Some(self.seed), objects: GoalObjects::AllGraspable, ..GoalSettings::default() };
        let goals = problem_goals(&problem, &options).map_err(|e| e.to_string())?;
        let mut arbiter = Arbiter::for_problem(&problem, &goals, self.settings).map_err(|e| e.to_string())?;
        if let Some(actor) = &self.actor {
            arbiter = arbiter.with_arbitration_policy(actor.clone()).map_err(|e| e.to_string())?;
        }
        Ok(arbiter)
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
    }
}
