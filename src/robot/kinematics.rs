//! Forward kinematics and Jacobians over a [`RobotModel`] and a
//! [`KinematicsWorkspace`].
//!
//! The workspace is allocated once (per thread); after that no call here
//! touches the heap. Jacobians are geometric, 6 × nq, linear rows first:
//! column `k` is the spatial velocity of the frame for a unit velocity of
//! active joint `k`.
//!
//! ```
//! use tandem::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};
//! use nalgebra::Matrix6xX;
//! let panda = RobotModel::panda();
//! let mut ws = KinematicsWorkspace::new(&panda);
//! let tcp = panda.frame_id("panda_hand_tcp").unwrap();
//! let q = panda.neutral_configuration();
//! panda.forward_kinematics(&mut ws, &q).unwrap();
//! let mut jac = Matrix6xX::zeros(panda.nq());
//! let pose = panda.frame_jacobian(&ws, tcp, ReferenceFrame::WorldAligned, &mut jac).unwrap();
//! assert!(pose.translation.vector.norm() > 0.3);
//! ```

use super::error::RobotError;
use super::model::{FrameId, Motion, RobotModel};
use nalgebra::{IsometryMatrix3, Matrix3, Matrix3xX, Matrix6xX, Point3, Rotation3, Vector3};

/// The frame in which a Jacobian's rows are expressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceFrame {
    /// Velocity of the frame origin and angular velocity, both in world
    /// axes (Pinocchio's `LOCAL_WORLD_ALIGNED`).
    WorldAligned,
    /// The same velocities expressed in the frame's own axes (Pinocchio's `LOCAL`).
    Local,
}

/// Mutable per-thread state of kinematics: body and frame placements.
#[derive(Debug, Clone)]
pub struct KinematicsWorkspace {
    /// World pose of each body, valid after [`RobotModel::forward_kinematics`].
    body_poses: Vec<IsometryMatrix3<f64>>,
    /// World pose of each frame, valid after [`RobotModel::update_frame_placements`].
    frame_poses: Vec<IsometryMatrix3<f64>>,
}

impl KinematicsWorkspace {
    /// Allocates the workspace for `model`; reuse it across calls.
    pub fn new(model: &RobotModel) -> Self {
        KinematicsWorkspace {
            body_poses: vec![IsometryMatrix3::identity(); model.bodies.len()],
            frame_poses: vec![IsometryMatrix3::identity(); model.frames().len()],
        }
    }

    /// Takes the body poses of `other`, a workspace of the same model, as
    /// if its forward kinematics had run here (frame placements excepted).
    ///
    /// # Panics
    /// If `other` belongs to a model with another number of bodies.
    pub(crate) fn copy_body_poses_from(&mut self, other: &KinematicsWorkspace) {
        self.body_poses.copy_from_slice(&other.body_poses);
    }

    /// World poses of all frames, in [`RobotModel::frames`] order, as of the
    /// last [`RobotModel::update_frame_placements`].
    pub fn frame_poses(&self) -> &[IsometryMatrix3<f64>] {
        &self.frame_poses
    }
}

/// Columns `A`, `B` of `m · Rot(θ)` for a rotation in the (A, B) plane;
/// constant indices let the compiler drop bounds checks and unroll.
#[inline(always)]
fn rotate_columns<const A: usize, const B: usize>(m: &mut Matrix3<f64>, s: f64, c: f64) {
    let ca = m.fixed_view::<3, 1>(0, A).into_owned();
    let cb = m.fixed_view::<3, 1>(0, B).into_owned();
    m.fixed_view_mut::<3, 1>(0, A).copy_from(&(ca * c + cb * s));
    m.fixed_view_mut::<3, 1>(0, B).copy_from(&(cb * c - ca * s));
}

/// `pose ∘ motion(value)`, specialised so axis-aligned rotations touch only
/// two columns.
#[inline(always)]
fn apply_motion(pose: &mut IsometryMatrix3<f64>, motion: &Motion, value: f64) {
    let m: &mut Matrix3<f64> = pose.rotation.matrix_mut_unchecked();
    match *motion {
        Motion::Prismatic(axis) => {
            let shift = *m * axis * value;
            pose.translation.vector += shift;
        }
        Motion::Revolute(axis) => {
            let rot = Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), value);
            *m *= rot.matrix();
        }
        _ => {
            let (s, c) = value.sin_cos();
            match *motion {
                Motion::RevoluteX => rotate_columns::<1, 2>(m, s, c),
                Motion::RevoluteY => rotate_columns::<2, 0>(m, s, c),
                _ => rotate_columns::<0, 1>(m, s, c),
            }
        }
    }
}

