//! The sRGB transfer functions of IEC 61966-2-1, exact, in `f32`.
//!
//! Encoding (OETF, linear -> signal): `12.92 x` for `x <= 0.0031308`, else
//! `1.055 x^(1/2.4) - 0.055`. Decoding (EOTF) inverts it with the threshold `0.04045`.
//! Inputs outside `[0, 1]` are clamped; NaN maps to 0, so the output is always in `[0, 1]`.

use crate::math;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
// The generators run in the build script and the tests; the library reads their statics.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) mod tables;

pub use tables::LINEAR_THRESHOLD;
use tables::{HIGH_ENTRIES, LOW_ENTRIES, RUNS, SEARCH8_TABLES};

// The encoding's tables as `static` arrays, from the build script (tables.rs's functions).
include!(concat!(env!("OUT_DIR"), "/encode_tables.rs"));

/// One plane of a row in halves (its `even` even columns, then its `odd` odd columns) as
/// chunks of `N` samples: the first `odd` even columns, then the odd columns, whole chunks
/// only. The vector encoders' pixel pairs.
#[cfg(target_arch = "x86_64")]
fn chunked_halves<T, const N: usize>(plane: &[T], even: usize, odd: usize) -> [&[[T; N]]; 2] {
    [
        plane[..odd].as_chunks().0,
        plane[even..even + odd].as_chunks().0,
    ]
}

/// Pixel pairs `first..first + out.len() / 6` of a row of planes in halves (see
/// [`chunked_halves`]), each sample through `code`, interleaved into `out`: what the vector
/// encoders write where their vectors do not reach.
#[cfg(target_arch = "x86_64")]
fn encode_pairs<T: Copy>(
    code: impl Fn(T) -> u8,
    planes: [&[T]; 3],
    even: usize,
    first: usize,
    out: &mut [u8],
) {
    let [r, g, b] = planes;
    for (k, px) in out.chunks_exact_mut(6).enumerate() {
        let (e, o) = (first + k, even + first + k);
        px.copy_from_slice(&[
            code(r[e]),
            code(g[e]),
            code(b[e]),
            code(r[o]),
            code(g[o]),
            code(b[o]),
        ]);
    }
}

/// The pairs from `done` to `odd` and, for an odd width, the last column: the rest of a row
/// after a vector encoder's whole chunks. `out` holds the row (`3 (even + odd)` bytes).
#[cfg(target_arch = "x86_64")]
fn encode_rest<T: Copy>(
    code: impl Fn(T) -> u8,
    planes: [&[T]; 3],
    even: usize,
    odd: usize,
    done: usize,
    out: &mut [u8],
) {
    encode_pairs(&code, planes, even, done, &mut out[6 * done..6 * odd]);
    if even > odd {
        let (i, w) = (even - 1, even + odd);
        out[3 * (w - 1)..3 * w].copy_from_slice(&planes.map(|p| code(p[i])));
    }
}

/// Encoded value above which the power segment applies.
pub const ENCODED_THRESHOLD: f32 = 0.040_45;

/// `x` clamped to `[0, 1]`, NaN and -0 as 0: the clamp [`encode`], [`decode`] and
/// [`EncodeThresholds8::code`] apply, and what [`EncodeThresholds8::code_clamped`] takes.
/// Written as two selects so that a loop of it vectorises.
#[inline(always)]
pub fn clamp_unit(x: f32) -> f32 {
    let below_one = if x < 1.0 { x } else { 1.0 };
    if x > 0.0 {
        below_one
    } else {
        0.0
    }
}

/// Linear light in `[0, 1]` to the sRGB signal in `[0, 1]`.
pub fn encode(linear: f32) -> f32 {
    let x = clamp_unit(linear);
    if x <= LINEAR_THRESHOLD {
        12.92 * x
    } else {
        clamp_unit(1.055 * math::powf(x, 1.0 / 2.4) - 0.055)
    }
}

