//! Arithmetic on [`LANES`] configurations side by side: every value is a
//! [`Lane`] array, one entry per configuration, and every loop runs over
//! the lanes so the compiler turns it into vector instructions (SSE2
//! always; AVX2 or AVX-512 in the builds `check.rs` dispatches to). All
//! functions are `#[inline(always)]` so they take the vector width of
//! their caller, and generic over the scalar ([`Real`]: f64, or f32 for
//! the single-precision plain check).
// Lane loops index several arrays by the lane on purpose: that is the
// shape the vectoriser recognises.
#![allow(clippy::needless_range_loop)]

pub use super::real::LANES;
pub(crate) use super::real::{Lane, Real, build};

/// The rotation of a body's constant joint frame in its parent's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum FrameRotation<T = f64> {
    /// Column `j` is `sign[j]` times basis vector `axis[j]`.
    Permutation { axis: [usize; 3], sign: [T; 3] },
    /// Column-major.
    General([T; 9]),
}

impl FrameRotation {
    /// The same rotation in single precision.
    pub(crate) fn single(&self) -> FrameRotation<f32> {
        match *self {
            FrameRotation::Permutation { axis, sign } => FrameRotation::Permutation { axis, sign: single(&sign) },
            FrameRotation::General(r) => FrameRotation::General(single(&r)),
        }
    }
}

/// `values` rounded to f32.
pub(crate) fn single<const N: usize>(values: &[f64; N]) -> [f32; N] {
    values.map(|x| x as f32)
}

/// A rigid transform per lane: rotation `r` column-major (`r[3 * col + row]`)
/// and translation `t`, mapping body coordinates to world coordinates (m).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LanePose<T = f64> {
    pub(crate) r: [Lane<T>; 9],
    pub(crate) t: [Lane<T>; 3],
}

impl<T: Real> LanePose<T> {
    pub(crate) const IDENTITY: LanePose<T> = {
        let (one, zero) = ([T::ONE; LANES], [T::ZERO; LANES]);
        LanePose { r: [one, zero, zero, zero, one, zero, zero, zero, one], t: [zero; 3] }
    };

    /// `parent ∘ (rotation, translation) ∘ joint`, written into `self`:
    /// a constant transform (rotation column-major), then a rotation about
    /// the body-frame `axis` by the per-lane angle with sine `s` and cosine
    /// `c` (x, y and z axes cost less).
    #[inline(always)]
    pub(crate) fn set_revolute(
        &mut self,
        parent: &LanePose<T>,
        (rotation, translation): (&FrameRotation<T>, &[T; 3]),
        axis: &[T; 3],
        (s, c): (&Lane<T>, &Lane<T>),
    ) {
        self.set_constant(parent, rotation, translation);
        // Columns `a` and `b` turn into each other; the third stays.
        let (o, z) = (T::ONE, T::ZERO);
        let (a, b) = match *axis {
            x if x == [o, z, z] => (1, 2),
            x if x == [z, o, z] => (2, 0),
            x if x == [z, z, o] => (0, 1),
            _ => return self.rotate_about(axis, s, c),
        };
        for i in 0..3 {
            let (ca, cb) = (self.r[3 * a + i], self.r[3 * b + i]);
            for l in 0..LANES {
                self.r[3 * a + i][l] = ca[l] * c[l] + cb[l] * s[l];
                self.r[3 * b + i][l] = cb[l] * c[l] - ca[l] * s[l];
            }
        }
    }

    /// `parent ∘ (rotation, translation) ∘ slide`, written into `self`: a
    /// constant transform, then a translation along the body-frame `axis`
    /// by the per-lane `value` (m).
    #[inline(always)]
    pub(crate) fn set_prismatic(
        &mut self,
        parent: &LanePose<T>,
        (rotation, translation): (&FrameRotation<T>, &[T; 3]),
        axis: &[T; 3],
        value: &Lane<T>,
    ) {
        self.set_constant(parent, rotation, translation);
        for i in 0..3 {
            let (r0, r1, r2) = (self.r[i], self.r[3 + i], self.r[6 + i]);
            for l in 0..LANES {
                self.t[i][l] += (r0[l] * axis[0] + r1[l] * axis[1] + r2[l] * axis[2]) * value[l];
            }
        }
    }