impl RobotModel {
    /// Computes the world pose of every body at `q` (one value per active
    /// joint). Frame poses are then available through
    /// [`frame_pose`](Self::frame_pose) and Jacobians through
    /// [`frame_jacobian`](Self::frame_jacobian).
    ///
    /// # Errors
    /// [`RobotError::WrongDof`] or [`RobotError::NonFinite`] for a bad `q`;
    /// the workspace is then left unchanged.
    pub fn forward_kinematics(&self, ws: &mut KinematicsWorkspace, q: &[f64]) -> Result<(), RobotError> {
        self.check_configuration(q)?;
        let poses = &mut ws.body_poses;
        for (b, body) in self.bodies.iter().enumerate().skip(1) {
            let mut pose = body.placement.after(&poses[body.parent]);
            apply_motion(&mut pose, &body.motion, body.multiplier * q[body.column] + body.offset);
            poses[b] = pose;
        }
        Ok(())
    }

    /// Stores the world pose of every frame in the workspace (after
    /// [`forward_kinematics`](Self::forward_kinematics)).
    pub fn update_frame_placements(&self, ws: &mut KinematicsWorkspace) {
        for (out, frame) in ws.frame_poses.iter_mut().zip(self.frames()) {
            *out = frame.placement.after(&ws.body_poses[frame.body]);
        }
    }

    /// World pose of one frame, from the last forward kinematics.
    #[inline]
    pub fn frame_pose(&self, ws: &KinematicsWorkspace, frame: FrameId) -> IsometryMatrix3<f64> {
        let f = &self.frames()[frame.0];
        f.placement.after(&ws.body_poses[f.body])
    }

    /// The world position of `frame` (m) after
    /// [`forward_kinematics`](Self::forward_kinematics): the translation of
    /// [`frame_pose`](Self::frame_pose) without its rotation's product.
    pub fn frame_position(&self, ws: &KinematicsWorkspace, frame: FrameId) -> Vector3<f64> {
        let f = &self.frames()[frame.0];
        f.placement.position_after(&ws.body_poses[f.body])
    }

