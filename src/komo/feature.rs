//! Features: differentiable functions of one configuration, each with an
//! analytic Jacobian. Order-k objectives difference them over consecutive
//! slices (see [`objective`](super::objective)).

use crate::robot::{FrameId, KinematicsWorkspace, ReferenceFrame, RobotError, RobotModel, rotation_log};
use nalgebra::{IsometryMatrix3, Matrix3, Matrix6xX, Vector3};

/// A frame a feature reads: a robot frame (moves with q), or a frame fixed
/// in the world (the world itself, a scene object, an object's grasp frame).
#[derive(Debug, Clone, PartialEq)]
pub enum FrameRef {
    /// A frame of the robot.
    Robot(FrameId),
    /// A world-fixed pose.
    Fixed(IsometryMatrix3<f64>),
}

/// A feature φ(q).
#[derive(Debug, Clone, PartialEq)]
pub enum Feature {
    /// The active joint values (rad or m), dimension nq.
    JointState,
    /// `q − (upper − margin)` and `(lower + margin) − q` for every joint
    /// with finite limits (≤ 0 inside): dimension 2 × limited joints.
    JointLimits {
        /// Distance (m) or angle (rad) kept from the limit or contact.
        margin: f64,
    },
    /// World position of a frame's origin (m), dimension 3.
    Position {
        /// The frame whose origin is measured.
        frame: FrameRef,
    },
    /// `p_a − p_b` in world axes (m), dimension 3.
    PositionDifference {
        /// First frame.
        a: FrameRef,
        /// Second frame.
        b: FrameRef,
    },
    /// `(R_a e_i) · (R_b e_j)`: the cosine between axis i of `a` and axis j
    /// of `b` (0 = x, 1 = y, 2 = z), dimension 1.
    ScalarProduct {
        /// First frame.
        a: FrameRef,
        /// Axis of the first frame (0 = x, 1 = y, 2 = z).
        axis_a: usize,
        /// Second frame.
        b: FrameRef,
        /// Axis of the second frame.
        axis_b: usize,
    },
    /// `R_bᵀ R_a e_i`: axis i of `a` in `b`'s coordinates, dimension 3. Its
    /// target is a unit direction: unlike a scalar product of ±1, it has a
    /// full-rank Jacobian at its target.
    Vector {
        /// First frame.
        a: FrameRef,
        /// Axis of the first frame (0 = x, 1 = y, 2 = z), expressed in the second.
        axis: usize,
        /// Second frame.
        b: FrameRef,
    },
    /// `log(R_bᵀ R_a)`: the rotation vector taking `b`'s orientation to
    /// `a`'s, in `b`'s axes (rad), dimension 3.
    OrientationDifference {
        /// First frame.
        a: FrameRef,
        /// Second frame.
        b: FrameRef,
    },
    /// Signed distance of every collision pair ≥ its margin (m): one
    /// inequality row `margin − d ≤ 0` per pair closer than the evaluation
    /// cutoff; rows are not a fixed-size vector, so it is evaluated apart.
    Collision {
        /// Distance (m) kept between robot shapes, and from the robot to
        /// the scene's objects.
        margin: f64,
        /// Distance (m) kept from the robot to the scene's obstacles (the
        /// table included); equal to `margin` unless clearance from the
        /// environment is wanted beyond what the robot's own close
        /// links (e.g. the Panda's wrist) allow.
        obstacle_margin: f64,
    },
}

/// Scratch space of feature evaluation: two frame Jacobians.
#[derive(Debug, Clone)]
pub struct FeatureWorkspace {
    jac_a: Matrix6xX<f64>,
    jac_b: Matrix6xX<f64>,
}

impl FeatureWorkspace {
    /// Scratch space for the features of `robot`.
    pub fn new(robot: &RobotModel) -> FeatureWorkspace {
        FeatureWorkspace { jac_a: Matrix6xX::zeros(robot.nq()), jac_b: Matrix6xX::zeros(robot.nq()) }
    }
}

