//! The network's input (the dissertation's §3.3.3 state, plus the obstacles of
//! §3.3.1): one layout shared by training (dataset rows) and queries.
//!
//! | values | what |
//! | --- | --- |
//! | 3 | gripper position `p` (m, world) |
//! | 3 | goal position relative to the gripper, `g − p` (m, world axes) |
//! | 6 | goal rotation, the first two columns of its matrix (continuous 6-D form) |
//! | n | the configuration `q` (rad or m) |
//! | 6 | gripper rotation `R`, 6-D form (beyond the dissertation) |
//! | 3 | `g − p` in the gripper frame, `Rᵀ(g − p)` (m; beyond the dissertation) |
//! | 7 per obstacle slot | obstacle centre relative to the gripper (3, m), its bounding-box edge lengths (3, m), 1 when the slot is used (0 and zeros otherwise) |
//! | then 3 per obstacle frame, in each slot | obstacle centre relative to that frame's origin (m, world axes; zeros in an unused slot) |
//!
//! The two rows marked "beyond the dissertation" are not in its input: they
//! are functions of `q` the network could learn, but given directly they make the final
//! approach (millimetres between the fingers and the object) a simple
//! function of the input.
//!
//! Obstacle frames ([`PolicyMeta::obstacle_frames`](super::PolicyMeta::obstacle_frames),
//! none by default; also beyond the dissertation) are links besides the
//! gripper whose distance to the obstacles matters: most of the policy's
//! collisions are the forearm's and the wrist's on the approach, where the
//! gripper is far from the obstacle it hits.
//!
//! Obstacle slots hold the scene's obstacles that are not static (the
//! static ones, such as the table, never move between tasks and the
//! network learns them from the data), in scene order; obstacles beyond
//! the last slot are not seen.

use nalgebra::{IsometryMatrix3, Vector3};

/// Most obstacle frames a network may have.
pub const MAX_OBSTACLE_FRAMES: usize = 8;

/// Values per obstacle slot without obstacle frames.
pub const OBSTACLE_FEATURES: usize = 7;

/// Values per obstacle slot with `frames` obstacle frames.
pub fn slot_width(frames: usize) -> usize {
    OBSTACLE_FEATURES + 3 * frames
}

/// Input width for `dof` joints and `slots` obstacle slots, each seen
/// from the gripper and `frames` obstacle frames.
pub fn input_width(dof: usize, slots: usize, frames: usize) -> usize {
    GRIPPER_FEATURES + dof + slot_width(frames) * slots
}

/// Values besides `q` and the obstacle slots.
const GRIPPER_FEATURES: usize = 21;

/// An obstacle as the network sees it: centre (m, world) and bounding-box
/// edge lengths in its shape frame (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObstacleFeature {
    /// Centre (m, world).
    pub center: [f64; 3],
    /// Bounding-box edge lengths (m).
    pub size: [f64; 3],
}

/// What a query is conditioned on: the goal pose of the gripper frame and
/// the obstacles in the slots (at most the network's slot count).
#[derive(Debug, Clone, PartialEq)]
pub struct GoalFeatures {
    /// Goal position (m, world).
    pub position: [f64; 3],
    /// First two columns of the goal rotation matrix (world axes).
    pub rotation6: [f64; 6],
    /// The obstacles of the slots, in scene order.
    pub obstacles: Vec<ObstacleFeature>,
}

impl GoalFeatures {
    /// The goal `pose` of the gripper frame with `obstacles`.
    pub fn new(pose: &IsometryMatrix3<f64>, obstacles: Vec<ObstacleFeature>) -> GoalFeatures {
        let r = pose.rotation.matrix();
        GoalFeatures {
            position: pose.translation.vector.into(),
            rotation6: [r[(0, 0)], r[(1, 0)], r[(2, 0)], r[(0, 1)], r[(1, 1)], r[(2, 1)]],
            obstacles,
        }
    }