    /// The world position (m) of `frame` at each configuration (a path
    /// to draw or measure; allocates).
    ///
    /// # Errors
    /// A configuration of the wrong length or with non-finite entries.
    pub fn frame_path<'q>(
        &self,
        frame: FrameId,
        configurations: impl IntoIterator<Item = &'q [f64]>,
    ) -> Result<Vec<[f64; 3]>, RobotError> {
        let mut ws = KinematicsWorkspace::new(self);
        configurations
            .into_iter()
            .map(|q| {
                self.forward_kinematics(&mut ws, q)?;
                Ok(self.frame_position(&ws, frame).into())
            })
            .collect()
    }

    /// Geometric Jacobian (6 × nq, linear rows then angular) of `frame`,
    /// from the last forward kinematics, written into `out`. Returns the
    /// frame's world pose, which the Jacobian needs anyway, so callers that
    /// want both compose it once.
    ///
    /// # Errors
    /// [`RobotError::OutputShape`] when `out` does not have nq columns.
    pub fn frame_jacobian(
        &self,
        ws: &KinematicsWorkspace,
        frame: FrameId,
        reference: ReferenceFrame,
        out: &mut Matrix6xX<f64>,
    ) -> Result<IsometryMatrix3<f64>, RobotError> {
        self.check_columns(out.ncols())?;
        let pose = self.frame_pose(ws, frame);
        // Slice fill: nalgebra's element iterator is several times slower here.
        let data = out.as_mut_slice();
        data.fill(0.0);
        self.accumulate_columns(ws, self.frames()[frame.0].body, &pose.translation.vector, |k, lin, ang| {
            let col = &mut data[6 * k..6 * k + 6];
            for i in 0..3 {
                col[i] += lin[i];
                col[i + 3] += ang[i];
            }
        });
        if reference == ReferenceFrame::Local {
            let rt = pose.rotation.matrix().transpose();
            for col in data.chunks_exact_mut(6) {
                let lin = rt * Vector3::new(col[0], col[1], col[2]);
                let ang = rt * Vector3::new(col[3], col[4], col[5]);
                col[..3].copy_from_slice(lin.as_slice());
                col[3..].copy_from_slice(ang.as_slice());
            }
        }
        Ok(pose)
    }

    /// Jacobian (3 × nq, world axes) of the velocity of a point fixed on a
    /// frame, given in that frame's coordinates (m). Also returns the
    /// point's world position.
    ///
    /// # Errors
    /// [`RobotError::OutputShape`] when `out` does not have nq columns.
    pub fn point_jacobian(
        &self,
        ws: &KinematicsWorkspace,
        frame: FrameId,
        point: &Point3<f64>,
        out: &mut Matrix3xX<f64>,
    ) -> Result<Point3<f64>, RobotError> {
        self.check_columns(out.ncols())?;
        let world = self.frame_pose(ws, frame) * point;
        out.as_mut_slice().fill(0.0);
        self.accumulate_columns(ws, self.frames()[frame.0].body, &world.coords, |k, lin, _| {
            out.column_mut(k).add_assign(&lin);
        });
        Ok(world)
    }

    /// Adds `direction · v_k(p)` to `out[k]` for every active joint `k`,
    /// where `v_k(p)` is the velocity of world point `p` (fixed on body
    /// `body`) for a unit velocity of joint `k`: a point Jacobian projected
    /// on one direction, without forming it.
    pub(crate) fn add_projected_point_velocity(
        &self,
        ws: &KinematicsWorkspace,
        body: usize,
        p: &Vector3<f64>,
        direction: &Vector3<f64>,
        out: &mut [f64],
    ) {
        self.accumulate_columns(ws, body, p, |k, lin, _| out[k] += direction.dot(&lin));
    }

    /// Index of the body carrying `frame`, and the frame's pose in it.
    pub(crate) fn frame_in_body(&self, frame: FrameId) -> (usize, IsometryMatrix3<f64>) {
        let f = &self.frames()[frame.0];
        (f.body, f.placement.after(&IsometryMatrix3::identity()))
    }

    /// World pose of body `body` as of the last forward kinematics.
    #[inline]
    pub(crate) fn body_pose<'w>(&self, ws: &'w KinematicsWorkspace, body: usize) -> &'w IsometryMatrix3<f64> {
        &ws.body_poses[body]
    }

    /// Parent of body `body` (the root is its own parent).
    pub(crate) fn parent_body(&self, body: usize) -> usize {
        self.bodies[body].parent
    }

    /// Number of bodies (the root included, as body 0).
    pub(crate) fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// How body `body` moves: the q column driving it, the multiplier of
    /// its joint value, whether it slides, and an upper bound of the
    /// distance of its frame origin from its parent's over every q within
    /// the joint limits (m): the placement offset, plus for a sliding joint
    /// the farthest it slides.
    pub(crate) fn body_joint(&self, body: usize) -> (usize, f64, bool, f64) {
        let b = &self.bodies[body];
        let mut offset = b.placement.after(&IsometryMatrix3::identity()).translation.vector.norm();
        if b.motion.is_prismatic() {
            let limits = &self.limits()[b.column];
            let value = |q: f64| (b.multiplier * q + b.offset).abs();
            offset += value(limits.lower).max(value(limits.upper));
        }
        (b.column, b.multiplier, b.motion.is_prismatic(), offset)
    }

    fn check_columns(&self, got: usize) -> Result<(), RobotError> {
        if got == self.nq() { Ok(()) } else { Err(RobotError::OutputShape { expected: self.nq(), got }) }
    }

    /// Calls `add(column, linear, angular)` for each body between `body` and
    /// the root, with the velocity contribution at world point `p` of a unit
    /// velocity of the active joint driving it.
    #[inline(always)]
    fn accumulate_columns(
        &self,
        ws: &KinematicsWorkspace,
        mut body: usize,
        p: &Vector3<f64>,
        mut add: impl FnMut(usize, Vector3<f64>, Vector3<f64>),
    ) {
        while body != 0 {
            let b = &self.bodies[body];
            let pose = &ws.body_poses[body];
            let axis = b.motion.world_axis(pose.rotation.matrix());
            if b.motion.is_prismatic() {
                add(b.column, axis * b.multiplier, Vector3::zeros());
            } else {
                let lin = axis.cross(&(p - pose.translation.vector));
                add(b.column, lin * b.multiplier, axis * b.multiplier);
            }
            body = b.parent;
        }
    }
}

use std::ops::AddAssign;
