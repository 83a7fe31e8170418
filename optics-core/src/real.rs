use crate::{OpticsError, Result};

/// The float types optics-core's scalar equations are generic over: `f32` and `f64`.
///
/// Math functions come from `num_traits::Float`, backed by `libm` so the crate stays `no_std`.
pub trait Real:
    num_traits::Float + num_traits::FloatConst + core::fmt::Debug + Default + Send + Sync + 'static
{
    /// The literal `x` in this type (rounded for `f32`).
    fn lit(x: f64) -> Self;
    /// This value widened (or kept) as `f64`.
    fn as_f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn as_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn as_f64(self) -> f64 {
        self
    }
}

/// A distance that may be infinite (far limit of depth of field, hyperfocal distance with c = 0,
/// an image at infinity). Infinity is a variant, never an `inf` float left for the caller to meet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distance<T> {
    /// A finite distance, in millimetres.
    Finite(T),
    /// Infinitely far.
    Infinite,
}

impl<T: Real> Distance<T> {
    /// The finite value, or `None` when infinite.
    pub fn finite(self) -> Option<T> {
        match self {
            Self::Finite(x) => Some(x),
            Self::Infinite => None,
        }
    }

    /// Vergence in dioptres (1/m) of this distance given in millimetres: 0 at infinity.
    pub fn vergence_dioptres(self) -> T {
        match self {
            Self::Finite(x) => T::lit(1000.0) / x,
            Self::Infinite => T::zero(),
        }
    }
}

// Parameter checks shared by every module: one place that says what "valid" means.

/// `x` finite and > 0.
pub(crate) fn positive<T: Real>(x: T, name: &'static str) -> Result<T> {
    if x.is_finite() && x > T::zero() {
        Ok(x)
    } else {
        Err(OpticsError::InvalidParameter {
            name,
            allowed: "finite and > 0",
        })
    }
}

/// `x` finite and >= 0.
pub(crate) fn non_negative<T: Real>(x: T, name: &'static str) -> Result<T> {
    if x.is_finite() && x >= T::zero() {
        Ok(x)
    } else {
        Err(OpticsError::InvalidParameter {
            name,
            allowed: "finite and >= 0",
        })
    }
}

/// `x` > 0, where +infinity is allowed and means "at infinity".
pub(crate) fn positive_or_infinite<T: Real>(x: T, name: &'static str) -> Result<T> {
    if x > T::zero() && !x.is_nan() {
        Ok(x)
    } else {
        Err(OpticsError::InvalidParameter {
            name,
            allowed: "> 0 (infinity allowed)",
        })
    }
}

/// `x` finite.
pub(crate) fn finite<T: Real>(x: T, name: &'static str) -> Result<T> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(OpticsError::InvalidParameter {
            name,
            allowed: "finite",
        })
    }
}

/// A computed result, refused if it overflowed to infinity or NaN.
pub(crate) fn checked<T: Real>(x: T) -> Result<T> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(OpticsError::Overflow)
    }
}
