//! Rotation helpers shared by IK and the optimizer's orientation features.

use nalgebra::{Rotation3, UnitQuaternion, Vector3};

/// The rotation vector `φ` (axis × angle, rad, angle in [0, π]) with
/// `exp(φ^) = r`, accurate to rounding over the whole range: the skew part
/// with `atan2` away from π, and the quaternion near π, where nalgebra's
/// `Rotation3::scaled_axis` can take `acos` of a value just past −1 and
/// return NaN.
///
/// ```
/// use nalgebra::{Rotation3, Vector3};
/// let phi = Vector3::new(0.0, 0.0, std::f64::consts::PI - 1e-9);
/// let log = tandem::robot::rotation_log(&Rotation3::new(phi));
/// assert!((log - phi).norm() < 1e-9);
/// ```
pub fn rotation_log(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    let v = 0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]);
    let (s, c) = (v.norm(), 0.5 * (m.trace() - 1.0));
    if s < 1e-7 && c > 0.0 {
        v * (1.0 + s * s / 6.0)
    } else if c > -0.9 {
        v * (s.atan2(c) / s)
    } else {
        UnitQuaternion::from_rotation_matrix(r).scaled_axis()
    }
}