/// Pose of `frame`, and its world-aligned Jacobian into `jac` (zero for a
/// fixed frame).
fn frame_with_jacobian(
    robot: &RobotModel,
    kin: &KinematicsWorkspace,
    frame: &FrameRef,
    jac: &mut Matrix6xX<f64>,
) -> Result<IsometryMatrix3<f64>, RobotError> {
    match frame {
        FrameRef::Robot(id) => robot.frame_jacobian(kin, *id, ReferenceFrame::WorldAligned, jac),
        FrameRef::Fixed(pose) => {
            jac.fill(0.0);
            Ok(*pose)
        }
    }
}

/// `out[r][k] = Σ_i w_i J[rows + i][k]` for three rows of a 6 × nq Jacobian
/// written into row `r` of the row-major `out` (nq columns).
fn project(jac: &Matrix6xX<f64>, first_row: usize, w: &Vector3<f64>, sign: f64, out: &mut [f64]) {
    for (k, o) in out.iter_mut().enumerate() {
        let col = jac.column(k);
        *o += sign * (w[0] * col[first_row] + w[1] * col[first_row + 1] + w[2] * col[first_row + 2]);
    }
}

/// The inverse left Jacobian of SO(3) at rotation vector `phi`:
/// `d log(exp(δ^) R) / dδ` at `δ = 0` for `R = exp(phi^)`.
fn so3_left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = phi.cross_matrix();
    let c = if theta < 1e-4 {
        1.0 / 12.0 + theta * theta / 720.0
    } else {
        1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    Matrix3::identity() - 0.5 * k + c * k * k
}

impl Feature {
    /// Number of values of the feature for `robot` (0 for collision, whose
    /// rows vary).
    pub fn dim(&self, robot: &RobotModel) -> usize {
        match self {
            Feature::JointState => robot.nq(),
            Feature::JointLimits { .. } => 2 * limited_joints(robot).count(),
            Feature::Position { .. }
            | Feature::PositionDifference { .. }
            | Feature::Vector { .. }
            | Feature::OrientationDifference { .. } => 3,
            Feature::ScalarProduct { .. } => 1,
            Feature::Collision { .. } => 0,
        }
    }

