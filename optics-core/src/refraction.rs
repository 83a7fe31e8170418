//! Refraction at an interface: Snell's law exact (angles and vectors), the paraxial
//! approximation, the paraxial single-surface equation, and the paraxial error against the exact
//! ray traced through a spherical surface.
//!
//! Sign convention of the single-surface equation (as in Hecht): light travels left to right;
//! the object distance `z` is positive for a real object left of the vertex, the image distance
//! `z'` positive for a real image right of it, the radius `r` positive when the centre of
//! curvature lies right of the vertex. Then `n/z + n'/z' = (n' - n)/r`, the same equation as
//! `n/z + n/r = n'/r - n'/z'` rearranged.
//!
//! Total internal reflection is `Ok(None)`, never NaN; invalid inputs are an error.

use crate::lens::ImageDistance;
use crate::real::{checked, finite, positive};
use crate::{OpticsError, Real, Result};

/// Refraction angle (radians) from Snell's law `n1 sin(theta_i) = n2 sin(theta_t)`.
///
/// `theta_i` is the angle of incidence from the normal, in (-pi/2, pi/2). Returns `Ok(None)` on
/// total internal reflection.
///
/// ```
/// use optics_core::refraction::snell_angle;
/// let t = snell_angle(1.0_f64, 1.5, 30f64.to_radians()).unwrap().unwrap();
/// assert!((t.sin() * 1.5 - 0.5).abs() < 1e-12);
/// assert_eq!(snell_angle(1.5_f64, 1.0, 60f64.to_radians()).unwrap(), None); // TIR
/// ```
pub fn snell_angle<T: Real>(n1: T, n2: T, theta_i: T) -> Result<Option<T>> {
    positive(n1, "n1")?;
    positive(n2, "n2")?;
    let half_pi = T::FRAC_PI_2();
    if !(theta_i.is_finite() && theta_i.abs() <= half_pi) {
        return Err(OpticsError::InvalidParameter {
            name: "theta_i",
            allowed: "an angle in [-pi/2, pi/2] radians",
        });
    }
    // n1 sin / n2, in that order: the ratio n1/n2 alone may overflow and meet sin = 0.
    let sin_t = n1 * theta_i.sin() / n2;
    if sin_t.abs() > T::one() {
        return Ok(None);
    }
    Ok(Some(sin_t.asin()))
}

/// Critical angle (radians) for total internal reflection going from `n1` into `n2`, or `None`
/// when `n1 <= n2` (no total internal reflection is possible).
pub fn critical_angle<T: Real>(n1: T, n2: T) -> Result<Option<T>> {
    positive(n1, "n1")?;
    positive(n2, "n2")?;
    Ok(if n1 > n2 {
        Some((n2 / n1).asin())
    } else {
        None
    })
}

/// Paraxial refraction `n i = n' i'`: the refracted angle `i' = n i / n'` (small angles).
pub fn paraxial_angle<T: Real>(n1: T, n2: T, theta_i: T) -> Result<T> {
    positive(n1, "n1")?;
    positive(n2, "n2")?;
    finite(theta_i, "theta_i")?;
    checked(n1 / n2 * theta_i)
}

fn dot<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalised<T: Real>(v: [T; 3], name: &'static str) -> Result<[T; 3]> {
    let len = dot(v, v).sqrt();
    if !(len.is_finite() && len > T::zero()) {
        return Err(OpticsError::InvalidParameter {
            name,
            allowed: "a finite, non-zero vector",
        });
    }
    Ok([v[0] / len, v[1] / len, v[2] / len])
}

/// Snell's law in vector form: the unit direction of the refracted ray.
///
/// `incident` is the ray's direction of travel, `normal` the surface normal (either side; it is
/// flipped to face the incoming ray), `eta = n1 / n2`. Neither vector needs to be unit length.
/// Returns `Ok(None)` on total internal reflection.
///
/// ```
/// use optics_core::refraction::refract;
/// // Straight through at normal incidence, whatever the indices.
/// let t = refract([0.0_f64, 0.0, -1.0], [0.0, 0.0, 1.0], 1.0 / 1.5).unwrap().unwrap();
/// assert!((t[2] + 1.0).abs() < 1e-15);
/// ```
pub fn refract<T: Real>(incident: [T; 3], normal: [T; 3], eta: T) -> Result<Option<[T; 3]>> {
    let i = normalised(incident, "incident")?;
    let mut n = normalised(normal, "normal")?;
    positive(eta, "eta")?;
    let mut cos_i = -dot(n, i);
    if cos_i < T::zero() {
        n = [-n[0], -n[1], -n[2]];
        cos_i = -cos_i;
    }
    let sin2_t = eta * eta * (T::one() - cos_i * cos_i).max(T::zero());
    if sin2_t > T::one() {
        return Ok(None);
    }
    let cos_t = (T::one() - sin2_t).sqrt();
    let k = eta * cos_i - cos_t;
    Ok(Some([
        eta * i[0] + k * n[0],
        eta * i[1] + k * n[1],
        eta * i[2] + k * n[2],
    ]))
}

