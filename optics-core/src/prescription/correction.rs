//! What an ISP needs to undo a lens, derived from its prescription (no heap; runs on the
//! firmware targets at start-up):
//!
//! - [`Prescription::fit_brown_conrady`]: distortion as OpenCV's radial coefficients
//!   `k1, k2, k3`, least squares over the field, for isp-core's distortion mesh. With the
//!   camera matrix's focal length `efl / pixel pitch`, the normalised ideal point is
//!   `x = tan(field)` and the lens puts it at `x_d = h(field) / efl`, `h` the chief ray's
//!   height on the focal plane.
//! - [`Prescription::lateral_colour_scale`]: how much larger a colour's image is than the
//!   reference colour's at an image radius, `h_c / h_ref` along one chief ray: the factor a
//!   lateral-colour stage reads that colour's plane at.
//! - [`Prescription::illumination_at_height`] (and [`Prescription::illumination_curve`] for
//!   several radii): relative illumination at an image radius, the
//!   projected solid angle of the light that reaches that film point (traced from the film
//!   through the lens turned round, over a grid on the rear element), against the centre's:
//!   the same quantity the renderer's lens camera weights its samples by, so a shading grid
//!   made from it flattens a render through the lens.
//!
//! All are on the plane a camera's film sits on: the paraxial focal plane at `reference_nm`,
//! or, for [`Prescription::fit_brown_conrady_centroid`], the plane the caller's film is on.

use super::trace::{Ray, Traced};
use super::{Prescription, Surface};
use crate::real::checked;
use crate::{OpticsError, Real, Result};

/// Chief rays the distortion fit samples over the field.
pub const FIT_SAMPLES: usize = 64;

/// A radial distortion model with the focal length it goes with
/// ([`Prescription::fit_brown_conrady_centroid`]): OpenCV's `fx = fy = focal_length_mm /
/// pixel pitch` and radial coefficients `k = [k1, k2, k3]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadialFit<T> {
    /// The focal length the fit's image scale implies, mm.
    pub focal_length_mm: T,
    /// `k1, k2, k3`.
    pub k: [T; 3],
}

