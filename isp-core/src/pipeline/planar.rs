//! The pipeline's one schedule: every stage over planar rows, so that each stage but the
//! gathers (the encodings' and tone's tables, the lens's taps) is a loop over contiguous
//! slices that the compiler vectorises. Both paths run it, for every configuration: mosaic
//! or linear input, every demosaic method, noise reduction, shading, distortion, tone, chroma
//! noise reduction, sharpening, and 8-bit, 16-bit or `f32` output.
//!
//! - **Prepared rows.** A prepared mosaic row (defect correction, black level, shading, gain,
//!   white balance) is held as its even columns, then its odd columns, each with one
//!   reflected sample on either side ([`Halves`]). Within one half every sample has the same
//!   CFA position, so the pointwise stage is one set of constants per half, and the padding
//!   makes the frame's reflect-101 border the same loop as the interior. The shading gains of
//!   a row are computed once per row, cell by cell of the grid.
//! - **Noise reduction** ([`crate::denoise`]) runs between defect correction with black level
//!   and the gains: its stream reads packed rows normalised straight into its planes (a
//!   packed row's four planes are the halves of its two mosaic rows) and gives filtered packed
//!   rows, which the gains turn into two prepared rows. Prepared rows are kept in a ring of 16
//!   (8 packed rows), so the rows the directional method reads again at the frame's bottom
//!   (reflected) are still held.
//! - **Demosaicing** writes three planes (R, G, B), each even half then odd half: bilinear and
//!   MHC through the parity-split filters, the directional method through its stream, and
//!   nearest and frames under 8 x 3 through the reference row function over interleaved
//!   copies of the rows (the same bytes; those are not where speed matters). Highlights follow,
//!   a loop over the planes without a branch per pixel.
//! - **Distortion correction**, when on, is a pass of its own over a ring of demosaiced plane
//!   rows, as tall as the lens bends a row ([`LensDistortion::window_rows`]): each output
//!   row's mesh nodes are interpolated once, each pixel's position from them, and its four taps
//!   gathered from the ring.
//! - **The finish**: colour matrix (clamped), tone (saturation as a matrix, contrast and
//!   curve per sample) and encoding, each a pass over the planes; the encoding interleaves
//!   into the output (8-bit through the ISA's encoder, else per sample). Sharpening keeps a
//!   ring of three encoded rows with their luma; chroma noise reduction a ring of seven rows
//!   of luma and chroma planes in column order after its horizontal pass, its vertical pass
//!   and the sharpening read from it.
//!
//! The arithmetic is the general engine's (`run_input_general`, the reference the tests
//! compare with), operation for operation: the same output bit for bit, but for the float
//! path's noise reduction, whose sums the two form in different orders (its stream is
//! tested against its definition instead). The fixed path keeps the engine's `u64`/`i64`
//! products exactly in 32-bit lanes where they are per sample ([`MulQ16`], [`CcmSplit`]).

use core::ops::Range;

use bytemuck::Pod;

use super::{
    Detail, FixedPipeline, FloatPipeline, Input, OutputSample, Path, RowWindow, CHUNK, IDENTITY,
    LUMA, LUMA_Q16,
};
use crate::chroma::{self, ColumnPass, PlanarArithmetic, COLUMN_WEIGHT_ROWS, RADIUS, SPLIT, TAPS};
#[cfg(target_arch = "x86_64")]
use crate::demosaic::directional::LANES_AVX512;
use crate::demosaic::directional::{Arithmetic, OutputRow, Stream, HALO, LANES};
use crate::demosaic::planar::{demosaic_row, Halves};
use crate::demosaic::{self, reflect, Method};
use crate::distortion::{interpolate_rows, row_position, taps, LensDistortion};
use crate::dpc::{self, DpcConfig};
use crate::frame::{LinearFrame, RawFrame, RgbViewMut, Sample};
use crate::highlights::{self, KneeQ16};
use crate::lsc::{self, LensShading, MAX_GRID_SIDE};
use crate::{ccm, denoise, srgb, IspError};

/// Narrowest frame the parity-split demosaic filters take (their padding reflects within the
/// first and last four columns); narrower frames, and frames under 3 rows, demosaic through
/// [`demosaic::row`].
const MIN_WIDTH: usize = 8;
/// Prepared rows the ring holds without noise reduction: the widest demosaic window.
const MOSAIC_ROWS: usize = 5;
/// Prepared rows the ring holds with noise reduction: eight packed rows, more than the
/// directional method reads again below the frame's last row (its 12-row halo, reflected).
const DENOISED_ROWS: usize = 16;
/// Rows of the sharpening stage's ring: the encoded rows above, at and below an output row.
const SHARPEN_ROWS: usize = 3;
/// Columns of padding either side of a row of the chroma stage's ring: the sharpening's.
const CHROMA_PAD: usize = 1;

/// What the schedule needs of a path.
pub(super) trait Planar:
    Path<P: PartialOrd + Pod, NrWork: Pod, NrSum: Pod, Chroma: Pod + Default>
{
    /// The pointwise stage's constants for one CFA position (or one channel of a linear frame).
    type Steps: Copy;
    /// A shading gain (`f32`, or Q4.16 in a `u32`), also the type of the grid's column
    /// fractions.
    type Gain: Copy + Default + Pod;
    /// The colour matrix in the form the planar loop applies.
    type Matrix;
    /// The chroma stage's parameters.
    type ChromaParams: PlanarArithmetic<D = Self::Chroma, W = Self::Chroma>;

    /// Shading, if on.
    fn lsc(&self) -> Option<&LensShading<'_>>;
    /// The pointwise constants for samples with black level `black`, white level `white` and
    /// white balance of colour `colour` (0, 1, 2).
    fn steps(&self, black: u16, white: u16, colour: usize) -> Self::Steps;
    /// Black level, normalisation, gain and white balance of one corrected raw sample.
    fn pointwise(steps: Self::Steps, raw: u16) -> Self::P;
    /// [`Planar::pointwise`] with the shading gain `gain` (after normalisation).
    fn pointwise_shaded(steps: Self::Steps, raw: u16, gain: Self::Gain) -> Self::P;
    /// Black level and normalisation alone: noise reduction's input.
    fn normalise(steps: Self::Steps, raw: u16) -> Self::P;
    /// Gain and white balance of a normalised (noise-reduced) sample.
    fn gained(steps: Self::Steps, v: Self::P) -> Self::P;
    /// Shading, gain and white balance of a normalised (noise-reduced) sample.
    fn gained_shaded(steps: Self::Steps, v: Self::P, gain: Self::Gain) -> Self::P;
    /// Column `x`'s fraction between its grid nodes, as the path's shading takes it.
    fn column_fraction(remainder: u32, divisor: u32) -> Self::Gain;
    /// The shading gains of one run of columns of row `y` between grid nodes `gx` and `gx + 1`
    /// at CFA position `position`, from their fractions.
    #[allow(clippy::too_many_arguments)]
    fn shading_run(
        lsc: &LensShading<'_>,
        gx: usize,
        gy: usize,
        fy: (u32, u32),
        position: usize,
        fractions: &[Self::Gain],
        out: &mut [Self::Gain],
    );
    /// The highlight stage's parameters.
    type Knee: Copy;
    /// The highlight stage's parameters, if it is on.
    fn knee(&self) -> Option<Self::Knee>;
    /// The highlight stage, branch-free.
    fn highlights_at_knee(knee: Self::Knee, rgb: [Self::P; 3], brightest: Self::P) -> [Self::P; 3];
    /// The colour matrix, if it is on.
    fn matrix(&self) -> Option<Self::Matrix>;
    /// The colour matrix at one pixel, clamped.
    fn colour_matrix(m: &Self::Matrix, rgb: [Self::P; 3]) -> [Self::P; 3];
    /// Whether [`Planar::clamp_for_code8`] changes values (else a row without a colour matrix
    /// skips its pass).
    const CLAMPS_FOR_CODE8: bool;
    /// A linear value as the encodings take it (the float path clamps to `[0, 1]`).
    fn clamp_for_code8(v: Self::P) -> Self::P;
    /// Whether tone (saturation, contrast or curve) is on.
    fn tone_on(&self) -> bool;
    /// Tone on one row of planes (`w` samples each).
    fn tone_row(&self, planes: &mut [Self::P], w: usize);
    /// The 8-bit sRGB code of a linear value from [`Planar::clamp_for_code8`].
    fn code8_clamped(&self, v: Self::P) -> u32;
    /// Where [`Self::code8_clamped`] is [`srgb::EncodeLut::lookup8`] (the fixed path), that
    /// table and `planes` as `u16`: for the vectorised encoder.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn lookup8_planes<'a>(
        &'a self,
        _planes: &'a [Self::P],
    ) -> Option<(&'a srgb::EncodeLut, &'a [u16])> {
        None
    }
    /// Where [`Self::code8_clamped`] is [`srgb::EncodeThresholds8::code_clamped`] (the float
    /// path), those thresholds and `planes` as `f32`: for the vectorised encoder.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn thresholds8_planes<'a>(
        &'a self,
        _planes: &'a [Self::P],
    ) -> Option<(&'a srgb::EncodeThresholds8, &'a [f32])> {
        None
    }
    /// A linear value (clamped) as an output sample of any depth.
    fn encoded_output<O: OutputSample>(&self, v: Self::P) -> O;
    /// The sharpening stage's amount (the path's own form of it).
    type Sharpen: Copy;
    /// The sharpening stage's amount, if it is on.
    fn sharpening(&self) -> Option<Self::Sharpen>;
    /// A linear value in the encoded domain sharpening and chroma noise reduction work in
    /// (the estimated curve in `f32`, 16-bit codes).
    fn encode_for_detail(&self, v: Self::P) -> Self::P;
    /// The Rec. 709 luma of an encoded pixel.
    fn luma(e: [Self::P; 3]) -> Self::P;
    /// The detail the sharpening stage adds to each channel of a pixel, from the luma of the
    /// 3x3 pixels around it, `luma[row][column]`.
    type Detail: Copy;
    /// See [`Planar::Detail`].
    fn detail(amount: Self::Sharpen, luma: [[Self::P; 3]; 3]) -> Self::Detail;
    /// No detail (sharpening off).
    fn no_detail() -> Self::Detail;
    /// An encoded channel `e` with the detail added, clamped, as a value [`Planar::output_of`]
    /// takes for `O`: its 8-bit code where `O` is 8-bit, else the encoded value.
    fn sharpened<O: OutputSample>(e: Self::P, detail: Self::Detail) -> Self::P;
    /// A value from [`Planar::sharpened`] as an output sample.
    fn output_of<O: OutputSample>(v: Self::P) -> O;
    /// The chroma stage's parameters, if it is on.
    fn chroma_params(&self) -> Option<Self::ChromaParams>;
    /// An encoded pixel as luma and chroma.
    fn split(e: [Self::P; 3]) -> [Self::Chroma; SPLIT];
    /// Luma from the chroma stage's rows in the encoded domain, for the sharpening.
    fn luma_of(y: Self::Chroma) -> Self::P;
    /// Luma plus chroma plus detail, clamped, as a value [`Planar::chroma_output_of`] takes
    /// for `O`: its 8-bit code where `O` is 8-bit (so the rounding vectorises with the sum),
    /// else the encoded value.
    fn combined<O: OutputSample>(
        y: Self::Chroma,
        c: Self::Chroma,
        detail: Self::Detail,
    ) -> Self::Chroma;
    /// A value from [`Planar::combined`] as an output sample.
    fn chroma_output_of<O: OutputSample>(v: Self::Chroma) -> O;
}