    /// φ(q) into `value` and ∂φ/∂q (row-major, dim × nq) into `jac`, with
    /// the forward kinematics of `q` already in `kin`.
    ///
    /// # Errors
    /// [`RobotError::OutputShape`] for buffers of the wrong size.
    pub fn evaluate(
        &self,
        robot: &RobotModel,
        kin: &KinematicsWorkspace,
        q: &[f64],
        scratch: &mut FeatureWorkspace,
        value: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), RobotError> {
        let (dim, nq) = (self.dim(robot), robot.nq());
        if value.len() != dim || jac.len() != dim * nq || q.len() != nq {
            return Err(RobotError::OutputShape { expected: dim * nq, got: jac.len() });
        }
        jac.fill(0.0);
        match self {
            Feature::JointState => {
                value.copy_from_slice(q);
                jac.iter_mut().step_by(nq + 1).for_each(|d| *d = 1.0);
            }
            Feature::JointLimits { margin } => {
                for (r, (k, limits)) in limited_joints(robot).enumerate() {
                    value[2 * r] = q[k] - (limits.upper - margin);
                    value[2 * r + 1] = (limits.lower + margin) - q[k];
                    jac[2 * r * nq + k] = 1.0;
                    jac[(2 * r + 1) * nq + k] = -1.0;
                }
            }
            Feature::Position { frame } => {
                let pose = frame_with_jacobian(robot, kin, frame, &mut scratch.jac_a)?;
                value.copy_from_slice(pose.translation.vector.as_slice());
                for (i, row) in jac.chunks_exact_mut(nq).enumerate() {
                    project(&scratch.jac_a, 0, &Vector3::ith(i, 1.0), 1.0, row);
                }
            }
            Feature::PositionDifference { a, b } => {
                let pa = frame_with_jacobian(robot, kin, a, &mut scratch.jac_a)?;
                let pb = frame_with_jacobian(robot, kin, b, &mut scratch.jac_b)?;
                value.copy_from_slice((pa.translation.vector - pb.translation.vector).as_slice());
                for (i, row) in jac.chunks_exact_mut(nq).enumerate() {
                    project(&scratch.jac_a, 0, &Vector3::ith(i, 1.0), 1.0, row);
                    project(&scratch.jac_b, 0, &Vector3::ith(i, 1.0), -1.0, row);
                }
            }
            Feature::ScalarProduct { a, axis_a, b, axis_b } => {
                let pa = frame_with_jacobian(robot, kin, a, &mut scratch.jac_a)?;
                let pb = frame_with_jacobian(robot, kin, b, &mut scratch.jac_b)?;
                let u = pa.rotation.matrix().column(*axis_a).into_owned();
                let v = pb.rotation.matrix().column(*axis_b).into_owned();
                value[0] = u.dot(&v);
                // d(u·v) = (ω_a − ω_b) · (u × v)
                let w = u.cross(&v);
                project(&scratch.jac_a, 3, &w, 1.0, jac);
                project(&scratch.jac_b, 3, &w, -1.0, jac);
            }
            Feature::Vector { a, axis, b } => {
                let pa = frame_with_jacobian(robot, kin, a, &mut scratch.jac_a)?;
                let pb = frame_with_jacobian(robot, kin, b, &mut scratch.jac_b)?;
                let u = pa.rotation.matrix().column(*axis).into_owned();
                let rbt = pb.rotation.matrix().transpose();
                value.copy_from_slice((rbt * u).as_slice());
                // d(R_bᵀu) = R_bᵀ((ω_a − ω_b) × u) = −R_bᵀ[u]× (ω_a − ω_b)
                let m = -rbt * u.cross_matrix();
                for (i, row) in jac.chunks_exact_mut(nq).enumerate() {
                    let w = m.row(i).transpose();
                    project(&scratch.jac_a, 3, &w, 1.0, row);
                    project(&scratch.jac_b, 3, &w, -1.0, row);
                }
            }
            Feature::OrientationDifference { a, b } => {
                let pa = frame_with_jacobian(robot, kin, a, &mut scratch.jac_a)?;
                let pb = frame_with_jacobian(robot, kin, b, &mut scratch.jac_b)?;
                let phi = rotation_log(&(pb.rotation.inverse() * pa.rotation));
                value.copy_from_slice(phi.as_slice());
                // d log(R_bᵀR_a) = J_l⁻¹(φ) R_bᵀ (ω_a − ω_b)
                let m = so3_left_jacobian_inverse(&phi) * pb.rotation.matrix().transpose();
                for (i, row) in jac.chunks_exact_mut(nq).enumerate() {
                    let w = m.row(i).transpose();
                    project(&scratch.jac_a, 3, &w, 1.0, row);
                    project(&scratch.jac_b, 3, &w, -1.0, row);
                }
            }
            Feature::Collision { .. } => {}
        }
        Ok(())
    }

    /// How far inside its bound (in the feature's units) an inequality row
    /// of this feature may be left out: joint limits farther than
    /// [`JOINT_LIMIT_CUTOFF`] away. Such a hinge is inactive, and a step
    /// that reaches the limit anyway finds the row at the trial point
    /// (like a collision pair beyond its cutoff). Most slices are far from
    /// every limit, so this drops most of their rows.
    pub fn inactive_cutoff(&self) -> Option<f64> {
        matches!(self, Feature::JointLimits { .. }).then_some(JOINT_LIMIT_CUTOFF)
    }

    /// Whether the feature reads frame poses (needs forward kinematics).
    pub fn reads_frames(&self) -> bool {
        !matches!(self, Feature::JointState | Feature::JointLimits { .. })
    }
}

/// Joint-limit inequality rows farther than this inside their limit (rad
/// or m) get no row; see [`Feature::inactive_cutoff`].
pub const JOINT_LIMIT_CUTOFF: f64 = 0.1;

