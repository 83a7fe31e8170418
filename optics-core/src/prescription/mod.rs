//! Real lenses: a prescription of surfaces, glasses and a stop, its paraxial data
//! ([`paraxial`]) and real rays traced through it ([`trace`]).
//!
//! A prescription is a sequence of [`Surface`]s from the object side, in caller storage (a
//! slice; no heap). Each surface has a shape ([`Shape`]: flat, spherical or an even asphere), a
//! clear semi-diameter, the thickness to the next surface's vertex (after the last: to the
//! image plane) and the medium after it; the object side is air. One surface is the aperture
//! stop (a flat surface with air on both sides, as pbrt's files mark it, or any surface whose
//! clear aperture is the stop).
//!
//! Conventions, those of lens-design programs: millimetres; `z` along the axis from the first
//! vertex towards the image; a radius of curvature is positive when its centre lies to the
//! right (`+z`) of the vertex; shapes are given by curvature `c = 1/R` so a flat surface is
//! `c = 0`, not an infinite radius; indices are relative to air, wavelengths in air (nm).
//!
//! ```
//! use optics_core::prescription::{glass::Medium, Prescription, Shape, Surface};
//! // A biconvex N-BK7 singlet, R = +/-50 mm, 5 mm thick, stop at its front vertex.
//! let bk7 = optics_core::prescription::glass::catalogue_glass("N-BK7").unwrap().medium();
//! let surfaces = [
//!     Surface::new(Shape::sphere_radius(50.0), 10.0, 5.0, bk7).stop(),
//!     Surface::new(Shape::sphere_radius(-50.0), 10.0, 47.0, Medium::Air),
//! ];
//! let lens = Prescription::new(&surfaces).unwrap();
//! let p = lens.paraxial(587.5618).unwrap();
//! // Thick lens: 1/f = (n - 1) (2/R - (n - 1) d / (n R^2)), n = 1.5168.
//! let n = 1.5168_f64;
//! let f = 1.0 / ((n - 1.0) * (2.0 / 50.0 - (n - 1.0) * 5.0 / (n * 2500.0)));
//! assert!((p.efl - f).abs() < 1e-3);
//! ```

pub mod analysis;
pub mod catalogue;
pub mod correction;
pub mod glass;
pub mod paraxial;
pub mod trace;

use crate::{OpticsError, Real, Result};
use glass::Medium;

/// Even-asphere coefficients: of `r^4, r^6, ..., r^16`.
pub const ASPHERE_TERMS: usize = 7;

/// A surface's shape, as a sag `z(r)` measured from its vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape<T> {
    /// A plane.
    Flat,
    /// A sphere of curvature `curvature` (1/mm; 1/R).
    Sphere {
        /// 1/R, 1/mm.
        curvature: T,
    },
    /// An even asphere: `z = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + sum A_i r^(2i + 4)`.
    EvenAsphere {
        /// `c = 1/R` at the vertex, 1/mm.
        curvature: T,
        /// The conic constant `k` (0 sphere, -1 paraboloid).
        conic: T,
        /// `A_4, A_6, ..., A_16`, mm^(1 - n).
        coefficients: [T; ASPHERE_TERMS],
    },
}

impl<T: Real> Shape<T> {
    /// A sphere of radius `r` mm (the sign says where its centre is); `r = 0` or infinite is
    /// a plane.
    pub fn sphere_radius(r: T) -> Self {
        if r == T::zero() || r.is_infinite() {
            Shape::Flat
        } else {
            Shape::Sphere {
                curvature: T::one() / r,
            }
        }
    }

    /// The vertex curvature (0 for a plane): what the paraxial trace sees.
    pub fn curvature(&self) -> T {
        match *self {
            Shape::Flat => T::zero(),
            Shape::Sphere { curvature } | Shape::EvenAsphere { curvature, .. } => curvature,
        }
    }

    /// The same surface seen from the other side (light travelling towards `-z`): every sag
    /// negated.
    pub fn reversed(&self) -> Self {
        match *self {
            Shape::Flat => Shape::Flat,
            Shape::Sphere { curvature } => Shape::Sphere {
                curvature: -curvature,
            },
            Shape::EvenAsphere {
                curvature,
                conic,
                coefficients,
            } => Shape::EvenAsphere {
                curvature: -curvature,
                conic,
                coefficients: coefficients.map(|a| -a),
            },
        }
    }

