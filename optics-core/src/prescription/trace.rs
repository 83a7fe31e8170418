//! Real rays through a prescription, surface by surface (sequential): the ray meets each
//! surface (an exact intersection for planes, spheres and conics, Newton's method on the sag
//! for even aspheres, started from the conic's), is vignetted beyond the clear semi-diameter,
//! and refracts by Snell's law at the index of its wavelength; total internal reflection ends
//! it.

use super::{Prescription, Shape};
use crate::real::finite;
use crate::refraction::refract;
use crate::{OpticsError, Real, Result};

/// A ray in the first vertex's frame (`z` along the axis towards the image), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray<T> {
    /// A point on the ray, in front of the first surface.
    pub origin: [T; 3],
    /// Its direction (any length but zero; `z > 0` to travel towards the lens).
    pub direction: [T; 3],
    /// Its wavelength in air, nm.
    pub wavelength_nm: T,
}

/// Why a ray did not reach the image plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loss {
    /// It misses the surface (passes beyond a sphere, or travels away from it).
    Missed,
    /// It meets the surface outside its clear semi-diameter.
    Vignetted,
    /// Total internal reflection at the surface.
    TotalInternalReflection,
    /// Newton's method did not find its meeting with an aspheric surface.
    NoIntersection,
}

/// Where a traced ray ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Traced<T> {
    /// It reached the image plane at `point`, travelling along unit `direction`.
    Image {
        /// Where it meets the image plane (its `z` is the plane's).
        point: [T; 3],
        /// Unit direction after the last surface.
        direction: [T; 3],
    },
    /// It was lost at surface `surface` (`surfaces.len()`: the image plane) for `loss`.
    Lost {
        /// The surface's index.
        surface: usize,
        /// Why.
        loss: Loss,
    },
}

/// Where a ray at local `p` (relative to the vertex) along unit `d` meets the conic part of
/// `shape` (plane, sphere or conic): the parameter along the ray, or `None` if it misses.
fn conic_hit<T: Real>(shape: &Shape<T>, p: [T; 3], d: [T; 3]) -> Option<T> {
    let (c, k) = match *shape {
        Shape::Flat => (T::zero(), T::zero()),
        Shape::Sphere { curvature } => (curvature, T::zero()),
        Shape::EvenAsphere {
            curvature, conic, ..
        } => (curvature, conic),
    };
    // c (x^2 + y^2 + (1 + k) z^2) - 2 z = 0 along p + t d: a t^2 + 2 h t + q = 0. The root
    // taken is the one that tends to the plane's -z/dz as c -> 0, `(-h + sqrt(disc)) / a`,
    // written in whichever of its two forms has no cancellation: `q / (-h + sqrt(disc))`
    // when h <= 0, `-(h + sqrt(disc)) / a` when h > 0 (a ray starting further than the
    // radius in front of a surface concave towards it).
    let kk = T::one() + k;
    let a = c * (d[0] * d[0] + d[1] * d[1] + kk * d[2] * d[2]);
    let h = c * (p[0] * d[0] + p[1] * d[1] + kk * p[2] * d[2]) - d[2];
    let q = c * (p[0] * p[0] + p[1] * p[1] + kk * p[2] * p[2]) - T::lit(2.0) * p[2];
    let disc = h * h - a * q;
    if disc < T::zero() {
        return None;
    }
    let root = disc.sqrt();
    let t = if h <= T::zero() {
        let denominator = root - h;
        if denominator == T::zero() {
            return None;
        }
        q / denominator
    } else {
        if a == T::zero() {
            return None;
        }
        -(h + root) / a
    };
    t.is_finite().then_some(t)
}

/// Where the ray meets `shape` and the surface normal there (unit, `+z` side), or why not.
fn intersect<T: Real>(
    shape: &Shape<T>,
    p: [T; 3],
    d: [T; 3],
) -> core::result::Result<([T; 3], [T; 3]), Loss> {
    let mut t = conic_hit(shape, p, d).ok_or(Loss::Missed)?;
    if let Shape::EvenAsphere { coefficients, .. } = shape {
        if coefficients.iter().any(|&a| a != T::zero()) {
            // Newton on g(t) = z(t) - sag(r(t)); quadratic convergence from the conic's root.
            let tolerance = T::epsilon() * T::lit(16.0);
            let mut converged = false;
            for _ in 0..50 {
                let x = p[0] + t * d[0];
                let y = p[1] + t * d[1];
                let z = p[2] + t * d[2];
                let r2 = x * x + y * y;
                let (sag, slope) = shape.sag_and_slope(r2).ok_or(Loss::NoIntersection)?;
                let r = r2.sqrt();
                let dr = if r > T::zero() {
                    (x * d[0] + y * d[1]) / r
                } else {
                    T::zero()
                };
                let g = z - sag;
                let dg = d[2] - slope * dr;
                if dg == T::zero() || !dg.is_finite() {
                    return Err(Loss::NoIntersection);
                }
                let step = g / dg;
                t = t - step;
                if step.abs() <= tolerance * (T::one() + t.abs()) {
                    converged = true;
                    break;
                }
            }
            if !converged {
                return Err(Loss::NoIntersection);
            }
        }
    }
    let x = p[0] + t * d[0];
    let y = p[1] + t * d[1];
    let z = p[2] + t * d[2];
    let r2 = x * x + y * y;
    let (_, slope) = shape.sag_and_slope(r2).ok_or(Loss::Missed)?;
    let r = r2.sqrt();
    let (nx, ny) = if r > T::zero() {
        (-slope * x / r, -slope * y / r)
    } else {
        (T::zero(), T::zero())
    };
    let norm = (nx * nx + ny * ny + T::one()).sqrt();
    Ok(([x, y, z], [nx / norm, ny / norm, T::one() / norm]))
}

