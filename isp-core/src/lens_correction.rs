//! The ISP's lens corrections derived from a lens prescription, as a camera derives them at
//! start-up from the lens it carries: the distortion mesh (a Brown-Conrady fit, with its focal
//! length), the lateral-colour scales composed into the same resampling, and the shading grid
//! from relative illumination. optics-core does the optics (`Prescription::fit_brown_conrady`,
//! `fit_brown_conrady_centroid`, `lateral_colour_scale`, `illumination_curve`); this
//! module turns what it finds into the stages' own types for one sensor behind the lens.
//!
//! No heap: the prescription borrows the caller's surfaces and the shading grid is the
//! caller's buffer.
//!
//! ```
//! use isp_core::lens_correction::{DistortionFit, LensCorrections, SensorFraming};
//! use optics_core::prescription::glass::{Medium, LAMBDA_D_NM};
//! use optics_core::prescription::{Prescription, Shape, Surface};
//! // A plano-convex singlet of n = 1.5 (f = 100 mm) with its stop in front.
//! let glass = Medium::Model { nd: 1.5, vd: 60.0 };
//! let surfaces = [
//!     Surface::aperture_stop(5.0, 2.0),
//!     Surface::new(Shape::sphere_radius(50.0), 10.0, 3.0, glass),
//!     Surface::new(Shape::Flat, 10.0, 98.0, Medium::Air),
//! ];
//! let lens = Prescription::new(&surfaces).unwrap();
//! let film_mm = lens.paraxial(LAMBDA_D_NM).unwrap().bfl;
//! let framing = SensorFraming::new(64, 48, 0.1, film_mm).unwrap();
//! let fix = LensCorrections::derive(&lens, &framing, 0.3, DistortionFit::ChiefRays).unwrap();
//! assert!(fix.distortion.lateral_colour().is_some());
//! ```

use core::fmt;

use optics_core::prescription::glass::LAMBDA_D_NM;
use optics_core::prescription::{Prescription, Surface};
use optics_core::OpticsError;

use crate::distortion::{BrownConrady, LensDistortion};
use crate::lateral_colour::LateralColour;
use crate::lsc::radial_gains;
use crate::{CfaColour, IspError};

/// The wavelengths camsim's renderer traces red, green and blue at (an RGB scene's channels),
/// nm: the colours the corrections are derived for unless a camera says otherwise.
pub const RENDER_COLOURS_NM: [f64; 3] = [647.5, 540.0, 442.5];

/// Radii of the relative-illumination table the shading grid is read from (centre to corner)
/// unless a caller picks another number ([`IlluminationTable`]'s `N`).
pub const SHADING_RADII: usize = 49;

/// What went wrong deriving the corrections: the optics, or a stage refusing what they gave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LensCorrectionError {
    /// optics-core refused the prescription or a derived curve.
    Optics(OpticsError),
    /// An ISP stage refused the derived correction.
    Isp(IspError),
}

impl fmt::Display for LensCorrectionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Optics(e) => write!(f, "lens: {e}"),
            Self::Isp(e) => write!(f, "lens correction: {e}"),
        }
    }
}

impl core::error::Error for LensCorrectionError {}

impl From<OpticsError> for LensCorrectionError {
    fn from(e: OpticsError) -> Self {
        Self::Optics(e)
    }
}

impl From<IspError> for LensCorrectionError {
    fn from(e: IspError) -> Self {
        Self::Isp(e)
    }
}

/// How the sensor sits behind the lens: its size in pixels, the pixel pitch and the film's
/// distance from the last vertex, centred on the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorFraming {
    width: usize,
    height: usize,
    pitch_mm: f64,
    film_mm: f64,
    colours_nm: [f64; 3],
}

