//! White balance: gains per CFA colour, presets from a camera's calibration, and automatic
//! white balance (AWB) from frame statistics.
//!
//! The gains multiply the mosaic before demosaicing (in the pipeline, after the ISO gain), and
//! each product is clipped at 1, the white point, so a clipped highlight stays neutral: all
//! three channels end at 1. Gains are in RGB order, normalised so green is 1, in `[0, 16)`
//! (the fixed path holds them in unsigned Q16).
//!
//! AWB is control code, as in a real ISP's statistics block plus its CPU-side algorithm: it runs
//! in `f32`/`f64` over 2x2 superpixels of the black-subtracted, normalised raw frame (each block
//! gives one R, one B and the mean of its two Gs; a trailing odd row or column is left out), and
//! leaves out blocks with any sample at or above 98% of white, whose colour the clipping has
//! already lost. The methods:
//! - **grey world**: the scene averages to grey, so the gains are `mean(G) / mean(c)`;
//! - **white patch** (max-RGB with a percentile): the `percentile`-th value of each channel is
//!   white; a percentile below 100 keeps a few hot pixels from deciding;
//! - **shades of grey** (Finlayson and Trezzi 2004): the Minkowski `p`-mean `(mean c^p)^(1/p)`
//!   instead of the mean (p = 1 is grey world, large p tends to max-RGB);
//! - **grey edge** (van de Weijer, Gevers and Gijsenij 2007), first order, no pre-smoothing:
//!   the Minkowski `p`-mean of the gradient magnitude `|c(i+1, j) - c(i, j)| + |c(i, j+1) - c(i, j)|`
//!   over superpixels.
//!
//! On a linear frame (already demosaiced, [`estimate_linear`]) each pixel is one superpixel.
//!
//! Each returns the gains, the camera's neutral (their reciprocal) and the correlated colour
//! temperature of that neutral, through the caller's camera-to-XYZ matrix and McCamy's formula.

use crate::colour::{self, Mat3};
use crate::frame::{LinearFrame, RawFrame};
use crate::{math, IspError};

/// Largest white-balance gain (exclusive), the range of unsigned Q4.10 in firmware ISPs (PiSP).
pub const MAX_GAIN: f32 = 16.0;
/// Samples at or above this fraction of white mark a block as clipped for AWB.
pub const CLIP_FRACTION: f32 = 0.98;
/// Histogram bins of the white-patch method.
const BINS: usize = 1024;

/// Checks a gain triple.
pub fn validate_gains(gains: [f32; 3]) -> Result<(), IspError> {
    if gains.iter().all(|g| (0.0..MAX_GAIN).contains(g)) {
        Ok(())
    } else {
        Err(IspError::InvalidParameter {
            name: "white balance gains",
            allowed: "each in [0, 16)",
        })
    }
}

/// An automatic white balance method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AwbMethod {
    /// Grey world.
    GreyWorld,
    /// Max-RGB at a percentile in `(0, 100]`.
    WhitePatch {
        /// The percentile taken as white, e.g. 99.
        percentile: f32,
    },
    /// Minkowski p-mean, `p` in `[1, 16]`.
    ShadesOfGrey {
        /// The norm, e.g. 6.
        p: f32,
    },
    /// First-order grey edge with a Minkowski p-mean, `p` in `[1, 16]`.
    GreyEdge {
        /// The norm, e.g. 6.
        p: f32,
    },
}

impl AwbMethod {
    /// The method with its usual parameter from a name: `grey-world`, `white-patch` (99th
    /// percentile), `shades-of-grey` (p = 6) or `grey-edge` (p = 6).
    pub fn from_name(name: &str) -> Result<Self, IspError> {
        let is = |a: &str| name.eq_ignore_ascii_case(a);
        match () {
            _ if is("grey-world") || is("gray-world") => Ok(Self::GreyWorld),
            _ if is("white-patch") => Ok(Self::WhitePatch { percentile: 99.0 }),
            _ if is("shades-of-grey") || is("shades-of-gray") => Ok(Self::ShadesOfGrey { p: 6.0 }),
            _ if is("grey-edge") || is("gray-edge") => Ok(Self::GreyEdge { p: 6.0 }),
            _ => Err(IspError::InvalidParameter {
                name: "AWB method",
                allowed: "one of grey-world, white-patch, shades-of-grey, grey-edge",
            }),
        }
    }

    fn validate(&self) -> Result<(), IspError> {
        let ok = match *self {
            Self::GreyWorld => true,
            Self::WhitePatch { percentile } => percentile > 0.0 && percentile <= 100.0,
            Self::ShadesOfGrey { p } | Self::GreyEdge { p } => (1.0..=16.0).contains(&p),
        };
        if ok {
            Ok(())
        } else {
            Err(IspError::InvalidParameter {
                name: "AWB parameter",
                allowed: "percentile in (0, 100], p in [1, 16]",
            })
        }
    }
}