/// `min(round(v * k / 2^16), 65535)` for a Q16 constant `k < 2^32` and `v < 2^16`, in `u32`
/// lanes: `k = hi * 2^16 + lo` makes it `v * hi + round(v * lo / 2^16)`, every term below
/// 2^32. The same value as the general engine's `u64` form.
#[derive(Debug, Clone, Copy)]
pub(super) struct MulQ16 {
    hi: u32,
    lo: u32,
}

impl MulQ16 {
    fn new(k: u64) -> Self {
        Self {
            hi: (k >> 16) as u32,
            lo: (k & 0xFFFF) as u32,
        }
    }

    /// Multiplying by 1.0, which is exact and changes nothing.
    const ONE: Self = Self { hi: 1, lo: 0 };

    #[inline(always)]
    fn apply(self, v: u32) -> u32 {
        (v * self.hi + ((v * self.lo + (1 << 15)) >> 16)).min(65535)
    }

    /// `floor(v * k / 2^16)` (below 2^32 for `v < 2^16`).
    #[inline(always)]
    fn floor(self, v: u32) -> u32 {
        v * self.hi + ((v * self.lo) >> 16)
    }
}

/// The fixed path's pointwise stage for one CFA position.
#[derive(Debug, Clone, Copy)]
pub(super) struct FixedSteps {
    black: u16,
    normalise: MulQ16,
    /// `None` for no gain, whose multiply by one changes nothing: skipping it took fixed MHC
    /// from 3.73-3.76 to 3.63-3.67 ns per pixel (issue 19's stages, best of 6 x 20 repeats).
    gain: Option<MulQ16>,
    wb: MulQ16,
}

impl FixedSteps {
    /// Gain and white balance of a 16-bit linear sample.
    #[inline(always)]
    fn gains(self, v: u32) -> u16 {
        let v = match self.gain {
            Some(gain) => gain.apply(v),
            None => v,
        };
        self.wb.apply(v) as u16
    }
}

/// A Q16 colour matrix split as [`MulQ16`] splits a constant: each coefficient
/// `m = hi * 2^16 + lo` with `lo` in `[0, 2^16)`, so `round(sum m_c v_c / 2^16)` is
/// `sum hi_c v_c` plus the rounded sum of the `lo_c v_c`, whose high and low halves are
/// added apart. Exact: the general engine's `i64` result in `u32` and `i32` lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct CcmSplit {
    hi: [[i32; 3]; 3],
    lo: [[u32; 3]; 3],
}

impl CcmSplit {
    fn new(m: &[[i32; 3]; 3]) -> Self {
        Self {
            hi: m.map(|row| row.map(|k| k >> 16)),
            lo: m.map(|row| row.map(|k| (k & 0xFFFF) as u32)),
        }
    }

    /// Output channel `c` of the pixel `v`.
    #[inline(always)]
    fn channel(&self, c: usize, v: [u32; 3]) -> u16 {
        let (hi, lo) = (self.hi[c], self.lo[c]);
        // Coefficients are within [-8, 8), so |hi| <= 8 and these sums stay far from overflow.
        let whole = hi[0] * v[0] as i32 + hi[1] * v[1] as i32 + hi[2] * v[2] as i32;
        let p = [lo[0] * v[0], lo[1] * v[1], lo[2] * v[2]];
        let high = (p[0] >> 16) + (p[1] >> 16) + (p[2] >> 16);
        let low = (p[0] & 0xFFFF) + (p[1] & 0xFFFF) + (p[2] & 0xFFFF);
        let fraction = high + ((low + (1 << 15)) >> 16);
        (whole + fraction as i32).clamp(0, 65535) as u16
    }

    #[inline(always)]
    fn apply(&self, rgb: [u16; 3]) -> [u16; 3] {
        let v = rgb.map(u32::from);
        [self.channel(0, v), self.channel(1, v), self.channel(2, v)]
    }
}

impl Planar for FixedPipeline<'_> {
    type Steps = FixedSteps;
    type Gain = u32;
    type Matrix = CcmSplit;
    type ChromaParams = chroma::FixedParams;

    fn lsc(&self) -> Option<&LensShading<'_>> {
        self.lsc.as_ref()
    }

    fn steps(&self, black: u16, white: u16, colour: usize) -> FixedSteps {
        FixedSteps {
            black,
            normalise: MulQ16::new(super::recip_q16(white.saturating_sub(black))),
            gain: self.gain_q16.map(MulQ16::new),
            wb: self
                .wb_q16
                .map_or(MulQ16::ONE, |wb| MulQ16::new(wb[colour])),
        }
    }

    #[inline(always)]
    fn pointwise(steps: FixedSteps, raw: u16) -> u16 {
        let d = u32::from(raw.saturating_sub(steps.black));
        steps.gains(steps.normalise.apply(d))
    }

    #[inline(always)]
    fn pointwise_shaded(steps: FixedSteps, raw: u16, gain: u32) -> u16 {
        // The engine's `(d * recip) >> 16`, times the Q4.16 gain, rounded by 16 bits.
        let n = steps
            .normalise
            .floor(u32::from(raw.saturating_sub(steps.black)));
        let t = ((u64::from(n) * u64::from(gain) + (1 << 15)) >> 16).min(65535);
        steps.gains(t as u32)
    }

    #[inline(always)]
    fn normalise(steps: FixedSteps, raw: u16) -> u16 {
        steps
            .normalise
            .apply(u32::from(raw.saturating_sub(steps.black))) as u16
    }

    #[inline(always)]
    fn gained(steps: FixedSteps, v: u16) -> u16 {
        steps.gains(u32::from(v))
    }

    #[inline(always)]
    fn gained_shaded(steps: FixedSteps, v: u16, gain: u32) -> u16 {
        steps.gains(MulQ16::new(u64::from(gain)).apply(u32::from(v)))
    }

    fn column_fraction(remainder: u32, divisor: u32) -> u32 {
        // The engine's Q16 fraction, at most 2^16.
        ((u64::from(remainder) << 16) / u64::from(divisor.max(1))) as u32
    }

    #[inline(always)]
    fn shading_run(
        lsc: &LensShading<'_>,
        gx: usize,
        gy: usize,
        (ry, dy): (u32, u32),
        position: usize,
        fractions: &[u32],
        out: &mut [u32],
    ) {
        // The grid interpolated down to the row (the engine's `row_nodes_q16`), then along it.
        let fy = (u64::from(ry) << 16) / u64::from(dy.max(1));
        let node = |gx: usize| {
            let a = u64::from(lsc.node(gx, gy, position));
            let b = u64::from(lsc.node(gx, gy + 1, position));
            (a * ((1 << 16) - fy) + b * fy + (1 << 11)) >> 12
        };
        let (a, b) = (node(gx), node(gx + 1));
        for (g, &fx) in out.iter_mut().zip(fractions) {
            let fx = u64::from(fx);
            *g = ((a * ((1 << 16) - fx) + b * fx + (1 << 15)) >> 16) as u32;
        }
    }

    type Knee = KneeQ16;

    fn knee(&self) -> Option<KneeQ16> {
        self.highlights
    }

    #[inline(always)]
    fn highlights_at_knee(knee: KneeQ16, rgb: [u16; 3], brightest: u16) -> [u16; 3] {
        knee.neutralise(rgb, brightest)
    }

    fn matrix(&self) -> Option<CcmSplit> {
        self.ccm_q.as_ref().map(CcmSplit::new)
    }

    #[inline(always)]
    fn colour_matrix(m: &CcmSplit, rgb: [u16; 3]) -> [u16; 3] {
        m.apply(rgb)
    }

    // The table takes every `u16`.
    const CLAMPS_FOR_CODE8: bool = false;

    #[inline(always)]
    fn clamp_for_code8(v: u16) -> u16 {
        v
    }

    fn tone_on(&self) -> bool {
        self.saturation_q.is_some() || self.tone_lut.is_some()
    }

    #[inline(always)]
    fn tone_row(&self, planes: &mut [u16], w: usize) {
        let (r, rest) = planes.split_at_mut(w);
        let (g, b) = rest.split_at_mut(w);
        let b = &mut b[..w];
        if let Some(m) = &self.saturation_q {
            // The saturation matrix has the colour matrix's format (Q16).
            let m = CcmSplit::new(m);
            for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
                [*r, *g, *b] = m.apply([*r, *g, *b]);
            }
        }
        if let Some(lut) = &self.tone_lut {
            for plane in [r, g, b] {
                for v in plane.iter_mut() {
                    *v = lut.lookup(*v);
                }
            }
        }
    }

    #[inline(always)]
    fn code8_clamped(&self, v: u16) -> u32 {
        self.encode.lookup8(v)
    }

    fn lookup8_planes<'a>(&'a self, planes: &'a [u16]) -> Option<(&'a srgb::EncodeLut, &'a [u16])> {
        Some((&self.encode, planes))
    }

    #[inline(always)]
    fn encoded_output<O: OutputSample>(&self, v: u16) -> O {
        O::from_code(self.encode.lookup(v))
    }

    type Sharpen = i32;

    fn sharpening(&self) -> Option<i32> {
        // The amount is at most 4 in Q12.
        self.sharpen_q12.map(|amount| amount as i32)
    }

    #[inline(always)]
    fn encode_for_detail(&self, v: u16) -> u16 {
        match &self.encode16 {
            // Codes of a 16-bit table fit u16.
            Some(encode16) => encode16.lookup16(v) as u16,
            None => v,
        }
    }

    #[inline(always)]
    fn luma(e: [u16; 3]) -> u16 {
        // The weights sum to 2^16, so the rounded luma is at most 65535.
        ((LUMA_Q16[0] * u32::from(e[0])
            + LUMA_Q16[1] * u32::from(e[1])
            + LUMA_Q16[2] * u32::from(e[2])
            + (1 << 15))
            >> 16) as u16
    }

    type Detail = i32;

    #[inline(always)]
    fn detail(amount: i32, luma: [[u16; 3]; 3]) -> i32 {
        let [up, mid, down] = luma.map(|row| row.map(i32::from));
        let column = |k: usize| up[k] + mid[k] + mid[k] + down[k];
        let blurred = column(0) + column(1) + column(1) + column(2);
        // 16 times the detail, |d| < 2^21; times the Q12 amount (<= 2^14) it would pass
        // 2^31, so with d = hi 2^16 + lo the rounded shift by 16 is amount hi plus the rounded
        // top of amount lo (< 2^30): the engine's `i64` value.
        let d = 16 * mid[1] - blurred;
        let (hi, lo) = (d >> 16, (d & 0xFFFF) as u32);
        amount * hi + ((amount as u32 * lo + (1 << 15)) >> 16) as i32
    }

    #[inline(always)]
    fn no_detail() -> i32 {
        0
    }

    #[inline(always)]
    fn sharpened<O: OutputSample>(e: u16, detail: i32) -> u16 {
        let v = (i32::from(e) + detail).clamp(0, 65535) as u32;
        match O::BITS {
            // The engine's 8-bit output of a 16-bit code, rounded: < 2^24 before the division.
            8 => ((v * 255 + 32767) / 65535) as u16,
            _ => v as u16,
        }
    }

    #[inline(always)]
    fn output_of<O: OutputSample>(v: u16) -> O {
        O::from_code(u32::from(v))
    }

    fn chroma_params(&self) -> Option<chroma::FixedParams> {
        self.chroma
    }

    #[inline(always)]
    fn split(e: [u16; 3]) -> [i32; SPLIT] {
        let y = i32::from(Self::luma(e));
        [
            y,
            i32::from(e[0]) - y,
            i32::from(e[1]) - y,
            i32::from(e[2]) - y,
        ]
    }

    #[inline(always)]
    fn luma_of(y: i32) -> u16 {
        y as u16
    }

    #[inline(always)]
    fn combined<O: OutputSample>(y: i32, c: i32, detail: i32) -> i32 {
        let v = (y + c + detail).clamp(0, 65535);
        match O::BITS {
            // Rounded to 8 bits: < 2^24 before the division.
            8 => (v * 255 + 32767) / 65535,
            _ => v,
        }
    }

    #[inline(always)]
    fn chroma_output_of<O: OutputSample>(v: i32) -> O {
        O::from_code(v as u32)
    }
}