/// [`encode`] with its power estimated in `f32` arithmetic alone (`math`'s
/// `2^(k log2 x)` by short series), so that a loop of it vectorises: the float pipeline's
/// encoding wherever it needs the continuous value (16-bit and `f32` output, sharpening,
/// chroma noise reduction), in place of a `powf` per sample. Within 2.5e-7 of the exact curve
/// (1.9e-7 the largest a test finds sweeping `[0, 1]`), a sixtieth of a 16-bit code.
#[inline(always)]
pub fn encode_estimated(linear: f32) -> f32 {
    let x = clamp_unit(linear);
    let power = math::pow_estimate(x, 1.0 / 2.4).0;
    let curved = clamp_unit(1.055 * power - 0.055);
    if x <= LINEAR_THRESHOLD {
        12.92 * x
    } else {
        curved
    }
}

/// The sRGB signal in `[0, 1]` to linear light in `[0, 1]`.
pub fn decode(encoded: f32) -> f32 {
    let v = clamp_unit(encoded);
    if v <= ENCODED_THRESHOLD {
        v / 12.92
    } else {
        clamp_unit(math::powf((v + 0.055) / 1.055, 2.4))
    }
}

/// The sRGB encoding in fixed point: linear `u16` (65535 is 1.0) to 8- or 16-bit sRGB.
///
/// Two tables, computed from the exact curve ([`encode`], in `f64`) when the library is built
/// (so a pipeline starts without evaluating a power: `static` data, in flash on firmware), with
/// 8 fractional bits: inputs below 1024 (where the curve bends hardest) read a direct table, the rest
/// interpolate linearly between entries 16 input steps apart. The interpolated value is within
/// 0.5 output LSB of the exact curve at either depth (a test sweeps every input), and the
/// output is that value rounded. Size: 5121 `u32`, 20 KiB, shared by every pipeline.
///
/// For 8-bit output [`EncodeLut::lookup`] reads one more table of 4096 `u16` entries instead:
/// per run of 16 inputs, the code at its start and where in the run it steps up by one (the
/// curve rises by under one 8-bit code per 16 inputs, 0.8 at its steepest), folded into one
/// word that the input is added to, so that the code is the sum's high byte: the
/// interpolated table's codes exactly with one load, an add and a shift (a load, a compare
/// and a clamp before: the fixed MHC pipeline went from 6.1 to 4.5 ns per pixel on a Zen 3
/// EPYC, whose AVX2 has no faster way). Beside it, 384 `u16` code thresholds in
/// the order a binary search reads them, for the AVX-512 encoder, which picks them per lane
/// from registers instead of loading per sample.
#[derive(Clone, Copy)]
pub struct EncodeLut {
    low: &'static [u32; LOW_ENTRIES],
    high: &'static [u32; HIGH_ENTRIES],
    /// 8-bit output: for run `i` (inputs `16 i..16 i + 16`), `256 code + 256 - step - 16 i`
    /// (wrapping), where `code` is the code of input `16 i` and `step` the offset in the run
    /// from which the code is one more (16: none). See [`EncodeLut::lookup8`]. (A 16-bit
    /// table carries the 8-bit one's, unused.)
    runs8: &'static [u16; RUNS],
    /// 8-bit output: the code thresholds (the smallest input of each code) in the order a
    /// binary search over the codes reads them, for the vectorised encoding.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    search8: &'static [[u16; 32]; SEARCH8_TABLES],
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
        let (low, high) = match max {
            255 => (&ENCODE8_LOW, &ENCODE8_HIGH),
            _ => (&ENCODE16_LOW, &ENCODE16_HIGH),
        };
        Ok(Self {
            low,
            high,
            runs8: &ENCODE8_RUNS,
            search8: &ENCODE8_SEARCH,
            max,
        })
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
        if self.max == 255 {
            self.lookup8(linear)
        } else {
            self.interpolated(linear)
        }
    }

    /// [`EncodeLut::lookup`] of a table for 8-bit output (a table for 16 bits gives
    /// meaningless codes): the same code without the test of the depth.
    ///
    /// The run's entry plus the input is `256 code + 256 - step + offset` (`offset` the
    /// input's place in the run): its low byte carries into the high byte exactly when
    /// `offset >= step`, so the high byte is the code. It never wraps: a run that starts at
    /// code 255 has no step.
    #[inline(always)]
    pub(crate) fn lookup8(&self, linear: u16) -> u32 {
        let entry = self.runs8[usize::from(linear >> 4)];
        u32::from(entry.wrapping_add(linear) >> 8)
    }

    /// [`EncodeLut::lookup`] of a table for 16-bit output without a branch (both tables
    /// read, one kept), so that a loop over it vectorises; for an 8-bit table it gives what
    /// [`EncodeLut::lookup`] gives for a 16-bit one, not the 8-bit code.
    #[inline(always)]
    pub(crate) fn lookup16(&self, linear: u16) -> u32 {
        let v = usize::from(linear);
        let direct = self.low[v % LOW_ENTRIES];
        // v >> 4 <= 4095, so both entries are within the 4097.
        let (i, f) = (v >> 4, (v & 15) as u32);
        let between = (self.high[i] * (16 - f) + self.high[i + 1] * f + 8) >> 4;
        // A mask, not a select: LLVM turned the select of two loads into a branch, which
        // mispredicts on the dark pixels of a real frame.
        let in_low = 0u32.wrapping_sub(u32::from(v < LOW_ENTRIES));
        let q8 = between ^ ((direct ^ between) & in_low);
        ((q8 + 128) >> 8).min(self.max)
    }

    /// [`EncodeLut::lookup`] from the interpolated tables.
    #[inline]
    fn interpolated(&self, linear: u16) -> u32 {
        ((self.lookup_q8(linear) + 128) >> 8).min(self.max)
    }
}

