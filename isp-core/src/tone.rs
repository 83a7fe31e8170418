//! Colour manipulation (photo-finishing) on linear sRGB after colour correction: saturation,
//! contrast and a tone curve, and named looks. The default is the identity and costs nothing.
//!
//! Per pixel, in this order:
//! 1. **Saturation** `s`: `c' = Y + s (c - Y)` with `Y = 0.2126 R + 0.7152 G + 0.0722 B`
//!    (Rec. 709 luminance), clamped to `[0, 1]`. `s = 0` is greyscale, `1` the identity.
//! 2. **Contrast** `k` about the pivot `p = 0.18` (mid grey), per channel: `p (x / p)^k` below
//!    the pivot and `1 - (1 - p) ((1 - x) / (1 - p))^k` above. An S-curve for `k > 1`, flatter
//!    for `k < 1`; it keeps 0, `p` and 1 fixed.
//! 3. **Tone curve**: the piecewise-linear curve through the caller's points (at most
//!    [`MAX_CURVE_POINTS`], `x` strictly increasing in `[0, 1]`, `y` in `[0, 1]`), extended
//!    flat beyond the first and last point. No points is the identity.
//!
//! The float path computes exactly this; the fixed-point path reads contrast and curve from one
//! table ([`ToneLut`]) interpolated between entries 16 input steps apart, and saturation as a
//! Q16 matrix.

use crate::math;
use crate::IspError;

/// Most points a tone curve holds.
pub const MAX_CURVE_POINTS: usize = 16;
/// The contrast pivot (mid grey, linear).
pub const PIVOT: f32 = 0.18;
/// Rec. 709 / sRGB luminance weights.
pub const LUMINANCE: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// A piecewise-linear tone curve; see the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ToneCurve {
    points: [[f32; 2]; MAX_CURVE_POINTS],
    len: usize,
}

impl ToneCurve {
    /// The identity (no points).
    pub const IDENTITY: ToneCurve = ToneCurve {
        points: [[0.0; 2]; MAX_CURVE_POINTS],
        len: 0,
    };

    /// A checked curve through `points` (`[x, y]`).
    pub fn new(points: &[[f32; 2]]) -> Result<Self, IspError> {
        let bad = IspError::InvalidParameter {
            name: "tone curve",
            allowed: "at most 16 points, x strictly increasing in [0, 1], y in [0, 1]",
        };
        if points.len() > MAX_CURVE_POINTS {
            return Err(bad);
        }
        let in01 = |v: f32| (0.0..=1.0).contains(&v);
        if points.iter().any(|p| !in01(p[0]) || !in01(p[1]))
            || points.windows(2).any(|w| w[0][0] >= w[1][0])
        {
            return Err(bad);
        }
        let mut curve = Self::IDENTITY;
        curve.points[..points.len()].copy_from_slice(points);
        curve.len = points.len();
        Ok(curve)
    }

    /// The points.
    pub fn points(&self) -> &[[f32; 2]] {
        &self.points[..self.len]
    }

    /// The curve at `x`.
    pub fn eval(&self, x: f32) -> f32 {
        let p = self.points();
        match p {
            [] => x,
            [only] => only[1],
            _ => {
                if x <= p[0][0] {
                    return p[0][1];
                }
                for w in p.windows(2) {
                    if x <= w[1][0] {
                        let t = (x - w[0][0]) / (w[1][0] - w[0][0]);
                        return w[0][1] + t * (w[1][1] - w[0][1]);
                    }
                }
                p[p.len() - 1][1]
            }
        }
    }
}

/// Photo-finishing settings. [`Tone::default`] is the identity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tone {
    /// Saturation, `0..=4`; 1 is the identity.
    pub saturation: f32,
    /// Contrast exponent, `0.25..=4`; 1 is the identity.
    pub contrast: f32,
    /// Tone curve, applied last.
    pub curve: ToneCurve,
}

impl Default for Tone {
    fn default() -> Self {
        Look::Neutral.tone()
    }
}

/// Named looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Look {
    /// The identity.
    #[default]
    Neutral,
    /// More saturation and contrast.
    Vivid,
    /// Less saturation, softer contrast.
    Muted,
    /// Greyscale with a little contrast.
    Mono,
    /// A strong S-curve, saturation kept.
    HighContrast,
}

impl Look {
    /// All looks.
    pub const ALL: [Look; 5] = [
        Self::Neutral,
        Self::Vivid,
        Self::Muted,
        Self::Mono,
        Self::HighContrast,
    ];

    /// The look's name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Neutral => "neutral",
            Self::Vivid => "vivid",
            Self::Muted => "muted",
            Self::Mono => "mono",
            Self::HighContrast => "high-contrast",
        }
    }

    /// The look's settings.
    pub const fn tone(self) -> Tone {
        let (saturation, contrast) = match self {
            Self::Neutral => (1.0, 1.0),
            Self::Vivid => (1.3, 1.15),
            Self::Muted => (0.75, 0.9),
            Self::Mono => (0.0, 1.1),
            Self::HighContrast => (1.0, 1.4),
        };
        Tone {
            saturation,
            contrast,
            curve: ToneCurve::IDENTITY,
        }
    }
}