    /// `parent ∘ (rotation, translation)` for a constant transform
    /// (rotation column-major), written into `self`. Zero entries are
    /// skipped (robots' joint frames are mostly axis permutations and
    /// offsets along one axis): adding a zero product changes no bit
    /// of the sum, so the result is that of the full product.
    #[inline(always)]
    fn set_constant(&mut self, parent: &LanePose<T>, rotation: &FrameRotation<T>, translation: &[T; 3]) {
        match rotation {
            // Column j is ±1 times parent column axis[j]: the product
            // `combine` would compute, without looking for the nonzero weight.
            FrameRotation::Permutation { axis, sign } => {
                // By columns: one bounds check per column, not per entry.
                let (columns, _) = parent.r.as_chunks::<3>();
                for j in 0..3 {
                    let column = &columns[axis[j]];
                    for i in 0..3 {
                        for l in 0..LANES {
                            self.r[3 * j + i][l] = column[i][l] * sign[j];
                        }
                    }
                }
            }
            // Column j of the product: Σ_k rotation(k, j) · parent column k.
            FrameRotation::General(rotation) => {
                for j in 0..3 {
                    let column = combine(&parent.r, &[rotation[3 * j], rotation[3 * j + 1], rotation[3 * j + 2]]);
                    self.r[3 * j..3 * j + 3].copy_from_slice(&column);
                }
            }
        }
        let offset = combine(&parent.r, translation);
        for i in 0..3 {
            for l in 0..LANES {
                self.t[i][l] = parent.t[i][l] + offset[i][l];
            }
        }
    }

    /// Right-multiplies the rotation by a per-lane rotation about the unit
    /// `axis` (body coordinates) by the angle with sine `s` and cosine `c`.
    #[inline(always)]
    fn rotate_about(&mut self, axis: &[T; 3], s: &Lane<T>, c: &Lane<T>) {
        let [x, y, z] = *axis;
        let old = self.r;
        for l in 0..LANES {
            let (s, c) = (s[l], c[l]);
            let v = T::ONE - c;
            // Rodrigues, column-major.
            let m = [
                c + x * x * v,
                y * x * v + z * s,
                z * x * v - y * s,
                x * y * v - z * s,
                c + y * y * v,
                z * y * v + x * s,
                x * z * v + y * s,
                y * z * v - x * s,
                c + z * z * v,
            ];
            for j in 0..3 {
                for i in 0..3 {
                    self.r[3 * j + i][l] =
                        old[i][l] * m[3 * j] + old[3 + i][l] * m[3 * j + 1] + old[6 + i][l] * m[3 * j + 2];
                }
            }
        }
    }

    /// World position of a point given in body coordinates (m).
    #[inline(always)]
    pub(crate) fn point(&self, p: &[T; 3]) -> [Lane<T>; 3] {
        let mut out = self.t;
        for (i, o) in out.iter_mut().enumerate() {
            for l in 0..LANES {
                o[l] += self.r[i][l] * p[0] + self.r[3 + i][l] * p[1] + self.r[6 + i][l] * p[2];
            }
        }
        out
    }
}

/// `Σ_k weights[k] · column k of r` (rotation column-major), the sum
/// taken in order of k over the nonzero weights only.
#[inline(always)]
fn combine<T: Real>(r: &[Lane<T>; 9], weights: &[T; 3]) -> [Lane<T>; 3] {
    let mut sum = [[T::ZERO; LANES]; 3];
    let Some(first) = weights.iter().position(|&w| w != T::ZERO) else { return sum };
    let w = weights[first];
    for i in 0..3 {
        let column = &r[3 * first + i];
        for l in 0..LANES {
            sum[i][l] = column[l] * w;
        }
    }
    for k in first + 1..3 {
        let w = weights[k];
        if w == T::ZERO {
            continue;
        }
        for i in 0..3 {
            let column = &r[3 * k + i];
            for l in 0..LANES {
                sum[i][l] += column[l] * w;
            }
        }
    }
    sum
}

/// The larger of `a` and `b`: one instruction, unlike `f64::max`, whose
/// NaN handling costs several (inputs here are finite).
#[inline(always)]
pub(crate) fn max<T: Real>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// The smaller of `a` and `b` (see [`max`]).
#[inline(always)]
pub(crate) fn min<T: Real>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The largest lane, by halving (shuffles, not a scalar loop).
#[inline(always)]
pub(crate) fn lane_max<T: Real>(x: &Lane<T>) -> T {
    lane_reduce(x, max)
}