impl SensorFraming {
    /// A `width x height` sensor of `pitch_mm` pixels, `film_mm` behind the lens's last vertex
    /// (the back focus plus any focusing move), its colours at [`RENDER_COLOURS_NM`].
    pub fn new(
        width: usize,
        height: usize,
        pitch_mm: f64,
        film_mm: f64,
    ) -> Result<Self, LensCorrectionError> {
        let ok = width >= 2
            && height >= 2
            && width <= crate::lateral_colour::MAX_SIDE
            && height <= crate::lateral_colour::MAX_SIDE
            && pitch_mm.is_finite()
            && pitch_mm > 0.0
            && film_mm.is_finite()
            && film_mm > 0.0;
        if !ok {
            return Err(IspError::InvalidParameter {
                name: "sensor framing",
                allowed: "2..=65536 pixels a side, a finite pitch and film distance > 0 mm",
            }
            .into());
        }
        Ok(Self {
            width,
            height,
            pitch_mm,
            film_mm,
            colours_nm: RENDER_COLOURS_NM,
        })
    }

    /// The wavelengths the sensor's red, green and blue are taken at, nm (green is the
    /// corrections' reference: red and blue are moved onto it).
    pub fn with_colours_nm(mut self, colours_nm: [f64; 3]) -> Result<Self, LensCorrectionError> {
        if !colours_nm.iter().all(|&nm| nm.is_finite() && nm > 0.0) {
            return Err(IspError::InvalidParameter {
                name: "colours_nm",
                allowed: "finite wavelengths > 0 nm",
            }
            .into());
        }
        self.colours_nm = colours_nm;
        Ok(self)
    }

    /// The optical centre in pixels (pixel centres at whole numbers).
    pub fn centre(&self) -> [f64; 2] {
        [
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        ]
    }

    /// The frame's half diagonal, mm on the film.
    pub fn corner_mm(&self) -> f64 {
        libm::hypot(self.width as f64, self.height as f64) / 2.0 * self.pitch_mm
    }
}

/// Which light the distortion fit follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DistortionFit {
    /// The chief rays on the paraxial focal plane at the lens's focal length
    /// (`Prescription::fit_brown_conrady`): cheap, what a camera can afford at start-up.
    ChiefRays,
    /// Where each field's light lands on the film, with its focal length fitted too
    /// (`Prescription::fit_brown_conrady_centroid`, an `n x n` pupil grid a field): what a
    /// dot chart measures, and what puts the dots back on a lens with coma or a vignetted
    /// pupil.
    Centroids {
        /// Pupil grid side, 2..=257.
        pupil_points: usize,
    },
}

/// The corrections for one lens and sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensCorrections {
    /// The focal length the distortion model goes with, mm (the corrected image is a
    /// rectilinear one at this focal length).
    pub focal_length_mm: f64,
    /// OpenCV's radial coefficients `[k1, k2, k3]`.
    pub k: [f64; 3],
    /// The distortion mesh with the lateral-colour correction composed into it (one
    /// resampling in the pipeline), fitted to the frame.
    pub distortion: LensDistortion,
}

impl LensCorrections {
    /// Derives the distortion and lateral-colour corrections of `lens` for `framing`: the
    /// model fitted over fields up to `max_field_rad` (beyond the frame's corner, so the
    /// mesh's outer nodes are fitted too) by `fit` at green's wavelength, and red's and blue's
    /// scales against green at the lateral-colour stage's nodes (on the d line's focal plane).
    pub fn derive(
        lens: &Prescription<'_, f64>,
        framing: &SensorFraming,
        max_field_rad: f64,
        fit: DistortionFit,
    ) -> Result<Self, LensCorrectionError> {
        let [red_nm, green_nm, blue_nm] = framing.colours_nm;
        let (focal_length_mm, k) = match fit {
            DistortionFit::ChiefRays => (
                lens.paraxial(green_nm)?.efl,
                lens.fit_brown_conrady(max_field_rad, green_nm)?,
            ),
            DistortionFit::Centroids { pupil_points } => {
                let f = lens.fit_brown_conrady_centroid(
                    max_field_rad,
                    green_nm,
                    framing.film_mm,
                    pupil_points,
                )?;
                (f.focal_length_mm, f.k)
            }
        };
        let [k1, k2, k3] = k;
        let model = BrownConrady::from_opencv([k1, k2, 0.0, 0.0, k3])?;
        let focal_px = focal_length_mm / framing.pitch_mm;
        let [cx, cy] = framing.centre();
        let (w, h) = (framing.width, framing.height);
        // A node whose scale optics-core cannot give (an error, or beyond the field the lens
        // passes) takes the last one found: LateralColour::from_curve's rule for `None`.
        let lca = LateralColour::from_curve(w, h, [cx, cy], None, |r_px| {
            lens.lateral_colour_scales(
                r_px * framing.pitch_mm,
                [red_nm, blue_nm],
                green_nm,
                LAMBDA_D_NM,
                max_field_rad,
            )
            .ok()
            .flatten()
        })?;
        let distortion = LensDistortion::new(focal_px, focal_px, cx, cy, model)?
            .with_lateral_colour(lca)
            .fitted(w, h);
        Ok(Self {
            focal_length_mm,
            k,
            distortion,
        })
    }
}

