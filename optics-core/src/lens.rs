//! Thin and thick lenses: lensmaker's equation, the Gaussian lens formula
//! `1/s_o + 1/s_i = 1/f`, lens power, lateral magnification, and focusing by moving the sensor.
//!
//! Distances in millimetres, positive for a real object in front of the lens and a real image
//! behind it. Power in dioptres (1/m) where the name says so, otherwise in 1/mm.

use crate::real::{checked, finite, positive, positive_or_infinite};
use crate::{OpticsError, Real, Result};

/// Where an image forms, told apart so a virtual image is never a negative number left for the
/// caller to misread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ImageDistance<T> {
    /// A real image this far behind the lens (or surface), in millimetres.
    Real(T),
    /// A virtual image this far in front of the lens (on the object's side), in millimetres.
    Virtual(T),
    /// The image is at infinity (object at the focal point).
    Infinite,
}

impl<T: Real> ImageDistance<T> {
    /// `z' = n' / vergence`, classified by sign; vergence 0 is an image at infinity.
    pub(crate) fn from_vergence(n_prime: T, vergence: T) -> Result<Self> {
        if vergence == T::zero() {
            return Ok(Self::Infinite);
        }
        let z = checked(n_prime / vergence)?;
        Ok(if z > T::zero() {
            Self::Real(z)
        } else {
            Self::Virtual(-z)
        })
    }

    /// Signed distance behind the lens (negative for a virtual image), `None` at infinity.
    pub fn signed(self) -> Option<T> {
        match self {
            Self::Real(z) => Some(z),
            Self::Virtual(d) => Some(-d),
            Self::Infinite => None,
        }
    }
}

fn radius<T: Real>(r: T, name: &'static str) -> Result<T> {
    if r.is_nan() || r == T::zero() {
        return Err(OpticsError::InvalidParameter {
            name,
            allowed: "non-zero (infinite for a flat surface)",
        });
    }
    Ok(r)
}

fn index<T: Real>(n: T) -> Result<T> {
    if n.is_finite() && n >= T::one() {
        Ok(n)
    } else {
        Err(OpticsError::InvalidParameter {
            name: "n",
            allowed: "finite and >= 1",
        })
    }
}

/// Power (1/mm) of a thin lens of index `n` in air with surface radii `r1`, `r2` (lensmaker's
/// equation `1/f = (n - 1)(1/R1 - 1/R2)`). Infinite radii are flat surfaces.
pub fn lensmaker_power<T: Real>(n: T, r1: T, r2: T) -> Result<T> {
    index(n)?;
    let (r1, r2) = (radius(r1, "r1")?, radius(r2, "r2")?);
    checked((n - T::one()) * (r1.recip() - r2.recip()))
}

/// Focal length (mm) of a thin lens from lensmaker's equation; [`OpticsError::ZeroPower`] for an
/// afocal lens (equal radii).
///
/// ```
/// use optics_core::lens::lensmaker_focal_length;
/// // Symmetric biconvex lens, n = 1.5, |R| = 100 mm: f = 100 mm.
/// let f = lensmaker_focal_length(1.5_f64, 100.0, -100.0).unwrap();
/// assert!((f - 100.0).abs() < 1e-12);
/// ```
pub fn lensmaker_focal_length<T: Real>(n: T, r1: T, r2: T) -> Result<T> {
    focal_length_from_power(lensmaker_power(n, r1, r2)?)
}

/// Power (1/mm) of a thick lens of index `n`, radii `r1`, `r2` and centre thickness `d` (mm):
/// `1/f = (n-1) [1/R1 - 1/R2 + (n-1) d / (n R1 R2)]`.
pub fn thick_lens_power<T: Real>(n: T, r1: T, r2: T, d: T) -> Result<T> {
    index(n)?;
    let (r1, r2) = (radius(r1, "r1")?, radius(r2, "r2")?);
    if !(d.is_finite() && d >= T::zero()) {
        return Err(OpticsError::InvalidParameter {
            name: "d",
            allowed: "finite and >= 0",
        });
    }
    let nm1 = n - T::one();
    // (r1 r2) may overflow or be infinite for flat surfaces: divide step by step.
    let thickness_term = nm1 * d / n / r1 / r2;
    checked(nm1 * (r1.recip() - r2.recip() + thickness_term))
}

/// Focal length (mm) of a thick lens (measured from its principal planes).
pub fn thick_lens_focal_length<T: Real>(n: T, r1: T, r2: T, d: T) -> Result<T> {
    focal_length_from_power(thick_lens_power(n, r1, r2, d)?)
}

fn focal_length_from_power<T: Real>(power_per_mm: T) -> Result<T> {
    if power_per_mm == T::zero() {
        return Err(OpticsError::ZeroPower);
    }
    checked(power_per_mm.recip())
}

/// Lens power in dioptres (1/m) of a focal length in millimetres: `P = 1000 / f`.
pub fn power_dioptres<T: Real>(focal_length_mm: T) -> Result<T> {
    let f = finite(focal_length_mm, "focal_length_mm")?;
    if f == T::zero() {
        return Err(OpticsError::InvalidParameter {
            name: "focal_length_mm",
            allowed: "non-zero",
        });
    }
    checked(T::lit(1000.0) / f)
}