/// The smallest lane (see [`lane_max`]).
#[inline(always)]
pub(crate) fn lane_min<T: Real>(x: &Lane<T>) -> T {
    lane_reduce(x, min)
}

/// `pick` over the lanes by halving: the two halves combined lane by lane
/// until one is left.
#[inline(always)]
fn lane_reduce<T: Real>(x: &Lane<T>, pick: impl Fn(T, T) -> T) -> T {
    let (mut v, mut n) = (*x, LANES);
    while n > 1 {
        n /= 2;
        for l in 0..n {
            v[l] = pick(v[l], v[l + n]);
        }
    }
    v[0]
}

/// Squared distance from each lane's point to a fixed point (m²).
#[inline(always)]
pub(crate) fn point_distance_squared<T: Real>(p: &[Lane<T>; 3], c: &[T; 3]) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        let (x, y, z) = (p[0][l] - c[0], p[1][l] - c[1], p[2][l] - c[2]);
        out[l] = x * x + y * y + z * z;
    }
    out
}

/// Squared distance between two lanes of points (m²).
#[inline(always)]
pub(crate) fn lane_distance_squared<T: Real>(p: &[Lane<T>; 3], q: &[Lane<T>; 3]) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        let (x, y, z) = (p[0][l] - q[0][l], p[1][l] - q[1][l], p[2][l] - q[2][l]);
        out[l] = x * x + y * y + z * z;
    }
    out
}

/// Squared distance from each lane's point to the segment from `a` to
/// `a + ab`, with `len2 = |ab|²` (m²).
#[inline(always)]
pub(crate) fn segment_distance_squared<T: Real>(p: &[Lane<T>; 3], a: &[T; 3], ab: &[T; 3], len2: T) -> Lane<T> {
    let e = segment_offset(p, a, ab, len2);
    build(|l| e[0][l] * e[0][l] + e[1][l] * e[1][l] + e[2][l] * e[2][l])
}

/// Per lane, `p − q` with `q` the point of the segment from `a` to
/// `a + ab` nearest `p`, `len2 = |ab|²`.
#[inline(always)]
fn segment_offset<T: Real>(p: &[Lane<T>; 3], a: &[T; 3], ab: &[T; 3], len2: T) -> [Lane<T>; 3] {
    let mut out = [[T::ZERO; LANES]; 3];
    let inv = if len2 > T::ZERO { T::ONE / len2 } else { T::ZERO };
    for l in 0..LANES {
        let (x, y, z) = (p[0][l] - a[0], p[1][l] - a[1], p[2][l] - a[2]);
        let t = max(min((x * ab[0] + y * ab[1] + z * ab[2]) * inv, T::ONE), T::ZERO);
        (out[0][l], out[1][l], out[2][l]) = (x - ab[0] * t, y - ab[1] * t, z - ab[2] * t);
    }
    out
}

/// A fixed pose (rotation column-major); `upright` when it turns about z
/// only (MotionBenchMaker's boxes), whose zero entries [`to_local`] skips.
#[derive(Debug, Clone)]
pub(crate) struct Frame<T = f64> {
    pub(crate) rotation: [T; 9],
    pub(crate) translation: [T; 3],
    upright: bool,
}

impl Frame {
    pub(crate) fn new(rotation: [f64; 9], translation: [f64; 3]) -> Frame {
        let upright = [rotation[2], rotation[5], rotation[6], rotation[7]] == [0.0; 4];
        Frame { rotation, translation, upright }
    }

    /// The same frame in single precision (zero entries stay zero).
    pub(crate) fn single(&self) -> Frame<f32> {
        Frame { rotation: single(&self.rotation), translation: single(&self.translation), upright: self.upright }
    }
}