/// The float path's pointwise stage for one CFA position: black, white minus black, ISO gain
/// and white-balance gain (a gain of 1 multiplies exactly and clamps nothing, so every
/// step runs).
#[derive(Debug, Clone, Copy)]
pub(super) struct FloatSteps {
    black: u16,
    range: f32,
    gain: f32,
    wb: f32,
}

impl FloatSteps {
    /// Gain and white balance of a linear value in `[0, 1]`.
    #[inline(always)]
    fn gains(self, v: f32) -> f32 {
        (self.wb * (self.gain * v).min(1.0)).min(1.0)
    }
}

impl Planar for FloatPipeline<'_> {
    type Steps = FloatSteps;
    type Gain = f32;
    type Matrix = [[f32; 3]; 3];
    type ChromaParams = chroma::FloatParams;

    fn lsc(&self) -> Option<&LensShading<'_>> {
        self.config.lsc.as_ref()
    }

    fn steps(&self, black: u16, white: u16, colour: usize) -> FloatSteps {
        FloatSteps {
            black,
            range: white as f32 - black as f32,
            gain: self.config.gain,
            wb: self.config.wb_gains[colour],
        }
    }

    #[inline(always)]
    fn pointwise(steps: FloatSteps, raw: u16) -> f32 {
        // FloatPipeline::pointwise without shading, every step taken.
        let v = (raw.saturating_sub(steps.black) as f32 / steps.range).clamp(0.0, 1.0);
        steps.gains(v)
    }

    #[inline(always)]
    fn pointwise_shaded(steps: FloatSteps, raw: u16, gain: f32) -> f32 {
        let v = (raw.saturating_sub(steps.black) as f32 / steps.range * gain).clamp(0.0, 1.0);
        steps.gains(v)
    }

    #[inline(always)]
    fn normalise(steps: FloatSteps, raw: u16) -> f32 {
        (raw.saturating_sub(steps.black) as f32 / steps.range).clamp(0.0, 1.0)
    }

    #[inline(always)]
    fn gained(steps: FloatSteps, v: f32) -> f32 {
        steps.gains(v.clamp(0.0, 1.0))
    }

    #[inline(always)]
    fn gained_shaded(steps: FloatSteps, v: f32, gain: f32) -> f32 {
        steps.gains((v * gain).clamp(0.0, 1.0))
    }

    fn column_fraction(remainder: u32, divisor: u32) -> f32 {
        remainder as f32 / divisor.max(1) as f32
    }

    #[inline(always)]
    fn shading_run(
        lsc: &LensShading<'_>,
        gx: usize,
        gy: usize,
        (ry, dy): (u32, u32),
        position: usize,
        fractions: &[f32],
        out: &mut [f32],
    ) {
        // `LensShading::gain_f32`, its sums in its order.
        let fy = ry as f32 / dy.max(1) as f32;
        let g = |i, j| lsc.node(i, j, position) as f32 * (1.0 / lsc::ONE_Q12 as f32);
        let (g00, g10, g01, g11) = (g(gx, gy), g(gx + 1, gy), g(gx, gy + 1), g(gx + 1, gy + 1));
        for (gain, &fx) in out.iter_mut().zip(fractions) {
            let top = g00 * (1.0 - fx) + g10 * fx;
            let bottom = g01 * (1.0 - fx) + g11 * fx;
            *gain = top * (1.0 - fy) + bottom * fy;
        }
    }

    type Knee = f32;

    fn knee(&self) -> Option<f32> {
        let knee = self.config.highlight_knee;
        (knee < 1.0).then_some(knee)
    }

    #[inline(always)]
    fn highlights_at_knee(knee: f32, rgb: [f32; 3], brightest: f32) -> [f32; 3] {
        highlights::neutralise_f32_below_clip(rgb, brightest, knee)
    }

    fn matrix(&self) -> Option<[[f32; 3]; 3]> {
        (self.config.ccm != IDENTITY).then_some(self.config.ccm)
    }

    #[inline(always)]
    fn colour_matrix(m: &[[f32; 3]; 3], rgb: [f32; 3]) -> [f32; 3] {
        ccm::apply_f32(m, rgb)
    }

    const CLAMPS_FOR_CODE8: bool = true;

    #[inline(always)]
    fn clamp_for_code8(v: f32) -> f32 {
        srgb::clamp_unit(v)
    }

    fn tone_on(&self) -> bool {
        let tone = &self.config.tone;
        !(tone.saturation_is_identity() && tone.curve_is_identity())
    }

    #[inline(always)]
    fn tone_row(&self, planes: &mut [f32], w: usize) {
        let tone = &self.config.tone;
        let (r, rest) = planes.split_at_mut(w);
        let (g, b) = rest.split_at_mut(w);
        let b = &mut b[..w];
        if !tone.saturation_is_identity() {
            // `Tone::saturate`, written out (its `array::map` is a call per pixel).
            let (s, l) = (tone.saturation, crate::tone::LUMINANCE);
            for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
                let y = l[0] * *r + l[1] * *g + l[2] * *b;
                *r = (y + s * (*r - y)).clamp(0.0, 1.0);
                *g = (y + s * (*g - y)).clamp(0.0, 1.0);
                *b = (y + s * (*b - y)).clamp(0.0, 1.0);
            }
        }
        if tone.curve.points().is_empty() && tone.contrast != 1.0 {
            // Contrast alone: a branch-free loop per plane, which vectorises.
            let k = tone.contrast;
            for plane in [r, g, b] {
                for v in plane.iter_mut() {
                    *v = crate::tone::contrast_estimated(*v, k).clamp(0.0, 1.0);
                }
            }
        } else if !tone.curve_is_identity() {
            for plane in [r, g, b] {
                for v in plane.iter_mut() {
                    *v = tone.channel_estimated(*v);
                }
            }
        }
    }

    #[inline(always)]
    fn code8_clamped(&self, v: f32) -> u32 {
        u32::from(self.codes8.code_clamped(v))
    }

    fn thresholds8_planes<'a>(
        &'a self,
        planes: &'a [f32],
    ) -> Option<(&'a srgb::EncodeThresholds8, &'a [f32])> {
        Some((&self.codes8, planes))
    }

    #[inline(always)]
    fn encoded_output<O: OutputSample>(&self, v: f32) -> O {
        match O::BITS {
            8 => O::from_code(self.code8_clamped(srgb::clamp_unit(v))),
            _ => O::from_encoded(srgb::encode_estimated(v)),
        }
    }

    type Sharpen = f32;

    fn sharpening(&self) -> Option<f32> {
        let amount = self.config.sharpen;
        (amount > 0.0).then_some(amount)
    }

    #[inline(always)]
    fn encode_for_detail(&self, v: f32) -> f32 {
        srgb::encode_estimated(v)
    }

    #[inline(always)]
    fn luma(e: [f32; 3]) -> f32 {
        LUMA[0] * e[0] + LUMA[1] * e[1] + LUMA[2] * e[2]
    }

    type Detail = f32;

    #[inline(always)]
    fn detail(amount: f32, luma: [[f32; 3]; 3]) -> f32 {
        // The engine's sums, in its order.
        let [up, mid, down] = luma;
        let column = |k: usize| up[k] + mid[k] + mid[k] + down[k];
        let blurred = column(0) + column(1) + column(1) + column(2);
        amount * (mid[1] - blurred * (1.0 / 16.0))
    }

    #[inline(always)]
    fn no_detail() -> f32 {
        0.0
    }

    #[inline(always)]
    fn sharpened<O: OutputSample>(e: f32, detail: f32) -> f32 {
        let v = (e + detail).clamp(0.0, 1.0);
        match O::BITS {
            // `OutputSample::from_encoded` for `u8`: a half added, truncated (`as i32`, whose
            // conversion x86 has in vector form, as it lacks `as u32`'s: the same for
            // `[0.5, 255.5]`).
            8 => ((v * 255.0 + 0.5) as i32) as f32,
            _ => v,
        }
    }

    #[inline(always)]
    fn output_of<O: OutputSample>(v: f32) -> O {
        match O::BITS {
            8 => O::from_code(v as i32 as u32),
            _ => O::from_encoded(v),
        }
    }

    fn chroma_params(&self) -> Option<chroma::FloatParams> {
        self.chroma
    }

    #[inline(always)]
    fn split(e: [f32; 3]) -> [f32; SPLIT] {
        let y = Self::luma(e);
        [y, e[0] - y, e[1] - y, e[2] - y]
    }

    #[inline(always)]
    fn luma_of(y: f32) -> f32 {
        y
    }

    #[inline(always)]
    fn combined<O: OutputSample>(y: f32, c: f32, detail: f32) -> f32 {
        Self::sharpened::<O>(y + c, detail)
    }

    #[inline(always)]
    fn chroma_output_of<O: OutputSample>(v: f32) -> O {
        Self::output_of::<O>(v)
    }
}

/// Elements of `P` that hold `n` elements of `T` (bytes rounded up, plus alignment).
fn typed_len<P, T>(n: usize) -> Option<usize> {
    let (p, t) = (core::mem::size_of::<P>(), core::mem::size_of::<T>());
    if t <= p {
        Some(n)
    } else {
        let ratio = t.div_ceil(p);
        n.checked_mul(ratio)?.checked_add(ratio - 1)
    }
}

/// The scratch left to carve, with typed parts split off the front.
struct Carve<'s, P> {
    rest: &'s mut [P],
}

impl<'s, P: Pod> Carve<'s, P> {
    /// `n` elements of `T` (aligned) split off the front.
    fn take<T: Pod>(&mut self, n: usize) -> Result<&'s mut [T], IspError> {
        let len = typed_len::<P, T>(n).ok_or(TOO_WIDE)?;
        if len > self.rest.len() {
            return Err(IspError::BufferTooSmall {
                needed: len,
                provided: self.rest.len(),
            });
        }
        let (part, rest) = core::mem::take(&mut self.rest).split_at_mut(len);
        self.rest = rest;
        bytemuck::pod_align_to_mut::<P, T>(part)
            .1
            .get_mut(..n)
            .ok_or(IspError::BufferTooSmall {
                needed: len,
                provided: len,
            })
    }
}

/// A frame too wide for the sizes to fit in memory.
const TOO_WIDE: IspError = IspError::InvalidParameter {
    name: "width",
    allowed: "a size that fits in memory",
};

/// Everything that sizes the schedule's scratch, from a configuration and a frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct Shape {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) linear: bool,
    pub(super) method: Method,
    pub(super) denoise: Option<denoise::Search>,
    pub(super) shading: bool,
    /// The lens's window of rows, when distortion correction is on.
    pub(super) distortion: Option<(usize, usize)>,
    pub(super) detail: Detail,
}

/// The sizes of the schedule's parts for a shape, in their own types.
#[derive(Debug, Clone, Copy)]
struct Layout {
    /// Prepared rows: slots of [`Halves::len`].
    slots: usize,
    /// Whether the row function demosaics (nearest, small frames): five interleaved rows and
    /// one RGB row.
    rows_fallback: bool,
    directional: bool,
    nr: Option<(usize, usize, usize)>,
    distortion: Option<(usize, usize)>,
}