/// `lens`'s relative illumination on `framing`'s film per colour, at `N` (at least 2;
/// [`SHADING_RADII`] unless given) radii from the centre to the frame's corner (`Prescription::illumination_curve` over
/// an `n x n` grid on the rear element, each colour at its wavelength against its own axis),
/// read linearly in radius: the lens's vignetting as a shading grid is made from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IlluminationTable<const N: usize = SHADING_RADII> {
    corner_mm: f64,
    /// Per colour (red, green, blue), per radius; `None` where not even the axis gets light.
    values: [[Option<f64>; N]; 3],
}

impl<const N: usize> IlluminationTable<N> {
    /// Traces the table. `scratch` holds the lens turned round (as many surfaces as the lens).
    pub fn derive(
        lens: &Prescription<'_, f64>,
        framing: &SensorFraming,
        pupil_points: usize,
        scratch: &mut [Surface<f64>],
    ) -> Result<Self, LensCorrectionError> {
        if N < 2 {
            return Err(IspError::InvalidParameter {
                name: "illumination table radii",
                allowed: "at least 2",
            }
            .into());
        }
        let corner_mm = framing.corner_mm();
        let last = (N - 1) as f64;
        let mut values = [[None; N]; 3];
        let mut radii = [0.0; N];
        for (i, r) in radii.iter_mut().enumerate() {
            *r = corner_mm * i as f64 / last;
        }
        for (row, &nm) in values.iter_mut().zip(&framing.colours_nm) {
            lens.illumination_curve(&radii, framing.film_mm, nm, pupil_points, scratch, row)?;
        }
        Ok(Self { corner_mm, values })
    }

    /// Colour `colour`'s (0 red, 1 green, 2 blue) illumination at `r_mm` from the centre
    /// against its axis, interpolated (0 beyond the image circle); the corner's beyond the
    /// corner; `None` where not even the axis gets light (or `colour` is not 0..=2).
    pub fn at(&self, colour: usize, r_mm: f64) -> Option<f64> {
        let row = self.values.get(colour)?;
        let last = N.checked_sub(1)? as f64;
        let t = (r_mm / self.corner_mm * last).clamp(0.0, last);
        let i = (t as usize).min(N.checked_sub(2)?);
        let (a, b) = (row[i]?, row[i + 1]?);
        Some(a + (b - a) * (t - i as f64))
    }

    /// Fills `gains` (a `grid_w x grid_h` shading grid in [`crate::lsc::LensShading`]'s
    /// format) with the gains that undo this fall-off, the 2x2 block's positions reading the
    /// colours `block` names (a CFA pattern's [`crate::CfaPattern::block`]), through
    /// [`radial_gains`] (nodes beyond the image circle take the gain found on the way in).
    /// The lens's own vignetting only: a sensor's shading multiplies in on top.
    pub fn fill_grid(
        &self,
        framing: &SensorFraming,
        block: [CfaColour; 4],
        gains: &mut [u16],
        grid_w: usize,
        grid_h: usize,
    ) -> Result<(), LensCorrectionError> {
        let pitch = framing.pitch_mm;
        radial_gains(
            gains,
            grid_w,
            grid_h,
            framing.width,
            framing.height,
            framing.centre(),
            |position, r_px| self.at(block[position].index(), r_px * pitch),
        )?;
        Ok(())
    }
}
