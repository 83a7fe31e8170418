//! First-order (paraxial) data of a prescription by the matrix method: each surface refracts
//! `(y, n u)` by its power `(n' - n) c`, each gap transfers it by its reduced thickness
//! `t / n'`. Object space is air.

use super::Prescription;
use crate::real::{non_negative, positive_or_infinite};
use crate::{OpticsError, Real, Result};

/// A 2 x 2 ray-transfer matrix on `(y, n u)`, `[[A, B], [C, D]]`.
type Matrix<T> = [[T; 2]; 2];

fn multiply<T: Real>(m: Matrix<T>, n: Matrix<T>) -> Matrix<T> {
    [
        [
            m[0][0] * n[0][0] + m[0][1] * n[1][0],
            m[0][0] * n[0][1] + m[0][1] * n[1][1],
        ],
        [
            m[1][0] * n[0][0] + m[1][1] * n[1][0],
            m[1][0] * n[0][1] + m[1][1] * n[1][1],
        ],
    ]
}

fn identity<T: Real>() -> Matrix<T> {
    [[T::one(), T::zero()], [T::zero(), T::one()]]
}

/// A pupil: where it is and how large.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pupil<T> {
    /// Position, mm: the entrance pupil from the first vertex, the exit pupil from the last
    /// vertex (positive towards the image).
    pub position: T,
    /// Semi-diameter, mm.
    pub semi_diameter: T,
}

/// First-order data at one wavelength, object at infinity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paraxial<T> {
    /// The wavelength, nm.
    pub wavelength_nm: T,
    /// Effective focal length `1 / power`, mm (negative for a diverging lens).
    pub efl: T,
    /// Back focal length: last vertex to the rear focal point, mm.
    pub bfl: T,
    /// Front focal length: first vertex to the front focal point, mm (negative when the
    /// focal point is in front of the lens, as usual).
    pub ffl: T,
    /// First vertex to the front principal plane, mm.
    pub front_principal: T,
    /// Last vertex to the rear principal plane, mm.
    pub rear_principal: T,
    /// The entrance pupil (the stop seen from the object side).
    pub entrance_pupil: Pupil<T>,
    /// The exit pupil (the stop seen from the image side); `None` when it is at infinity.
    pub exit_pupil: Option<Pupil<T>>,
    /// The image-space f-number at infinite conjugate, `efl / entrance pupil diameter`.
    pub f_number: T,
}

/// First-order data at a finite (or infinite) object distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conjugate<T> {
    /// Last vertex to the paraxial image, mm.
    pub image_distance: T,
    /// Lateral magnification (negative: inverted).
    pub magnification: T,
    /// Working f-number `1 / (2 n' |u'|)` of the paraxial marginal ray.
    pub working_f_number: T,
}

