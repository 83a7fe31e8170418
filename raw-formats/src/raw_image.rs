//! [`RawImage`]: the one owned raw frame of the host side. The sensor model produces it, the
//! DNG writer and reader and the PNG/PGM mosaic reader hold it, and [`RawImage::frame`] lends
//! it to isp-core as the checked borrowed view [`RawFrame`] (or [`LinearFrame`] for a linear,
//! already demosaiced frame).

use isp_core::frame::{LinearFrame, RawFrame};
use isp_core::pipeline::Input;
use isp_core::CfaPattern;

use crate::error::{FormatError, Result};

/// A raw frame: a CFA mosaic (one `u16` sample per pixel) or a linear, already demosaiced
/// frame (three, R G B, as a DNG's LinearRaw), holding `bits`-bit data, with its levels.
///
/// ```
/// use raw_formats::RawImage;
/// use isp_core::CfaPattern;
/// let raw = RawImage::new(4, 2, CfaPattern::Rggb, 12, [64; 4], 4095, vec![100; 8]).unwrap();
/// let frame = raw.frame().unwrap();
/// assert_eq!(frame.black_at(1, 1), 64);
/// assert!(RawImage::new(4, 2, CfaPattern::Rggb, 12, [64; 4], 4095, vec![100; 7]).is_err());
/// let linear = RawImage::linear_rgb(4, 2, 12, [64, 60, 62], 4095, vec![100; 24]).unwrap();
/// assert_eq!(linear.linear_frame().unwrap().black_level(), [64, 60, 62]);
/// assert!(linear.frame().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// CFA pattern by the top-left 2x2 block (unused for a linear frame).
    pub pattern: CfaPattern,
    /// Samples per pixel: 1 for a CFA mosaic, 3 for linear R, G, B.
    pub samples_per_pixel: u8,
    /// Significant bits per sample, 8..=16.
    pub bits: u8,
    /// Black level per 2x2 CFA position, row by row; for a linear frame per channel R, G, B
    /// (the fourth unused, kept equal to green).
    pub black_level: [u16; 4],
    /// White level (the largest meaningful code).
    pub white_level: u16,
    /// `width * height * samples_per_pixel` samples, row-major, a pixel's samples together.
    pub samples: Vec<u16>,
}

impl RawImage {
    /// A checked raw image: sizes agree, `bits` in 8..=16, white within `bits`, black below
    /// white.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: usize,
        height: usize,
        pattern: CfaPattern,
        bits: u8,
        black_level: [u16; 4],
        white_level: u16,
        samples: Vec<u16>,
    ) -> Result<Self> {
        let raw = Self {
            width,
            height,
            pattern,
            samples_per_pixel: 1,
            bits,
            black_level,
            white_level,
            samples,
        };
        raw.check()?;
        Ok(raw)
    }

    /// A checked linear frame (already demosaiced): `width * height * 3` samples, R G B per
    /// pixel, with each channel's black level.
    pub fn linear_rgb(
        width: usize,
        height: usize,
        bits: u8,
        black_level: [u16; 3],
        white_level: u16,
        samples: Vec<u16>,
    ) -> Result<Self> {
        let [r, g, b] = black_level;
        let raw = Self {
            width,
            height,
            pattern: CfaPattern::Rggb,
            samples_per_pixel: 3,
            bits,
            black_level: [r, g, b, g],
            white_level,
            samples,
        };
        raw.check()?;
        Ok(raw)
    }

    /// Whether this is a linear, already demosaiced frame.
    pub fn is_linear(&self) -> bool {
        self.samples_per_pixel == 3
    }

    /// Checks the fields against each other (the public fields may have been edited).
    pub fn check(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 {
            return Err(FormatError::OutOfRange {
                field: "raw image size",
                value: format!("{} x {}", self.width, self.height),
                allowed: "at least 1 x 1".into(),
            });
        }
        if !matches!(self.samples_per_pixel, 1 | 3) {
            return Err(FormatError::OutOfRange {
                field: "samples per pixel",
                value: self.samples_per_pixel.to_string(),
                allowed: "1 (a CFA mosaic) or 3 (linear RGB)".into(),
            });
        }
        let pixels = self
            .width
            .saturating_mul(self.height)
            .saturating_mul(usize::from(self.samples_per_pixel));
        if self.samples.len() != pixels {
            return Err(FormatError::SizeMismatch {
                what: "raw samples",
                found: self.samples.len(),
                expected: pixels,
            });
        }
        if !(8..=16).contains(&self.bits) {
            return Err(FormatError::OutOfRange {
                field: "raw bit depth",
                value: self.bits.to_string(),
                allowed: "8..=16".into(),
            });
        }
        if self.white_level == 0 || u32::from(self.white_level) > self.max_code() as u32 {
            return Err(FormatError::OutOfRange {
                field: "white level",
                value: self.white_level.to_string(),
                allowed: format!("1..={}", self.max_code()),
            });
        }
        if self.black_level.iter().any(|b| *b >= self.white_level) {
            return Err(FormatError::BlackNotBelowWhite {
                black: self.black_level,
                white: self.white_level,
            });
        }
        Ok(())
    }

    /// The largest code `bits` bits hold.
    pub fn max_code(&self) -> u16 {
        ((1u32 << self.bits.clamp(1, 16)) - 1) as u16
    }

    /// The borrowed view isp-core runs on: the mosaic, or the linear frame.
    pub fn input(&self) -> std::result::Result<Input<'_>, isp_core::IspError> {
        if self.is_linear() {
            self.linear_frame().map(Input::Linear)
        } else {
            self.frame().map(Input::Mosaic)
        }
    }

    /// The linear frame as isp-core's view; an error for a mosaic.
    pub fn linear_frame(&self) -> std::result::Result<LinearFrame<'_>, isp_core::IspError> {
        if !self.is_linear() {
            return Err(isp_core::IspError::InvalidParameter {
                name: "raw image",
                allowed: "a linear (3 samples per pixel) frame",
            });
        }
        let [r, g, b, _] = self.black_level;
        LinearFrame::new(
            &self.samples,
            self.width,
            self.height,
            3 * self.width,
            self.bits,
            [r, g, b],
            [self.white_level; 3],
        )
    }

    /// The mosaic as isp-core's view; an error for a linear frame.
    pub fn frame(&self) -> std::result::Result<RawFrame<'_>, isp_core::IspError> {
        if self.is_linear() {
            return Err(isp_core::IspError::InvalidParameter {
                name: "raw image",
                allowed: "a CFA mosaic, not a linear (already demosaiced) frame",
            });
        }
        RawFrame::new(
            &self.samples,
            self.width,
            self.height,
            self.width,
            self.bits,
            self.pattern,
            self.black_level,
            self.white_level,
        )
    }
}
