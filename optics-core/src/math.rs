//! f32 math for the per-sample geometry: `libm` by name, and a short polynomial sine and
//! cosine for the sampling warps.
//!
//! Method syntax (`x.cos()`) would resolve to std's inherent methods whenever std is linked into
//! the build (test harnesses, clippy's `--all-targets`), and to `num_traits::Float` otherwise;
//! calling libm by name gives the firmware's arithmetic in every build.

/// `(sin x, cos x)` for `|x| <= pi/4`, to within 1e-7.
///
/// Taylor polynomials to `x^9` and `x^8`: on this range the next terms are below 1e-9 and
/// 3e-8, so the error is float rounding. Inline and branch-free, it is several times cheaper
/// than a general `sin` and `cos`, which must reduce any argument; sampling warps (disk and
/// hemisphere) only ever need this range.
///
/// ```
/// let (s, c) = optics_core::math::sin_cos_small(0.5);
/// assert!((s - 0.5f32.sin()).abs() < 1e-7 && (c - 0.5f32.cos()).abs() < 1e-7);
/// ```
#[inline]
pub fn sin_cos_small(x: f32) -> (f32, f32) {
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0))));
    (s, c)
}

/// `(sin, cos)` of the angle `2 pi turns`, for `turns` in `[0, 1]`, to within 2e-7.
///
/// The angle is reduced to a quarter turn around 0 for [`sin_cos_small`], and the result
/// rotated back by the quadrant with bit operations, not a branch: in a sampling warp the
/// quadrant is random and a branch on it mispredicts three times in four. Arguments outside
/// `[0, 1]` give finite values in `[-1, 1]` but not the sine and cosine.
///
/// ```
/// let (s, c) = optics_core::math::sin_cos_turns(0.3);
/// let a = 0.3f32 * core::f32::consts::TAU;
/// assert!((s - a.sin()).abs() < 2e-7 && (c - a.cos()).abs() < 2e-7);
/// ```
#[inline]
pub fn sin_cos_turns(turns: f32) -> (f32, f32) {
    // Truncation rounds here (the argument is not negative); `round` is a libm call on the
    // baseline x86-64 target.
    let quadrant = (turns * 4.0 + 0.5) as i32;
    let (s, c) = sin_cos_small((turns - quadrant as f32 * 0.25) * core::f32::consts::TAU);
    // (sin, cos) of x + q pi/2: q odd swaps them, q = 2, 3 negates the sine, q = 1, 2 the
    // cosine.
    let q = quadrant as u32;
    let swap = 0u32.wrapping_sub(q & 1);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let sin = (sb & !swap) | (cb & swap);
    let cos = (cb & !swap) | (sb & swap);
    let sin_sign = (q & 2) << 30;
    let cos_sign = ((q + 1) & 2) << 30;
    (
        f32::from_bits(sin ^ sin_sign),
        f32::from_bits(cos ^ cos_sign),
    )
}

#[inline]
pub(crate) fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

#[inline]
pub(crate) fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

#[inline]
pub(crate) fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

#[inline]
pub(crate) fn atan(x: f32) -> f32 {
    libm::atanf(x)
}

#[inline]
pub(crate) fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_turns_matches_libm_over_the_whole_turn() {
        let mut worst = 0.0f64;
        for k in 0..=100_000 {
            let turns = k as f32 / 100_000.0;
            let (s, c) = sin_cos_turns(turns);
            let angle = core::f64::consts::TAU * turns as f64;
            worst = worst
                .max((s as f64 - libm::sin(angle)).abs())
                .max((c as f64 - libm::cos(angle)).abs());
        }
        assert!(worst < 2e-7, "{worst}");
    }

    #[test]
    fn sin_cos_small_matches_libm_on_its_range() {
        let quarter = core::f32::consts::FRAC_PI_4;
        let mut worst = 0.0f64;
        for k in -10_000..=10_000 {
            let x = quarter * k as f32 / 10_000.0;
            let (s, c) = sin_cos_small(x);
            worst = worst
                .max((s as f64 - libm::sin(x as f64)).abs())
                .max((c as f64 - libm::cos(x as f64)).abs());
        }
        assert!(worst < 1e-7, "{worst}");
    }
}