/// Inputs above which each 8-bit code starts, for the float path: the exact 8-bit encoding
/// `round(255 * encode(x))` ([`encode`], then [`crate::pipeline::OutputSample`]'s rounding)
/// without evaluating a power.
///
/// The code of `x` is the number of thresholds at or below it. Threshold `k` is the smallest
/// `f32` whose exact code is at least `k`, found once by bisection over the bit patterns of
/// `[0, 1]` (non-negative floats order as their bits). That equals the exact encoding wherever
/// the exact encoding is monotone in `x`, which the tests check at every `f32` near every
/// threshold. A table indexed by the top bits of `x` gives the code at the start of its bucket
/// of 2^16 floats, from which at most one threshold follows (the curve rises by at most 0.9
/// codes per bucket), so a lookup is a byte load, a word load and one compare: the 8-bit
/// encoding is the float path's costliest stage after the demosaic, and the step per bucket
/// this saves over buckets of 2^17 took a tenth of its time. Size: 17 KiB.
#[derive(Clone, Copy)]
pub struct EncodeThresholds8 {
    /// The smallest input of code `k` for `k` in `1..=255`, as its bit pattern (bit patterns
    /// order non-negative floats as their values do, so the lookup compares integers);
    /// `threshold_bits[0]` is 0 and `threshold_bits[256]` (infinity) is above every input, so
    /// the lookup's index (at most 256) needs no bounds check.
    threshold_bits: [u32; 257],
    /// The code of the first float of each bucket of 2^16 (`x.to_bits() >> 16`), up to 1.0;
    /// a power of two long, so a masked index needs no bounds check.
    bucket: [u8; BUCKET_SLOTS],
    /// The curve's approximation for the AVX2 encoder ([`avx2`]).
    #[cfg(target_arch = "x86_64")]
    power: avx2::PowerTables,
}

/// Bits below a bucket's index: buckets of 2^16 floats.
const BUCKET_SHIFT: u32 = 16;
/// Buckets that cover `[0, 1]`: `1.0f32.to_bits() >> BUCKET_SHIFT` is the last.
const BUCKETS: usize = (0x3F80_0000 >> BUCKET_SHIFT) + 1;
/// [`BUCKETS`] rounded up to a power of two.
const BUCKET_SLOTS: usize = BUCKETS.next_power_of_two();

impl core::fmt::Debug for EncodeThresholds8 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("EncodeThresholds8").finish_non_exhaustive()
    }
}

impl Default for EncodeThresholds8 {
    fn default() -> Self {
        Self::new()
    }
}