impl<T: Real> Prescription<'_, T> {
    /// The field angle (radians, in `[0, max_field_rad]`) whose chief ray at `wavelength_nm`
    /// meets the paraxial focal plane at `reference_nm` at height `height_mm`, by bisection
    /// (the height must rise with the field, as it does in a camera lens); `None` when the
    /// height is beyond the field's or a chief ray on the way is lost.
    pub fn field_at_height(
        &self,
        height_mm: T,
        wavelength_nm: T,
        reference_nm: T,
        max_field_rad: T,
    ) -> Result<Option<T>> {
        if !(height_mm.is_finite() && height_mm >= T::zero()) {
            return Err(OpticsError::InvalidParameter {
                name: "height_mm",
                allowed: "finite and >= 0",
            });
        }
        if !(max_field_rad > T::zero() && max_field_rad < T::lit(1.5)) {
            return Err(OpticsError::InvalidParameter {
                name: "max_field_rad",
                allowed: "above 0 and below 1.5 radians",
            });
        }
        if height_mm == T::zero() {
            return Ok(Some(T::zero()));
        }
        // The pupil and the plane once, not per step (each is a paraxial analysis).
        let bfl = self.paraxial(reference_nm)?.bfl;
        let ep = self.paraxial(wavelength_nm)?.entrance_pupil;
        let height = |field| self.chief_height_with(&ep, field, wavelength_nm, bfl);
        let Some(top) = height(max_field_rad)? else {
            return Ok(None);
        };
        if top < height_mm {
            return Ok(None);
        }
        let (mut lo, mut hi) = (T::zero(), max_field_rad);
        for _ in 0..60 {
            let mid = (lo + hi) * T::lit(0.5);
            match height(mid)? {
                Some(h) if h < height_mm => lo = mid,
                Some(_) => hi = mid,
                None => return Ok(None),
            }
        }
        Ok(Some((lo + hi) * T::lit(0.5)))
    }

    /// OpenCV's radial distortion coefficients `[k1, k2, k3]` fitted (least squares, on
    /// [`FIT_SAMPLES`] chief rays evenly spread in field up to `max_field_rad`) to the lens at
    /// `wavelength_nm`: `h / (efl tan(field)) = 1 + k1 x^2 + k2 x^4 + k3 x^6`, `x = tan(field)`.
    /// The tangential terms are 0 for a centred lens.
    pub fn fit_brown_conrady(&self, max_field_rad: T, wavelength_nm: T) -> Result<[T; 3]> {
        self.fit_radial::<3>(max_field_rad, wavelength_nm, |field| {
            self.chief_height(field, wavelength_nm, wavelength_nm)
        })
    }

    /// [`Prescription::fit_brown_conrady`] to where a distant point's light lands on a sensor
    /// `image_distance_mm` behind the last vertex ([`Prescription::centroid_height`], an
    /// `n x n` pupil grid per field), not to its chief ray, with the focal length fitted too
    /// (`h = f x (1 + k1 x^2 + k2 x^4 + k3 x^6)`): off the paraxial focal plane, or with
    /// spherical aberration, a point's light is off its chief ray in proportion to the field
    /// even near the axis, a change of scale, which a calibrated camera's `fx` holds. What a
    /// dot chart measures: where coma or a vignetted pupil moves a point's light off its
    /// chief ray (an f/1 singlet's by several of its pixels), this is the fit that puts the
    /// dots back.
    pub fn fit_brown_conrady_centroid(
        &self,
        max_field_rad: T,
        wavelength_nm: T,
        image_distance_mm: T,
        n: usize,
    ) -> Result<RadialFit<T>> {
        let [m, a1, a2, a3] = self.fit_radial::<4>(max_field_rad, wavelength_nm, |field| {
            self.centroid_height(field, wavelength_nm, image_distance_mm, n)
        })?;
        if m <= T::zero() {
            return Err(OpticsError::InvalidParameter {
                name: "image_distance_mm",
                allowed: "a plane where the image is upright",
            });
        }
        let efl = self.paraxial(wavelength_nm)?.efl;
        Ok(RadialFit {
            focal_length_mm: checked(m * efl)?,
            k: [checked(a1 / m)?, checked(a2 / m)?, checked(a3 / m)?],
        })
    }

    /// The mean height (mm) at which the rays of a distant point at `field_rad` through an
    /// `n x n` grid over the paraxial entrance pupil's disk meet the plane `image_distance_mm`
    /// behind the last vertex, at `wavelength_nm`: the centroid of its image (equal flux per
    /// ray, as from a point at infinity). `None` when no ray passes.
    pub fn centroid_height(
        &self,
        field_rad: T,
        wavelength_nm: T,
        image_distance_mm: T,
        n: usize,
    ) -> Result<Option<T>> {
        if !(2..=super::analysis::MAX_GRID).contains(&n) {
            return Err(OpticsError::InvalidParameter {
                name: "n",
                allowed: "2..=257",
            });
        }
        if !image_distance_mm.is_finite() {
            return Err(OpticsError::InvalidParameter {
                name: "image_distance_mm",
                allowed: "finite",
            });
        }
        let ep = self.paraxial(wavelength_nm)?.entrance_pupil;
        let (mut sum, mut arrived) = (T::zero(), 0usize);
        for pupil in super::analysis::pupil_points::<T>(n) {
            let ray = self.aim_at(&ep, field_rad, pupil, wavelength_nm)?;
            if let Traced::Image { point, .. } = self.trace_to_plane(&ray, image_distance_mm)? {
                sum = sum + point[1];
                arrived += 1;
            }
        }
        (arrived > 0)
            .then(|| checked(sum / T::lit(arrived as f64)))
            .transpose()
    }

    /// The radial fit of `height(field)` (mm, `None` where the lens passes nothing) over
    /// [`FIT_SAMPLES`] fields up to `max_field_rad`, against `efl tan(field)` at
    /// `wavelength_nm`: `h / (efl x) - 1 = k1 x^2 + k2 x^4 + k3 x^6` for `N = 3`, and
    /// `h / (efl x) = m + a1 x^2 + a2 x^4 + a3 x^6` (the scale `m` fitted too) for `N = 4`.
    fn fit_radial<const N: usize>(
        &self,
        max_field_rad: T,
        wavelength_nm: T,
        mut height: impl FnMut(T) -> Result<Option<T>>,
    ) -> Result<[T; N]> {
        if !(max_field_rad > T::zero() && max_field_rad < T::lit(1.5)) {
            return Err(OpticsError::InvalidParameter {
                name: "max_field_rad",
                allowed: "above 0 and below 1.5 radians",
            });
        }
        let efl = self.paraxial(wavelength_nm)?.efl;
        // Normal equations of the 3-term fit, accumulated without storing the samples.
        let mut a = [[T::zero(); N]; N];
        let mut b = [T::zero(); N];
        let mut used = 0;
        for i in 1..=FIT_SAMPLES {
            let field = max_field_rad * T::lit(i as f64 / FIT_SAMPLES as f64);
            let Some(h) = height(field)? else {
                continue;
            };
            let x = field.tan();
            let x2 = x * x;
            // Powers x^2.. for the fixed scale, x^0.. for the fitted one.
            let first = if N == 3 { x2 } else { T::one() };
            let mut basis = [first; N];
            for k in 1..N {
                basis[k] = basis[k - 1] * x2;
            }
            let offset = if N == 3 { T::one() } else { T::zero() };
            let y = h / (efl * x) - offset;
            for r in 0..N {
                for c in 0..N {
                    a[r][c] = a[r][c] + basis[r] * basis[c];
                }
                b[r] = b[r] + basis[r] * y;
            }
            used += 1;
        }
        if used < N {
            return Err(OpticsError::InvalidParameter {
                name: "max_field_rad",
                allowed: "a field the lens passes chief rays over",
            });
        }
        let k = solve(a, b).ok_or(OpticsError::InvalidParameter {
            name: "max_field_rad",
            allowed: "a field wide enough to fit the coefficients",
        })?;
        for v in k {
            checked(v)?;
        }
        Ok(k)
    }

    /// The factor by which the image at `wavelength_nm` is larger than at `reference_nm` at
    /// image radius `height_mm` (of the reference colour), on the paraxial focal plane at
    /// `focal_plane_nm`: `h(field, wavelength) / h(field, reference)` for the field whose
    /// reference chief ray lands at `height_mm`. At the axis, the limit (the ratio of the
    /// paraxial image heights, taken at a small field). `None` beyond the field the lens
    /// passes.
    pub fn lateral_colour_scale(
        &self,
        height_mm: T,
        wavelength_nm: T,
        reference_nm: T,
        focal_plane_nm: T,
        max_field_rad: T,
    ) -> Result<Option<T>> {
        Ok(self
            .lateral_colour_scales(
                height_mm,
                [wavelength_nm],
                reference_nm,
                focal_plane_nm,
                max_field_rad,
            )?
            .map(|[s]| s))
    }

    /// [`Self::lateral_colour_scale`] for several colours at once (red and blue against
    /// green, say): the reference's field and chief ray are found once. `None` beyond the
    /// field the lens passes or when any colour's chief ray is lost.
    pub fn lateral_colour_scales<const N: usize>(
        &self,
        height_mm: T,
        wavelengths_nm: [T; N],
        reference_nm: T,
        focal_plane_nm: T,
        max_field_rad: T,
    ) -> Result<Option<[T; N]>> {
        let small = max_field_rad * T::lit(1e-3);
        let field =
            match self.field_at_height(height_mm, reference_nm, focal_plane_nm, max_field_rad)? {
                Some(f) if f > small => f,
                Some(_) => small,
                None => return Ok(None),
            };
        let reference = match self.chief_height(field, reference_nm, focal_plane_nm)? {
            Some(r) if r > T::zero() => r,
            _ => return Ok(None),
        };
        let mut scales = [T::zero(); N];
        for (scale, &nm) in scales.iter_mut().zip(&wavelengths_nm) {
            match self.chief_height(field, nm, focal_plane_nm)? {
                Some(c) => *scale = checked(c / reference)?,
                None => return Ok(None),
            }
        }
        Ok(Some(scales))
    }

    /// Relative illumination at image radius `height_mm` on the plane `image_distance_mm`
    /// behind the last vertex, at `wavelength_nm`, against the axis: the projected solid angle
    /// (`sum of cos^4 / d^2` over an `n x n` grid on the rear element's clear aperture) of the
    /// rays from that film point that pass the lens. `scratch` holds the lens turned round (as
    /// many surfaces as the lens). `None` when no ray from the axis passes. For several radii,
    /// [`Prescription::illumination_curve`] traces the axis once.
    pub fn illumination_at_height(
        &self,
        height_mm: T,
        image_distance_mm: T,
        wavelength_nm: T,
        n: usize,
        scratch: &mut [Surface<T>],
    ) -> Result<Option<T>> {
        let mut out = [None];
        self.illumination_curve(
            &[height_mm],
            image_distance_mm,
            wavelength_nm,
            n,
            scratch,
            &mut out,
        )?;
        Ok(out[0])
    }

    /// [`Prescription::illumination_at_height`] at each of `heights_mm` into `out` (as long):
    /// the lens is turned round and the axis traced once for all of them (a radius of 0 is
    /// the axis itself, 1), the values are the same to the bit. Every `out` is `None` when no
    /// ray from the axis passes.
    ///
    /// ```
    /// use optics_core::prescription::{glass::Medium, Prescription, Shape, Surface};
    /// let bk7 = optics_core::prescription::glass::catalogue_glass("N-BK7").unwrap().medium();
    /// let surfaces = [
    ///     Surface::new(Shape::sphere_radius(50.0), 10.0, 5.0, bk7).stop(),
    ///     Surface::new(Shape::sphere_radius(-50.0), 10.0, 48.0, Medium::Air),
    /// ];
    /// let lens = Prescription::new(&surfaces).unwrap();
    /// let mut scratch = surfaces; // room for the lens turned round
    /// let mut curve: [Option<f64>; 3] = [None; 3];
    /// lens.illumination_curve(&[0.0, 4.0, 8.0], 48.0, 587.6, 32, &mut scratch, &mut curve).unwrap();
    /// let [Some(axis), Some(mid), Some(edge)] = curve else { panic!("no light on the axis") };
    /// assert_eq!(axis, 1.0);
    /// // Near the axis the grid's cells (counted by their centres) move it by ~1 %.
    /// assert!((mid - 1.0).abs() < 0.02);
    /// assert!(edge < 0.98);
    /// ```
    pub fn illumination_curve(
        &self,
        heights_mm: &[T],
        image_distance_mm: T,
        wavelength_nm: T,
        n: usize,
        scratch: &mut [Surface<T>],
        out: &mut [Option<T>],
    ) -> Result<()> {
        if !(2..=super::analysis::MAX_GRID).contains(&n) {
            return Err(OpticsError::InvalidParameter {
                name: "n",
                allowed: "2..=257",
            });
        }
        if heights_mm
            .iter()
            .any(|h| !(h.is_finite() && *h >= T::zero()))
        {
            return Err(OpticsError::InvalidParameter {
                name: "height_mm",
                allowed: "finite and >= 0",
            });
        }
        if out.len() != heights_mm.len() {
            return Err(OpticsError::InvalidParameter {
                name: "out",
                allowed: "as long as heights_mm",
            });
        }
        if !(image_distance_mm.is_finite() && image_distance_mm > T::zero()) {
            return Err(OpticsError::InvalidParameter {
                name: "image_distance_mm",
                allowed: "finite and > 0",
            });
        }
        let back = self.reversed_into(scratch)?;
        let axis = projected_solid_angle(&back, T::zero(), image_distance_mm, wavelength_nm, n)?;
        if axis <= T::zero() {
            out.fill(None);
            return Ok(());
        }
        for (slot, &h) in out.iter_mut().zip(heights_mm) {
            let here = if h == T::zero() {
                axis
            } else {
                projected_solid_angle(&back, h, image_distance_mm, wavelength_nm, n)?
            };
            *slot = Some(checked(here / axis)?);
        }
        Ok(())
    }
}