impl Shape {
    fn layout(&self) -> Layout {
        let mosaic = !self.linear;
        // The directional method streams every frame at least 2 x 2 (narrower ones take
        // bilinear's line rule, as the whole-frame method does).
        let streams = self.width >= 2 && self.height >= 2;
        let rows_fallback = mosaic
            && match self.method {
                Method::Nearest => true,
                Method::Directional => !streams,
                Method::Bilinear | Method::Mhc => !planar_frame(self.width, self.height),
            };
        let directional = mosaic && self.method == Method::Directional && !rows_fallback;
        let slots = match (self.linear, self.denoise, directional) {
            (true, _, _) => 0,
            (false, Some(_), _) => DENOISED_ROWS,
            (false, None, true) => 1,
            (false, None, false) => MOSAIC_ROWS,
        };
        Layout {
            slots,
            rows_fallback,
            directional,
            nr: self
                .denoise
                .filter(|_| mosaic)
                .and_then(|s| denoise::scratch_len(s, self.width / 2)),
            distortion: self.distortion,
        }
    }

    /// Scratch elements of a path (sample `P`, with its directional, noise-reduction and
    /// chroma types) the schedule needs for this shape.
    pub(super) fn scratch_len<P, E, W, S, G, C>(&self) -> Option<usize> {
        let w = self.width;
        let layout = self.layout();
        let halves = Halves::new(w);
        let mut total = layout.slots.checked_mul(halves.len())?;
        let mut add = |n: Option<usize>| -> Option<()> {
            total = total.checked_add(n?)?;
            Some(())
        };
        if layout.rows_fallback {
            add(w.checked_mul(8))?;
        }
        if layout.directional {
            add(typed_len::<P, E>(
                crate::demosaic::directional::scratch_len(w)?,
            ))?;
        }
        if let Some((samples, work, sums)) = layout.nr {
            add(Some(samples))?;
            add(typed_len::<P, W>(work))?;
            add(typed_len::<P, S>(sums))?;
            add(w.checked_mul(2))?;
        }
        if self.shading {
            add(typed_len::<P, G>(w.checked_mul(2)?))?;
        }
        add(w.checked_mul(3))?;
        if let Some((window, columns)) = layout.distortion {
            add(window.checked_mul(3)?.checked_mul(w))?;
            add(w.checked_mul(3))?;
            add(typed_len::<P, i32>(columns.checked_mul(6)?))?;
        }
        match self.detail {
            Detail::Off => {}
            Detail::Sharpen => add(w.checked_mul(4 * SHARPEN_ROWS))?,
            Detail::Chroma => {
                let split = w.checked_add(2 * RADIUS)?.checked_mul(SPLIT)?;
                let ring = w.checked_add(2 * CHROMA_PAD)?.checked_mul(SPLIT * TAPS)?;
                // The vertical pass's output and both passes' weights.
                let out = w
                    .checked_mul(SPLIT + COLUMN_WEIGHT_ROWS)?
                    // chroma::row_weights_len(w), checked.
                    .checked_add(w.checked_add(RADIUS)?.checked_mul(RADIUS)?)?;
                add(typed_len::<P, C>(
                    split.checked_add(ring)?.checked_add(out)?,
                ))?;
            }
        }
        Some(total)
    }
}

/// Whether a frame takes the parity-split demosaic filters.
fn planar_frame(w: usize, h: usize) -> bool {
    w >= MIN_WIDTH && h >= 3
}

/// The shading grid's column fractions for a frame `w` wide (halves order) and, per column
/// parity, the runs of columns between each pair of nodes.
struct ShadingColumns<'s, G> {
    fractions: &'s mut [G],
    /// `runs[parity][gx]`: the first site of the parity's half between nodes `gx` and `gx + 1`
    /// (and the end, at `grid_w - 1`).
    runs: [[usize; MAX_GRID_SIDE]; 2],
    /// The row's gains, halves order.
    row: &'s mut [G],
}

impl<'s, G: Copy> ShadingColumns<'s, G> {
    fn new<A: Planar<Gain = G>>(
        lsc: &LensShading<'_>,
        w: usize,
        halves: Halves,
        fractions: &'s mut [G],
        row: &'s mut [G],
    ) -> Self {
        let nodes = lsc.grid_w();
        let mut runs = [[0usize; MAX_GRID_SIDE]; 2];
        for (parity, run) in runs.iter_mut().enumerate() {
            let (start, n) = match parity {
                0 => (0, halves.even),
                _ => (halves.even, halves.odd),
            };
            // Sites before node gx's run, counted as the column's cell is found.
            let mut first = [n; MAX_GRID_SIDE];
            for i in (0..n).rev() {
                let x = 2 * i + parity;
                let (gx, rem, den) = lsc::split(x, w, nodes);
                fractions[start + i] = A::column_fraction(rem, den);
                first[gx] = i;
            }
            // Cells no column falls in start where the next one does.
            for gx in (0..nodes - 1).rev() {
                if first[gx] == n && gx + 1 < nodes - 1 {
                    first[gx] = first[gx + 1];
                }
            }
            run[..nodes].copy_from_slice(&first[..nodes]);
            run[nodes - 1] = n;
        }
        Self {
            fractions,
            runs,
            row,
        }
    }

    /// Row `y`'s gains into `self.row`.
    fn compute<A: Planar<Gain = G>>(
        &mut self,
        lsc: &LensShading<'_>,
        y: usize,
        h: usize,
        halves: Halves,
    ) {
        let (gy, ry, dy) = lsc::split(y, h, lsc.grid_h());
        for parity in 0..2 {
            let start = if parity == 0 { 0 } else { halves.even };
            let run = &self.runs[parity];
            for gx in 0..lsc.grid_w() - 1 {
                let (a, b) = (start + run[gx], start + run[gx + 1].max(run[gx]));
                A::shading_run(
                    lsc,
                    gx,
                    gy,
                    (ry, dy),
                    (y & 1) * 2 + parity,
                    &self.fractions[a..b],
                    &mut self.row[a..b],
                );
            }
        }
    }
}

/// The shading state of a run, when shading is on.
fn shading_for<'s, 'p, A: Planar>(
    path: &'p A,
    w: usize,
    halves: Halves,
    part: &'s mut [A::Gain],
) -> Option<(LensShading<'p>, ShadingColumns<'s, A::Gain>)> {
    let lsc = path.lsc()?;
    let (fractions, row) = part.split_at_mut(w);
    Some((
        *lsc,
        ShadingColumns::new::<A>(lsc, w, halves, fractions, row),
    ))
}

/// Noise reduction in one run: its stream and the filtered packed row's four planes.
struct Nr<'s, 'p, A: Planar + 'p> {
    stream: denoise::Stream<'s, A::Nlm<'p>>,
    filtered: &'s mut [A::P],
}

/// The prepared mosaic rows of one run: a ring of rows keyed by frame row, each produced by
/// defect correction and the pointwise stages, or by noise reduction and the gains.
struct Source<'s, 'p, A: Planar + 'p> {
    raw: RawFrame<'p>,
    dpc: &'p DpcConfig<'p>,
    halves: Halves,
    steps: [[A::Steps; 2]; 2],
    ring: &'s mut [A::P],
    tags: [usize; DENOISED_ROWS],
    slots: usize,
    shading: Option<(LensShading<'p>, ShadingColumns<'s, A::Gain>)>,
    nr: Option<Nr<'s, 'p, A>>,
}

impl<'s, 'p, A: Planar + 'p> Source<'s, 'p, A> {
    /// Makes prepared row `my` held.
    #[inline(always)]
    fn ensure(&mut self, my: usize) -> Result<(), IspError> {
        if self.tags[my % self.slots] == my {
            return Ok(());
        }
        let mosaic = self.raw.mosaic();
        let (w, h) = (mosaic.width(), mosaic.height());
        let len = self.halves.len();
        let Some(nr) = &mut self.nr else {
            let slot = my % self.slots;
            let gains = match &mut self.shading {
                Some((lsc, columns)) => {
                    columns.compute::<A>(lsc, my, h, self.halves);
                    Some(&*columns.row)
                }
                None => None,
            };
            let row = &mut self.ring[slot * len..(slot + 1) * len];
            prepare_row::<A>(
                self.dpc,
                &self.raw,
                my,
                self.steps[my & 1],
                self.halves,
                gains,
                row,
            );
            self.tags[slot] = my;
            return Ok(());
        };
        let j = my / 2;
        let wp = w / 2;
        let (f01, f23) = nr.filtered.split_at_mut(2 * wp);
        let (f0, f1) = f01.split_at_mut(wp);
        let (f2, f3) = f23.split_at_mut(wp);
        let (dpc, raw, steps) = (self.dpc, &self.raw, self.steps);
        nr.stream.row(
            j,
            |r, planes| {
                normalise_pair::<A>(dpc, raw, r, steps, planes);
                Ok(())
            },
            [f0, f1, f2, f3],
        )?;
        let filtered: &[A::P] = nr.filtered;
        for py in 0..2 {
            let y = 2 * j + py;
            let slot = y % self.slots;
            self.tags[slot] = usize::MAX;
            let row = &mut self.ring[slot * len..(slot + 1) * len];
            let [even, odd] = [2 * py, 2 * py + 1].map(|k| &filtered[k * wp..(k + 1) * wp]);
            let steps = self.steps[y & 1];
            let o = self.halves.odd_start();
            match &mut self.shading {
                Some((lsc, columns)) => {
                    columns.compute::<A>(lsc, y, h, self.halves);
                    let gains: &[A::Gain] = columns.row;
                    let (ge, go) = gains.split_at(wp);
                    for ((d, &v), &g) in row[1..1 + wp].iter_mut().zip(even).zip(ge) {
                        *d = A::gained_shaded(steps[0], v, g);
                    }
                    for ((d, &v), &g) in row[o + 1..o + 1 + wp].iter_mut().zip(odd).zip(go) {
                        *d = A::gained_shaded(steps[1], v, g);
                    }
                }
                None => {
                    for (d, &v) in row[1..1 + wp].iter_mut().zip(even) {
                        *d = A::gained(steps[0], v);
                    }
                    for (d, &v) in row[o + 1..o + 1 + wp].iter_mut().zip(odd) {
                        *d = A::gained(steps[1], v);
                    }
                }
            }
            pad(self.halves, row);
            self.tags[slot] = y;
        }
        Ok(())
    }

    /// Prepared row `my` (held: [`Source::ensure`] first).
    #[inline(always)]
    fn row(&self, my: usize) -> &[A::P] {
        let (slot, len) = (my % self.slots, self.halves.len());
        &self.ring[slot * len..(slot + 1) * len]
    }
}

/// Writes the reflected samples of a row whose halves are filled, for any width: the padding
/// of [`Halves::pad`] where the frame is at least 4 wide, else each padded column's reflection
/// (its value wherever reflect-101 lands, which may be in the other half).
#[inline(always)]
fn pad<T: Copy>(halves: Halves, row: &mut [T]) {
    let w = halves.even + halves.odd;
    if w >= 4 {
        halves.pad(row);
        return;
    }
    let o = halves.odd_start();
    let at = |x: usize| {
        if x.is_multiple_of(2) {
            1 + x / 2
        } else {
            o + 1 + x / 2
        }
    };
    // Padded entries: E(-1) = column -2, E(even) = column 2 even, O(-1) = column -1, O(odd)
    // = column 2 odd + 1.
    for (index, column) in [
        (0, -2isize),
        (1 + halves.even, 2 * halves.even as isize),
        (o, -1),
        (o + 1 + halves.odd, 2 * halves.odd as isize + 1),
    ] {
        row[index] = row[at(reflect(column, w))];
    }
}