/// The smallest bit pattern in `lo..=hi` that `reaches` (a predicate false then true along
/// the range, true at `hi`), searched from `guess`: a bracket around it grown by doubling
/// steps, then bisection. The same answer as a bisection over the whole range, in about
/// `2 log2(distance from the guess)` evaluations.
fn first_reaching(lo: u32, hi: u32, guess: u32, reaches: impl Fn(u32) -> bool) -> u32 {
    let guess = guess.clamp(lo, hi);
    let (mut a, mut b) = (lo, hi);
    let mut step = 4u32;
    if reaches(guess) {
        b = guess;
        // The answer is at or below b: step down until a pattern does not reach.
        while b - lo > step {
            let c = b - step;
            if reaches(c) {
                b = c;
                step = step.saturating_mul(2);
            } else {
                a = c + 1;
                break;
            }
        }
    } else {
        a = (guess + 1).min(hi);
        // The answer is above the guess: step up until a pattern reaches.
        while hi - a > step {
            let c = a + step;
            if reaches(c) {
                b = c;
                break;
            }
            a = c + 1;
            step = step.saturating_mul(2);
        }
    }
    // The smallest in a..=b that reaches (b does, or is hi).
    while a < b {
        let mid = a + (b - a) / 2;
        if reaches(mid) {
            b = mid;
        } else {
            a = mid + 1;
        }
    }
    a
}

/// The exact 8-bit code of linear `x`: the float path's definition.
#[inline]
pub fn exact_code8(x: f32) -> u8 {
    <u8 as crate::pipeline::OutputSample>::from_encoded(encode(x))
}

impl EncodeThresholds8 {
    /// The thresholds, each searched for over the exact curve from an estimate: the estimated
    /// decoding of the code's lower edge (a vectorisable power estimate, not `powf`), a bracket
    /// grown from it by doubling steps, then bisection inside it. The same thresholds as a
    /// bisection over all of `[0, 1]` (about 30 exact evaluations each, 1.8 million
    /// instructions on a Cortex-M4 for the 255) in about a third of the evaluations.
    pub fn new() -> Self {
        let one = 1.0f32.to_bits();
        let mut thresholds = [0.0f32; 257];
        thresholds[256] = f32::INFINITY;
        let mut lo_bits = 0u32;
        for (k, t) in thresholds.iter_mut().enumerate().take(256).skip(1) {
            let edge = (k as f32 - 0.5) / 255.0;
            let guess = if edge <= ENCODED_THRESHOLD {
                edge / 12.92
            } else {
                math::pow_estimate((edge + 0.055) / 1.055, 2.4).0
            };
            let reaches = |bits: u32| usize::from(exact_code8(f32::from_bits(bits))) >= k;
            lo_bits = first_reaching(lo_bits, one, guess.to_bits(), reaches);
            *t = f32::from_bits(lo_bits);
        }
        let mut bucket = [255u8; BUCKET_SLOTS];
        let mut code = 0usize;
        for (i, b) in bucket.iter_mut().enumerate().take(BUCKETS) {
            let first = f32::from_bits((i as u32) << BUCKET_SHIFT);
            while first >= thresholds[code + 1] {
                code += 1;
            }
            *b = code as u8;
        }
        Self {
            threshold_bits: thresholds.map(f32::to_bits),
            bucket,
            #[cfg(target_arch = "x86_64")]
            power: avx2::PowerTables::new(),
        }
    }

    /// The 8-bit code of linear `x` (clamped to `[0, 1]`, NaN as 0), equal to
    /// [`exact_code8`].
    #[inline(always)]
    pub fn code(&self, x: f32) -> u8 {
        self.code_clamped(clamp_unit(x))
    }

    /// [`EncodeThresholds8::code`] of an `x` already clamped: the same code wherever `x` is
    /// what [`clamp_unit`] returns (a value in `[0, 1]`, never -0 or NaN), so a caller
    /// can clamp a row in a vector loop and look the codes up after. Any other `x` gives some
    /// code, without a panic.
    #[inline(always)]
    pub fn code_clamped(&self, x: f32) -> u8 {
        let bits = x.to_bits();
        let k = usize::from(self.bucket[(bits >> BUCKET_SHIFT) as usize & (BUCKET_SLOTS - 1)]);
        // At most one threshold follows a bucket's start (the table is the same on every
        // build; the tests check it): one step without a branch. (A loop after it, which
        // never ran, let LLVM fold the step into it in some builds, branching on every pixel:
        // 60 % slower.)
        (k + usize::from(bits >= self.threshold_bits[k + 1])) as u8
    }