impl<T: Real> Prescription<'_, T> {
    /// The matrix of surfaces `from..to` (each surface's refraction, then its gap, except the
    /// gap after surface `to - 1` when `last_gap` is false).
    fn matrix(
        &self,
        from: usize,
        to: usize,
        last_gap: bool,
        wavelength_nm: T,
    ) -> Result<Matrix<T>> {
        let mut m = identity();
        for i in from..to {
            let s = &self.surfaces[i];
            let n = self.index_before(i, wavelength_nm)?;
            let n_after = s.medium.index(wavelength_nm)?;
            let power = (n_after - n) * s.shape.curvature();
            m = multiply([[T::one(), T::zero()], [-power, T::one()]], m);
            if i + 1 < to || last_gap {
                m = multiply(
                    [[T::one(), s.thickness / n_after], [T::zero(), T::one()]],
                    m,
                );
            }
        }
        Ok(m)
    }

    /// The paraxial data at `wavelength_nm`.
    pub fn paraxial(&self, wavelength_nm: T) -> Result<Paraxial<T>> {
        let k = self.surfaces.len();
        let n_image = self.surfaces[k - 1].medium.index(wavelength_nm)?;
        let [[a, _b], [c, d]] = self.matrix(0, k, false, wavelength_nm)?;
        let power = -c;
        if power == T::zero() || !power.is_finite() {
            return Err(OpticsError::ZeroPower);
        }
        let efl = T::one() / power;
        let bfl = a * n_image / power;
        let ffl = -d / power;
        let front_principal = (T::one() - d) / power;
        let rear_principal = n_image * (a - T::one()) / power;

        // Entrance pupil: the stop imaged back through the surfaces before it.
        let stop = self.stop;
        let sd = self.surfaces[stop].semi_diameter;
        let [[a_s, b_s], _] = self.matrix(0, stop, true, wavelength_nm)?;
        if a_s == T::zero() {
            return Err(OpticsError::PupilAtInfinity);
        }
        let entrance_pupil = Pupil {
            position: b_s / a_s,
            semi_diameter: (sd / a_s).abs(),
        };
        // Exit pupil: the stop imaged forward through itself and the surfaces after it.
        let [[_, b_x], [_, d_x]] = self.matrix(stop, k, false, wavelength_nm)?;
        let exit_pupil = (d_x != T::zero()).then(|| Pupil {
            position: -b_x * n_image / d_x,
            semi_diameter: (sd / d_x).abs(),
        });
        let f_number = efl.abs() / (T::lit(2.0) * entrance_pupil.semi_diameter);
        let out = Paraxial {
            wavelength_nm,
            efl,
            bfl,
            ffl,
            front_principal,
            rear_principal,
            entrance_pupil,
            exit_pupil,
            f_number,
        };
        let all = [efl, bfl, ffl, front_principal, rear_principal, f_number];
        if all.iter().all(|v| v.is_finite()) {
            Ok(out)
        } else {
            Err(OpticsError::Overflow)
        }
    }

    /// The paraxial image of an axial object `object_distance` mm in front of the first vertex
    /// (`+inf`: at infinity), at `wavelength_nm`.
    pub fn conjugate(&self, object_distance: T, wavelength_nm: T) -> Result<Conjugate<T>> {
        positive_or_infinite(object_distance, "object_distance")?;
        let p = self.paraxial(wavelength_nm)?;
        let k = self.surfaces.len();
        let n_image = self.surfaces[k - 1].medium.index(wavelength_nm)?;
        let ep = p.entrance_pupil;
        // The marginal ray: from the object point to the rim of the entrance pupil.
        let (y, u) = if object_distance.is_infinite() {
            (ep.semi_diameter, T::zero())
        } else {
            let reach = object_distance + ep.position;
            if reach <= T::zero() {
                return Err(OpticsError::InvalidParameter {
                    name: "object_distance",
                    allowed: "in front of the entrance pupil",
                });
            }
            let u = ep.semi_diameter / reach;
            (u * object_distance, u)
        };
        let m = self.matrix(0, k, false, wavelength_nm)?;
        let y_out = m[0][0] * y + m[0][1] * u;
        let nu_out = m[1][0] * y + m[1][1] * u;
        if nu_out == T::zero() {
            return Err(OpticsError::SubjectAtFocalLength);
        }
        let u_out = nu_out / n_image;
        let image_distance = -y_out / u_out;
        let magnification = if object_distance.is_infinite() {
            T::zero()
        } else {
            u / nu_out
        };
        let working_f_number = T::one() / (T::lit(2.0) * nu_out.abs());
        let out = Conjugate {
            image_distance,
            magnification,
            working_f_number,
        };
        if [image_distance, magnification, working_f_number]
            .iter()
            .all(|v| v.is_finite())
        {
            Ok(out)
        } else {
            Err(OpticsError::Overflow)
        }
    }

    /// Unit focusing: how far the whole lens moves away from a fixed image plane to focus an
    /// object `object_distance` mm in front of the first vertex, relative to its position
    /// focused at infinity (the image-distance change, mm, >= 0 for a positive lens). Refused
    /// when the image would be virtual or the move exceeds `max_extension` mm.
    pub fn focus_extension(
        &self,
        object_distance: T,
        wavelength_nm: T,
        max_extension: T,
    ) -> Result<T> {
        let far = self.conjugate(T::infinity(), wavelength_nm)?;
        let near = self.conjugate(object_distance, wavelength_nm)?;
        if near.image_distance <= T::zero() || near.magnification > T::zero() {
            return Err(OpticsError::SubjectInsideFocalLength);
        }
        let extension = near.image_distance - far.image_distance;
        non_negative(max_extension, "max_extension")?;
        if extension.abs() > max_extension {
            return Err(OpticsError::InvalidParameter {
                name: "object_distance",
                allowed: "far enough that the focusing move stays within max_extension",
            });
        }
        Ok(extension)
    }
}
