//! Quarter turns, snapped. Many URDFs write π/2 to eleven digits
//! (`rpy="1.57079632679 0 0"`: Baxter's, TIAGo's, the UR5's, and
//! MotionBenchMaker's Panda's), so their joint frames turn a few 1e-12 rad
//! away from a signed permutation. The exact model keeps them as written
//! (it agrees with Pinocchio), but on the fast path each costs a full 3×3
//! product per body and lane where a permutation costs a third of it.
//!
//! The fast path replaces such a rotation by the permutation when the error
//! this brings to every point it places, bounded along each chain, stays
//! within a quarter of [`TOLERANCE`]. The fast path then checks a robot
//! whose spheres lie at most that far from the exact model's, for every
//! configuration, and the tolerance band still hands each close call to
//! the exact model.
//!
//! ```text
//! error(point p on body b) ≤ shift[b] + turn[b]·|p|
//! turn[b]  = turn[parent] + ‖ΔC_b‖        (rotation error, spectral ≤ Frobenius)
//! shift[b] = shift[parent] + turn[parent]·|c_b|   (c_b the joint frame's offset)
//! ```

use super::{FrameRotation, LaneBody, TOLERANCE};
use crate::robot::{Motion, signed_permutation_near};
use nalgebra::Matrix3;

/// Entries within this of 0 or ±1 make a rotation a candidate (the budget
/// decides): an eleven-digit π/2 is 4.9e-12 off, a four-digit one 3.7e-6.
const SNAP: f64 = 1e-9;

/// The largest error (m) snapping may bring to any sphere.
const BUDGET: f64 = TOLERANCE / 4.0;

/// What the sphere fast path did with joint frames a rounding error away
/// from quarter turns (see
/// [`CollisionModel::snapped_quarter_turns`](crate::collision::CollisionModel::snapped_quarter_turns)).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SnappedQuarterTurns {
    /// Joint frames replaced by the exact quarter turns (0: none, either
    /// because none was off or because the bound would exceed the budget).
    pub frames: usize,
    /// Bound on how far any sphere the fast path places lies from the exact
    /// model's, for every configuration (m; 0 when nothing was snapped).
    pub error: f64,
}

/// The signed permutation within [`SNAP`] of the general rotation `r`
/// (column-major) per entry, with the Frobenius norm of their difference
/// (0 when `r` is one exactly, or already a permutation).
fn nearest_signed_permutation(r: &FrameRotation) -> Option<(FrameRotation, f64)> {
    let FrameRotation::General(r) = r else { return Some((*r, 0.0)) };
    let (axis, sign) = signed_permutation_near(&Matrix3::from_column_slice(r), SNAP)?;
    let exact: [f64; 9] = std::array::from_fn(|k| if k % 3 == axis[k / 3] { sign[k / 3] } else { 0.0 });
    let error = r.iter().zip(&exact).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    Some((FrameRotation::Permutation { axis, sign }, error))
}