    fn conic_and_terms(&self) -> (T, T, [T; ASPHERE_TERMS]) {
        match *self {
            Shape::Flat => (T::zero(), T::zero(), [T::zero(); ASPHERE_TERMS]),
            Shape::Sphere { curvature } => (curvature, T::zero(), [T::zero(); ASPHERE_TERMS]),
            Shape::EvenAsphere {
                curvature,
                conic,
                coefficients,
            } => (curvature, conic, coefficients),
        }
    }

    /// The sag `z(r)` and its slope `dz/dr` at `r^2 = r2`; `None` where the conic is not
    /// defined (beyond its rim).
    pub fn sag_and_slope(&self, r2: T) -> Option<(T, T)> {
        let (c, k, a) = self.conic_and_terms();
        let root2 = T::one() - (T::one() + k) * c * c * r2;
        if root2 < T::zero() {
            return None;
        }
        let root = root2.sqrt();
        let mut sag = c * r2 / (T::one() + root);
        let r = r2.sqrt();
        // dz/dr of the conic: c r / sqrt(1 - (1 + k) c^2 r^2); undefined only at the rim.
        let mut slope = if root > T::zero() {
            c * r / root
        } else if c == T::zero() {
            T::zero()
        } else {
            return None;
        };
        let mut power = r2 * r2; // r^4
        for (i, &ai) in a.iter().enumerate() {
            if ai != T::zero() {
                sag = sag + ai * power;
                slope = slope
                    + ai * T::lit((2 * i + 4) as f64) * power / r.max(T::min_positive_value());
            }
            power = power * r2;
        }
        Some((sag, slope))
    }

    fn validate(&self, semi_diameter: T, surface: usize) -> Result<()> {
        let bad = |problem| Err(OpticsError::BadSurface { surface, problem });
        let (c, k, a) = self.conic_and_terms();
        if !c.is_finite() || !k.is_finite() || a.iter().any(|v| !v.is_finite()) {
            return bad("a curvature, conic or coefficient that is not finite");
        }
        match self.sag_and_slope(semi_diameter * semi_diameter) {
            Some((z, s)) if z.is_finite() && s.is_finite() => Ok(()),
            _ => bad("the clear semi-diameter reaches beyond the surface's rim (a sphere narrower than the aperture)"),
        }
    }
}

/// One refracting surface (or the stop) and what follows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface<T> {
    /// Its shape.
    pub shape: Shape<T>,
    /// Clear semi-diameter, mm: rays beyond it are vignetted.
    pub semi_diameter: T,
    /// Distance to the next surface's vertex (after the last surface: to the image plane),
    /// mm, at least 0.
    pub thickness: T,
    /// The medium after the surface.
    pub medium: Medium<T>,
    /// Whether this surface is the aperture stop.
    pub is_stop: bool,
}

impl<T: Real> Surface<T> {
    /// A surface that is not the stop.
    pub fn new(shape: Shape<T>, semi_diameter: T, thickness: T, medium: Medium<T>) -> Self {
        Surface {
            shape,
            semi_diameter,
            thickness,
            medium,
            is_stop: false,
        }
    }

    /// A flat aperture stop of semi-diameter `semi_diameter`, in air.
    pub fn aperture_stop(semi_diameter: T, thickness: T) -> Self {
        Surface {
            shape: Shape::Flat,
            semi_diameter,
            thickness,
            medium: Medium::Air,
            is_stop: true,
        }
    }

    /// This surface, marked as the stop.
    pub fn stop(self) -> Self {
        Surface {
            is_stop: true,
            ..self
        }
    }
}

/// A checked prescription borrowing its surfaces.
#[derive(Debug, Clone, Copy)]
pub struct Prescription<'a, T> {
    surfaces: &'a [Surface<T>],
    stop: usize,
}

