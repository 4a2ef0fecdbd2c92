//! Constant rigid transforms with a fast composition.
//!
//! URDF origins are mostly axis-aligned: identity rotations or quarter turns
//! (`rpy="1.5707963267948966 0 0"`). A [`Placement`] recognises rotations
//! that are signed permutations, so composing a pose with it moves columns
//! instead of multiplying matrices — the bulk of forward kinematics.

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3, Vector3};

/// Entries this close to 0 or ±1 are snapped: only rounding noise of
/// `cos(π/2)` (6e-17) qualifies, never a genuinely different angle.
const SNAP: f64 = 1e-15;

#[derive(Debug, Clone, Copy, PartialEq)]
enum RotationKind {
    Identity,
    /// Column `j` of the rotation is `sign[j]` times basis vector `axis[j]`.
    SignedPermutation {
        axis: [usize; 3],
        sign: [f64; 3],
    },
    General,
}

/// The signed permutation within `tolerance` of `r`, entry by entry: per
/// column, the basis vector it is (`axis`) and its sign. `None` when some
/// column is not one ±1 and two zeros within the tolerance.
pub(crate) fn signed_permutation_near(r: &Matrix3<f64>, tolerance: f64) -> Option<([usize; 3], [f64; 3])> {
    let (mut axis, mut sign) = ([0; 3], [0.0; 3]);
    for j in 0..3 {
        let unit = (0..3).find(|&i| (r[(i, j)].abs() - 1.0).abs() <= tolerance)?;
        if (0..3).any(|i| i != unit && r[(i, j)].abs() > tolerance) {
            return None;
        }
        (axis[j], sign[j]) = (unit, r[(unit, j)].signum());
    }
    Some((axis, sign))
}

/// A constant transform `(R, t)` mapping child coordinates to parent coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placement {
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
    kind: RotationKind,
    identity: bool,
}

impl Placement {
    pub(crate) fn new(iso: &IsometryMatrix3<f64>) -> Self {
        let r = *iso.rotation.matrix();
        let (kind, axis, sign) = match signed_permutation_near(&r, SNAP) {
            None => (RotationKind::General, [0, 1, 2], [1.0; 3]),
            Some(([0, 1, 2], [1.0, 1.0, 1.0])) => (RotationKind::Identity, [0, 1, 2], [1.0; 3]),
            Some((axis, sign)) => (RotationKind::SignedPermutation { axis, sign }, axis, sign),
        };
        let rotation = match kind {
            RotationKind::General => r,
            _ => Matrix3::from_fn(|i, j| if i == axis[j] { sign[j] } else { 0.0 }),
        };
        Placement {
            rotation,
            translation: iso.translation.vector,
            identity: kind == RotationKind::Identity && iso.translation.vector == Vector3::zeros(),
            kind,
        }
    }

    /// True for the identity transform (most link frames sit on their body).
    pub(crate) fn is_identity(&self) -> bool {
        self.identity
    }

    /// `pose ∘ self`.
    #[inline(always)]
    /// The translation of [`after`](Self::after) alone: `pose`'s rotation
    /// applied to this placement's translation, plus `pose`'s translation.
    pub(crate) fn position_after(&self, pose: &IsometryMatrix3<f64>) -> Vector3<f64> {
        pose.translation.vector + pose.rotation.matrix() * self.translation
    }

    pub(crate) fn after(&self, pose: &IsometryMatrix3<f64>) -> IsometryMatrix3<f64> {
        if self.is_identity() {
            return *pose;
        }
        let rp = pose.rotation.matrix();
        let t = pose.translation.vector + rp * self.translation;
        let r = match self.kind {
            RotationKind::Identity => *rp,
            RotationKind::SignedPermutation { axis, sign } => Matrix3::from_columns(&[
                rp.column(axis[0]) * sign[0],
                rp.column(axis[1]) * sign[1],
                rp.column(axis[2]) * sign[2],
            ]),
            RotationKind::General => {
                let b = &self.rotation;
                let (c0, c1, c2) = (rp.column(0), rp.column(1), rp.column(2));
                Matrix3::from_columns(&[
                    c0 * b[(0, 0)] + c1 * b[(1, 0)] + c2 * b[(2, 0)],
                    c0 * b[(0, 1)] + c1 * b[(1, 1)] + c2 * b[(2, 1)],
                    c0 * b[(0, 2)] + c1 * b[(1, 2)] + c2 * b[(2, 2)],
                ])
            }
        };
        IsometryMatrix3::from_parts(Translation3::from(t), Rotation3::from_matrix_unchecked(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    // 1.57079632679 is the truncated π/2 many URDFs carry; it must stay General.
    #[allow(clippy::approx_constant)]
    fn every_kind_composes_like_a_matrix_product_and_positions_agree() {
        let pose = IsometryMatrix3::from_parts(
            Translation3::new(0.3, -0.2, 0.9),
            Rotation3::from_euler_angles(0.4, -1.1, 2.3),
        );
        for (rpy, kind) in [
            ([0.0, 0.0, 0.0], "identity"),
            ([std::f64::consts::FRAC_PI_2, 0.0, 0.0], "perm"),
            ([-std::f64::consts::FRAC_PI_2, 0.0, std::f64::consts::PI], "perm"),
            ([1.57079632679, 0.0, 0.0], "general"),
            ([0.1, 0.2, 0.3], "general"),
        ] {
            let iso = IsometryMatrix3::from_parts(
                Translation3::new(0.1, 0.0, -0.4),
                Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
            );
            let p = Placement::new(&iso);
            let expected = match kind {
                "identity" => RotationKind::Identity,
                "general" => RotationKind::General,
                _ => p.kind,
            };
            assert_eq!(p.kind, expected, "{rpy:?}");
            assert_ne!(matches!(p.kind, RotationKind::SignedPermutation { .. }), kind != "perm");
            let diff = (p.after(&pose).to_homogeneous() - (pose * iso).to_homogeneous()).abs().max();
            assert!(diff < 1e-15, "{rpy:?}: {diff:e}");
            let moved = (p.position_after(&pose) - (pose * iso).translation.vector).abs().max();
            assert!(moved < 1e-15, "{rpy:?}: {moved:e}");
        }
    }
}