    /// The goal from a pose stored as `[x, y, z, qx, qy, qz, qw]` (the
    /// dataset's `goal_pose`).
    pub fn from_pose_array(pose: &[f64; 7], obstacles: Vec<ObstacleFeature>) -> GoalFeatures {
        let rotation =
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(pose[6], pose[3], pose[4], pose[5]))
                .to_rotation_matrix();
        let pose = IsometryMatrix3::from_parts(Vector3::new(pose[0], pose[1], pose[2]).into(), rotation);
        GoalFeatures::new(&pose, obstacles)
    }
}

/// A network's gripper frame and obstacle frames, resolved on a robot.
#[derive(Debug, Clone)]
pub(crate) struct InputFrames {
    pub(crate) gripper: crate::robot::FrameId,
    pub(crate) obstacle: Vec<crate::robot::FrameId>,
}

impl InputFrames {
    /// Looks the frames up on `robot`.
    ///
    /// # Errors
    /// A frame the robot lacks (named), more than [`MAX_OBSTACLE_FRAMES`]
    /// obstacle frames.
    pub(crate) fn resolve(
        robot: &crate::robot::RobotModel,
        gripper: &str,
        frames: &[String],
    ) -> Result<InputFrames, super::LearnError> {
        if frames.len() > MAX_OBSTACLE_FRAMES {
            return Err(super::LearnError::Mismatch {
                what: "obstacle frames".into(),
                expected: format!("at most {MAX_OBSTACLE_FRAMES}"),
                got: frames.len().to_string(),
            });
        }
        let find = |what: &str, name: &str| {
            robot.frame_id(name).map_err(|_| super::LearnError::Mismatch {
                what: what.into(),
                expected: name.into(),
                got: "a robot without it".into(),
            })
        };
        let obstacle = frames.iter().map(|f| find("obstacle frame", f)).collect::<Result<_, _>>()?;
        Ok(InputFrames { gripper: find("gripper frame", gripper)?, obstacle })
    }

    /// The gripper pose and the obstacle frames' origins (into `origins`)
    /// of the forward kinematics in `ws`.
    pub(crate) fn place<'o>(
        &self,
        robot: &crate::robot::RobotModel,
        ws: &crate::robot::KinematicsWorkspace,
        origins: &'o mut [[f64; 3]; MAX_OBSTACLE_FRAMES],
    ) -> (IsometryMatrix3<f64>, &'o [[f64; 3]]) {
        for (o, f) in origins.iter_mut().zip(&self.obstacle) {
            *o = robot.frame_position(ws, *f).into();
        }
        (robot.frame_pose(ws, self.gripper), &origins[..self.obstacle.len()])
    }
}

/// Where the robot is at a query: the gripper frame's pose and the
/// obstacle frames' origins (m, world), both from the forward kinematics
/// at `q`.
#[derive(Debug, Clone, Copy)]
pub struct Placement<'a> {
    /// The gripper frame (world).
    pub gripper: &'a IsometryMatrix3<f64>,
    /// Origins of the obstacle frames (m, world), in the network's order.
    pub frames: &'a [[f64; 3]],
}

