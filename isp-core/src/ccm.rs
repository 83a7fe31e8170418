//! Colour correction: from white-balanced camera RGB to linear sRGB.
//!
//! The pipeline applies one 3x3 matrix per frame, `lin = clamp(CCM * rgb, 0, 1)`. This module
//! builds that matrix from a camera's calibration: two camera-to-XYZ matrices measured under two
//! illuminants (say A at 2856 K and D65 at 6504 K), interpolated for the scene's colour
//! temperature the way DNG does it: the XYZ-to-camera matrices (DNG's `ColorMatrix1/2`) are
//! blended linearly in inverse CCT, with the weight clamped to `[0, 1]` outside the two
//! temperatures, and the blend inverted. Then
//!
//! `CCM = XYZ_to_sRGB * Bradford(scene white -> D65) * camera_to_XYZ(cct) * diag(1 / gains)`
//!
//! scaled so the white-balanced neutral `(1, 1, 1)` has luminance 1: a grey in the scene comes
//! out grey. Computed in `f64` once per frame; the fixed-point path holds the result in signed
//! Q4.16 (range `[-8, 8)` as in Raspberry Pi's PiSP, six more fractional bits: see
//! [`crate::pipeline::CCM_FRAC_BITS`]).
//!
//! ```
//! use isp_core::ccm::Calibration;
//! use isp_core::colour::LINEAR_SRGB_TO_XYZ;
//! // A camera whose RGB is linear sRGB: the CCM for neutral gains is the identity.
//! let cal = Calibration::single(6504.0, LINEAR_SRGB_TO_XYZ).unwrap();
//! let ccm = cal.ccm(6504.0, [1.0, 1.0, 1.0]).unwrap();
//! for i in 0..3 {
//!     for j in 0..3 {
//!         let expected = if i == j { 1.0 } else { 0.0 };
//!         assert!((ccm[i][j] - expected).abs() < 2e-3);
//!     }
//! }
//! ```

use crate::colour::{self, Mat3};
use crate::wb::WbPreset;
use crate::IspError;

/// Largest coefficient magnitude of a pipeline CCM (exclusive), the range of the fixed path's signed Q4.16.
pub const MAX_COEFFICIENT: f32 = 8.0;

/// Checks a pipeline CCM: finite, every coefficient in `[-8, 8)`.
pub fn validate(ccm: &[[f32; 3]; 3]) -> Result<(), IspError> {
    if ccm
        .iter()
        .flatten()
        .all(|c| (-MAX_COEFFICIENT..MAX_COEFFICIENT).contains(c))
    {
        Ok(())
    } else {
        Err(IspError::InvalidParameter {
            name: "ccm",
            allowed: "finite coefficients in [-8, 8)",
        })
    }
}

/// `ccm * rgb`, clamped to `[0, 1]` (the float reference).
#[inline]
pub fn apply_f32(ccm: &[[f32; 3]; 3], rgb: [f32; 3]) -> [f32; 3] {
    core::array::from_fn(|i| {
        (ccm[i][0] * rgb[0] + ccm[i][1] * rgb[1] + ccm[i][2] * rgb[2]).clamp(0.0, 1.0)
    })
}

/// A matrix of `f32` coefficients in signed fixed point with `frac_bits` fractional bits.
pub fn quantise(m: &[[f32; 3]; 3], frac_bits: u32) -> [[i32; 3]; 3] {
    let scale = (1u32 << frac_bits) as f32;
    m.map(|row| {
        row.map(|c| {
            let v = c * scale;
            if v >= 0.0 {
                (v + 0.5) as i32
            } else {
                (v - 0.5) as i32
            }
        })
    })
}

/// `m * rgb` for `u16` pixels (65535 is 1.0) and a matrix with `frac_bits` fractional bits,
/// rounded and clamped to `0..=65535`.
#[inline]
pub fn apply_u16(m: &[[i32; 3]; 3], frac_bits: u32, rgb: [u16; 3]) -> [u16; 3] {
    let half = 1i64 << (frac_bits - 1);
    core::array::from_fn(|i| {
        let s = m[i][0] as i64 * rgb[0] as i64
            + m[i][1] as i64 * rgb[1] as i64
            + m[i][2] as i64 * rgb[2] as i64;
        ((s + half) >> frac_bits).clamp(0, 65535) as u16
    })
}