/// What AWB found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AwbEstimate {
    /// Gains, RGB, green 1.
    pub gains: [f32; 3],
    /// The illuminant's colour in camera RGB (the gains' reciprocals), green 1.
    pub neutral: [f32; 3],
    /// Correlated colour temperature of the neutral, kelvin (McCamy 1992).
    pub cct_k: f64,
}

/// One superpixel: black-subtracted, normalised RGB, or `None` if clipped.
fn superpixel(raw: &RawFrame<'_>, bx: usize, by: usize) -> Option<[f32; 3]> {
    let m = raw.mosaic();
    let range = |x: usize, y: usize| (raw.white_level() - raw.black_at(x, y)) as f32;
    let mut rgb = [0.0f32; 3];
    let mut clipped = false;
    for dy in 0..2 {
        let row = m.row(2 * by + dy);
        for dx in 0..2 {
            let (x, y) = (2 * bx + dx, 2 * by + dy);
            let v = (row[x].saturating_sub(raw.black_at(x, y))) as f32 / range(x, y);
            clipped |= v >= CLIP_FRACTION;
            let c = m.pattern().colour_at(x, y).index();
            rgb[c] += if c == 1 { 0.5 * v.min(1.0) } else { v.min(1.0) };
        }
    }
    (!clipped).then_some(rgb)
}

fn minkowski(sum: [f64; 3], n: f64, p: f32) -> [f64; 3] {
    sum.map(|s| math::pow(s / n, 1.0 / p as f64))
}

/// Estimates the white balance of `raw` with `method`; `camera_to_xyz` converts the neutral
/// to XYZ for the colour temperature ([`colour::LINEAR_SRGB_TO_XYZ`] when camera RGB is
/// linear sRGB, as in a synthetic frame).
pub fn estimate(
    raw: &RawFrame<'_>,
    method: AwbMethod,
    camera_to_xyz: &Mat3,
) -> Result<AwbEstimate, IspError> {
    let (bw, bh) = (raw.mosaic().width() / 2, raw.mosaic().height() / 2);
    if bw == 0 || bh == 0 {
        return Err(IspError::InvalidParameter {
            name: "frame",
            allowed: "at least 2x2 pixels for AWB",
        });
    }
    estimate_over(
        bw,
        bh,
        |bx, by| superpixel(raw, bx, by),
        method,
        camera_to_xyz,
    )
}

/// [`estimate`] for a linear frame (already demosaiced): each pixel is a superpixel, left out
/// if any channel is at or above 98% of its white.
///
/// ```
/// use isp_core::colour::LINEAR_SRGB_TO_XYZ;
/// use isp_core::frame::LinearFrame;
/// use isp_core::wb::{estimate_linear, AwbMethod};
/// // A grey scene under a light that doubles red and halves blue, and one clipped pixel.
/// let data = [800u16, 400, 200, 400, 200, 100, 4095, 4095, 4095];
/// let frame = LinearFrame::new(&data, 3, 1, 9, 12, [0; 3], [4095; 3]).unwrap();
/// let awb = estimate_linear(&frame, AwbMethod::GreyWorld, &LINEAR_SRGB_TO_XYZ).unwrap();
/// assert!((awb.gains[0] - 0.5).abs() < 1e-6 && (awb.gains[2] - 2.0).abs() < 1e-6);
/// ```
pub fn estimate_linear(
    frame: &LinearFrame<'_>,
    method: AwbMethod,
    camera_to_xyz: &Mat3,
) -> Result<AwbEstimate, IspError> {
    let (black, white) = (frame.black_level(), frame.white_level());
    let pixel = |x: usize, y: usize| {
        let p = frame.pixel(x, y)?;
        let rgb: [f32; 3] = core::array::from_fn(|c| {
            p[c].saturating_sub(black[c]) as f32 / (white[c] - black[c]) as f32
        });
        rgb.iter()
            .all(|v| *v < CLIP_FRACTION)
            .then(|| rgb.map(|v| v.min(1.0)))
    };
    estimate_over(frame.width(), frame.height(), pixel, method, camera_to_xyz)
}

