//! The scalars the sphere lanes compute in ([`Real`]: f64, or f32 for the
//! single-precision plain check of `single.rs`) and their lane-parallel
//! sines and cosines, which the forward kinematics of every check needs.
// Lane loops index several arrays by the lane on purpose (see `lanes.rs`).
#![allow(clippy::needless_range_loop)]

/// Configurations the sphere fast path checks together.
pub const LANES: usize = 8;

/// One value per configuration.
pub(crate) type Lane<T = f64> = [T; LANES];

/// The array of `f(i)` for every index, by a plain loop:
/// `std::array::from_fn` goes through a closure adapter that LLVM does not
/// always inline, and when it does not, every lane of the hot checks
/// costs a call (seen as `try_trait::Wrapped::call_mut` in profiles, +6 %
/// of the Panda's planning instructions after an unrelated change).
#[inline(always)]
pub(crate) fn build<T: Copy + Default, const N: usize>(mut f: impl FnMut(usize) -> T) -> [T; N] {
    let mut out = [T::default(); N];
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(i);
    }
    out
}

/// The scalar the lanes compute in: `f64` for certification and the
/// checks a caller sees, `f32` for the single-precision plain check that
/// answers most of a search's checks first (see `single.rs`).
pub(crate) trait Real:
    Copy
    + Default
    + PartialOrd
    + std::fmt::Debug
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
    + std::ops::AddAssign
{
    const ZERO: Self;
    const ONE: Self;
    const INFINITY: Self;
    const NEG_INFINITY: Self;
    /// `x`, rounded to this type.
    fn of(x: f64) -> Self;
    /// The value in f64 (exact).
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn copysign(self, sign: Self) -> Self;
    fn is_nan(self) -> bool;
    /// Sine and cosine of `r`, |r| ≤ π/4 (rad), by a kernel polynomial.
    fn sin_cos_kernel(r: f64) -> (Self, Self);
    /// Sine and cosine of every lane's angle (rad), see [`sin_cos`].
    fn lane_sin_cos(x: &Lane) -> (Lane<Self>, Lane<Self>);
}

/// The [`Real`] items both precisions write the same way.
macro_rules! real_basics {
    ($t:ident) => {
        const ZERO: $t = 0.0;
        const ONE: $t = 1.0;
        const INFINITY: $t = $t::INFINITY;
        const NEG_INFINITY: $t = $t::NEG_INFINITY;
        #[inline(always)]
        fn of(x: f64) -> $t {
            x as $t
        }
        #[inline(always)]
        fn to_f64(self) -> f64 {
            self as f64
        }
        #[inline(always)]
        fn sqrt(self) -> $t {
            $t::sqrt(self)
        }
        #[inline(always)]
        fn abs(self) -> $t {
            $t::abs(self)
        }
        #[inline(always)]
        fn copysign(self, sign: $t) -> $t {
            $t::copysign(self, sign)
        }
        #[inline(always)]
        fn is_nan(self) -> bool {
            $t::is_nan(self)
        }
    };
}

impl Real for f64 {
    real_basics!(f64);
    /// fdlibm's kernel polynomials.
    #[inline(always)]
    fn sin_cos_kernel(r: f64) -> (f64, f64) {
        const S: [f64; 6] = [
            f64::from_bits(0xBFC5_5555_5555_5549),
            f64::from_bits(0x3F81_1111_1110_F8A6),
            f64::from_bits(0xBF2A_01A0_19C1_61D5),
            f64::from_bits(0x3EC7_1DE3_57B1_FE7D),
            f64::from_bits(0xBE5A_E5E6_8A2B_9CEB),
            f64::from_bits(0x3DE5_D93A_5ACF_D57C),
        ];
        const C: [f64; 6] = [
            f64::from_bits(0x3FA5_5555_5555_554C),
            f64::from_bits(0xBF56_C16C_16C1_5177),
            f64::from_bits(0x3EFA_01A0_19CB_1590),
            f64::from_bits(0xBE92_7E4F_809C_52AD),
            f64::from_bits(0x3E21_EE9E_BDB4_B1C4),
            f64::from_bits(0xBDA8_FAE9_BE88_38D4),
        ];
        let z = r * r;
        let ps = S[0] + z * (S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5]))));
        let pc = C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5]))));
        (r + r * z * ps, (1.0 - 0.5 * z) + z * z * pc)
    }
    #[inline(always)]
    fn lane_sin_cos(x: &Lane) -> (Lane, Lane) {
        sin_cos(x)
    }
}

impl Real for f32 {
    real_basics!(f32);
    #[inline(always)]
    fn sin_cos_kernel(r: f64) -> (f32, f32) {
        single_kernel(r as f32)
    }
    #[inline(always)]
    fn lane_sin_cos(x: &Lane) -> (Lane<f32>, Lane<f32>) {
        single_sin_cos(x)
    }
}

