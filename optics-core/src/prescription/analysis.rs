//! Curves of a lens against the field, from real rays, object at infinity: distortion,
//! lateral colour, relative illumination and RMS spot size; and the chromatic focal shift from
//! the paraxial data.
//!
//! Rays are aimed paraxially, as lens-design programs do by default: a ray of field angle
//! `theta` (in the `y-z` plane) and normalised pupil point `(px, py)` passes the paraxial
//! entrance pupil's plane at `(px, py)` times its semi-diameter. The chief ray is `(0, 0)`.
//! Every figure is taken on the paraxial focal plane at the reference wavelength.

use super::paraxial::Pupil;
use super::trace::{Ray, Traced};
use super::Prescription;
use crate::real::{checked, positive};
use crate::{OpticsError, Real, Result};

/// The largest pupil grid side: `n x n` rays per field point.
pub const MAX_GRID: usize = 257;

/// The points of an `n x n` grid of cell centres over the square `[-1, 1]^2` that lie on the
/// unit disk: a normalised pupil's rays.
pub(super) fn pupil_points<T: Real>(n: usize) -> impl Iterator<Item = [T; 2]> {
    let step = T::lit(2.0) / T::lit(n as f64);
    let at = move |i: usize| -T::one() + (T::lit(i as f64) + T::lit(0.5)) * step;
    (0..n)
        .flat_map(move |i| (0..n).map(move |j| [at(i), at(j)]))
        .filter(|&[px, py]| px * px + py * py <= T::one())
}

