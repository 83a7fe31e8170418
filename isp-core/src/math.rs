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