/// Active joints with finite limits: (column, limits).
fn limited_joints(robot: &RobotModel) -> impl Iterator<Item = (usize, &crate::robot::JointLimits)> {
    robot.limits().iter().enumerate().filter(|(_, l)| l.lower.is_finite() && l.upper.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use tandem_solvers::finite_diff::central_jacobian;

    fn features(robot: &RobotModel) -> Vec<Feature> {
        let tcp = FrameRef::Robot(robot.frame_id("panda_hand_tcp").unwrap());
        let link4 = FrameRef::Robot(robot.frame_id("panda_link4").unwrap());
        let fixed = FrameRef::Fixed(IsometryMatrix3::from_parts(
            nalgebra::Translation3::new(0.5, 0.1, 0.06),
            Rotation3::from_euler_angles(3.0, 0.2, -0.4),
        ));
        vec![
            Feature::JointState,
            Feature::JointLimits { margin: 0.01 },
            Feature::Position { frame: tcp.clone() },
            Feature::PositionDifference { a: tcp.clone(), b: fixed.clone() },
            Feature::PositionDifference { a: tcp.clone(), b: link4.clone() },
            Feature::ScalarProduct { a: tcp.clone(), axis_a: 2, b: fixed.clone(), axis_b: 2 },
            Feature::ScalarProduct { a: tcp.clone(), axis_a: 1, b: link4.clone(), axis_b: 0 },
            Feature::Vector { a: tcp.clone(), axis: 2, b: fixed.clone() },
            Feature::Vector { a: tcp.clone(), axis: 0, b: link4.clone() },
            Feature::OrientationDifference { a: tcp.clone(), b: fixed },
            Feature::OrientationDifference { a: tcp, b: link4 },
        ]
    }

    #[test]
    fn jacobians_match_central_differences() {
        let robot = RobotModel::panda();
        let nq = robot.nq();
        let mut kin = KinematicsWorkspace::new(&robot);
        let mut scratch = FeatureWorkspace::new(&robot);
        let mut worst: f64 = 0.0;
        for feature in features(&robot) {
            let dim = feature.dim(&robot);
            for s in 0..20 {
                let q: Vec<f64> = robot
                    .limits()
                    .iter()
                    .enumerate()
                    .map(|(k, l)| l.lower + (l.upper - l.lower) * (0.5 + 0.4 * ((s * 7 + k * 3) as f64).sin()))
                    .collect();
                robot.forward_kinematics(&mut kin, &q).unwrap();
                let (mut value, mut jac) = (vec![0.0; dim], vec![0.0; dim * nq]);
                feature.evaluate(&robot, &kin, &q, &mut scratch, &mut value, &mut jac).unwrap();
                let mut fd = vec![0.0; dim * nq];
                let mut kin2 = KinematicsWorkspace::new(&robot);
                let mut scratch2 = FeatureWorkspace::new(&robot);
                let f = |x: &[f64], out: &mut [f64]| {
                    robot.forward_kinematics(&mut kin2, x).unwrap();
                    let mut j = vec![0.0; dim * nq];
                    feature.evaluate(&robot, &kin2, x, &mut scratch2, out, &mut j).unwrap();
                };
                central_jacobian(f, &q, dim, 1e-6, &mut fd);
                for r in 0..dim {
                    for k in 0..nq {
                        let err = (jac[r * nq + k] - fd[k * dim + r]).abs();
                        worst = worst.max(err);
                        assert!(err < 1e-7, "{feature:?} row {r} col {k}: {} vs {}", jac[r * nq + k], fd[k * dim + r]);
                    }
                }
            }
        }
        assert!(worst > 0.0);
    }

    #[test]
    fn small_and_large_rotations_have_exact_log_jacobians() {
        // J_l⁻¹ against differences of log(exp(δ) R) near zero and near π.
        for phi in [Vector3::new(1e-6, -2e-6, 3e-7), Vector3::new(0.3, -1.1, 0.7), Vector3::new(0.0, 3.1, 0.0)] {
            let r = Rotation3::new(phi);
            assert!((rotation_log(&r) - phi).norm() < 1e-15 * phi.norm().max(1.0) * 10.0, "log of exp({phi:?})");
            let inv = so3_left_jacobian_inverse(&phi);
            for i in 0..3 {
                let h = 1e-7;
                let plus = rotation_log(&(Rotation3::new(Vector3::ith(i, h)) * r));
                let minus = rotation_log(&(Rotation3::new(Vector3::ith(i, -h)) * r));
                let fd = (plus - minus) / (2.0 * h);
                let err = (fd - inv.column(i)).norm();
                assert!(err < 1e-6, "phi {phi:?} col {i}: {fd:?} vs {}", inv.column(i));
            }
        }
    }
}