/// Each lane's point in `frame`, i.e. `Rᵀ (p − t)`. Upright frames skip
/// the products with zero, which change at most the sign of a zero
/// coordinate (the distances below take absolute values).
#[inline(always)]
pub(crate) fn to_local<T: Real>(p: &[Lane<T>; 3], frame: &Frame<T>) -> [Lane<T>; 3] {
    let (rotation, translation) = (&frame.rotation, &frame.translation);
    let mut out = [[T::ZERO; LANES]; 3];
    if frame.upright {
        for l in 0..LANES {
            let (x, y) = (p[0][l] - translation[0], p[1][l] - translation[1]);
            out[0][l] = rotation[0] * x + rotation[1] * y;
            out[1][l] = rotation[3] * x + rotation[4] * y;
            out[2][l] = rotation[8] * (p[2][l] - translation[2]);
        }
        return out;
    }
    for l in 0..LANES {
        let (x, y, z) = (p[0][l] - translation[0], p[1][l] - translation[1], p[2][l] - translation[2]);
        for (i, o) in out.iter_mut().enumerate() {
            o[l] = rotation[3 * i] * x + rotation[3 * i + 1] * y + rotation[3 * i + 2] * z;
        }
    }
    out
}

/// Squared distance from each lane's point (box frame) to a box of half
/// extents `h` (m²), or −1 for points inside it (and for those outside
/// by less than the square root of the smallest positive value, whose
/// square is 0: any pair limit fails them).
#[inline(always)]
pub(crate) fn box_distance_squared_local<T: Real>(p: &[Lane<T>; 3], h: &[T; 3]) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        let e = [p[0][l].abs() - h[0], p[1][l].abs() - h[1], p[2][l].abs() - h[2]];
        let (x, y, z) = (max(e[0], T::ZERO), max(e[1], T::ZERO), max(e[2], T::ZERO));
        let d2 = x * x + y * y + z * z;
        out[l] = if d2 > T::ZERO { d2 } else { -T::ONE };
    }
    out
}

/// Squared distance from each lane's point (cylinder frame) to a cylinder
/// along z of `radius` and `half_length` (m²), or −1 for points inside it.
#[inline(always)]
pub(crate) fn cylinder_distance_squared<T: Real>(p: &[Lane<T>; 3], radius: T, half_length: T) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        let rho = (p[0][l] * p[0][l] + p[1][l] * p[1][l]).sqrt();
        let (dr, dz) = (rho - radius, p[2][l].abs() - half_length);
        let side = max(dr, dz);
        out[l] = if dr > T::ZERO && dz > T::ZERO {
            dr * dr + dz * dz
        } else if side > T::ZERO {
            side * side
        } else {
            -T::ONE
        };
    }
    out
}

/// `(a − b) · v` for lanes of points `a`, `b` and vectors `v`.
#[inline(always)]
pub(crate) fn offset_dot<T: Real>(a: &[Lane<T>; 3], b: &[Lane<T>; 3], v: &[Lane<T>; 3]) -> Lane<T> {
    build(|l| (a[0][l] - b[0][l]) * v[0][l] + (a[1][l] - b[1][l]) * v[1][l] + (a[2][l] - b[2][l]) * v[2][l])
}

/// Per lane, the absolute rate of change of a distance `distance` (m)
/// whose offset `e` has `e · v = along`: `|along| / distance`.
#[inline(always)]
pub(crate) fn distance_rate<T: Real>(along: &Lane<T>, distance: &Lane<T>) -> Lane<T> {
    build(|l| (along[l] / distance[l]).abs())
}

/// `(p − c) · v` per lane (see `StaticShape::core_approach`).
#[inline(always)]
pub(crate) fn point_approach<T: Real>(p: &[Lane<T>; 3], c: &[T; 3], v: &[Lane<T>; 3]) -> Lane<T> {
    offset_dot(p, &c.map(|x| [x; LANES]), v)
}

/// `(p − q) · v` per lane, with `q` the point of the segment from `a` to
/// `a + ab` nearest `p` (as in [`segment_distance_squared`]).
#[inline(always)]
pub(crate) fn segment_approach<T: Real>(
    p: &[Lane<T>; 3],
    a: &[T; 3],
    ab: &[T; 3],
    len2: T,
    v: &[Lane<T>; 3],
) -> Lane<T> {
    let e = segment_offset(p, a, ab, len2);
    build(|l| e[0][l] * v[0][l] + e[1][l] * v[1][l] + e[2][l] * v[2][l])
}

/// Each lane's vector in `frame`'s coordinates, `Rᵀ v`.
#[inline(always)]
pub(crate) fn rotate_to_local<T: Real>(v: &[Lane<T>; 3], frame: &Frame<T>) -> [Lane<T>; 3] {
    let r = &frame.rotation;
    build(|i| build(|l| r[3 * i] * v[0][l] + r[3 * i + 1] * v[1][l] + r[3 * i + 2] * v[2][l]))
}