/// Writes the input of a query at configuration `q` with the robot placed
/// at `at` into `out` (length [`input_width`]`(q.len(), slots,
/// at.frames.len())`). Allocates nothing.
pub fn encode(out: &mut [f32], at: Placement, goal: &GoalFeatures, q: &[f64], slots: usize) {
    let (gripper, frames) = (at.gripper, at.frames);
    debug_assert_eq!(out.len(), input_width(q.len(), slots, frames.len()));
    let p = gripper.translation.vector;
    let r = gripper.rotation.matrix();
    let to_goal = Vector3::new(goal.position[0] - p.x, goal.position[1] - p.y, goal.position[2] - p.z);
    let local = gripper.rotation.inverse() * to_goal;
    for i in 0..3 {
        out[i] = p[i] as f32;
        out[3 + i] = to_goal[i] as f32;
    }
    for (o, v) in out[6..12].iter_mut().zip(&goal.rotation6) {
        *o = *v as f32;
    }
    let n = q.len();
    for (o, v) in out[12..12 + n].iter_mut().zip(q) {
        *o = *v as f32;
    }
    let g = 12 + n;
    for c in 0..2 {
        for i in 0..3 {
            out[g + 3 * c + i] = r[(i, c)] as f32;
        }
    }
    for i in 0..3 {
        out[g + 6 + i] = local[i] as f32;
    }
    let (first, width) = (GRIPPER_FEATURES + n, slot_width(frames.len()));
    for k in 0..slots {
        let slot = &mut out[first + width * k..first + width * (k + 1)];
        match goal.obstacles.get(k) {
            Some(o) => {
                for i in 0..3 {
                    slot[i] = (o.center[i] - p[i]) as f32;
                    slot[3 + i] = o.size[i] as f32;
                }
                slot[6] = 1.0;
                for (f, origin) in frames.iter().enumerate() {
                    for i in 0..3 {
                        slot[OBSTACLE_FEATURES + 3 * f + i] = (o.center[i] - origin[i]) as f32;
                    }
                }
            }
            None => slot.fill(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_of_a_query() {
        let pose = IsometryMatrix3::from_parts(
            Vector3::new(0.5, 0.1, 0.2).into(),
            nalgebra::Rotation3::from_euler_angles(std::f64::consts::PI, 0.0, 0.3),
        );
        let goal = GoalFeatures::new(&pose, vec![ObstacleFeature { center: [0.4, 0.0, 0.5], size: [0.1, 0.1, 0.2] }]);
        let mut out = vec![f32::NAN; input_width(2, 2, 0)];
        let gripper = IsometryMatrix3::from_parts(
            Vector3::new(0.3, 0.0, 0.6).into(),
            nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        );
        encode(&mut out, Placement { gripper: &gripper, frames: &[] }, &goal, &[0.1, -0.2], 2);
        let r = pose.rotation.matrix();
        // The gripper turned a quarter about z: its x is world y, its y world −x;
        // g − p = (0.2, 0.1, −0.4) in the world is (0.1, −0.2, −0.4) in its frame.
        let expected = [
            0.3,
            0.0,
            0.6,
            0.2,
            0.1,
            -0.4,
            r[(0, 0)],
            r[(1, 0)],
            r[(2, 0)],
            r[(0, 1)],
            r[(1, 1)],
            r[(2, 1)],
            0.1,
            -0.2,
            0.0,
            1.0,
            0.0,
            -1.0,
            0.0,
            0.0,
            0.1,
            -0.2,
            -0.4,
            0.1,
            0.0,
            -0.1,
            0.1,
            0.1,
            0.2,
            1.0,
        ];
        for (i, e) in expected.iter().enumerate() {
            assert!((f64::from(out[i]) - e).abs() < 1e-6, "value {i}: {} vs {e}", out[i]);
        }
        assert!(out[30..].iter().all(|v| *v == 0.0), "an unused slot is zero");
        let quaternion = nalgebra::UnitQuaternion::from_rotation_matrix(&pose.rotation);
        let t = pose.translation.vector;
        let same = GoalFeatures::from_pose_array(
            &[t.x, t.y, t.z, quaternion.i, quaternion.j, quaternion.k, quaternion.w],
            vec![ObstacleFeature { center: [0.4, 0.0, 0.5], size: [0.1, 0.1, 0.2] }],
        );
        for (a, b) in same.rotation6.iter().zip(&goal.rotation6) {
            assert!((a - b).abs() < 1e-12);
        }

        // With two obstacle frames each slot grows by 3 values per frame:
        // the obstacle centre relative to the frame's origin; the values
        // before the slots do not change.
        let frames = [[0.4, 0.0, 0.3], [0.0, 0.5, 1.0]];
        let mut wide = vec![f32::NAN; input_width(2, 2, 2)];
        assert_eq!(wide.len(), out.len() + 2 * 6);
        encode(&mut wide, Placement { gripper: &gripper, frames: &frames }, &goal, &[0.1, -0.2], 2);
        assert_eq!(wide[..30], out[..30], "the gripper part and the slot's first values");
        let expected = [0.0, 0.0, 0.2, 0.4, -0.5, -0.5];
        for (i, e) in expected.iter().enumerate() {
            assert!((f64::from(wide[30 + i]) - e).abs() < 1e-6, "frame value {i}: {} vs {e}", wide[30 + i]);
        }
        assert!(wide[36..].iter().all(|v| *v == 0.0), "an unused slot is zero, its frame values too");
    }
}