/// `sum cos^4 / d^2 * cell` over the rays from film point `(h, 0)` at distance `d` before the
/// turned lens's first vertex towards an `n x n` grid on its clear aperture that pass.
fn projected_solid_angle<T: Real>(
    back: &Prescription<'_, T>,
    h: T,
    d: T,
    wavelength_nm: T,
    n: usize,
) -> Result<T> {
    let r = back.surfaces()[0].semi_diameter;
    let cell = T::lit(2.0) * r / T::lit(n as f64);
    let mut sum = T::zero();
    for gy in 0..n {
        for gx in 0..n {
            let px = -r + (T::lit(gx as f64) + T::lit(0.5)) * cell;
            let py = -r + (T::lit(gy as f64) + T::lit(0.5)) * cell;
            if px * px + py * py > r * r {
                continue;
            }
            let (dx, dy) = (px - h, py);
            let ray = Ray {
                origin: [h, T::zero(), -d],
                direction: [dx, dy, d],
                wavelength_nm,
            };
            if let Traced::Image { .. } = back.trace(&ray)? {
                let cos2 = d * d / (dx * dx + dy * dy + d * d);
                sum = sum + cos2 * cos2 / (d * d);
            }
        }
    }
    Ok(sum * cell * cell)
}

/// Solves the 3x3 system `a x = b` by Gaussian elimination with partial pivoting; `None` when
/// it is singular.
fn solve<T: Real, const N: usize>(mut a: [[T; N]; N], mut b: [T; N]) -> Option<[T; N]> {
    for col in 0..N {
        let mut pivot = col;
        for row in col + 1..N {
            if a[row][col].abs() > a[pivot][col].abs() {
                pivot = row;
            }
        }
        if a[pivot][col].abs() <= T::min_positive_value() {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let (pivot_row, pivot_b) = (a[col], b[col]);
        for (row, rhs) in a.iter_mut().zip(b.iter_mut()).skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (v, p) in row.iter_mut().zip(pivot_row).skip(col) {
                *v = *v - f * p;
            }
            *rhs = *rhs - f * pivot_b;
        }
    }
    let mut x = [T::zero(); N];
    for row in (0..N).rev() {
        let mut s = b[row];
        for c in row + 1..N {
            s = s - a[row][c] * x[c];
        }
        x[row] = s / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}