    /// The smallest linear input of each code `1..=255` (for tests and tables).
    pub fn thresholds(&self) -> [f32; 255] {
        core::array::from_fn(|k| f32::from_bits(self.threshold_bits[k + 1]))
    }
}

#[cfg(test)]
mod tests {
    use super::{
        encode_estimated, exact_code8, first_reaching, tables, EncodeLut, EncodeThresholds8,
        LINEAR_THRESHOLD,
    };

    /// The thresholds searched from estimates are those a bisection over the whole of
    /// `[0, 1]` finds, and the search from any guess finds what the plain bisection does.
    #[test]
    fn thresholds_match_a_whole_range_bisection() {
        let one = 1.0f32.to_bits();
        let table = EncodeThresholds8::new().thresholds();
        let mut lo_bits = 0u32;
        for (k, t) in table.iter().enumerate() {
            let k = k + 1;
            let (mut lo, mut hi) = (lo_bits, one);
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if usize::from(exact_code8(f32::from_bits(mid))) >= k {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            assert_eq!(t.to_bits(), lo, "code {k}");
            lo_bits = lo;
        }
        // Any guess, near or far, below or above, and the range's ends.
        let answer = 1_000_003u32;
        for guess in [
            0,
            1,
            999_000,
            1_000_002,
            answer,
            1_000_004,
            1_100_000,
            u32::MAX,
        ] {
            assert_eq!(first_reaching(0, 2_000_000, guess, |b| b >= answer), answer);
        }
        assert_eq!(first_reaching(5, 9, 0, |_| true), 5);
        assert_eq!(first_reaching(5, 9, 7, |b| b >= 9), 9);
    }

    /// The build script's static tables are the curve's: every entry evaluated again here.
    #[test]
    fn static_tables_are_the_curves() {
        for (bits, max) in [(8, 255), (16, 65535)] {
            let lut = EncodeLut::new(bits).unwrap();
            assert_eq!(*lut.low, tables::low(max), "{bits}-bit direct table");
            assert_eq!(
                *lut.high,
                tables::high(max),
                "{bits}-bit interpolated table"
            );
        }
        let (low, high) = (tables::low(255), tables::high(255));
        let runs8 = tables::runs8(&low, &high);
        let lut = EncodeLut::new(8).unwrap();
        assert_eq!(*lut.runs8, runs8);
        assert_eq!(*lut.search8, tables::search8(&runs8));
        // The 8-bit codes from the runs are the interpolated tables' rounded values.
        for v in 0..=u16::MAX {
            assert_eq!(
                lut.lookup8(v),
                tables::interpolated(&low, &high, 255, v),
                "{v}"
            );
        }
    }

    /// The branch-free 16-bit lookup the planar sharpening stage uses is the table's own
    /// lookup at every input.
    #[test]
    fn estimated_encoding_is_within_its_bound() {
        // Every 16th float of [0, 1] and every float of the top octave's last 2^16 steps.
        let exact = |x: f32| {
            let x = f64::from(x);
            if x <= f64::from(LINEAR_THRESHOLD) {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            }
        };
        let mut worst = 0.0f64;
        let top = 1.0f32.to_bits();
        for bits in (0..=top).step_by(16).chain(top - 65536..=top) {
            let x = f32::from_bits(bits);
            let e = (f64::from(encode_estimated(x)) - exact(x)).abs();
            worst = worst.max(e);
        }
        assert!(worst <= 2.5e-7, "largest error {worst:e}");
        assert!(worst > 1e-8, "the test sees no error at all");
        assert_eq!(encode_estimated(-1.0), 0.0);
        assert_eq!(encode_estimated(f32::NAN), 0.0);
        assert!(encode_estimated(2.0) <= 1.0);
    }

    #[test]
    fn lookup16_is_the_16_bit_lookup_at_every_input() {
        let lut = EncodeLut::new(16).unwrap();
        for v in 0..=u16::MAX {
            assert_eq!(lut.lookup16(v), lut.lookup(v), "{v}");
        }
        // The comparison could fail: the codes span the 16-bit range.
        assert_eq!((lut.lookup16(0), lut.lookup16(u16::MAX)), (0, 65535));
    }
}
