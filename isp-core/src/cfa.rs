use core::str::FromStr;

use crate::IspError;

/// A colour filter of the Bayer mosaic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CfaColour {
    /// Red.
    Red,
    /// Green.
    Green,
    /// Blue.
    Blue,
}

impl CfaColour {
    /// Channel index in RGB order: red 0, green 1, blue 2.
    pub const fn index(self) -> usize {
        match self {
            Self::Red => 0,
            Self::Green => 1,
            Self::Blue => 2,
        }
    }
}

/// Bayer pattern, named by the colours of the top-left 2x2 block read row by row.
///
/// OpenCV names its conversion codes by the second row instead: an RGGB sensor is
/// `COLOR_BayerBG2RGB` ([`CfaPattern::opencv_name`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CfaPattern {
    /// R G / G B.
    Rggb,
    /// B G / G R.
    Bggr,
    /// G R / B G.
    Grbg,
    /// G B / R G.
    Gbrg,
}

impl CfaPattern {
    /// All four patterns.
    pub const ALL: [CfaPattern; 4] = [Self::Rggb, Self::Bggr, Self::Grbg, Self::Gbrg];

    /// Colours of the 2x2 block, row by row.
    pub const fn block(self) -> [CfaColour; 4] {
        use CfaColour::*;
        match self {
            Self::Rggb => [Red, Green, Green, Blue],
            Self::Bggr => [Blue, Green, Green, Red],
            Self::Grbg => [Green, Red, Blue, Green],
            Self::Gbrg => [Green, Blue, Red, Green],
        }
    }

    /// Colour of the filter over pixel `(x, y)`.
    pub const fn colour_at(self, x: usize, y: usize) -> CfaColour {
        self.block()[(y & 1) * 2 + (x & 1)]
    }

    /// The pattern's name, e.g. `"RGGB"`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Rggb => "RGGB",
            Self::Bggr => "BGGR",
            Self::Grbg => "GRBG",
            Self::Gbrg => "GBRG",
        }
    }

    /// OpenCV's name for the Bayer-to-RGB conversion of this pattern (named by the second row).
    pub const fn opencv_name(self) -> &'static str {
        match self {
            Self::Rggb => "COLOR_BayerBG2RGB",
            Self::Bggr => "COLOR_BayerRG2RGB",
            Self::Grbg => "COLOR_BayerGB2RGB",
            Self::Gbrg => "COLOR_BayerGR2RGB",
        }
    }
}

impl FromStr for CfaPattern {
    type Err = IspError;

    /// Parses `RGGB`, `BGGR`, `GRBG` or `GBRG` (any case).
    fn from_str(s: &str) -> Result<Self, IspError> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or(IspError::InvalidParameter {
                name: "pattern",
                allowed: "one of RGGB, BGGR, GRBG, GBRG",
            })
    }
}