/// Raw row `my` through defect correction and the pointwise stage (with its shading `gains`,
/// halves order) into the halves of `dst`.
#[inline(always)]
fn prepare_row<A: Planar>(
    dpc_config: &DpcConfig<'_>,
    raw: &RawFrame<'_>,
    my: usize,
    steps: [A::Steps; 2],
    halves: Halves,
    gains: Option<&[A::Gain]>,
    dst: &mut [A::P],
) {
    let w = halves.even + halves.odd;
    let o = halves.odd_start();
    let mut corrected = [0u16; CHUNK];
    // CHUNK is even, so each chunk starts at an even column.
    for x0 in (0..w).step_by(CHUNK) {
        let n = CHUNK.min(w - x0);
        dpc::correct_span(raw, dpc_config, my, x0, &mut corrected[..n]);
        let pairs = &corrected[..n - n % 2];
        let (e0, e1) = (x0 / 2, x0 / 2 + pairs.len() / 2);
        let (left, right) = dst.split_at_mut(o);
        let even = &mut left[1 + e0..1 + e1];
        let odd = &mut right[1 + e0..1 + e1];
        match gains {
            Some(g) => {
                let (ge, go) = (&g[e0..e1], &g[halves.even + e0..halves.even + e1]);
                for ((e, pair), &g) in even.iter_mut().zip(pairs.chunks_exact(2)).zip(ge) {
                    *e = A::pointwise_shaded(steps[0], pair[0], g);
                }
                for ((d, pair), &g) in odd.iter_mut().zip(pairs.chunks_exact(2)).zip(go) {
                    *d = A::pointwise_shaded(steps[1], pair[1], g);
                }
            }
            None => {
                for (e, pair) in even.iter_mut().zip(pairs.chunks_exact(2)) {
                    *e = A::pointwise(steps[0], pair[0]);
                }
                for (d, pair) in odd.iter_mut().zip(pairs.chunks_exact(2)) {
                    *d = A::pointwise(steps[1], pair[1]);
                }
            }
        }
        if n % 2 == 1 {
            // The last column of an odd width.
            let x = x0 + n - 1;
            dst[1 + x / 2] = match gains {
                Some(g) => A::pointwise_shaded(steps[0], corrected[n - 1], g[x / 2]),
                None => A::pointwise(steps[0], corrected[n - 1]),
            };
        }
    }
    pad(halves, dst);
}

/// Packed row `r`'s two mosaic rows through defect correction and black level alone, into the
/// noise filter's four planes (position `2 py + (x & 1)` of mosaic row `2 r + py`).
#[inline(always)]
fn normalise_pair<A: Planar>(
    dpc_config: &DpcConfig<'_>,
    raw: &RawFrame<'_>,
    r: usize,
    steps: [[A::Steps; 2]; 2],
    planes: [&mut [A::P]; 4],
) {
    let w = raw.mosaic().width();
    let [p0, p1, p2, p3] = planes;
    let mut corrected = [0u16; CHUNK];
    for (py, (even, odd)) in [(p0, p1), (p2, p3)].into_iter().enumerate() {
        let my = 2 * r + py;
        let steps = steps[my & 1];
        for x0 in (0..w).step_by(CHUNK) {
            let n = CHUNK.min(w - x0);
            dpc::correct_span(raw, dpc_config, my, x0, &mut corrected[..n]);
            let pairs = corrected[..n].chunks_exact(2);
            let (e, o) = (
                &mut even[x0 / 2..x0 / 2 + n / 2],
                &mut odd[x0 / 2..x0 / 2 + n / 2],
            );
            for ((e, o), pair) in e.iter_mut().zip(o.iter_mut()).zip(pairs) {
                *e = A::normalise(steps[0], pair[0]);
                *o = A::normalise(steps[1], pair[1]);
            }
        }
    }
}

/// How a run demosaics.
// One per band, on the stack, and no heap to box into: the size difference costs nothing.
#[allow(clippy::large_enum_variant)]
enum Demosaicer<'s, A: Planar> {
    /// Bilinear or MHC through the parity-split filters.
    Planar(Method),
    /// The directional method's stream.
    Directional(Stream<'s, A::Directional>),
    /// The reference row function over interleaved copies of the rows: nearest, and frames
    /// under 8 x 3 (five rows and one RGB row).
    Rows {
        method: Method,
        rows: &'s mut [A::P],
    },
}

/// Where linear RGB rows come from.
// One per band, on the stack (see `Demosaicer`).
#[allow(clippy::large_enum_variant)]
enum Front<'s, 'p, A: Planar + 'p> {
    Mosaic {
        source: Source<'s, 'p, A>,
        demosaic: Demosaicer<'s, A>,
    },
    Linear {
        frame: LinearFrame<'p>,
        steps: [A::Steps; 3],
        shading: Option<(LensShading<'p>, ShadingColumns<'s, A::Gain>)>,
    },
}

impl<'s, 'p, A: Planar + 'p> Front<'s, 'p, A> {
    /// Linear RGB row `y` (demosaiced, highlights applied) into `planes`.
    #[inline(always)]
    fn row<const L: usize>(
        &mut self,
        path: &A,
        y: usize,
        planes: &mut [A::P],
    ) -> Result<(), IspError> {
        let knee = path.knee();
        match self {
            Front::Mosaic { source, demosaic } => {
                let mosaic = source.raw.mosaic();
                let (h, pattern) = (mosaic.height(), mosaic.pattern());
                let halves = source.halves;
                match demosaic {
                    Demosaicer::Planar(method) => {
                        for dm in -2..=2isize {
                            source.ensure(reflect(y as isize + dm, h))?;
                        }
                        let rows: [&[A::P]; 5] = core::array::from_fn(|k| {
                            source.row(reflect(y as isize + k as isize - 2, h))
                        });
                        demosaic_row(*method, rows, halves, pattern, y, planes);
                        if let Some(knee) = knee {
                            highlights_row::<A>(knee, rows, halves, planes);
                        }
                    }
                    Demosaicer::Rows { method, rows } => {
                        let w = halves.even + halves.odd;
                        for dm in -2..=2isize {
                            source.ensure(reflect(y as isize + dm, h))?;
                        }
                        let source_rows: [&[A::P]; 5] = core::array::from_fn(|k| {
                            source.row(reflect(y as isize + k as isize - 2, h))
                        });
                        let (interleaved, rgb) = rows.split_at_mut(5 * w);
                        for (k, row) in interleaved.chunks_exact_mut(w).enumerate() {
                            unsplit(halves, source_rows[k], row);
                        }
                        let five: [&[A::P]; 5] =
                            core::array::from_fn(|k| &interleaved[k * w..(k + 1) * w]);
                        // The directional method's line rule on frames it does not stream.
                        let method = match method {
                            Method::Directional => Method::Bilinear,
                            m => *m,
                        };
                        demosaic::row(method, five, y, h, pattern, &mut rgb[..3 * w])?;
                        split_rgb(halves, &rgb[..3 * w], planes);
                        if let Some(knee) = knee {
                            highlights_row::<A>(knee, source_rows, halves, planes);
                        }
                    }
                    Demosaicer::Directional(stream) => {
                        if stream.next_output() != Some(y) {
                            stream.restart(y);
                        }
                        loop {
                            if stream.finished() {
                                // A restart at a frame row always reaches it; this is not reached.
                                return Err(IspError::InvalidParameter {
                                    name: "rows",
                                    allowed: "rows within the frame",
                                });
                            }
                            let read = stream.next_read();
                            if let Some(my) = read {
                                source.ensure(my)?;
                            }
                            let src = read.map(|my| halves.unpadded(source.row(my)));
                            if stream.next_output() == Some(y) {
                                stream.step::<L>(src, Some(OutputRow::Planes(&mut *planes)));
                                break;
                            }
                            stream.step::<L>(src, None);
                        }
                        if let Some(knee) = knee {
                            directional_highlights::<A>(knee, stream, y, halves, planes);
                        }
                    }
                }
            }
            Front::Linear {
                frame,
                steps,
                shading,
            } => {
                let (w, h) = (frame.width(), frame.height());
                let halves = Halves::new(w);
                let gains = match shading {
                    Some((lsc, columns)) => {
                        columns.compute::<A>(lsc, y, h, halves);
                        Some(&*columns.row)
                    }
                    None => None,
                };
                linear_row::<A>(frame.row(y), *steps, gains, knee, halves, planes);
            }
        }
        Ok(())
    }
}

/// One row of a linear frame through the pointwise stages (each channel its own levels and
/// white balance, the pixel's shading gain on all three) and the highlight stage on the pixel
/// itself, into planes.
#[inline(always)]
fn linear_row<A: Planar>(
    raw: &[u16],
    steps: [A::Steps; 3],
    gains: Option<&[A::Gain]>,
    knee: Option<A::Knee>,
    halves: Halves,
    planes: &mut [A::P],
) {
    let w = halves.even + halves.odd;
    let max = |a: A::P, b: A::P| if a > b { a } else { b };
    for (x, px) in raw.chunks_exact(3).enumerate().take(w) {
        let i = if x % 2 == 0 {
            x / 2
        } else {
            halves.even + x / 2
        };
        let mut rgb: [A::P; 3] = core::array::from_fn(|c| match gains {
            Some(g) => A::pointwise_shaded(steps[c], px[c], g[i]),
            None => A::pointwise(steps[c], px[c]),
        });
        if let Some(knee) = knee {
            let brightest = max(max(max(A::P::default(), rgb[0]), rgb[1]), rgb[2]);
            rgb = A::highlights_at_knee(knee, rgb, brightest);
        }
        for (c, v) in rgb.into_iter().enumerate() {
            planes[c * w + i] = v;
        }
    }
}

/// A prepared row's halves (padded) back in column order.
#[inline(always)]
fn unsplit<T: Copy>(halves: Halves, row: &[T], out: &mut [T]) {
    let o = halves.odd_start();
    for (x, v) in out.iter_mut().enumerate() {
        *v = if x % 2 == 0 {
            row[1 + x / 2]
        } else {
            row[o + 1 + x / 2]
        };
    }
}

/// An interleaved RGB row as planes, halves order.
#[inline(always)]
fn split_rgb<T: Copy>(halves: Halves, rgb: &[T], planes: &mut [T]) {
    let w = halves.even + halves.odd;
    for (x, px) in rgb.chunks_exact(3).enumerate() {
        let i = if x % 2 == 0 {
            x / 2
        } else {
            halves.even + x / 2
        };
        for c in 0..3 {
            planes[c * w + i] = px[c];
        }
    }
}

/// Distortion correction in one run: a ring of demosaiced plane rows (the lens's window), the
/// mesh's node rows for the current cell row and the row interpolated between them.
struct Distorter<'s> {
    lens: LensDistortion,
    slots: usize,
    window: RowWindow,
    /// Node rows: the cell row's top and bottom, then the interpolated row (two elements a
    /// node each).
    nodes: &'s mut [i32],
    held: usize,
    /// Rows red and blue read beyond green's (lateral colour), 0 without.
    reach: i64,
}

