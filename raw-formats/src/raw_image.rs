//! [`RawImage`]: the one owned raw frame of the host side. The sensor model produces it, the
//! DNG writer and reader and the PNG/PGM mosaic reader hold it, and [`RawImage::frame`] lends
//! it to isp-core as the checked borrowed view [`RawFrame`].

use isp_core::frame::RawFrame;
use isp_core::CfaPattern;

use crate::error::{FormatError, Result};

/// A raw CFA frame: one `u16` sample per pixel holding `bits`-bit data, with its pattern and
/// levels.
///
/// ```
/// use raw_formats::RawImage;
/// use isp_core::CfaPattern;
/// let raw = RawImage::new(4, 2, CfaPattern::Rggb, 12, [64; 4], 4095, vec![100; 8]).unwrap();
/// let frame = raw.frame().unwrap();
/// assert_eq!(frame.black_at(1, 1), 64);
/// assert!(RawImage::new(4, 2, CfaPattern::Rggb, 12, [64; 4], 4095, vec![100; 7]).is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// CFA pattern by the top-left 2x2 block.
    pub pattern: CfaPattern,
    /// Significant bits per sample, 8..=16.
    pub bits: u8,
    /// Black level per 2x2 CFA position, row by row.
    pub black_level: [u16; 4],
    /// White level (the largest meaningful code).
    pub white_level: u16,
    /// `width * height` samples, row-major.
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
            bits,
            black_level,
            white_level,
            samples,
        };
        raw.check()?;
        Ok(raw)
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
        let pixels = self.width.saturating_mul(self.height);
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

    /// The borrowed view isp-core runs on.
    pub fn frame(&self) -> std::result::Result<RawFrame<'_>, isp_core::IspError> {
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