/// Cephes' single-precision kernels (`sinf`, `cosf`), a few units in the
/// last place of f32 on [−π/4, π/4].
#[inline(always)]
fn single_kernel(r: f32) -> (f32, f32) {
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// Up to this |angle| (rad), f32 lanes reduce their argument in f32: the
/// angle's rounding to f32 costs at most `u · 8` rad (`u` the unit
/// roundoff of f32, see `single.rs`). Joint ranges within ±2π fit.
pub(crate) const SINGLE_REDUCTION_LIMIT: f32 = 8.0;

/// [`sin_cos`] in f32, the argument reduced in f32 when every lane's angle
/// is within [`SINGLE_REDUCTION_LIMIT`] (one register per operation with
/// AVX2), else in f64.
#[inline(always)]
fn single_sin_cos(x: &Lane) -> (Lane<f32>, Lane<f32>) {
    // 1.5 · 2^23 (see `sin_cos`), and π/2 in three parts (Cephes' π/4
    // parts, doubled): the first two have few bits, so their products
    // with the small quadrant numbers here are exact.
    const SHIFT: f32 = 12_582_912.0;
    const PIO2_1: f32 = 1.570_312_5;
    const PIO2_2: f32 = 4.837_513e-4;
    const PIO2_3: f32 = 7.549_79e-8;
    let xf: Lane<f32> = build(|l| x[l] as f32);
    let mut within = true;
    for l in 0..LANES {
        within &= xf[l].abs() <= SINGLE_REDUCTION_LIMIT;
    }
    if !within {
        return sin_cos(x);
    }
    let (mut sin, mut cos) = ([0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let shifted = xf[l] * std::f32::consts::FRAC_2_PI + SHIFT;
        let n = shifted - SHIFT;
        let quadrant = shifted.to_bits() & 3;
        let r = ((xf[l] - n * PIO2_1) - n * PIO2_2) - n * PIO2_3;
        let (s, c) = single_kernel(r);
        (sin[l], cos[l]) = by_quadrant(quadrant & 1 != 0, quadrant & 2 != 0, (s, c));
    }
    (sin, cos)
}

/// Sine and cosine of `r + k π/2` from those of `r`, given `k`'s two low
/// bits (`odd`: bit 0; `negate`: bit 1). The bits are tested in each
/// caller's own integer width, so the lanes' masks stay that width.
#[inline(always)]
fn by_quadrant<T: Real>(odd: bool, negate: bool, (s, c): (T, T)) -> (T, T) {
    let (s, c) = if odd { (c, -s) } else { (s, c) };
    if negate { (-s, -c) } else { (s, c) }
}

/// Beyond this |angle| (rad) the polynomial's argument reduction is not
/// trusted and the lanes go through the standard library.
const REDUCTION_LIMIT: f64 = 1.0e5;

/// Sine and cosine of every lane (angles in f64, rad), within a few units
/// in the last place of `T`: argument reduction by π/2 in three parts
/// (fdlibm's constants) in f64, then `T`'s kernel polynomials on
/// [−π/4, π/4]. For f64, within a few units in the last place of the
/// standard library's.
#[inline(always)]
pub(crate) fn sin_cos<T: Real>(x: &Lane) -> (Lane<T>, Lane<T>) {
    // 1.5 · 2^52: adding it rounds to an integer kept in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    // fdlibm's π/2 in three 33-bit parts, by their bits.
    const PIO2_1: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_2: f64 = f64::from_bits(0x3DD0_B461_1A60_0000);
    const PIO2_3: f64 = f64::from_bits(0x3BA3_198A_2E00_0000);
    let (mut sin, mut cos) = ([T::ZERO; LANES], [T::ZERO; LANES]);
    for l in 0..LANES {
        let shifted = x[l] * std::f64::consts::FRAC_2_PI + SHIFT;
        let n = shifted - SHIFT;
        let quadrant = shifted.to_bits() & 3;
        let r = ((x[l] - n * PIO2_1) - n * PIO2_2) - n * PIO2_3;
        let (s, c) = T::sin_cos_kernel(r);
        (sin[l], cos[l]) = by_quadrant(quadrant & 1 != 0, quadrant & 2 != 0, (s, c));
    }
    if x.iter().any(|v| v.abs() > REDUCTION_LIMIT) {
        for l in 0..LANES {
            if x[l].abs() > REDUCTION_LIMIT {
                let (s, c) = x[l].sin_cos();
                (sin[l], cos[l]) = (T::of(s), T::of(c));
            }
        }
    }
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_matches_the_standard_library_in_both_precisions() {
        let (mut worst, mut worst32) = (0.0f64, 0.0f64);
        for k in -20000..20000 {
            let base = k as f64 * 7.3e-4;
            let x: Lane = std::array::from_fn(|l| base * (1.0 + l as f64) + [0.0, 1e-300, -0.0, 1e5][l % 4]);
            let (s, c) = sin_cos::<f64>(&x);
            let (s32, c32) = sin_cos::<f32>(&x);
            for l in 0..LANES {
                let (es, ec) = x[l].sin_cos();
                worst32 = worst32.max((s32[l] as f64 - es).abs()).max((c32[l] as f64 - ec).abs());
                worst = worst.max((s[l] - es).abs()).max((c[l] - ec).abs());
            }
        }
        assert!(worst < 4.0 * f64::EPSILON, "{worst:e}");
        // Single precision: the kernel's error, the argument reduced in f64.
        assert!(worst32 < 2.0 * f32::EPSILON as f64, "{worst32:e}");
        // Reduced in f32: the angle's rounding to f32 adds up to u·|x|.
        let mut worst_small = 0.0f64;
        for k in -20000..=20000 {
            let x: Lane = std::array::from_fn(|l| (k as f64 * 4e-4 + l as f64 * 1e-5).clamp(-8.0, 8.0));
            let (s, c) = f32::lane_sin_cos(&x);
            for l in 0..LANES {
                let (es, ec) = x[l].sin_cos();
                let allowed = f32::EPSILON as f64 * (2.0 + 0.5 * x[l].abs());
                worst_small = worst_small.max(((s[l] as f64 - es).abs()).max((c[l] as f64 - ec).abs()) / allowed);
            }
        }
        assert!(worst_small <= 1.0, "{worst_small}");
        let (s, c) = sin_cos::<f64>(&[1e6, -3e7, 1e300, 0.5, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!((s[0], c[1]), (1e6f64.sin(), (-3e7f64).cos()));
        assert!(s[2].is_finite() && c[2].is_finite());
    }
}
