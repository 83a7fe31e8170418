//! Depth of field of a thin lens: circle of confusion, hyperfocal distance, near and far limits,
//! and the classic approximation `DoF ~ 2 u^2 N c / f^2`.
//!
//! With focal length `f`, f-number `N`, acceptable circle of confusion `c` and focus distance
//! `s` (all mm): `H = f^2/(N c) + f`, `near = s (H - f) / (H + s - 2f)`,
//! `far = s (H - f) / (H - s)` for `s < H` and infinite for `s >= H`.

use crate::real::{checked, non_negative, positive, positive_or_infinite};
use crate::{Distance, OpticsError, Real, Result};

/// Depth of field of one focus setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthOfField<T> {
    /// Hyperfocal distance `H = f^2/(N c) + f` (infinite when `c = 0`).
    pub hyperfocal: Distance<T>,
    /// Near limit of acceptable sharpness.
    pub near: T,
    /// Far limit: infinite when focused at or beyond `H`.
    pub far: Distance<T>,
    /// `far - near`: infinite with `far`.
    pub total: Distance<T>,
}

fn subject<T: Real>(f: T, s: T, name: &'static str) -> Result<T> {
    let s = positive_or_infinite(s, name)?;
    if s == f {
        Err(OpticsError::SubjectAtFocalLength)
    } else if s < f {
        Err(OpticsError::SubjectInsideFocalLength)
    } else {
        Ok(s)
    }
}

/// Hyperfocal distance `H = f^2/(N c) + f` (mm); infinite when `c = 0`.
pub fn hyperfocal_distance<T: Real>(f: T, n: T, c: T) -> Result<Distance<T>> {
    let f = positive(f, "focal_length")?;
    let n = positive(n, "f_number")?;
    let c = non_negative(c, "circle_of_confusion")?;
    if c == T::zero() {
        return Ok(Distance::Infinite);
    }
    let h = f * f / (n * c) + f;
    if h.is_finite() {
        Ok(Distance::Finite(h))
    } else {
        Ok(Distance::Infinite)
    }
}

/// Depth of field when focused at `s` (`+inf` allowed: then near = `H - f`).
///
/// ```
/// use optics_core::dof::depth_of_field;
/// use optics_core::Distance;
/// // 50 mm at f/2.8, c = 0.03 mm, focused at 3 m.
/// let d = depth_of_field(50.0_f64, 2.8, 0.03, 3000.0).unwrap();
/// let h = 50.0 * 50.0 / (2.8 * 0.03) + 50.0;
/// assert_eq!(d.hyperfocal, Distance::Finite(h));
/// assert!((d.near - 3000.0 * (h - 50.0) / (h + 3000.0 - 100.0)).abs() < 1e-9);
/// // At the hyperfocal distance the far limit is infinite.
/// assert_eq!(depth_of_field(50.0_f64, 2.8, 0.03, h).unwrap().far, Distance::Infinite);
/// ```
pub fn depth_of_field<T: Real>(f: T, n: T, c: T, s: T) -> Result<DepthOfField<T>> {
    let hyperfocal = hyperfocal_distance(f, n, c)?;
    let s = subject(f, s, "focus_distance")?;
    let Distance::Finite(h) = hyperfocal else {
        // c = 0: only the plane of focus itself is sharp.
        if s.is_infinite() {
            return Err(OpticsError::InvalidParameter {
                name: "circle_of_confusion",
                allowed: "> 0 when focused at infinity (with c = 0 nothing finite is sharp)",
            });
        }
        let (far, total) = (Distance::Finite(s), Distance::Finite(T::zero()));
        return Ok(DepthOfField {
            hyperfocal,
            near: s,
            far,
            total,
        });
    };
    let two_f = T::lit(2.0) * f;
    let near = if s.is_infinite() {
        h - f
    } else {
        checked(s * (h - f) / (h + s - two_f))?
    };
    let far = if s >= h {
        Distance::Infinite
    } else {
        Distance::Finite(checked(s * (h - f) / (h - s))?)
    };
    let total = match far {
        Distance::Finite(x) => Distance::Finite(x - near),
        Distance::Infinite => Distance::Infinite,
    };
    Ok(DepthOfField {
        hyperfocal,
        near,
        far,
        total,
    })
}

/// Diameter (mm, on the sensor) of the blur circle of a point at distance `d` when the lens is
/// focused at `s`: `c = (f/N) f |d - s| / (d (s - f))`, written in vergences so that either
/// distance may be `+inf`. `d` may be closer than `f`.
///
/// ```
/// use optics_core::dof::{circle_of_confusion, depth_of_field};
/// // A point at the near limit blurs to exactly the acceptable circle.
/// let d = depth_of_field(50.0_f64, 2.8, 0.03, 3000.0).unwrap();
/// let c = circle_of_confusion(50.0_f64, 2.8, 3000.0, d.near).unwrap();
/// assert!((c - 0.03).abs() < 1e-12);
/// ```
pub fn circle_of_confusion<T: Real>(f: T, n: T, s: T, d: T) -> Result<T> {
    let f = positive(f, "focal_length")?;
    let n = positive(n, "f_number")?;
    let s = subject(f, s, "focus_distance")?;
    let d = positive_or_infinite(d, "point_distance")?;
    let (vs, vd) = (s.recip(), d.recip());
    checked(f * f / n * (vs - vd).abs() / (T::one() - f * vs))
}

/// The classic approximation `DoF ~ 2 u^2 N c / f^2` (mm), good when `u` is large against `f`
/// and small against `H`.
pub fn depth_of_field_approx<T: Real>(f: T, n: T, c: T, u: T) -> Result<Distance<T>> {
    let f = positive(f, "focal_length")?;
    let n = positive(n, "f_number")?;
    let c = non_negative(c, "circle_of_confusion")?;
    let u = positive_or_infinite(u, "focus_distance")?;
    if u.is_infinite() {
        return Ok(if c == T::zero() {
            Distance::Finite(T::zero())
        } else {
            Distance::Infinite
        });
    }
    let dof = T::lit(2.0) * u * u * n * c / (f * f);
    Ok(if dof.is_finite() {
        Distance::Finite(dof)
    } else {
        Distance::Infinite
    })
}

/// Relative error `(approx - exact) / exact` of [`depth_of_field_approx`] against
/// [`depth_of_field`]. An error where the exact value is infinite (focus at or beyond `H`) or
/// zero (`c = 0`), since no relative error exists there.
pub fn depth_of_field_approx_error<T: Real>(f: T, n: T, c: T, s: T) -> Result<T> {
    let exact = depth_of_field(f, n, c, s)?.total;
    let approx = depth_of_field_approx(f, n, c, s)?;
    match (exact, approx) {
        (Distance::Finite(e), Distance::Finite(a)) if e > T::zero() => checked((a - e) / e),
        _ => Err(OpticsError::InvalidParameter {
            name: "focus_distance",
            allowed: "below the hyperfocal distance, with c > 0 (exact DoF finite and non-zero)",
        }),
    }
}