impl<T: Real> Prescription<'_, T> {
    /// The ray of field angle `field_rad` (0 to below pi/2) through the normalised entrance
    /// pupil point `(px, py)` at `wavelength_nm`, starting 1 mm before the first surface's rim.
    pub fn aimed_ray(&self, field_rad: T, pupil: [T; 2], wavelength_nm: T) -> Result<Ray<T>> {
        let ep = self.paraxial(wavelength_nm)?.entrance_pupil;
        self.aim_at(&ep, field_rad, pupil, wavelength_nm)
    }

    /// [`Self::aimed_ray`] with the entrance pupil already known (a pupil grid computes it
    /// once, not per ray).
    pub(super) fn aim_at(
        &self,
        ep: &Pupil<T>,
        field_rad: T,
        pupil: [T; 2],
        wavelength_nm: T,
    ) -> Result<Ray<T>> {
        if !(field_rad >= T::zero() && field_rad < T::lit(1.5)) {
            return Err(OpticsError::InvalidParameter {
                name: "field_rad",
                allowed: "0 to 1.5 radians",
            });
        }
        if !(pupil[0].is_finite() && pupil[1].is_finite()) {
            return Err(OpticsError::InvalidParameter {
                name: "pupil",
                allowed: "finite",
            });
        }
        let first = &self.surfaces[0];
        let rim = first
            .shape
            .sag_and_slope(first.semi_diameter * first.semi_diameter)
            .map_or(T::zero(), |(z, _)| z);
        let z0 = -(rim.abs() + T::one());
        let (sin, cos) = (field_rad.sin(), field_rad.cos());
        let tan = sin / cos;
        Ok(Ray {
            origin: [
                pupil[0] * ep.semi_diameter,
                pupil[1] * ep.semi_diameter - (ep.position - z0) * tan,
                z0,
            ],
            direction: [T::zero(), sin, cos],
            wavelength_nm,
        })
    }

    /// Where the chief ray of `field_rad` at `wavelength_nm` meets the paraxial focal plane at
    /// `reference_nm` (its `y`, mm), or `None` when the lens stops it.
    pub fn chief_height(
        &self,
        field_rad: T,
        wavelength_nm: T,
        reference_nm: T,
    ) -> Result<Option<T>> {
        let bfl = self.paraxial(reference_nm)?.bfl;
        let ep = self.paraxial(wavelength_nm)?.entrance_pupil;
        self.chief_height_with(&ep, field_rad, wavelength_nm, bfl)
    }

    /// [`Self::chief_height`] with the entrance pupil at `wavelength_nm` and the plane (`bfl`
    /// behind the last vertex) already known: a search over the field computes them once.
    pub(super) fn chief_height_with(
        &self,
        ep: &Pupil<T>,
        field_rad: T,
        wavelength_nm: T,
        bfl: T,
    ) -> Result<Option<T>> {
        let ray = self.aim_at(ep, field_rad, [T::zero(); 2], wavelength_nm)?;
        match self.trace_to_plane(&ray, bfl)? {
            Traced::Image { point, .. } => checked(point[1]).map(Some),
            Traced::Lost { .. } => Ok(None),
        }
    }

    /// Distortion at `field_rad`, percent: the chief ray's height on the paraxial focal plane
    /// against `efl tan(field)`, all at `wavelength_nm`. `None` when the chief ray is lost;
    /// [`OpticsError::Overflow`] when the ratio does not fit `T` (an ideal height of zero).
    pub fn distortion_percent(&self, field_rad: T, wavelength_nm: T) -> Result<Option<T>> {
        positive(field_rad, "field_rad")?;
        let efl = self.paraxial(wavelength_nm)?.efl;
        let ideal = efl * field_rad.tan();
        self.chief_height(field_rad, wavelength_nm, wavelength_nm)?
            .map(|y| {
                // A field so small that `efl tan(field)` underflows to zero has no ratio to
                // report: an error, never a NaN.
                checked(T::lit(100.0) * (y - ideal) / ideal)
            })
            .transpose()
    }

    /// Lateral colour at `field_rad`, mm: the chief ray's height at `short_nm` less that at
    /// `long_nm`, both on the paraxial focal plane at `reference_nm`.
    pub fn lateral_colour(
        &self,
        field_rad: T,
        short_nm: T,
        long_nm: T,
        reference_nm: T,
    ) -> Result<Option<T>> {
        let short = self.chief_height(field_rad, short_nm, reference_nm)?;
        let long = self.chief_height(field_rad, long_nm, reference_nm)?;
        short.zip(long).map(|(s, l)| checked(s - l)).transpose()
    }

    /// Chromatic focal shift, mm: the back focal length at `wavelength_nm` less that at
    /// `reference_nm`.
    pub fn chromatic_focal_shift(&self, wavelength_nm: T, reference_nm: T) -> Result<T> {
        checked(self.paraxial(wavelength_nm)?.bfl - self.paraxial(reference_nm)?.bfl)
    }

    /// Traces an `n x n` grid over the entrance pupil's disk at `field_rad` to the paraxial
    /// focal plane at `wavelength_nm`: returns (rays inside the disk, rays that arrived, the
    /// RMS distance of the arrivals from their centroid in mm, the chief ray's angle to the
    /// axis after the lens in radians if it arrived).
    fn pupil_grid(
        &self,
        field_rad: T,
        wavelength_nm: T,
        n: usize,
    ) -> Result<(usize, usize, T, Option<T>)> {
        if !(2..=MAX_GRID).contains(&n) {
            return Err(OpticsError::InvalidParameter {
                name: "grid",
                allowed: "2 to 257 rays a side",
            });
        }
        let p = self.paraxial(wavelength_nm)?;
        let (bfl, ep) = (p.bfl, p.entrance_pupil);
        let chief = self.aim_at(&ep, field_rad, [T::zero(); 2], wavelength_nm)?;
        let (anchor, chief_angle) = match self.trace_to_plane(&chief, bfl)? {
            Traced::Image { point, direction } => (
                [point[0], point[1]],
                Some((direction[0].hypot(direction[1])).atan2(direction[2])),
            ),
            Traced::Lost { .. } => ([T::zero(); 2], None),
        };
        let (mut inside, mut arrived) = (0usize, 0usize);
        // Sums about the chief ray's landing point: the spot is small beside the image height.
        let (mut sx, mut sy, mut sxx) = (T::zero(), T::zero(), T::zero());
        for pupil in pupil_points::<T>(n) {
            inside += 1;
            let ray = self.aim_at(&ep, field_rad, pupil, wavelength_nm)?;
            if let Traced::Image { point, .. } = self.trace_to_plane(&ray, bfl)? {
                arrived += 1;
                let (dx, dy) = (point[0] - anchor[0], point[1] - anchor[1]);
                sx = sx + dx;
                sy = sy + dy;
                sxx = sxx + dx * dx + dy * dy;
            }
        }
        let rms = if arrived > 0 {
            let m = T::lit(arrived as f64);
            (sxx / m - (sx / m) * (sx / m) - (sy / m) * (sy / m))
                .max(T::zero())
                .sqrt()
        } else {
            T::zero()
        };
        Ok((inside, arrived, rms, chief_angle))
    }

    /// RMS spot radius at `field_rad` and `wavelength_nm`, mm, about the spot's centroid on the
    /// paraxial focal plane, from an `n x n` grid over the entrance pupil (rays the lens stops
    /// left out); `None` when no ray arrives.
    pub fn rms_spot(&self, field_rad: T, wavelength_nm: T, n: usize) -> Result<Option<T>> {
        let (_, arrived, rms, _) = self.pupil_grid(field_rad, wavelength_nm, n)?;
        (arrived > 0).then(|| checked(rms)).transpose()
    }

    /// Relative illumination at `field_rad` against the axis: the fraction of an `n x n`
    /// entrance-pupil grid that reaches the image (vignetting by clear apertures), times the
    /// cosine-fourth law in image space, `cos^4` of the chief ray's angle to the axis after the
    /// lens, each relative to the axis. An approximation that takes the exit pupil as small
    /// against its distance and its shape as the beam's; `None` when the chief ray is lost.
    pub fn relative_illumination(
        &self,
        field_rad: T,
        wavelength_nm: T,
        n: usize,
    ) -> Result<Option<T>> {
        let (inside0, arrived0, _, angle0) = self.pupil_grid(T::zero(), wavelength_nm, n)?;
        let (inside, arrived, _, angle) = self.pupil_grid(field_rad, wavelength_nm, n)?;
        let (Some(a0), Some(a)) = (angle0, angle) else {
            return Ok(None);
        };
        if arrived0 == 0 || inside == 0 || inside0 == 0 {
            return Ok(None);
        }
        let fraction = (T::lit(arrived as f64) / T::lit(inside as f64))
            / (T::lit(arrived0 as f64) / T::lit(inside0 as f64));
        let c = a.cos() / a0.cos();
        checked(fraction * c * c * c * c).map(Some)
    }
}