/// The 3x3 matrix `M` that maps camera values to reference values with the least squared
/// error, `min sum_i |M camera_i - reference_i|^2`: the linear colour-correction fit of Cheung
/// et al. 2004 with 3 terms (colour-science's `matrix_colour_correction(camera, reference,
/// method='Cheung 2004')`). Typically `camera` holds a chart's 24 patches as the camera saw
/// them and `reference` their XYZ, giving a camera-to-XYZ matrix for [`Calibration`].
///
/// Solved through the normal equations in `f64` (`M = (R^T C) (C^T C)^-1`), with the columns
/// scaled to unit norm first so the 3x3 solve stays well conditioned. Needs at least three
/// patches, equal counts, finite values, and camera values that span three dimensions.
///
/// ```
/// use isp_core::ccm::fit;
/// // Patches seen through a known matrix are fitted back exactly.
/// let m = [[0.6, 0.3, 0.1], [0.2, 0.7, 0.1], [0.0, 0.1, 0.9]];
/// let camera = [[0.2, 0.1, 0.05], [0.5, 0.6, 0.2], [0.1, 0.3, 0.8], [0.9, 0.8, 0.7]];
/// let reference: Vec<[f64; 3]> = camera
///     .iter()
///     .map(|c| core::array::from_fn(|i| (0..3).map(|j| m[i][j] * c[j]).sum()))
///     .collect();
/// let fitted = fit(&camera, &reference).unwrap();
/// for i in 0..3 {
///     for j in 0..3 {
///         assert!((fitted[i][j] - m[i][j]).abs() < 1e-12);
///     }
/// }
/// ```
pub fn fit(camera: &[[f64; 3]], reference: &[[f64; 3]]) -> Result<Mat3, IspError> {
    if camera.len() != reference.len() || camera.len() < 3 {
        return Err(IspError::InvalidParameter {
            name: "patches",
            allowed: "at least 3, as many camera values as reference values",
        });
    }
    if !camera
        .iter()
        .chain(reference)
        .flatten()
        .all(|v| v.is_finite())
    {
        return Err(IspError::InvalidParameter {
            name: "patch values",
            allowed: "finite numbers",
        });
    }
    // Column scales: the fit of scaled columns, unscaled, is the same matrix.
    let scale: [f64; 3] = core::array::from_fn(|j| {
        let norm = libm::sqrt(camera.iter().map(|c| c[j] * c[j]).sum::<f64>());
        if norm > 0.0 {
            1.0 / norm
        } else {
            1.0
        }
    });
    let mut gram = [[0.0; 3]; 3];
    let mut cross = [[0.0; 3]; 3];
    for (c, r) in camera.iter().zip(reference) {
        let c: [f64; 3] = core::array::from_fn(|j| c[j] * scale[j]);
        for i in 0..3 {
            for j in 0..3 {
                gram[i][j] += c[i] * c[j];
                cross[i][j] += r[i] * c[j];
            }
        }
    }
    let inverse = colour::mat3_inverse(&gram).map_err(|_| IspError::InvalidParameter {
        name: "camera patch values",
        allowed: "values spanning three dimensions (not all on a plane through black)",
    })?;
    let m = colour::mat3_mul(&cross, &inverse);
    Ok(core::array::from_fn(|i| {
        core::array::from_fn(|j| m[i][j] * scale[j])
    }))
}

/// The colour matrix [`Calibration::ccm_for_white_balance`] chose, with the temperature it
/// chose it for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChosenCcm {
    /// The white balance's correlated colour temperature, kelvin.
    pub cct_k: f64,
    /// The pipeline CCM at that temperature for those gains.
    pub ccm: [[f32; 3]; 3],
}

/// A camera's colour calibration under one or two illuminants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    cct: [f64; 2],
    xyz_to_camera: [Mat3; 2],
}

impl Calibration {
    /// Two calibrations: `camera_to_xyz` matrices measured under illuminants of the given
    /// correlated colour temperatures (kelvin, distinct, 1000..=25000).
    pub fn new(cct: [f64; 2], camera_to_xyz: [Mat3; 2]) -> Result<Self, IspError> {
        let ok = cct.iter().all(|t| (1000.0..=25000.0).contains(t)) && cct[0] != cct[1];
        if !ok {
            return Err(IspError::InvalidParameter {
                name: "calibration cct",
                allowed: "two distinct temperatures in 1000..=25000 K",
            });
        }
        Ok(Self {
            cct,
            xyz_to_camera: [
                colour::mat3_inverse(&camera_to_xyz[0])?,
                colour::mat3_inverse(&camera_to_xyz[1])?,
            ],
        })
    }

    /// One calibration, used at every temperature.
    pub fn single(cct: f64, camera_to_xyz: Mat3) -> Result<Self, IspError> {
        if !(1000.0..=25000.0).contains(&cct) {
            return Err(IspError::InvalidParameter {
                name: "calibration cct",
                allowed: "1000..=25000 K",
            });
        }
        let m = colour::mat3_inverse(&camera_to_xyz)?;
        Ok(Self {
            cct: [cct, cct + 1.0],
            xyz_to_camera: [m, m],
        })
    }

    /// The weight of the first calibration at `cct`: linear in inverse CCT, clamped to `[0, 1]`.
    pub fn weight(&self, cct: f64) -> f64 {
        let (a, b) = (1.0 / self.cct[0], 1.0 / self.cct[1]);
        ((1.0 / cct - b) / (a - b)).clamp(0.0, 1.0)
    }