/// The statistics of `method` over a `bw` x `bh` grid of superpixels (`None` where clipped).
fn estimate_over(
    bw: usize,
    bh: usize,
    superpixel: impl Fn(usize, usize) -> Option<[f32; 3]>,
    method: AwbMethod,
    camera_to_xyz: &Mat3,
) -> Result<AwbEstimate, IspError> {
    method.validate()?;
    let mut sum = [0.0f64; 3];
    let mut n = 0.0f64;
    let stat: [f64; 3] = match method {
        AwbMethod::GreyWorld | AwbMethod::ShadesOfGrey { .. } => {
            let p = match method {
                AwbMethod::ShadesOfGrey { p } => p,
                _ => 1.0,
            };
            for by in 0..bh {
                for bx in 0..bw {
                    if let Some(rgb) = superpixel(bx, by) {
                        for c in 0..3 {
                            sum[c] += math::pow(rgb[c] as f64, p as f64);
                        }
                        n += 1.0;
                    }
                }
            }
            minkowski(sum, n, p)
        }
        AwbMethod::GreyEdge { p } => {
            for by in 0..bh.saturating_sub(1) {
                for bx in 0..bw.saturating_sub(1) {
                    let (Some(a), Some(r), Some(d)) = (
                        superpixel(bx, by),
                        superpixel(bx + 1, by),
                        superpixel(bx, by + 1),
                    ) else {
                        continue;
                    };
                    for c in 0..3 {
                        let g = (r[c] - a[c]).abs() + (d[c] - a[c]).abs();
                        sum[c] += math::pow(g as f64, p as f64);
                    }
                    n += 1.0;
                }
            }
            minkowski(sum, n, p)
        }
        AwbMethod::WhitePatch { percentile } => {
            let mut hist = [[0u32; BINS]; 3];
            for by in 0..bh {
                for bx in 0..bw {
                    if let Some(rgb) = superpixel(bx, by) {
                        for c in 0..3 {
                            let bin = ((rgb[c] * BINS as f32) as usize).min(BINS - 1);
                            hist[c][bin] += 1;
                        }
                        n += 1.0;
                    }
                }
            }
            let rank = libm::ceil(percentile as f64 / 100.0 * n).max(1.0) as u64;
            hist.map(|h| {
                let mut seen = 0u64;
                for (i, count) in h.iter().enumerate() {
                    seen += *count as u64;
                    if seen >= rank {
                        return (i as f64 + 0.5) / BINS as f64;
                    }
                }
                1.0
            })
        }
    };
    if n == 0.0
        || stat
            .iter()
            .any(|s| s.is_nan() || *s <= 1e-9 || !s.is_finite())
    {
        return Err(IspError::InvalidParameter {
            name: "frame",
            allowed: "unclipped, non-black content in every channel for AWB",
        });
    }
    let gains = [(stat[1] / stat[0]) as f32, 1.0, (stat[1] / stat[2]) as f32]
        .map(|g| g.clamp(1.0 / 64.0, 15.99));
    let neutral = gains.map(|g| 1.0 / g);
    let cct_k = cct_of_neutral(neutral, camera_to_xyz)?;
    Ok(AwbEstimate {
        gains,
        neutral,
        cct_k,
    })
}

/// Correlated colour temperature (McCamy 1992) of a camera neutral.
pub fn cct_of_neutral(neutral: [f32; 3], camera_to_xyz: &Mat3) -> Result<f64, IspError> {
    let xyz = colour::mat3_mul_vec(camera_to_xyz, neutral.map(|v| v as f64));
    colour::xy_to_cct_mccamy(colour::xyz_to_xy(xyz)?)
}

/// White-balance presets for common illuminants.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WbPreset {
    /// Direct sunlight, D55 (CIE daylight locus at 5503 K).
    Daylight,
    /// Overcast sky, D65.
    Cloudy,
    /// Open shade, D75.
    Shade,
    /// Incandescent, CIE illuminant A (2856 K).
    Tungsten,
    /// Cool white fluorescent, CIE F2 (about 4230 K).
    Fluorescent,
    /// Xenon flash, the daylight locus at 5800 K.
    Flash,
}

impl WbPreset {
    /// All presets.
    pub const ALL: [WbPreset; 6] = [
        Self::Daylight,
        Self::Cloudy,
        Self::Shade,
        Self::Tungsten,
        Self::Fluorescent,
        Self::Flash,
    ];

    /// The preset's name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Daylight => "daylight",
            Self::Cloudy => "cloudy",
            Self::Shade => "shade",
            Self::Tungsten => "tungsten",
            Self::Fluorescent => "fluorescent",
            Self::Flash => "flash",
        }
    }

    /// CIE 1931 chromaticity of the illuminant. A and F2 from CIE 15:2004 table T.1 / T.8;
    /// the daylight ones from the CIE daylight locus.
    pub fn xy(self) -> Result<[f64; 2], IspError> {
        match self {
            // CCTs of D55/D65/D75 are stated on the 1968 scale, 1.4388/1.438 times the nominal.
            Self::Daylight => colour::cct_to_xy_daylight(5500.0 * 1.4388 / 1.438),
            Self::Cloudy => colour::cct_to_xy_daylight(6500.0 * 1.4388 / 1.438),
            Self::Shade => colour::cct_to_xy_daylight(7500.0 * 1.4388 / 1.438),
            Self::Tungsten => Ok([0.44757, 0.40745]),
            Self::Fluorescent => Ok([0.37208, 0.37529]),
            Self::Flash => colour::cct_to_xy_daylight(5800.0),
        }
    }
}

impl core::str::FromStr for WbPreset {
    type Err = IspError;

    fn from_str(s: &str) -> Result<Self, IspError> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or(IspError::InvalidParameter {
                name: "white balance preset",
                allowed: "one of daylight, cloudy, shade, tungsten, fluorescent, flash",
            })
    }
}