/// `e · v` per lane (box frame), `e` the offset from the box's point
/// nearest `p` to `p` (as in [`box_distance_squared_local`]).
#[inline(always)]
pub(crate) fn box_approach_local<T: Real>(p: &[Lane<T>; 3], h: &[T; 3], v: &[Lane<T>; 3]) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        for i in 0..3 {
            let e = max(p[i][l].abs() - h[i], T::ZERO);
            out[l] += e.copysign(p[i][l]) * v[i][l];
        }
    }
    out
}

/// `e · v` per lane (cylinder frame), `e` the offset from the cylinder's
/// point nearest `p` to `p` (as in [`cylinder_distance_squared`]).
#[inline(always)]
pub(crate) fn cylinder_approach_local<T: Real>(
    p: &[Lane<T>; 3],
    radius: T,
    half_length: T,
    v: &[Lane<T>; 3],
) -> Lane<T> {
    let mut out = [T::ZERO; LANES];
    for l in 0..LANES {
        let rho = (p[0][l] * p[0][l] + p[1][l] * p[1][l]).sqrt();
        let (radial, axial) = (max(rho - radius, T::ZERO), max(p[2][l].abs() - half_length, T::ZERO));
        // A point off the axis by `radial` moves away at the radial speed.
        let outward = if rho > T::ZERO { (p[0][l] * v[0][l] + p[1][l] * v[1][l]) / rho } else { T::ZERO };
        out[l] = radial * outward + axial.copysign(p[2][l]) * v[2][l];
    }
    out
}

/// Cross products `a × b` per lane.
#[inline(always)]
pub(crate) fn cross<T: Real>(a: &[Lane<T>; 3], b: &[Lane<T>; 3]) -> [Lane<T>; 3] {
    build(|i| {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        build(|l| a[j][l] * b[k][l] - a[k][l] * b[j][l])
    })
}

#[cfg(test)]
mod tests {
    use super::super::real::sin_cos;
    use super::*;

    #[test]
    fn upright_frames_transform_as_the_full_product() {
        let (s, c) = 0.3f64.sin_cos();
        let upright = Frame::new([c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0 - f64::EPSILON], [0.5, -0.2, 0.1]);
        let full = Frame { upright: false, ..upright.clone() };
        assert!(upright.upright);
        let p: [Lane; 3] = std::array::from_fn(|i| std::array::from_fn(|l| (l as f64 - 3.5) * 0.37 + i as f64 * 0.1));
        let (a, b) = (to_local(&p, &upright), to_local(&p, &full));
        for i in 0..3 {
            for l in 0..LANES {
                assert_eq!(a[i][l].abs().to_bits(), b[i][l].abs().to_bits());
            }
        }
    }

    #[test]
    fn permuted_placements_compose_as_the_full_product() {
        let mut parent = LanePose::IDENTITY;
        let angle: Lane = std::array::from_fn(|l| 0.3 + 0.71 * l as f64);
        let (s, c) = sin_cos::<f64>(&angle);
        let identity = FrameRotation::General([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        parent.set_revolute(&LanePose::IDENTITY, (&identity, &[0.1, 0.2, 0.3]), &[0.6, 0.0, 0.8], (&s, &c));
        // rpy = (π/2, 0, π/2), column-major: columns y, z, x; and its negative.
        for sign in [1.0, -1.0] {
            let general = FrameRotation::General([0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0].map(|x| x * sign));
            let permutation = FrameRotation::Permutation { axis: [1, 2, 0], sign: [sign; 3] };
            let (mut full, mut permuted) = (LanePose::IDENTITY, LanePose::IDENTITY);
            full.set_revolute(&parent, (&general, &[0.0, 0.0, 0.27]), &[0.0, 0.0, 1.0], (&s, &c));
            permuted.set_revolute(&parent, (&permutation, &[0.0, 0.0, 0.27]), &[0.0, 0.0, 1.0], (&s, &c));
            assert_eq!(full.r.map(|x| x.map(f64::to_bits)), permuted.r.map(|x| x.map(f64::to_bits)));
            assert_eq!(full.t.map(|x| x.map(f64::to_bits)), permuted.t.map(|x| x.map(f64::to_bits)));
        }
    }
}