    /// The camera-to-XYZ matrix at `cct` (kelvin, positive).
    pub fn camera_to_xyz(&self, cct: f64) -> Result<Mat3, IspError> {
        if !(cct.is_finite() && cct > 0.0) {
            return Err(IspError::InvalidParameter {
                name: "cct",
                allowed: "finite and positive",
            });
        }
        let w = self.weight(cct);
        let [m1, m2] = &self.xyz_to_camera;
        let blend: Mat3 =
            core::array::from_fn(|i| core::array::from_fn(|j| w * m1[i][j] + (1.0 - w) * m2[i][j]));
        colour::mat3_inverse(&blend)
    }

    /// The pipeline CCM for white-balanced data at `cct` with the `gains` the WB stage applied;
    /// see the module docs.
    pub fn ccm(&self, cct: f64, gains: [f32; 3]) -> Result<[[f32; 3]; 3], IspError> {
        crate::wb::validate_gains(gains)?;
        if gains.iter().any(|g| *g <= 0.0) {
            return Err(IspError::InvalidParameter {
                name: "white balance gains",
                allowed: "positive",
            });
        }
        let to_xyz = self.camera_to_xyz(cct)?;
        let unbalance: Mat3 = core::array::from_fn(|i| {
            core::array::from_fn(|j| if i == j { 1.0 / gains[i] as f64 } else { 0.0 })
        });
        let camera = colour::mat3_mul(&to_xyz, &unbalance);
        let white = colour::mat3_mul_vec(&camera, [1.0; 3]);
        let d65 = colour::xy_to_xyz(colour::D65_XY)?.map(|v| v * white[1]);
        let adapt = colour::bradford_adaptation(white, d65)?;
        let m = colour::mat3_mul(
            &colour::XYZ_TO_LINEAR_SRGB,
            &colour::mat3_mul(&adapt, &camera),
        );
        let y = white[1];
        if !(y.is_finite() && y > 0.0) {
            return Err(IspError::InvalidParameter {
                name: "calibration",
                allowed: "a neutral with positive luminance",
            });
        }
        let ccm = m.map(|row| row.map(|c| (c / y) as f32));
        validate(&ccm)?;
        Ok(ccm)
    }

    /// The correlated colour temperature (kelvin) of a camera neutral: the illuminant's colour
    /// in camera RGB, as AWB estimates it or as a DNG's AsShotNeutral states it. The
    /// camera-to-XYZ matrix depends on the temperature, so this iterates three times from
    /// 5000 K (McCamy's CCT of the neutral through the matrix at the last estimate).
    pub fn cct_of_neutral(&self, neutral: [f32; 3]) -> Result<f64, IspError> {
        let mut cct = 5000.0;
        for _ in 0..3 {
            let m = self.camera_to_xyz(cct)?;
            cct = crate::wb::cct_of_neutral(neutral, &m)?;
        }
        Ok(cct)
    }

    /// The colour matrix that follows the white balance: white-balance `gains` -> their neutral
    /// (`1 / gains`) -> its CCT ([`Self::cct_of_neutral`]) -> the calibration interpolated there
    /// ([`Self::ccm`]). The one place that choice is made, as libcamera's CCM algorithm does
    /// from its AWB result.
    ///
    /// ```
    /// use isp_core::ccm::Calibration;
    /// use isp_core::colour::LINEAR_SRGB_TO_XYZ;
    /// let cal = Calibration::single(6504.0, LINEAR_SRGB_TO_XYZ).unwrap();
    /// let chosen = cal.ccm_for_white_balance([1.0, 1.0, 1.0]).unwrap();
    /// assert!((chosen.cct_k - 6504.0).abs() < 50.0); // a neutral camera's white is D65
    /// ```
    pub fn ccm_for_white_balance(&self, gains: [f32; 3]) -> Result<ChosenCcm, IspError> {
        crate::wb::validate_gains(gains)?;
        let neutral = gains.map(|g| 1.0 / g);
        let cct_k = self.cct_of_neutral(neutral)?;
        let ccm = self.ccm(cct_k, gains)?;
        Ok(ChosenCcm { cct_k, ccm })
    }

    /// White-balance gains (green 1) that make `preset`'s illuminant neutral for this camera.
    pub fn preset_gains(&self, preset: WbPreset) -> Result<[f32; 3], IspError> {
        let xy = preset.xy()?;
        let cct = colour::xy_to_cct_mccamy(xy)?;
        let to_camera = colour::mat3_inverse(&self.camera_to_xyz(cct)?)?;
        let neutral = colour::mat3_mul_vec(&to_camera, colour::xy_to_xyz(xy)?);
        if !neutral.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(IspError::InvalidParameter {
                name: "calibration",
                allowed: "a positive camera response to the preset's illuminant",
            });
        }
        let gains = [neutral[1] / neutral[0], 1.0, neutral[1] / neutral[2]].map(|g| g as f32);
        crate::wb::validate_gains(gains)?;
        Ok(gains)
    }
}