/// Focal length (mm) of a power in dioptres; [`OpticsError::ZeroPower`] for 0.
pub fn focal_length_from_dioptres<T: Real>(power: T) -> Result<T> {
    finite(power, "power")?;
    focal_length_from_power(power / T::lit(1000.0))
}

/// Power (dioptres) of two thin lenses separated by `separation_mm`:
/// `P = P1 + P2 - d P1 P2` (with `d` in metres); `d = 0` is two lenses in contact, `P1 + P2`.
pub fn combined_power_dioptres<T: Real>(p1: T, p2: T, separation_mm: T) -> Result<T> {
    finite(p1, "p1")?;
    finite(p2, "p2")?;
    if !(separation_mm.is_finite() && separation_mm >= T::zero()) {
        return Err(OpticsError::InvalidParameter {
            name: "separation_mm",
            allowed: "finite and >= 0",
        });
    }
    checked(p1 + p2 - separation_mm / T::lit(1000.0) * p1 * p2)
}

fn focal_length<T: Real>(f: T) -> Result<T> {
    let f = finite(f, "focal_length")?;
    if f == T::zero() {
        return Err(OpticsError::InvalidParameter {
            name: "focal_length",
            allowed: "finite and non-zero (negative for a diverging lens)",
        });
    }
    Ok(f)
}

/// Gaussian lens formula `1/s_o + 1/s_i = 1/f`: where a lens of focal length `f` (negative for a
/// diverging lens) images a subject at `s_o` (`+inf` allowed).
///
/// A subject at `f` gives [`ImageDistance::Infinite`]; one inside `f` a virtual image.
///
/// ```
/// use optics_core::lens::{image_distance, ImageDistance};
/// assert_eq!(image_distance(50.0_f64, 100.0).unwrap(), ImageDistance::Real(100.0)); // 1:1
/// assert_eq!(image_distance(50.0_f64, 50.0).unwrap(), ImageDistance::Infinite);
/// assert_eq!(image_distance(50.0_f64, 25.0).unwrap(), ImageDistance::Virtual(50.0));
/// assert_eq!(image_distance(50.0_f64, f64::INFINITY).unwrap(), ImageDistance::Real(50.0));
/// ```
pub fn image_distance<T: Real>(f: T, s_o: T) -> Result<ImageDistance<T>> {
    let f = focal_length(f)?;
    let s_o = positive_or_infinite(s_o, "subject_distance")?;
    if s_o == f {
        return Ok(ImageDistance::Infinite);
    }
    // s_i = f s_o / (s_o - f): exact for s_o = 2f (gives 2f) and tends to f as s_o -> inf.
    let s_i = if s_o.is_infinite() {
        f
    } else {
        checked(f * s_o / (s_o - f))?
    };
    Ok(if s_i > T::zero() {
        ImageDistance::Real(s_i)
    } else {
        ImageDistance::Virtual(-s_i)
    })
}

/// Lateral magnification `m = -s_i / s_o = f / (f - s_o)`: negative for the inverted real image
/// a camera forms, positive (upright) for a virtual image, 0 for a subject at infinity.
pub fn lateral_magnification<T: Real>(f: T, s_o: T) -> Result<T> {
    let f = focal_length(f)?;
    let s_o = positive_or_infinite(s_o, "subject_distance")?;
    if s_o == f {
        return Err(OpticsError::SubjectAtFocalLength);
    }
    if s_o.is_infinite() {
        return Ok(T::zero());
    }
    checked(f / (f - s_o))
}

/// Sensor-to-lens distance (mm) that focuses a subject at `s_o` (`+inf` allowed) with a
/// converging lens of focal length `f`: the "move the sensor to focus" rule.
///
/// A subject at or inside `f` cannot be focused on a sensor:
/// [`OpticsError::SubjectAtFocalLength`] or [`OpticsError::SubjectInsideFocalLength`].
pub fn sensor_distance_for_focus<T: Real>(f: T, s_o: T) -> Result<T> {
    let f = positive(f, "focal_length")?;
    let s_o = positive_or_infinite(s_o, "subject_distance")?;
    if s_o == f {
        return Err(OpticsError::SubjectAtFocalLength);
    }
    if s_o < f {
        return Err(OpticsError::SubjectInsideFocalLength);
    }
    match image_distance(f, s_o)? {
        ImageDistance::Real(s_i) => Ok(s_i),
        // Unreachable for s_o > f > 0, kept as an error rather than a panic.
        _ => Err(OpticsError::SubjectInsideFocalLength),
    }
}

/// How far (mm) the sensor moves back from the infinity-focus position to focus at `s_o`:
/// `s_i - f = f^2 / (s_o - f)`.
pub fn focus_extension<T: Real>(f: T, s_o: T) -> Result<T> {
    let s_i = sensor_distance_for_focus(f, s_o)?;
    Ok(s_i - f)
}

/// Subject (and sensor) distance for 1:1 imaging: `s_o = s_i = 2f`.
pub fn unit_magnification_distance<T: Real>(f: T) -> Result<T> {
    checked(positive(f, "focal_length")? * T::lit(2.0))
}
