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
        } else {
            let (base, below) = contrast_base(x);
            contrast_from_power(below, math::powf(base, k))
        };
        self.curve.eval(c).clamp(0.0, 1.0)
    }

    /// [`Tone::channel`] with the contrast's power estimated in `f32` arithmetic alone
    /// (`2^(k log2 b)` by short series, as the fixed path's table is built), so a loop of
    /// it vectorises: the float pipeline's contrast and curve. Within 2e-6 of [`Tone::channel`]
    /// at every input and contrast (tested), a thirtieth of a 16-bit code.
    #[inline(always)]
    pub fn channel_estimated(&self, x: f32) -> f32 {
        let k = self.contrast;
        let c = if k == 1.0 {
            x
        } else {
            contrast_estimated(x, k)
        };
        if self.curve.len == 0 {
            c.clamp(0.0, 1.0)
        } else {
            self.curve.eval(c).clamp(0.0, 1.0)
        }
    }

    /// Saturation on a linear RGB pixel, clamped to `[0, 1]`.
    #[inline(always)]
    pub fn saturate(&self, rgb: [f32; 3]) -> [f32; 3] {
        let s = self.saturation;
        let y = LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2];
        rgb.map(|c| (y + s * (c - y)).clamp(0.0, 1.0))
    }

    /// The whole stage on one pixel (the float reference).
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        self.apply_with(rgb, Self::channel)
    }

    /// [`Tone::apply`] with [`Tone::channel_estimated`]: the float pipeline's tone.
    pub fn apply_estimated(&self, rgb: [f32; 3]) -> [f32; 3] {
        self.apply_with(rgb, Self::channel_estimated)
    }

    /// Saturation, then `channel` per channel, each skipped where it is the identity.
    #[inline(always)]
    fn apply_with(&self, rgb: [f32; 3], channel: impl Fn(&Self, f32) -> f32) -> [f32; 3] {
        let rgb = if self.saturation_is_identity() {
            rgb
        } else {
            self.saturate(rgb)
        };
        if self.curve_is_identity() {
            rgb
        } else {
            rgb.map(|c| channel(self, c))
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

/// The contrast stage at `x` (in `[0, 1]`) with its power estimated (see
/// [`Tone::channel_estimated`]), branch-free so that a loop of it vectorises: without a curve,
/// clamped, it is [`Tone::channel_estimated`].
#[inline(always)]
pub(crate) fn contrast_estimated(x: f32, k: f32) -> f32 {
    let below = x <= PIVOT;
    let base = if below {
        x * (1.0 / PIVOT)
    } else {
        (1.0 - x) * (1.0 / (1.0 - PIVOT))
    };
    let power = math::pow_estimate(base, k).0;
    let low = PIVOT * power;
    let high = 1.0 - (1.0 - PIVOT) * power;
    if below {
        low
    } else {
        high
    }
}

/// The base of the contrast power at `x`, and whether `x` is at or below the pivot.
#[inline]
fn contrast_base(x: f32) -> (f32, bool) {
    if x <= PIVOT {
        (x / PIVOT, true)
    } else {
        ((1.0 - x) / (1.0 - PIVOT), false)
    }
}

/// The contrast stage's value from its power (`base^k`): increasing in the power below the
/// pivot, decreasing above it.
#[inline]
fn contrast_from_power(below: bool, power: f32) -> f32 {
    if below {
        PIVOT * power
    } else {
        1.0 - (1.0 - PIVOT) * power
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
    /// The table of `tone`'s contrast and curve: every entry is the float path's channel
    /// ([`Tone::channel_estimated`], within 2e-6 of [`Tone::channel`]) rounded to `u16`, so
    /// the fixed path's tone is the float path's, and within one code of libm's `powf`
    /// everywhere (tested). On a Cortex-M4, whose FPU has no `f64` and whose libm `powf` costs
    /// about 235 instructions, an entry costs about a third of that: the table took 1.94
    /// million instructions with `powf` for every entry, 0.86 million with `powf` only where a
    /// bracket around the estimate left the rounding open.
    pub fn new(tone: &Tone) -> Self {
        let entry = |v: usize| {
            (tone.channel_estimated((v as f32 / 65535.0).min(1.0)) * 65535.0 + 0.5) as u16
        };
        let low: [u16; TONE_LOW] = core::array::from_fn(entry);
        let high: [u16; TONE_LOW] = core::array::from_fn(|i| entry(TONE_HIGH_START + i));
        // Entries whose input the direct tables already hold are copied from them.
        let table = core::array::from_fn(|i| {
            let input = 16 * i;
            if input < TONE_LOW {
                low[input]
            } else if (TONE_HIGH_START..65536).contains(&input) {
                high[input - TONE_HIGH_START]
            } else {
                entry(input.min(65535))
            }
        });
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

#[cfg(test)]
mod tests {
    use super::{Look, Tone, ToneCurve, ToneLut};

    /// A table with every entry from `channel`, rounded.
    fn table_of(tone: &Tone, channel: impl Fn(&Tone, f32) -> f32) -> ToneLut {
        let mut lut = ToneLut::new(&Tone {
            contrast: 1.0,
            ..*tone
        });
        let value =
            |v: usize| (channel(tone, (v as f32 / 65535.0).min(1.0)) * 65535.0 + 0.5) as u16;
        for (i, e) in lut.low.iter_mut().enumerate() {
            *e = value(i);
        }
        for (i, e) in lut.high.iter_mut().enumerate() {
            *e = value(super::TONE_HIGH_START + i);
        }
        for (i, e) in lut.table.iter_mut().enumerate() {
            *e = value(16 * i);
        }
        lut
    }

    /// The contrasts the tests try: a grid over the whole range, its ends, the looks' values,
    /// and values between grid steps.
    fn contrasts() -> impl Iterator<Item = f32> {
        let grid = (0..=75).map(|i| 0.25 + 0.05 * i as f32);
        let looks = Look::ALL.into_iter().map(|l| l.tone().contrast);
        let odd = [
            0.2500001,
            0.333_333_3,
            1.000_000_1,
            0.999_999_9,
            core::f32::consts::E,
            3.999_999_8,
            4.0,
        ];
        grid.chain(looks).chain(odd)
    }

    /// Every entry of the table is the float path's channel rounded, and within one code of
    /// the entry libm's `powf` gives, at every contrast tried, with and without a curve (a
    /// non-monotone one among them); most entries equal libm's.
    #[test]
    fn table_is_the_estimated_channel_within_a_code_of_libm() {
        let curves = [
            ToneCurve::IDENTITY,
            ToneCurve::new(&[[0.0, 0.1], [0.3, 0.6], [0.6, 0.4], [1.0, 0.9]]).unwrap(),
        ];
        let (mut equal, mut total) = (0usize, 0usize);
        for k in contrasts() {
            for curve in curves {
                let tone = Tone {
                    saturation: 1.0,
                    contrast: k,
                    curve,
                };
                let table = ToneLut::new(&tone);
                let definition = table_of(&tone, Tone::channel_estimated);
                assert_eq!(
                    (table.low, table.high, table.table),
                    (definition.low, definition.high, definition.table),
                    "contrast {k}"
                );
                let libm = table_of(&tone, Tone::channel);
                let pairs = table
                    .low
                    .iter()
                    .chain(&table.high)
                    .chain(&table.table)
                    .zip(libm.low.iter().chain(&libm.high).chain(&libm.table));
                for (a, b) in pairs {
                    assert!(a.abs_diff(*b) <= 1, "contrast {k}: {a} against libm's {b}");
                    equal += usize::from(a == b);
                    total += 1;
                }
            }
        }
        assert!(equal * 100 >= total * 90, "{equal} of {total} equal libm's");
    }

    /// The float path's estimated contrast is the exact one to within 2e-6 at every input
    /// (every 16th `f32` of `[0, 1]`) and contrast tried, with and without a curve.
    #[test]
    fn estimated_channel_is_the_channel() {
        let curve = ToneCurve::new(&[[0.0, 0.05], [0.5, 0.6], [1.0, 0.95]]).unwrap();
        for k in contrasts() {
            for curve in [ToneCurve::IDENTITY, curve] {
                let tone = Tone {
                    saturation: 1.0,
                    contrast: k,
                    curve,
                };
                let mut worst = 0.0f32;
                for bits in (0..=1.0f32.to_bits()).step_by(4099) {
                    let x = f32::from_bits(bits);
                    worst = worst.max((tone.channel_estimated(x) - tone.channel(x)).abs());
                }
                assert!(worst <= 2e-6, "contrast {k}: {worst:e}");
            }
        }
    }
}