impl Distorter<'_> {
    /// Corrected row `v` into `out` (planes), demosaicing the rows it reads into `ring`
    /// through `front` (`ring` holds `self.slots` rows of `3 w`).
    #[inline(always)]
    fn row<P: Sample>(
        &mut self,
        v: usize,
        w: usize,
        h: usize,
        ring: &mut [P],
        out: &mut [P],
        mut front: impl FnMut(usize, &mut [P]) -> Result<(), IspError>,
    ) -> Result<(), IspError> {
        let bits = self.lens.mesh_cell().trailing_zeros();
        let columns = self.lens.mesh_columns(w);
        let (top, rest) = self.nodes.split_at_mut(2 * columns);
        let (bottom, row) = rest.split_at_mut(2 * columns);
        let row = &mut row[..2 * columns];
        let j = v >> bits;
        if self.held != j {
            self.lens.mesh_row(j, 0, top);
            self.lens.mesh_row(j + 1, 0, bottom);
            self.held = j;
        }
        interpolate_rows(bits, top, bottom, v, row);
        let mut bounds = (i64::MAX, i64::MIN);
        self.lens.node_row_bounds(row, h, self.reach, &mut bounds);
        if bounds.0 > bounds.1 {
            out[..3 * w].fill(P::default());
            return Ok(());
        }
        let (s0, s1) = (bounds.0 as usize, bounds.1 as usize);
        if s1 - s0 + 1 > self.slots {
            // The ring is the lens's window; a row never reads more.
            return Err(IspError::InvalidParameter {
                name: "distortion",
                allowed: "a lens whose window the scratch was sized for",
            });
        }
        for range in self.window.request(s0, s1, self.slots) {
            for y in range {
                let slot = y % self.slots;
                front(y, &mut ring[slot * 3 * w..(slot + 1) * 3 * w])?;
            }
        }
        let halves = Halves::new(w);
        let index = |x: usize| {
            if x.is_multiple_of(2) {
                x / 2
            } else {
                halves.even + x / 2
            }
        };
        let ring: &[P] = ring;
        let mask = (1usize << bits) - 1;
        if let Some(lca) = self.lens.lateral_colour() {
            let slots = self.slots;
            let read =
                |xi: usize, yi: usize, c: usize| ring[(yi % slots) * 3 * w + c * w + index(xi)];
            for u in 0..w {
                let q = row_position(bits, &row[2 * (u >> bits)..], u & mask);
                let acc = LensDistortion::colour_pixel(lca, q, w, h, read);
                let i = index(u);
                for (c, a) in acc.into_iter().enumerate() {
                    out[c * w + i] = P::scaled_down(a, 10);
                }
            }
            return Ok(());
        }
        for u in 0..w {
            let mut acc = [P::Acc::default(); 3];
            if let Some(q) = row_position(bits, &row[2 * (u >> bits)..], u & mask) {
                for (xi, yi, weight) in taps(q, w, h).into_iter().flatten() {
                    let base = (yi % self.slots) * 3 * w + index(xi);
                    for (c, a) in acc.iter_mut().enumerate() {
                        *a = *a + ring[base + c * w].weighted(weight);
                    }
                }
            }
            let i = index(u);
            for (c, a) in acc.into_iter().enumerate() {
                out[c * w + i] = P::scaled_down(a, 10);
            }
        }
        Ok(())
    }
}

/// Runs rows `rows` of `input` through `path` into `out` on the schedule. `L` is the sites
/// per block of the directional method's integer vector loops; `encode` the 8-bit encoding
/// of a row of planes for the build's ISA.
#[inline(always)]
pub(super) fn run<A: Planar, O: OutputSample, const L: usize>(
    path: &A,
    input: Input<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
    encode: impl Fn(&A, &[A::P], Halves, &mut [O]),
) -> Result<(), IspError> {
    super::check_rows(path, input, &rows, out)?;
    let (w, h) = (input.width(), input.height());
    let shape = super::shape(path, input, &rows)?;
    let needed = super::scratch_for::<A>(&shape).ok_or(TOO_WIDE)?;
    if scratch.len() < needed {
        return Err(IspError::BufferTooSmall {
            needed,
            provided: scratch.len(),
        });
    }
    let layout = shape.layout();
    let halves = Halves::new(w);
    let mut carve = Carve { rest: scratch };
    let ring = carve.take::<A::P>(layout.slots * halves.len())?;
    let fallback = match layout.rows_fallback {
        true => Some(carve.take::<A::P>(8 * w)?),
        false => None,
    };
    let directional_part = match layout.directional {
        true => {
            let n = crate::demosaic::directional::scratch_len(w).ok_or(TOO_WIDE)?;
            let len = typed_len::<A::P, <A::Directional as Arithmetic>::E>(n).ok_or(TOO_WIDE)?;
            Some(A::directional_planes(carve.take::<A::P>(len)?))
        }
        false => None,
    };
    let nr_parts = match layout.nr {
        Some((samples, work, sums)) => Some((
            carve.take::<A::P>(samples)?,
            carve.take::<A::NrWork>(work)?,
            carve.take::<A::NrSum>(sums)?,
            carve.take::<A::P>(2 * w)?,
        )),
        None => None,
    };
    let shading_part = match shape.shading {
        true => Some(carve.take::<A::Gain>(2 * w)?),
        false => None,
    };
    let planes = carve.take::<A::P>(3 * w)?;
    let distortion_parts = match layout.distortion {
        Some((window, columns)) => Some((
            window,
            carve.take::<A::P>(window * 3 * w)?,
            carve.take::<A::P>(3 * w)?,
            carve.take::<i32>(6 * columns)?,
        )),
        None => None,
    };
    let detail_part = carve.rest;

    let mut front = match input {
        Input::Mosaic(raw) => {
            let pattern = raw.mosaic().pattern();
            let white = raw.white_level();
            let steps: [[A::Steps; 2]; 2] = core::array::from_fn(|ry| {
                core::array::from_fn(|rx| {
                    let colour = pattern.colour_at(rx, ry).index();
                    path.steps(raw.black_at(rx, ry), white, colour)
                })
            });
            let nr = match (nr_parts, path.nlm(pattern)) {
                (Some((samples, work, sums, filtered)), Some((nlm, search))) => Some(Nr {
                    stream: denoise::Stream::new(nlm, search, w / 2, h / 2, samples, work, sums)?,
                    filtered,
                }),
                _ => None,
            };
            let demosaic = match (fallback, directional_part) {
                (Some(rows), _) => Demosaicer::Rows {
                    method: path.method(),
                    rows,
                },
                (None, Some(part)) => match Stream::new(w, h, pattern, part)? {
                    Some(stream) => Demosaicer::Directional(stream),
                    None => Demosaicer::Planar(Method::Bilinear),
                },
                (None, None) => Demosaicer::Planar(path.method()),
            };
            Front::Mosaic {
                source: Source {
                    raw,
                    dpc: path.dpc(),
                    halves,
                    steps,
                    ring,
                    tags: [usize::MAX; DENOISED_ROWS],
                    slots: layout.slots,
                    shading: shading_part.and_then(|part| shading_for(path, w, halves, part)),
                    nr,
                },
                demosaic,
            }
        }
        Input::Linear(frame) => {
            let (black, white) = (frame.black_level(), frame.white_level());
            Front::Linear {
                frame,
                steps: core::array::from_fn(|c| path.steps(black[c], white[c], c)),
                shading: shading_part.and_then(|part| shading_for(path, w, halves, part)),
            }
        }
    };
    let detail = shape.detail;
    match distortion_parts {
        None => emit_rows::<A, O>(
            path,
            h,
            halves,
            detail,
            rows,
            planes,
            detail_part,
            out,
            encode,
            #[inline(always)]
            |y, planes| front.row::<L>(path, y, planes),
        ),
        Some((window, ring, corrected, nodes)) => {
            let lens = *path.distortion().ok_or(TOO_WIDE)?;
            let mut distorter = Distorter {
                lens,
                slots: window,
                window: RowWindow::default(),
                nodes,
                held: usize::MAX,
                reach: lens.colour_reach(w, h),
            };
            emit_rows::<A, O>(
                path,
                h,
                halves,
                detail,
                rows,
                planes,
                detail_part,
                out,
                encode,
                #[inline(always)]
                |y, planes| {
                    distorter.row(y, w, h, ring, corrected, |v, dst| {
                        front.row::<L>(path, v, dst)
                    })?;
                    planes[..3 * w].copy_from_slice(&corrected[..3 * w]);
                    Ok(())
                },
            )
        }
    }
}

/// The linear planes of a row after the colour matrix (clamped as the encodings take them)
/// and tone.
#[inline(always)]
fn linear_finish<A: Planar>(path: &A, matrix: Option<&A::Matrix>, planes: &mut [A::P], w: usize) {
    matrix_row::<A>(matrix, planes, w);
    if path.tone_on() {
        path.tone_row(planes, w);
    }
}

/// Writes output rows `rows`, each from linear planes that `produce(y, planes)` fills for
/// frame row `y`: through the colour matrix, tone and the encoding; or with sharpening on, each
/// row encoded into a ring (rows produced in order, each once) and the output row sharpened
/// from the encoded rows above, at and below it (reflected at the frame's edges); or with
/// chroma noise reduction on, each row encoded, split and filtered along itself into a ring
/// of seven, and the output row filtered down the ring (and sharpened).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn emit_rows<A: Planar, O: OutputSample>(
    path: &A,
    h: usize,
    halves: Halves,
    detail: Detail,
    rows: Range<usize>,
    planes: &mut [A::P],
    detail_part: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
    encode: impl Fn(&A, &[A::P], Halves, &mut [O]),
    mut produce: impl FnMut(usize, &mut [A::P]) -> Result<(), IspError>,
) -> Result<(), IspError> {
    let w = halves.even + halves.odd;
    let matrix = path.matrix();
    match detail {
        Detail::Off => {
            for y in rows.clone() {
                produce(y, planes)?;
                linear_finish::<A>(path, matrix.as_ref(), planes, w);
                let row = out.row_mut(y - rows.start);
                if O::BITS == 8 {
                    encode(path, planes, halves, row);
                } else {
                    interleave(planes, halves, row, |v| path.encoded_output::<O>(v));
                }
            }
            Ok(())
        }
        Detail::Sharpen => {
            let Some(amount) = path.sharpening() else {
                return Ok(());
            };
            let slot_len = 4 * w;
            let ring = &mut detail_part[..SHARPEN_ROWS * slot_len];
            let mut tags = [usize::MAX; SHARPEN_ROWS];
            for y in rows.clone() {
                let taps = [-1isize, 0, 1].map(|dy| reflect(y as isize + dy, h));
                let (lo, hi) = (taps[0].min(y), taps[2].max(y));
                for v in lo..=hi {
                    let slot = v % SHARPEN_ROWS;
                    if tags[slot] == v {
                        continue;
                    }
                    produce(v, planes)?;
                    linear_finish::<A>(path, matrix.as_ref(), planes, w);
                    let encoded = &mut ring[slot * slot_len..(slot + 1) * slot_len];
                    encode_for_sharpening(path, planes, encoded, w);
                    tags[slot] = v;
                }
                let ring: &[A::P] = ring;
                let encoded = taps.map(|v| {
                    let slot = v % SHARPEN_ROWS;
                    &ring[slot * slot_len..(slot + 1) * slot_len]
                });
                sharpen_row::<A, O>(amount, encoded, halves, planes);
                interleave(
                    planes,
                    halves,
                    out.row_mut(y - rows.start),
                    A::output_of::<O>,
                );
            }
            Ok(())
        }
        Detail::Chroma => {
            let Some(params) = path.chroma_params() else {
                return Ok(());
            };
            let chroma_part = bytemuck::pod_align_to_mut::<A::P, A::Chroma>(detail_part).1;
            let split_len = SPLIT * (w + 2 * RADIUS);
            let slot_len = SPLIT * (w + 2 * CHROMA_PAD);
            let (split, rest) = chroma_part.split_at_mut(split_len);
            let (ring, rest) = rest.split_at_mut(TAPS * slot_len);
            let (vertical, rest) = rest.split_at_mut(SPLIT * w);
            let (row_weights, rest) = rest.split_at_mut(chroma::row_weights_len(w));
            let mut column = ColumnPass::new(&mut rest[..COLUMN_WEIGHT_ROWS * w], w);
            let mut window = RowWindow::default();
            for y in rows.clone() {
                let taps: [usize; TAPS] =
                    core::array::from_fn(|k| reflect(y as isize + k as isize - RADIUS as isize, h));
                let lo = taps.iter().fold(y, |m, v| m.min(*v));
                let hi = taps.iter().fold(y, |m, v| m.max(*v));
                for range in window.request(lo, hi, TAPS) {
                    for v in range {
                        produce(v, planes)?;
                        linear_finish::<A>(path, matrix.as_ref(), planes, w);
                        let slot = v % TAPS;
                        chroma_horizontal::<A>(
                            path,
                            &params,
                            planes,
                            halves,
                            split,
                            &mut ring[slot * slot_len..(slot + 1) * slot_len],
                            row_weights,
                        );
                    }
                }
                let ring: &[A::Chroma] = ring;
                let rows_k: [&[A::Chroma]; TAPS] =
                    taps.map(|v| &ring[(v % TAPS) * slot_len..(v % TAPS + 1) * slot_len]);
                chroma_vertical::<A>(&params, &mut column, rows_k, y, w, vertical);
                chroma_output::<A, O>(
                    path.sharpening(),
                    [rows_k[RADIUS - 1], rows_k[RADIUS], rows_k[RADIUS + 1]],
                    vertical,
                    w,
                    out.row_mut(y - rows.start),
                );
            }
            Ok(())
        }
    }
}

