//! The sRGB transfer functions of IEC 61966-2-1, exact, in `f32`.
//!
//! Encoding (OETF, linear -> signal): `12.92 x` for `x <= 0.0031308`, else
//! `1.055 x^(1/2.4) - 0.055`. Decoding (EOTF) inverts it with the threshold `0.04045`.
//! Inputs outside `[0, 1]` are clamped; NaN maps to 0, so the output is always in `[0, 1]`.

use crate::math;

/// Linear value above which the power segment applies.
pub const LINEAR_THRESHOLD: f32 = 0.003_130_8;
/// Encoded value above which the power segment applies.
pub const ENCODED_THRESHOLD: f32 = 0.040_45;

fn clamp01(x: f32) -> f32 {
    if x > 0.0 {
        x.min(1.0)
    } else {
        0.0 // also NaN
    }
}

/// Linear light in `[0, 1]` to the sRGB signal in `[0, 1]`.
pub fn encode(linear: f32) -> f32 {
    let x = clamp01(linear);
    if x <= LINEAR_THRESHOLD {
        12.92 * x
    } else {
        clamp01(1.055 * math::powf(x, 1.0 / 2.4) - 0.055)
    }
}

/// The sRGB signal in `[0, 1]` to linear light in `[0, 1]`.
pub fn decode(encoded: f32) -> f32 {
    let v = clamp01(encoded);
    if v <= ENCODED_THRESHOLD {
        v / 12.92
    } else {
        clamp01(math::powf((v + 0.055) / 1.055, 2.4))
    }
}

/// Entries of [`EncodeLut`]'s direct table for the darkest inputs.
const LOW_ENTRIES: usize = 1024;
/// Entries of [`EncodeLut`]'s interpolated table: one every 16 input steps, plus the end.
const HIGH_ENTRIES: usize = 65536 / 16 + 1;

/// The sRGB encoding in fixed point: linear `u16` (65535 is 1.0) to 8- or 16-bit sRGB.
///
/// Two tables, filled once from the exact curve ([`encode`]) and stored with 8 fractional
/// bits: inputs below 1024 (where the curve bends hardest) read a direct table, the rest
/// interpolate linearly between entries 16 input steps apart. The interpolated value is within
/// 0.5 output LSB of the exact curve at either depth (a test sweeps every input), and the
/// output is that value rounded. Size: 5121 `u32`, 20 KiB.
#[derive(Clone)]
pub struct EncodeLut {
    low: [u32; LOW_ENTRIES],
    high: [u32; HIGH_ENTRIES],
    max: u32,
}

impl core::fmt::Debug for EncodeLut {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("EncodeLut").field("max", &self.max).finish()
    }
}

impl EncodeLut {
    /// The table for `out_bits`-bit output (8 or 16).
    pub fn new(out_bits: u8) -> Result<Self, crate::IspError> {
        let max = match out_bits {
            8 => 255u32,
            16 => 65535u32,
            _ => {
                return Err(crate::IspError::InvalidParameter {
                    name: "out_bits",
                    allowed: "8 or 16",
                })
            }
        };
        let exact = |v: f64| -> u32 {
            // f64 for the table so its entries carry no f32 error of their own.
            let x = (v / 65535.0).clamp(0.0, 1.0);
            let e = if x <= LINEAR_THRESHOLD as f64 {
                12.92 * x
            } else {
                1.055 * libm::pow(x, 1.0 / 2.4) - 0.055
            };
            (e.clamp(0.0, 1.0) * max as f64 * 256.0 + 0.5) as u32
        };
        let mut low = [0u32; LOW_ENTRIES];
        for (i, v) in low.iter_mut().enumerate() {
            *v = exact(i as f64);
        }
        let mut high = [0u32; HIGH_ENTRIES];
        for (i, v) in high.iter_mut().enumerate() {
            *v = exact((16 * i) as f64);
        }
        Ok(Self { low, high, max })
    }

    /// Largest output value (255 or 65535).
    pub fn max(&self) -> u32 {
        self.max
    }

    /// The encoded value with 8 fractional bits.
    #[inline]
    pub fn lookup_q8(&self, linear: u16) -> u32 {
        let v = linear as usize;
        if v < LOW_ENTRIES {
            self.low[v]
        } else {
            let (i, f) = (v >> 4, (v & 15) as u32);
            (self.high[i] * (16 - f) + self.high[i + 1] * f + 8) >> 4
        }
    }

    /// The encoded value, rounded to the output depth.
    #[inline]
    pub fn lookup(&self, linear: u16) -> u32 {
        ((self.lookup_q8(linear) + 128) >> 8).min(self.max)
    }
}
