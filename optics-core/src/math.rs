//! f32 math for the per-sample geometry, always from `libm`.
//!
//! Method syntax (`x.cos()`) would resolve to std's inherent methods whenever std is linked into
//! the build (test harnesses, clippy's `--all-targets`), and to `num_traits::Float` otherwise;
//! calling libm by name gives the firmware's arithmetic in every build.

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