/// The colour matrix on one row of demosaiced planes, each value then clamped as the 8-bit
/// encoding takes it (or the clamp alone, where there is no matrix).
#[inline(always)]
fn matrix_row<A: Planar>(matrix: Option<&A::Matrix>, planes: &mut [A::P], w: usize) {
    if let Some(m) = matrix {
        let (r, rest) = planes.split_at_mut(w);
        let (g, b) = rest.split_at_mut(w);
        for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
            let [cr, cg, cb] = A::colour_matrix(m, [*r, *g, *b]);
            *r = A::clamp_for_code8(cr);
            *g = A::clamp_for_code8(cg);
            *b = A::clamp_for_code8(cb);
        }
    } else if A::CLAMPS_FOR_CODE8 {
        for v in planes[..3 * w].iter_mut() {
            *v = A::clamp_for_code8(*v);
        }
    }
}

/// A row of linear planes (after [`linear_finish`]) into one row of the sharpening ring: the
/// encoded planes, then the luma of each pixel.
#[inline(always)]
fn encode_for_sharpening<A: Planar>(path: &A, planes: &[A::P], slot: &mut [A::P], w: usize) {
    let (encoded, luma) = slot.split_at_mut(3 * w);
    for (e, v) in encoded.iter_mut().zip(&planes[..3 * w]) {
        *e = path.encode_for_detail(*v);
    }
    let (r, rest) = encoded.split_at(w);
    let (g, b) = rest.split_at(w);
    for (((y, r), g), b) in luma[..w].iter_mut().zip(r).zip(g).zip(b) {
        *y = A::luma([*r, *g, *b]);
    }
}

/// The sharpening stage on the middle row of three ring rows (`rows`: above, at, below),
/// into `values` (three planes, halves as the planes, of [`Planar::sharpened`] values). A
/// site's neighbours left and right are in the other half: for the even column `2i` the odd
/// sites `i - 1` and `i`, for the odd column `2i + 1` the even sites `i` and `i + 1`. The sites
/// whose neighbour lies past the frame's edge (reflect-101) are done one by one, the rest in
/// one loop per half over equal-length slices, which vectorises.
#[inline(always)]
fn sharpen_row<A: Planar, O: OutputSample>(
    amount: A::Sharpen,
    rows: [&[A::P]; 3],
    halves: Halves,
    values: &mut [A::P],
) {
    let (ne, no) = (halves.even, halves.odd);
    let w = ne + no;
    let luma = rows.map(|row| row[3 * w..4 * w].split_at(ne));
    let centre = rows[1];
    // Interior even sites 1..even_end, odd sites 0..odd_end.
    let even_end = if ne > no { ne - 1 } else { ne };
    let odd_end = if ne > no { no } else { no.saturating_sub(1) };
    let (r, rest) = values[..3 * w].split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    let (r_even, r_odd) = r.split_at_mut(ne);
    let (g_even, g_odd) = g.split_at_mut(ne);
    let (b_even, b_odd) = b.split_at_mut(ne);
    if even_end > 1 {
        let n = even_end - 1;
        // Site i + 1 of the even half: odd i to the left, odd i + 1 to the right.
        let taps = luma.map(|(even, odd)| [&odd[..n], &even[1..1 + n], &odd[1..1 + n]]);
        let channels = [0, 1, 2].map(|c| &centre[c * w + 1..c * w + 1 + n]);
        sharpen_span::<A, O>(
            amount,
            taps,
            channels,
            [
                &mut r_even[1..1 + n],
                &mut g_even[1..1 + n],
                &mut b_even[1..1 + n],
            ],
        );
    }
    if odd_end > 0 {
        let n = odd_end;
        // Site i of the odd half: even i to the left, even i + 1 to the right.
        let taps = luma.map(|(even, odd)| [&even[..n], &odd[..n], &even[1..1 + n]]);
        let channels = [0, 1, 2].map(|c| &centre[c * w + ne..c * w + ne + n]);
        sharpen_span::<A, O>(
            amount,
            taps,
            channels,
            [&mut r_odd[..n], &mut g_odd[..n], &mut b_odd[..n]],
        );
    }
    // The edge sites: column 0, and the last column or two (and every site of a frame under
    // three columns wide).
    let index = |x: usize| {
        if x.is_multiple_of(2) {
            x / 2
        } else {
            ne + x / 2
        }
    };
    let mut edge = |x: usize| {
        let columns = [-1isize, 0, 1].map(|dx| index(reflect(x as isize + dx, w)));
        let luma = rows.map(|row| columns.map(|i| row[3 * w + i]));
        let detail = A::detail(amount, luma);
        let i = index(x);
        for c in 0..3 {
            values[c * w + i] = A::sharpened::<O>(centre[c * w + i], detail);
        }
    };
    edge(0);
    for x in [2 * even_end, 2 * odd_end + 1] {
        if x > 0 && x < w {
            edge(x);
        }
    }
    if w < 3 {
        for x in 1..w {
            edge(x);
        }
    }
}

/// [`sharpen_row`]'s loop over `n` sites of one half: `luma[row][column]` the luma of the
/// rows above, at and below, at the columns left, at and right of each site, `channels` the
/// sites' encoded channels, `values` their sharpened values.
#[inline(always)]
fn sharpen_span<A: Planar, O: OutputSample>(
    amount: A::Sharpen,
    luma: [[&[A::P]; 3]; 3],
    channels: [&[A::P]; 3],
    values: [&mut [A::P]; 3],
) {
    let [r, g, b] = values;
    let n = r.len();
    let (g, b) = (&mut g[..n], &mut b[..n]);
    let [cr, cg, cb] = channels.map(|c| &c[..n]);
    let [[ul, uc, ur], [ml, mc, mr], [dl, dc, dr]] = luma.map(|row| row.map(|s| &s[..n]));
    for i in 0..n {
        let detail = A::detail(
            amount,
            [
                [ul[i], uc[i], ur[i]],
                [ml[i], mc[i], mr[i]],
                [dl[i], dc[i], dr[i]],
            ],
        );
        r[i] = A::sharpened::<O>(cr[i], detail);
        g[i] = A::sharpened::<O>(cg[i], detail);
        b[i] = A::sharpened::<O>(cb[i], detail);
    }
}

/// A row of linear planes (after [`linear_finish`]) encoded for detail, split into luma and
/// chroma in column order with [`RADIUS`] reflected pixels either side (`split`, four planes),
/// then filtered along the row into `slot` (four planes with [`CHROMA_PAD`] reflected pixels
/// either side, for the sharpening's luma).
#[inline(always)]
fn chroma_horizontal<A: Planar>(
    path: &A,
    params: &A::ChromaParams,
    planes: &mut [A::P],
    halves: Halves,
    split: &mut [A::Chroma],
    slot: &mut [A::Chroma],
    weights: &mut [A::Chroma],
) {
    let w = halves.even + halves.odd;
    for v in planes[..3 * w].iter_mut() {
        *v = path.encode_for_detail(*v);
    }
    let stride = w + 2 * RADIUS;
    {
        let (y_plane, rest) = split.split_at_mut(stride);
        let (r_plane, rest) = rest.split_at_mut(stride);
        let (g_plane, b_plane) = rest.split_at_mut(stride);
        let [pr, pg, pb] = [0, 1, 2].map(|c| &planes[c * w..(c + 1) * w]);
        // Column x is at RADIUS + x: even columns from the even halves, odd from the odd.
        for parity in 0..2 {
            let (start, n) = match parity {
                0 => (0, halves.even),
                _ => (halves.even, halves.odd),
            };
            let at = |i: usize| RADIUS + 2 * i + parity;
            for i in 0..n {
                let j = start + i;
                let [y, r, g, b] = A::split([pr[j], pg[j], pb[j]]);
                y_plane[at(i)] = y;
                r_plane[at(i)] = r;
                g_plane[at(i)] = g;
                b_plane[at(i)] = b;
            }
        }
        for plane in [&mut *y_plane, r_plane, g_plane, &mut b_plane[..stride]] {
            for k in 0..RADIUS {
                plane[k] = plane[RADIUS + reflect(k as isize - RADIUS as isize, w)];
                plane[RADIUS + w + k] = plane[RADIUS + reflect((w + k) as isize, w)];
            }
        }
    }
    let row: [&[A::Chroma]; SPLIT] = core::array::from_fn(|c| &split[c * stride..(c + 1) * stride]);
    let out_stride = w + 2 * CHROMA_PAD;
    let (o0, rest) = slot.split_at_mut(out_stride);
    let (o1, rest) = rest.split_at_mut(out_stride);
    let (o2, o3) = rest.split_at_mut(out_stride);
    let o3 = &mut o3[..out_stride];
    chroma::pass_row(
        params,
        row,
        [
            &mut o0[CHROMA_PAD..CHROMA_PAD + w],
            &mut o1[CHROMA_PAD..CHROMA_PAD + w],
            &mut o2[CHROMA_PAD..CHROMA_PAD + w],
            &mut o3[CHROMA_PAD..CHROMA_PAD + w],
        ],
        weights,
    );
    for plane in [o0, o1, o2, o3] {
        plane[0] = plane[CHROMA_PAD + reflect(-1, w)];
        plane[CHROMA_PAD + w] = plane[CHROMA_PAD + reflect(w as isize, w)];
    }
}

/// The chroma stage's vertical pass for output row `y`, the middle of `rows` (seven ring
/// rows), into `vertical` (four planes of `w`).
#[inline(always)]
fn chroma_vertical<A: Planar>(
    params: &A::ChromaParams,
    column: &mut ColumnPass<'_, A::Chroma>,
    rows: [&[A::Chroma]; TAPS],
    y: usize,
    w: usize,
    vertical: &mut [A::Chroma],
) {
    let stride = w + 2 * CHROMA_PAD;
    let taps: [[&[A::Chroma]; SPLIT]; TAPS] = rows.map(|row| {
        core::array::from_fn(|c| &row[c * stride + CHROMA_PAD..c * stride + CHROMA_PAD + w])
    });
    let (o0, rest) = vertical.split_at_mut(w);
    let (o1, rest) = rest.split_at_mut(w);
    let (o2, o3) = rest.split_at_mut(w);
    column.pass(params, taps, y, [o0, o1, o2, &mut o3[..w]]);
}