/// Paraxial single-surface equation `n/z + n'/z' = (n' - n)/r`: where a spherical surface of
/// radius `r` between indices `n` and `n'` images an axial object at distance `z`.
///
/// `z = +inf` is an object at infinity; `r = ±inf` a flat surface. A flat surface with the object
/// at infinity has its image at infinity.
pub fn paraxial_surface_image<T: Real>(n: T, n_prime: T, r: T, z: T) -> Result<ImageDistance<T>> {
    positive(n, "n")?;
    positive(n_prime, "n_prime")?;
    if r.is_nan() || r == T::zero() {
        return Err(OpticsError::InvalidParameter {
            name: "r",
            allowed: "non-zero (infinite for a flat surface)",
        });
    }
    if z.is_nan() || z == T::zero() || z == T::neg_infinity() {
        return Err(OpticsError::InvalidParameter {
            name: "z",
            allowed: "non-zero, < +inf for a virtual object (negative) or up to +inf",
        });
    }
    // n'/z' = (n' - n)/r - n/z; infinite r or z make their term exactly 0.
    let vergence = (n_prime - n) / r - n / z;
    ImageDistance::from_vergence(n_prime, vergence)
}

/// The exact ray against the paraxial prediction at one surface (spherical aberration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParaxialError<T> {
    /// Where the exact refracted ray at height `h` crosses the axis.
    pub exact: ImageDistance<T>,
    /// The paraxial image of the same object.
    pub paraxial: ImageDistance<T>,
    /// Signed `z'_exact - z'_paraxial` in millimetres along the axis (longitudinal aberration),
    /// `None` when either image is at infinity.
    pub longitudinal: Option<T>,
}

/// Traces the exact ray from an axial object at distance `z` (`+inf` for a collimated beam)
/// through height `h` on a spherical surface of radius `r` (indices `n` then `n'`), and reports
/// where it crosses the axis against the paraxial image.
///
/// Errors: `|h| >= |r|` or `h = 0` ([`OpticsError::InvalidParameter`]); total internal reflection
/// at that height or a ray that cannot reach it ([`OpticsError::RayMissesSurface`]).
///
/// ```
/// use optics_core::refraction::paraxial_error;
/// // Glass sphere surface, collimated beam: marginal rays focus short of the paraxial focus.
/// let e = paraxial_error(1.0_f64, 1.5, 50.0, f64::INFINITY, 10.0).unwrap();
/// assert!(e.longitudinal.unwrap() < 0.0);
/// let small = paraxial_error(1.0_f64, 1.5, 50.0, f64::INFINITY, 0.01).unwrap();
/// assert!(small.longitudinal.unwrap().abs() < 1e-4);
/// ```
pub fn paraxial_error<T: Real>(n: T, n_prime: T, r: T, z: T, h: T) -> Result<ParaxialError<T>> {
    let paraxial = paraxial_surface_image(n, n_prime, r, z)?;
    finite(r, "r")?;
    if !(h.is_finite() && h != T::zero() && h.abs() < r.abs()) {
        return Err(OpticsError::InvalidParameter {
            name: "h",
            allowed: "non-zero with |h| < |r|",
        });
    }
    if z.is_nan() || z <= T::zero() {
        return Err(OpticsError::InvalidParameter {
            name: "z",
            allowed: "> 0 (a real object; infinity allowed) for the exact trace",
        });
    }
    let zero = T::zero();
    // Surface point at height h: sag measured from the vertex (at x = 0) towards +x.
    let sag = r - r.signum() * (r * r - h * h).sqrt();
    let dir = if z.is_infinite() {
        [T::one(), zero, zero]
    } else {
        [sag + z, h, zero]
    };
    if dir[0] <= zero {
        return Err(OpticsError::RayMissesSurface);
    }
    let normal = [sag - r, h, zero];
    let t = refract(dir, normal, n / n_prime)?.ok_or(OpticsError::RayMissesSurface)?;
    // Crossing of the axis y = 0: hit + s t, s = -h / t_y.
    let exact = if t[1] == zero || (h / t[1]) >= zero {
        // Parallel to the axis, or diverging away from it: the crossing is at infinity or
        // behind the surface (a virtual image on the extension of the ray).
        if t[1] == zero {
            ImageDistance::Infinite
        } else {
            let x = checked(sag - h / t[1] * t[0])?;
            ImageDistance::Virtual(-x)
        }
    } else {
        ImageDistance::Real(checked(sag - h / t[1] * t[0])?)
    };
    let longitudinal = match (exact.signed(), paraxial.signed()) {
        (Some(a), Some(b)) => Some(a - b),
        _ => None,
    };
    Ok(ParaxialError {
        exact,
        paraxial,
        longitudinal,
    })
}
