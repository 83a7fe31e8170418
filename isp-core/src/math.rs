//! Float math from `libm` by name, so every build (including test builds that link std)
//! computes what the firmware computes.

#[inline]
pub(crate) fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

#[inline]
pub(crate) fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

#[inline]
pub(crate) fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}

#[inline]
pub(crate) fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

#[inline]
pub(crate) fn sin(x: f64) -> f64 {
    libm::sin(x)
}

#[inline]
pub(crate) fn cos(x: f64) -> f64 {
    libm::cos(x)
}

#[inline]
pub(crate) fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

#[inline]
pub(crate) fn exp(x: f64) -> f64 {
    libm::exp(x)
}

#[inline]
pub(crate) fn log10(x: f64) -> f64 {
    libm::log10(x)
}

#[inline]
pub(crate) fn acos(x: f64) -> f64 {
    libm::acos(x)
}

/// `x` rounded to the nearest integer (ties to even), for `|x| < 2^22`, by adding 1.5 x 2^23,
/// which leaves the integer in the low bits of the sum: no float-to-integer conversion, whose
/// saturating `as` LLVM leaves as a scalar conversion (or a branch) per lane.
#[inline(always)]
pub(crate) fn nearest(x: f32) -> i32 {
    const ROUNDER: f32 = 12_582_912.0;
    ((x + ROUNDER).to_bits() as i32).wrapping_sub(ROUNDER.to_bits() as i32)
}

/// A xorshift64 generator (Marsaglia 2003, shifts 13, 7, 17) from a non-zero `seed`: the
/// tests' reproducible operands.
#[cfg(test)]
pub(crate) fn xorshift(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// `sqrt(a)` for finite `a >= 0`, in `f32` arithmetic alone so that a loop of it vectorises
/// (libm's `sqrtf` is an instruction in inline assembly on x86, which the vectoriser cannot
/// widen, and a software routine on a Cortex-M): the reciprocal square root from the bit
/// pattern's estimate (Lomont's constant, within 3.5 % of it) refined by three Newton steps,
/// then times `a`. Within 4e-7 of the square root relative (tested over every octave); 0 at 0.
/// The same operations in the same order on every target, so the same bits.
#[inline(always)]
pub(crate) fn sqrt_f32(a: f32) -> f32 {
    let mut y = f32::from_bits(0x5f37_5a86u32.wrapping_sub(a.to_bits() >> 1));
    let half = 0.5 * a;
    for _ in 0..3 {
        y *= 1.5 - half * y * y;
    }
    a * y
}

/// `b^k` for `b >= 0` and `k` in `(0, 4]` estimated in `f32` arithmetic alone, as `2^(k log2 b)`
/// (so a loop of it vectorises: no `powf` call per sample), and `y = k log2 b`.
///
/// `log2 b` is the exponent plus `log2 m` for the mantissa `m` in `[1/sqrt 2, sqrt 2]`, from
/// the series `(2 / ln 2) (s + s^3/3 + ... + s^9/9)` in `s = (m - 1) / (m + 1)`, `|s| < 0.172`
/// (the next term is below 2^-31); `2^f` for the fraction `|f| <= 1/2` of `y` is Taylor's
/// series of `e^(f ln 2)` to degree 6 (the rest about 2^-23). Relative to the exact power the
/// estimate is within `(|y| + k + 4) 2^-22` for normal `b` with `y > -100` (the tone table's
/// test checks it against libm over every base it evaluates; the pipeline's float tone and
/// sRGB curve are tested against the exact curves); a power below 2^-100 (a base of 0
/// among them) is 0, with `y` clamped at -100: never NaN, infinite or subnormal.
#[inline(always)]
pub(crate) fn pow_estimate(b: f32, k: f32) -> (f32, f32) {
    const SQRT_2: f32 = core::f32::consts::SQRT_2;
    const LOG2_E_2: f32 = 2.0 * core::f32::consts::LOG2_E;
    let bits = b.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    // Selects, not a branch, so that a loop of this vectorises.
    let high = m > SQRT_2;
    let m = if high { m * 0.5 } else { m };
    let exponent = exponent + i32::from(high);
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0))));
    let y = k * (exponent as f32 + LOG2_E_2 * s * series);
    // Powers below 2^-100 are 0: no subnormal result (whose arithmetic x86 takes a hundred
    // cycles over), and 0 for a base of 0, as the exact power.
    let tiny = y <= -100.0;
    let y = if tiny { -100.0 } else { y };
    let n = nearest(y);
    let t = (y - n as f32) * core::f32::consts::LN_2;
    let taylor = 1.0
        + t * (1.0
            + t * (1.0 / 2.0
                + t * (1.0 / 6.0 + t * (1.0 / 24.0 + t * (1.0 / 120.0 + t * (1.0 / 720.0))))));
    // 2^n, a normal `f32`: -100 <= n <= 127 for y in [-100, 127].
    let scale = f32::from_bits(((n + 127) as u32) << 23);
    (if tiny { 0.0 } else { taylor * scale }, y)
}