/// Euclidean length of `v`.
pub(super) fn norm(v: &[f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Snaps the bodies' near-quarter-turn rotations when the bound stays within
/// [`BUDGET`]; `extent[b]` is the largest distance (m) from body `b`'s
/// origin of a point the fast path places on it. Bodies come after their
/// parents; body 0 is the root. Nothing is snapped above a prismatic
/// joint: its slide's error would grow with the joint's value.
pub(super) fn snap(bodies: &mut [LaneBody], extent: &[f64]) -> SnappedQuarterTurns {
    let candidates: Vec<_> = bodies.iter().map(|b| nearest_signed_permutation(&b.rotation)).collect();
    let (mut turn, mut shift) = (vec![0.0; bodies.len()], vec![0.0; bodies.len()]);
    let mut worst = 0.0f64;
    for b in 1..bodies.len() {
        let (body, parent) = (&bodies[b], bodies[b].parent);
        shift[b] = shift[parent] + turn[parent] * norm(&body.translation);
        turn[b] = turn[parent] + candidates[b].map_or(0.0, |(_, e)| e);
        // A slide carries its frame's error by the joint's value.
        let slides = matches!(body.motion, Motion::Prismatic(_)) && turn[b] > 0.0;
        worst = if slides { f64::INFINITY } else { worst.max(shift[b] + turn[b] * extent[b]) };
    }
    let snapping = worst <= BUDGET;
    let mut frames = 0;
    // Exact permutations compose as such whether or not the others snap.
    for (body, (p, error)) in bodies.iter_mut().zip(candidates).filter_map(|(b, c)| Some((b, c?))) {
        if snapping || error == 0.0 {
            frames += usize::from(error > 0.0);
            body.rotation = p;
        }
    }
    SnappedQuarterTurns { frames, error: if frames > 0 { worst } else { 0.0 } }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn column_major(r: &Rotation3<f64>) -> FrameRotation {
        FrameRotation::General(std::array::from_fn(|k| r.matrix()[(k % 3, k / 3)]))
    }

    #[test]
    #[allow(clippy::approx_constant)]
    fn eleven_digit_quarter_turns_are_candidates_and_others_are_not() {
        let truncated = column_major(&Rotation3::from_euler_angles(1.57079632679, 0.0, 1.57079632679));
        let (p, error) = nearest_signed_permutation(&truncated).expect("a quarter turn");
        assert!(error > 0.0 && error < 1e-10, "{error:e}");
        // Columns y, z, x.
        assert_eq!(p, FrameRotation::Permutation { axis: [1, 2, 0], sign: [1.0; 3] });
        for angle in [1.5708, 0.7854, 0.3] {
            assert!(
                nearest_signed_permutation(&column_major(&Rotation3::from_euler_angles(angle, 0.0, 0.0))).is_none()
            );
        }
    }

    /// A chain of `motions` below the root, each joint frame a quarter turn
    /// about x missed by `off` rad, 1 m from its parent.
    fn chain(off: f64, motions: &[Motion]) -> Vec<LaneBody> {
        let rotation = column_major(&Rotation3::from_euler_angles(std::f64::consts::FRAC_PI_2 - off, 0.0, 0.0));
        let body = |parent: usize, motion: Motion| LaneBody {
            parent,
            rotation,
            translation: [0.0, 0.0, 1.0],
            motion,
            axis: [0.0, 0.0, 1.0],
            column: parent,
            multiplier: 1.0,
            offset: 0.0,
        };
        let root = LaneBody { rotation: column_major(&Rotation3::identity()), ..body(0, Motion::RevoluteZ) };
        std::iter::once(root).chain(motions.iter().enumerate().map(|(k, &m)| body(k, m))).collect()
    }

    #[test]
    fn snapping_stays_within_its_budget() {
        let revolute = [Motion::RevoluteZ; 3];
        // 1e-12 rad per frame: snapped, the bound summed along the chain.
        let mut bodies = chain(1e-12, &revolute);
        let snapped = snap(&mut bodies, &[0.0, 1.0, 1.0, 1.0]);
        assert_eq!(snapped.frames, 3);
        assert!(snapped.error > 5e-12 && snapped.error < 2e-11, "{snapped:?}");
        assert!(bodies[1..].iter().all(|b| matches!(b.rotation, FrameRotation::Permutation { .. })));
        // 4e-10 rad per frame: each a candidate, but the chain's bound
        // exceeds the budget, so none is snapped.
        let mut bodies = chain(4e-10, &revolute);
        let before: Vec<_> = bodies.iter().map(|b| b.rotation).collect();
        assert_eq!(snap(&mut bodies, &[0.0, 1.0, 1.0, 1.0]), SnappedQuarterTurns::default());
        // (The root's exact identity composes as a permutation either way.)
        assert!(bodies[1..].iter().zip(&before[1..]).all(|(b, r)| b.rotation == *r));
        // A slide below a snapped frame would carry its error by the
        // joint's value: nothing is snapped.
        let mut bodies = chain(1e-12, &[Motion::RevoluteZ, Motion::Prismatic(nalgebra::Vector3::z())]);
        assert_eq!(snap(&mut bodies, &[0.0, 1.0, 1.0]), SnappedQuarterTurns::default());
    }
}