/// Luma plus filtered chroma (plus the sharpening's detail from the luma of the ring rows
/// above, at and below, `around`) into an interleaved output row: the values first, in
/// place in `vertical`'s chroma planes (a loop that vectorises), then interleaved.
#[inline(always)]
fn chroma_output<A: Planar, O: OutputSample>(
    sharpen: Option<A::Sharpen>,
    around: [&[A::Chroma]; 3],
    vertical: &mut [A::Chroma],
    w: usize,
    out: &mut [O],
) {
    let (y, rest) = vertical.split_at_mut(w);
    let (r, rest) = rest.split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    let b = &mut b[..w];
    match sharpen {
        Some(amount) => {
            // Luma planes are the rows' first planes; column x is at x + CHROMA_PAD.
            let [up, mid, down] = around.map(|row| &row[..w + 2 * CHROMA_PAD]);
            for x in 0..w {
                let luma = [up, mid, down].map(|row| [x, x + 1, x + 2].map(|i| A::luma_of(row[i])));
                let detail = A::detail(amount, luma);
                r[x] = A::combined::<O>(y[x], r[x], detail);
                g[x] = A::combined::<O>(y[x], g[x], detail);
                b[x] = A::combined::<O>(y[x], b[x], detail);
            }
        }
        None => {
            for x in 0..w {
                r[x] = A::combined::<O>(y[x], r[x], A::no_detail());
                g[x] = A::combined::<O>(y[x], g[x], A::no_detail());
                b[x] = A::combined::<O>(y[x], b[x], A::no_detail());
            }
        }
    }
    for (((px, r), g), b) in out.chunks_exact_mut(3).zip(&*r).zip(&*g).zip(&*b) {
        px[0] = A::chroma_output_of::<O>(*r);
        px[1] = A::chroma_output_of::<O>(*g);
        px[2] = A::chroma_output_of::<O>(*b);
    }
}

/// Three planes (each even half, then odd half) into an interleaved RGB row, each sample
/// through `sample`.
#[inline(always)]
fn interleave<P: Copy, O>(planes: &[P], halves: Halves, out: &mut [O], sample: impl Fn(P) -> O) {
    let w = halves.even + halves.odd;
    let [(r_even, r_odd), (g_even, g_odd), (b_even, b_odd)] =
        colour_planes(planes, halves).map(|plane| plane.split_at(halves.even));
    // Zipped, not indexed by `even + i`: two bounds checks per pair of pixels fewer.
    let evens = r_even.iter().zip(g_even).zip(b_even);
    let odds = r_odd.iter().zip(g_odd).zip(b_odd);
    let pairs = out[..6 * halves.odd].chunks_exact_mut(6);
    for (px, (((re, ge), be), ((ro, go), bo))) in pairs.zip(evens.zip(odds)) {
        px[0] = sample(*re);
        px[1] = sample(*ge);
        px[2] = sample(*be);
        px[3] = sample(*ro);
        px[4] = sample(*go);
        px[5] = sample(*bo);
    }
    if halves.even > halves.odd {
        let i = halves.even - 1;
        out[3 * (w - 1)] = sample(r_even[i]);
        out[3 * (w - 1) + 1] = sample(g_even[i]);
        out[3 * (w - 1) + 2] = sample(b_even[i]);
    }
}

/// The red, green and blue planes of a row of planes, each `halves.even + halves.odd` long.
#[inline(always)]
fn colour_planes<P>(planes: &[P], halves: Halves) -> [&[P]; 3] {
    let w = halves.even + halves.odd;
    [0, 1, 2].map(|c| &planes[c * w..(c + 1) * w])
}

/// The schedule compiled for the baseline target, out of line.
#[inline(never)]
pub(super) fn run_general<A: Planar, O: OutputSample>(
    path: &A,
    input: Input<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    run::<A, O, LANES>(path, input, rows, scratch, out, encode_row)
}

/// The schedule compiled for AVX2 (and FMA, for the float path's encoder,
/// [`encode_row_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
pub(super) fn run_avx2<A: Planar, O: OutputSample>(
    path: &A,
    input: Input<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let encode = |path: &A, planes: &[A::P], halves: Halves, out: &mut [O]| {
        encode_row_avx2(path, planes, halves, out)
    };
    run::<A, O, LANES>(path, input, rows, scratch, out, encode)
}

/// The schedule compiled for AVX-512 (F, BW, VL, DQ).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
#[inline(never)]
pub(super) fn run_avx512<A: Planar, O: OutputSample>(
    path: &A,
    input: Input<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let encode = |path: &A, planes: &[A::P], halves: Halves, out: &mut [O]| {
        encode_row_avx512(path, planes, halves, out)
    };
    run::<A, O, LANES_AVX512>(path, input, rows, scratch, out, encode)
}

/// [`encode_row`] with AVX2 and FMA where the path's encoding is the float path's 8-bit
/// thresholds: the same codes, the curve evaluated eight samples at a time instead of two
/// table loads per sample ([`srgb::avx2::encode_halves8`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) fn encode_row_avx2<A: Planar, O: OutputSample>(
    path: &A,
    planes: &[A::P],
    halves: Halves,
    out: &mut [O],
) {
    match (path.thresholds8_planes(planes), O::as_bytes_mut(out)) {
        (Some((codes, planes)), Some(bytes)) => srgb::avx2::encode_halves8(
            codes,
            colour_planes(planes, halves),
            halves.even,
            halves.odd,
            bytes,
        ),
        _ => encode_row(path, planes, halves, out),
    }
}

/// [`encode_row`] with AVX-512 (F and BW) where the path's encoding is the fixed path's
/// 8-bit table: the same codes without a table load per sample
/// ([`srgb::avx512::encode_halves8`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw")]
pub(super) fn encode_row_avx512<A: Planar, O: OutputSample>(
    path: &A,
    planes: &[A::P],
    halves: Halves,
    out: &mut [O],
) {
    match (path.lookup8_planes(planes), O::as_bytes_mut(out)) {
        (Some((lut, planes)), Some(bytes)) => srgb::avx512::encode_halves8(
            lut,
            colour_planes(planes, halves),
            halves.even,
            halves.odd,
            bytes,
        ),
        _ => encode_row_avx2(path, planes, halves, out),
    }
}

/// The highlight stage after the directional method: each pixel with the largest sample of
/// the 3x3 around it in the rows the stream holds (its working values, which leave it as the
/// prepared samples; the maximum leaves as the maximum, since leaving is monotone), as the
/// general engine reads them. Without a branch per pixel, like [`highlights_row`].
#[inline(always)]
fn directional_highlights<A: Planar>(
    knee: A::Knee,
    stream: &Stream<'_, A::Directional>,
    y: usize,
    halves: Halves,
    planes: &mut [A::P],
) {
    let w = halves.even + halves.odd;
    let (r, rest) = planes.split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    let (rows, half) = stream.mosaic_around(y);
    let max = |a, b| if a > b { a } else { b };
    // Frame column 2i (even) is at index i + HALO / 2 of the even half, its neighbours at
    // i + HALO / 2 - 1 and i + HALO / 2 of the odd half; frame column 2i + 1 the other way
    // round, its right neighbour one further on.
    const AT: usize = HALO / 2;
    for parity in 0..2 {
        let (start, n) = match parity {
            0 => (0, halves.even),
            _ => (halves.even, halves.odd),
        };
        let [up, mid, down] = rows;
        fn span<E>(row: &[E], from: usize, n: usize) -> &[E] {
            &row[from..from + n]
        }
        let span = |row, from| span(row, from, n);
        let (same_at, left_at, right_at) = match parity {
            0 => (AT, half + AT - 1, half + AT),
            _ => (half + AT, AT, AT + 1),
        };
        let (u, m, d) = (span(up, same_at), span(mid, same_at), span(down, same_at));
        let (ul, ml, dl) = (span(up, left_at), span(mid, left_at), span(down, left_at));
        let (ur, mr, dr) = (
            span(up, right_at),
            span(mid, right_at),
            span(down, right_at),
        );
        let (r, g, b) = (
            &mut r[start..start + n],
            &mut g[start..start + n],
            &mut b[start..start + n],
        );
        for i in 0..n {
            let brightest = max(
                max(max(ul[i], u[i]), max(ur[i], ml[i])),
                max(max(m[i], mr[i]), max(max(dl[i], d[i]), dr[i])),
            );
            let brightest = <A::Directional as Arithmetic>::leave(brightest);
            [r[i], g[i], b[i]] = A::highlights_at_knee(knee, [r[i], g[i], b[i]], brightest);
        }
    }
}

/// The highlight stage on the demosaiced planes: each pixel with the largest prepared sample
/// of the 3x3 around it (the reflected columns at the edges, as the engine reads them),
/// without a branch per pixel ([`Planar::highlights_at_knee`]), so the loop vectorises.
#[inline(always)]
fn highlights_row<A: Planar>(
    knee: A::Knee,
    source: [&[A::P]; 5],
    halves: Halves,
    planes: &mut [A::P],
) {
    let w = halves.even + halves.odd;
    let (r, rest) = planes.split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    // A select, not `Ord::max`/`f32::max` (a call, or a NaN rule): the samples are never NaN.
    let max = |a: A::P, b: A::P| if a > b { a } else { b };
    for parity in 0..2 {
        let [(up, up_other), (mid, mid_other), (down, down_other)] =
            [1, 2, 3].map(|k| halves.sites(source[k], parity));
        let (start, n) = match parity {
            0 => (0, halves.even),
            _ => (halves.even, halves.odd),
        };
        let (r, g, b) = (
            &mut r[start..start + n],
            &mut g[start..start + n],
            &mut b[start..start + n],
        );
        let (up, mid, down) = (&up[..n + 2], &mid[..n + 2], &down[..n + 2]);
        let (up_other, mid_other, down_other) = (
            &up_other[..n + 1],
            &mid_other[..n + 1],
            &down_other[..n + 1],
        );
        for i in 0..n {
            let brightest = max(
                max(
                    max(up_other[i], up[i + 1]),
                    max(up_other[i + 1], mid_other[i]),
                ),
                max(
                    max(mid[i + 1], mid_other[i + 1]),
                    max(max(down_other[i], down[i + 1]), down_other[i + 1]),
                ),
            );
            [r[i], g[i], b[i]] = A::highlights_at_knee(knee, [r[i], g[i], b[i]], brightest);
        }
    }
}

/// Encodes the planes to 8-bit sRGB, interleaving the halves into the output row.
#[inline(always)]
pub(super) fn encode_row<A: Planar, O: OutputSample>(
    path: &A,
    planes: &[A::P],
    halves: Halves,
    out: &mut [O],
) {
    // The planes come from matrix_row, which clamped them.
    interleave(planes, halves, out, |v: A::P| {
        O::from_code(path.code8_clamped(v))
    });
}

/// The fixed path's Q16 colour matrix (also its saturation matrix) in `u32` and `i32` lanes.
#[cfg(test)]
mod tests {
    use super::CcmSplit;
    use crate::ccm;
    use crate::pipeline::CCM_FRAC_BITS;

    /// The split colour matrix is the general engine's `i64` one, at the extreme
    /// coefficients (-8 and just below 8 in Q16), the samples' byte edges and full scale, and
    /// over random matrices and pixels.
    #[test]
    fn ccm_split_is_the_engine_matrix() {
        let mut next = crate::math::xorshift(0x9e37_79b9_7f4a_7c15);
        let extremes = [
            -(8 << 16),
            (8 << 16) - 1,
            0,
            1,
            -1,
            1 << 16,
            -(1 << 15),
            12345,
        ];
        let samples = [
            0u16, 1, 127, 128, 255, 256, 257, 32767, 32768, 65280, 65534, 65535,
        ];
        for round in 0..20_000 {
            let m: [[i32; 3]; 3] = core::array::from_fn(|_| {
                core::array::from_fn(|_| {
                    if round % 2 == 0 {
                        extremes[(next() % extremes.len() as u64) as usize]
                    } else {
                        (next() % (1 << 20)) as i32 - (1 << 19)
                    }
                })
            });
            let split = CcmSplit::new(&m);
            for _ in 0..8 {
                let rgb: [u16; 3] = core::array::from_fn(|_| {
                    if next().is_multiple_of(2) {
                        samples[(next() % samples.len() as u64) as usize]
                    } else {
                        next() as u16
                    }
                });
                assert_eq!(
                    split.apply(rgb),
                    ccm::apply_u16(&m, CCM_FRAC_BITS, rgb),
                    "{m:?} {rgb:?}"
                );
            }
        }
    }
}