impl<'a, T: Real> Prescription<'a, T> {
    /// Checks `surfaces`: at least one, exactly one stop, every thickness finite and >= 0,
    /// every clear semi-diameter finite and > 0 and within its surface's rim, every medium
    /// valid.
    pub fn new(surfaces: &'a [Surface<T>]) -> Result<Self> {
        if surfaces.is_empty() {
            return Err(OpticsError::BadPrescription {
                problem: "no surfaces",
            });
        }
        let mut stop = None;
        for (i, s) in surfaces.iter().enumerate() {
            let bad = |problem| {
                Err(OpticsError::BadSurface {
                    surface: i,
                    problem,
                })
            };
            if !(s.thickness.is_finite() && s.thickness >= T::zero()) {
                return bad("a thickness that is negative or not finite");
            }
            if !(s.semi_diameter.is_finite() && s.semi_diameter > T::zero()) {
                return bad("a clear semi-diameter that is not finite and > 0");
            }
            s.shape.validate(s.semi_diameter, i)?;
            if s.medium.validate().is_err() {
                return bad("its medium's parameters are out of range");
            }
            if s.is_stop {
                if stop.is_some() {
                    return Err(OpticsError::BadPrescription {
                        problem: "more than one aperture stop",
                    });
                }
                stop = Some(i);
            }
        }
        let stop = stop.ok_or(OpticsError::BadPrescription {
            problem: "no aperture stop",
        })?;
        Ok(Prescription { surfaces, stop })
    }

    /// The surfaces.
    pub fn surfaces(&self) -> &'a [Surface<T>] {
        self.surfaces
    }

    /// The stop's index.
    pub fn stop_index(&self) -> usize {
        self.stop
    }

    /// The index of the medium before surface `i` (air before the first) at `wavelength_nm`.
    pub fn index_before(&self, i: usize, wavelength_nm: T) -> Result<T> {
        match i.checked_sub(1).and_then(|j| self.surfaces.get(j)) {
            Some(s) => s.medium.index(wavelength_nm),
            None => Medium::<T>::Air.index(wavelength_nm),
        }
    }

    /// The vertex of surface `i` on the axis, mm from the first vertex; `i = len` is the image
    /// plane.
    pub fn vertex_z(&self, i: usize) -> T {
        self.surfaces
            .iter()
            .take(i)
            .fold(T::zero(), |z, s| z + s.thickness)
    }

    /// The distance from the first vertex to the image plane, mm.
    pub fn total_length(&self) -> T {
        self.vertex_z(self.surfaces.len())
    }

    /// The lens turned round, written into `out` (as long as the lens): its last surface
    /// first, for tracing from the image side towards the object, as a camera traces from the
    /// film. Coordinates map by `z' = L - z` with `L` the last vertex's `z`, so the turned
    /// lens's first vertex is the last one here; its last thickness is 0 (its image plane is
    /// this lens's first vertex). Media, stop and clear apertures go with their surfaces.
    ///
    /// ```
    /// use optics_core::prescription::{glass::Medium, Prescription, Shape, Surface};
    /// let s = [
    ///     Surface::new(Shape::sphere_radius(40.0_f64), 8.0, 4.0, Medium::Constant { n: 1.5 }).stop(),
    ///     Surface::new(Shape::sphere_radius(-90.0), 8.0, 60.0, Medium::Air),
    /// ];
    /// let lens = Prescription::new(&s).unwrap();
    /// let mut storage = s;
    /// let back = lens.reversed_into(&mut storage).unwrap();
    /// // Focal length does not depend on the direction light goes through a lens in air.
    /// let (f, g) = (lens.paraxial(550.0).unwrap().efl, back.paraxial(550.0).unwrap().efl);
    /// assert!((f - g).abs() < 1e-9);
    /// ```
    pub fn reversed_into<'b>(&self, out: &'b mut [Surface<T>]) -> Result<Prescription<'b, T>> {
        let k = self.surfaces.len();
        if out.len() != k {
            return Err(OpticsError::InvalidParameter {
                name: "reversed lens storage",
                allowed: "as many surfaces as the lens",
            });
        }
        for (j, slot) in out.iter_mut().enumerate() {
            let i = k - 1 - j;
            let s = &self.surfaces[i];
            let (thickness, medium) = match i.checked_sub(1) {
                Some(before) => (
                    self.surfaces[before].thickness,
                    self.surfaces[before].medium,
                ),
                None => (T::zero(), Medium::Air),
            };
            *slot = Surface {
                shape: s.shape.reversed(),
                semi_diameter: s.semi_diameter,
                thickness,
                medium,
                is_stop: s.is_stop,
            };
        }
        Prescription::new(out)
    }
}