impl core::str::FromStr for Look {
    type Err = IspError;

    fn from_str(s: &str) -> Result<Self, IspError> {
        Self::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(s))
            .ok_or(IspError::InvalidParameter {
                name: "look",
                allowed: "one of neutral, vivid, muted, mono, high-contrast",
            })
    }
}

impl Tone {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), IspError> {
        if !(0.0..=4.0).contains(&self.saturation) {
            return Err(IspError::InvalidParameter {
                name: "saturation",
                allowed: "0..=4",
            });
        }
        if !(0.25..=4.0).contains(&self.contrast) {
            return Err(IspError::InvalidParameter {
                name: "contrast",
                allowed: "0.25..=4",
            });
        }
        Ok(())
    }

    /// Whether saturation is the identity.
    pub fn saturation_is_identity(&self) -> bool {
        self.saturation == 1.0
    }

    /// Whether contrast and curve are the identity.
    pub fn curve_is_identity(&self) -> bool {
        self.contrast == 1.0 && self.curve.len == 0
    }

    /// Contrast then curve, for one channel value in `[0, 1]`.
    pub fn channel(&self, x: f32) -> f32 {
        let k = self.contrast;
        let c = if k == 1.0 {
            x
        } else if x <= PIVOT {
            PIVOT * math::powf(x / PIVOT, k)
        } else {
            1.0 - (1.0 - PIVOT) * math::powf((1.0 - x) / (1.0 - PIVOT), k)
        };
        self.curve.eval(c).clamp(0.0, 1.0)
    }

    /// Saturation on a linear RGB pixel, clamped to `[0, 1]`.
    pub fn saturate(&self, rgb: [f32; 3]) -> [f32; 3] {
        let s = self.saturation;
        let y = LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2];
        rgb.map(|c| (y + s * (c - y)).clamp(0.0, 1.0))
    }

    /// The whole stage on one pixel (the float reference).
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        let rgb = if self.saturation_is_identity() {
            rgb
        } else {
            self.saturate(rgb)
        };
        if self.curve_is_identity() {
            rgb
        } else {
            rgb.map(|c| self.channel(c))
        }
    }

    /// Saturation as a matrix (row-major), `s I + (1 - s) [Y; Y; Y]`, for the fixed-point
    /// path to quantise.
    pub fn saturation_matrix(&self) -> [[f32; 3]; 3] {
        let s = self.saturation;
        core::array::from_fn(|i| {
            core::array::from_fn(|j| (1.0 - s) * LUMINANCE[j] + if i == j { s } else { 0.0 })
        })
    }
}

/// Entries of each of [`ToneLut`]'s direct tables for the darkest and the brightest inputs,
/// where a contrast below 1 is steepest.
const TONE_LOW: usize = 1024;
/// First input of the bright direct table.
const TONE_HIGH_START: usize = 65536 - TONE_LOW;
/// Entries of [`ToneLut`]'s interpolated table: one every 16 input steps, plus the end.
const TONE_ENTRIES: usize = 65536 / 16 + 1;

/// Contrast and curve as tables for the fixed-point path: linear `u16` (65535 is 1.0) in and
/// out; the lowest and highest 1024 inputs read direct tables, the rest interpolate linearly
/// between entries 16 input steps apart. 6145 `u16`, 12 KiB.
#[derive(Clone)]
pub struct ToneLut {
    low: [u16; TONE_LOW],
    high: [u16; TONE_LOW],
    table: [u16; TONE_ENTRIES],
}

impl core::fmt::Debug for ToneLut {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("ToneLut")
    }
}

impl ToneLut {
    /// The table of `tone`'s contrast and curve.
    pub fn new(tone: &Tone) -> Self {
        let value = |v: usize| (tone.channel((v as f32 / 65535.0).min(1.0)) * 65535.0 + 0.5) as u16;
        let mut low = [0u16; TONE_LOW];
        for (i, v) in low.iter_mut().enumerate() {
            *v = value(i);
        }
        let mut high = [0u16; TONE_LOW];
        for (i, v) in high.iter_mut().enumerate() {
            *v = value(TONE_HIGH_START + i);
        }
        let mut table = [0u16; TONE_ENTRIES];
        for (i, v) in table.iter_mut().enumerate() {
            *v = value(16 * i);
        }
        Self { low, high, table }
    }

    /// One channel through the table.
    #[inline]
    pub fn lookup(&self, x: u16) -> u16 {
        let v = x as usize;
        if v < TONE_LOW {
            return self.low[v];
        }
        if v >= TONE_HIGH_START {
            return self.high[v - TONE_HIGH_START];
        }
        let (i, f) = ((x >> 4) as usize, (x & 15) as u32);
        ((self.table[i] as u32 * (16 - f) + self.table[i + 1] as u32 * f + 8) >> 4) as u16
    }
}