impl<T: Real> Prescription<'_, T> {
    /// Traces `ray` to the image plane (`total_length()` from the first vertex).
    ///
    /// Errors are for bad input only (a non-finite origin, a zero direction, a wavelength out
    /// of the media's range); a ray the lens stops is [`Traced::Lost`].
    ///
    /// ```
    /// use optics_core::prescription::{glass::Medium, trace::{Ray, Traced}, Prescription, Shape, Surface};
    /// let s = [Surface::new(Shape::Flat, 5.0, 10.0, Medium::Air).stop()];
    /// let lens = Prescription::new(&s).unwrap();
    /// let ray = Ray { origin: [1.0, 0.0, -1.0], direction: [0.0, 0.0, 1.0], wavelength_nm: 550.0 };
    /// let Traced::Image { point, .. } = lens.trace(&ray).unwrap() else { panic!() };
    /// assert_eq!(point, [1.0, 0.0, 10.0]);
    /// ```
    pub fn trace(&self, ray: &Ray<T>) -> Result<Traced<T>> {
        self.trace_to(ray, self.total_length())
    }

    /// Traces `ray` to the plane `image_distance` mm after the last vertex (the paraxial focal
    /// plane, say) instead of the one the prescription's last thickness gives.
    pub fn trace_to_plane(&self, ray: &Ray<T>, image_distance: T) -> Result<Traced<T>> {
        finite(image_distance, "image_distance")?;
        let last = self.vertex_z(self.surfaces.len() - 1);
        self.trace_to(ray, last + image_distance)
    }

    fn trace_to(&self, ray: &Ray<T>, image_z: T) -> Result<Traced<T>> {
        for v in ray.origin.iter().chain(ray.direction.iter()) {
            finite(*v, "ray")?;
        }
        let len = (ray.direction.iter().fold(T::zero(), |a, &v| a + v * v)).sqrt();
        if len.is_nan() || len <= T::zero() {
            return Err(OpticsError::InvalidParameter {
                name: "ray direction",
                allowed: "non-zero",
            });
        }
        let mut d = ray.direction.map(|v| v / len);
        let mut p = ray.origin;
        let mut n_before = self.index_before(0, ray.wavelength_nm)?;
        let mut vertex = T::zero();
        for (i, s) in self.surfaces.iter().enumerate() {
            let lost = |loss| Ok(Traced::Lost { surface: i, loss });
            let local = [p[0], p[1], p[2] - vertex];
            let (hit, normal) = match intersect(&s.shape, local, d) {
                Ok(h) => h,
                Err(loss) => return lost(loss),
            };
            // A sequential trace goes forward: a meeting behind the ray is a miss.
            let back = (hit[0] - local[0]) * d[0]
                + (hit[1] - local[1]) * d[1]
                + (hit[2] - local[2]) * d[2];
            if back < -T::epsilon() * T::lit(1e3) * (T::one() + local[2].abs()) {
                return lost(Loss::Missed);
            }
            if hit[0] * hit[0] + hit[1] * hit[1] > s.semi_diameter * s.semi_diameter {
                return lost(Loss::Vignetted);
            }
            let n_after = s.medium.index(ray.wavelength_nm)?;
            let Some(refracted) = refract(d, normal, n_before / n_after)? else {
                return lost(Loss::TotalInternalReflection);
            };
            let norm = (refracted.iter().fold(T::zero(), |a, &v| a + v * v)).sqrt();
            d = refracted.map(|v| v / norm);
            p = [hit[0], hit[1], hit[2] + vertex];
            n_before = n_after;
            vertex = vertex + s.thickness;
        }
        if d[2].is_nan() || d[2] <= T::zero() {
            return Ok(Traced::Lost {
                surface: self.surfaces.len(),
                loss: Loss::Missed,
            });
        }
        let t = (image_z - p[2]) / d[2];
        let point = [p[0] + t * d[0], p[1] + t * d[1], image_z];
        if point.iter().all(|v| v.is_finite()) {
            Ok(Traced::Image {
                point,
                direction: d,
            })
        } else {
            Err(OpticsError::Overflow)
        }
    }
}
