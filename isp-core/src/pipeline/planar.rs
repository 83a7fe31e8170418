//! The common camera pipeline (defect correction, black level, gain, white balance, bilinear,
//! MHC or directional, highlights, colour matrix, 8-bit sRGB, sharpening), scheduled over planar rows so
//! that every stage but the encoding is a loop over contiguous slices that the compiler
//! vectorises. Both paths run it. The directional method is its own stream (see
//! [`run_directional`]), between the same preparation and finish.
//! The arithmetic is the general engine's, operation for operation (the float sums in the
//! same order); only the layout and the order of the loops differ, so the output is
//! bit-identical (tested).
//!
//! - A prepared mosaic row is held as its even columns, then its odd columns, each with one
//!   reflected sample on either side ([`Halves`]). Within one half every sample has the same
//!   CFA position, so the pointwise stage is one set of constants per half, and a demosaic
//!   filter at every site of a half reads the same offsets: `x - 2`, `x`, `x + 2` of the
//!   site's own half and `x - 1`, `x + 1` of the other half. The padding makes the frame's
//!   reflect-101 border the same loop as the interior.
//! - The demosaiced row is three planes (R, G, B), each even half then odd half, one filter
//!   (a tap table of `demosaic`) per plane and half; the colour matrix runs on the planes; the
//!   encoding (table loads, the one gather; in the fixed path's AVX-512 entries a search in
//!   registers, [`srgb::avx512`]; in the float path's AVX2 entries the curve evaluated,
//!   [`srgb::avx2`]) writes the interleaved output. The highlight
//!   stage, when on, is a loop over the planes without a branch per pixel, so it vectorises
//!   too.
//! - With sharpening on, each row after the colour matrix is encoded (16-bit codes in the
//!   fixed path, the exact curve in `f32` in the float path) into a ring of three rows, with
//!   its luma, one row ahead of the output; the unsharp mask then reads a site's left and
//!   right neighbours from the other half and writes three planes of 8-bit codes, which one
//!   pass interleaves ([`emit_rows`]).
//! - The fixed path keeps the general engine's `u64`/`i64` products in `u32`/`i32` lanes by
//!   splitting each Q16 constant into its integer and fraction parts ([`MulQ16`],
//!   [`CcmSplit`]), which is exact.

use core::ops::Range;

use super::{FixedPipeline, FloatPipeline, OutputSample, Path, CHUNK, IDENTITY, MOSAIC_ROWS};
#[cfg(target_arch = "x86_64")]
use crate::demosaic::directional::LANES_AVX512;
use crate::demosaic::directional::{Arithmetic, OutputRow, Stream, HALO, LANES};
use crate::demosaic::planar::{demosaic_row, Halves};
use crate::demosaic::{reflect, Method};
use crate::dpc;
use crate::frame::{RawFrame, RgbViewMut};
use crate::highlights::{self, KneeQ16};
use crate::{ccm, srgb, IspError};

/// Narrowest frame the planar schedule takes; the padding reflects within the first and last
/// four columns.
const MIN_WIDTH: usize = 8;

/// What the planar schedule needs of a path beyond the engine's [`Path`].
pub(super) trait Planar: Path<P: PartialOrd> {
    /// The pointwise stage's constants for one CFA position.
    type Steps: Copy;
    /// The colour matrix in the form the planar loop applies.
    type Matrix;
    /// Whether everything the general engine would do to `raw` with output samples `O` is
    /// among the planar schedule's stages.
    fn planar_takes<O: OutputSample>(&self, raw: &RawFrame<'_>) -> bool;
    /// The pointwise constants of each CFA position, `[row parity][column parity]`.
    fn steps(&self, raw: &RawFrame<'_>) -> [[Self::Steps; 2]; 2];
    /// Black level, normalisation, gain and white balance of one corrected raw sample.
    fn pointwise(steps: Self::Steps, raw: u16) -> Self::P;
    /// The colour matrix, if it is on.
    fn matrix(&self) -> Option<Self::Matrix>;
    /// The colour matrix at one pixel.
    fn colour_matrix(m: &Self::Matrix, rgb: [Self::P; 3]) -> [Self::P; 3];
    /// Whether [`Planar::clamp_for_code8`] changes values (else a row without a colour
    /// matrix skips its pass).
    const CLAMPS_FOR_CODE8: bool;
    /// A linear value as [`Planar::code8_clamped`] takes it, formed in a vector loop (the
    /// colour matrix's, or a pass of its own) so that the scalar lookups need not clamp: the
    /// float path clamps to `[0, 1]` here.
    fn clamp_for_code8(v: Self::P) -> Self::P;
    /// The 8-bit sRGB code of a linear value from [`Planar::clamp_for_code8`].
    fn code8_clamped(&self, v: Self::P) -> u32;
    /// Where [`Self::code8_clamped`] is [`srgb::EncodeLut::lookup8`] of `u16` samples (the fixed
    /// path), that table and `planes` as `u16`: for the vectorised encoder.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn lookup8_planes<'a>(
        &'a self,
        _planes: &'a [Self::P],
    ) -> Option<(&'a srgb::EncodeLut, &'a [u16])> {
        None
    }
    /// Where [`Self::code8_clamped`] is [`srgb::EncodeThresholds8::code_clamped`] of `f32`
    /// samples (the float path), those thresholds and `planes` as `f32`: for the vectorised
    /// encoder.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn thresholds8_planes<'a>(
        &'a self,
        _planes: &'a [Self::P],
    ) -> Option<(&'a srgb::EncodeThresholds8, &'a [f32])> {
        None
    }
    /// The sharpening stage's amount (the path's own form of it).
    type Sharpen: Copy;
    /// The sharpening stage's amount, if it is on.
    fn sharpening(&self) -> Option<Self::Sharpen>;
    /// A linear value from [`Planar::clamp_for_code8`] in the encoded domain the sharpening
    /// stage works in ([`Path::encoded_row`]'s: the exact curve in `f32`, 16-bit codes).
    fn encode_for_sharpening(&self, v: Self::P) -> Self::P;
    /// The Rec. 709 luma of an encoded pixel, as [`Path::sharpen_row`] forms it.
    fn luma(e: [Self::P; 3]) -> Self::P;
    /// The detail the sharpening stage adds to each channel of a pixel, from the luma of the
    /// 3x3 pixels around it, `luma[row][column]` (rows and columns -1, 0, 1), formed as
    /// [`Path::sharpen_row`] forms it.
    type Detail: Copy;
    /// See [`Planar::Detail`].
    fn detail(amount: Self::Sharpen, luma: [[Self::P; 3]; 3]) -> Self::Detail;
    /// The 8-bit code of an encoded channel `e` with the detail added, clamped, as
    /// [`Path::sharpen_row`] gives it (held as a `P`, which holds every code exactly).
    fn sharpened_code8(e: Self::P, detail: Self::Detail) -> Self::P;
    /// A code from [`Planar::sharpened_code8`] as an integer.
    fn code_of(v: Self::P) -> u32;
    /// The highlight stage's parameters.
    type Knee: Copy;
    /// The highlight stage's parameters, if it is on (fetched once per frame).
    fn knee(&self) -> Option<Self::Knee>;
    /// [`Path::highlights`] with those parameters: the stage's branch-free form, so its loop
    /// vectorises.
    fn highlights_at_knee(knee: Self::Knee, rgb: [Self::P; 3], brightest: Self::P) -> [Self::P; 3];
}

/// Whether the planar schedule runs `path` on `raw` for output samples `O`, with the frame
/// wide and high enough.
pub(super) fn takes<A: Planar, O: OutputSample>(path: &A, raw: &RawFrame<'_>) -> bool {
    let mosaic = raw.mosaic();
    O::BITS == 8
        && matches!(
            path.method(),
            Method::Bilinear | Method::Mhc | Method::Directional
        )
        && mosaic.width() >= MIN_WIDTH
        && mosaic.height() >= 3
        && path.planar_takes::<O>(raw)
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
}

impl Planar for FixedPipeline<'_> {
    type Steps = FixedSteps;
    type Matrix = CcmSplit;

    fn planar_takes<O: OutputSample>(&self, _raw: &RawFrame<'_>) -> bool {
        self.lsc.is_none()
            && self.distortion.is_none()
            && self.denoise.is_none()
            && self.chroma.is_none()
            && self.saturation_q.is_none()
            && self.tone_lut.is_none()
            && self.encode.max() == 255
    }

    fn steps(&self, raw: &RawFrame<'_>) -> [[FixedSteps; 2]; 2] {
        let pattern = raw.mosaic().pattern();
        core::array::from_fn(|ry| {
            core::array::from_fn(|rx| {
                let black = raw.black_at(rx, ry);
                let colour = pattern.colour_at(rx, ry).index();
                FixedSteps {
                    black,
                    normalise: MulQ16::new(super::recip_q16(raw.white_level() - black)),
                    gain: self.gain_q16.map(MulQ16::new),
                    wb: self
                        .wb_q16
                        .map_or(MulQ16::ONE, |wb| MulQ16::new(wb[colour])),
                }
            })
        })
    }

    #[inline(always)]
    fn pointwise(steps: FixedSteps, raw: u16) -> u16 {
        let d = u32::from(raw.saturating_sub(steps.black));
        let v = steps.normalise.apply(d);
        let v = match steps.gain {
            Some(gain) => gain.apply(v),
            None => v,
        };
        steps.wb.apply(v) as u16
    }

    fn matrix(&self) -> Option<CcmSplit> {
        self.ccm_q.as_ref().map(CcmSplit::new)
    }

    #[inline(always)]
    fn colour_matrix(m: &CcmSplit, rgb: [u16; 3]) -> [u16; 3] {
        let v = rgb.map(u32::from);
        [m.channel(0, v), m.channel(1, v), m.channel(2, v)]
    }

    // The table takes every `u16`.
    const CLAMPS_FOR_CODE8: bool = false;

    #[inline(always)]
    fn clamp_for_code8(v: u16) -> u16 {
        v
    }

    #[inline(always)]
    fn code8_clamped(&self, v: u16) -> u32 {
        self.encode.lookup8(v)
    }

    fn lookup8_planes<'a>(&'a self, planes: &'a [u16]) -> Option<(&'a srgb::EncodeLut, &'a [u16])> {
        Some((&self.encode, planes))
    }

    type Sharpen = i32;

    fn sharpening(&self) -> Option<i32> {
        // The amount is at most 4 in Q12.
        self.sharpen_q12.map(|amount| amount as i32)
    }

    #[inline(always)]
    fn encode_for_sharpening(&self, v: u16) -> u16 {
        match &self.encode16 {
            // Codes of a 16-bit table fit u16.
            Some(encode16) => encode16.lookup16(v) as u16,
            None => v,
        }
    }

    #[inline(always)]
    fn luma(e: [u16; 3]) -> u16 {
        // The weights sum to 2^16, so the rounded luma is at most 65535.
        ((super::LUMA_Q16[0] * u32::from(e[0])
            + super::LUMA_Q16[1] * u32::from(e[1])
            + super::LUMA_Q16[2] * u32::from(e[2])
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
    fn sharpened_code8(e: u16, detail: i32) -> u16 {
        let v = (i32::from(e) + detail).clamp(0, 65535) as u32;
        // The engine's 8-bit output of a 16-bit code, rounded: < 2^24 before the division.
        ((v * 255 + 32767) / 65535) as u16
    }

    #[inline(always)]
    fn code_of(v: u16) -> u32 {
        u32::from(v)
    }

    type Knee = KneeQ16;

    fn knee(&self) -> Option<KneeQ16> {
        self.highlights
    }

    #[inline(always)]
    fn highlights_at_knee(knee: KneeQ16, rgb: [u16; 3], brightest: u16) -> [u16; 3] {
        knee.neutralise(rgb, brightest)
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

impl Planar for FloatPipeline<'_> {
    type Steps = FloatSteps;
    type Matrix = [[f32; 3]; 3];

    fn planar_takes<O: OutputSample>(&self, _raw: &RawFrame<'_>) -> bool {
        let c = &self.config;
        c.lsc.is_none()
            && c.active_distortion().is_none()
            && c.denoise == 0.0
            && c.chroma_denoise == 0.0
            && c.tone.saturation_is_identity()
            && c.tone.curve_is_identity()
    }

    fn steps(&self, raw: &RawFrame<'_>) -> [[FloatSteps; 2]; 2] {
        let c = &self.config;
        let pattern = raw.mosaic().pattern();
        core::array::from_fn(|ry| {
            core::array::from_fn(|rx| {
                let black = raw.black_at(rx, ry);
                FloatSteps {
                    black,
                    range: raw.white_level() as f32 - black as f32,
                    gain: c.gain,
                    wb: c.wb_gains[pattern.colour_at(rx, ry).index()],
                }
            })
        })
    }

    #[inline(always)]
    fn pointwise(steps: FloatSteps, raw: u16) -> f32 {
        // FloatPipeline::pointwise without shading, every step taken.
        let v = (raw.saturating_sub(steps.black) as f32 / steps.range).clamp(0.0, 1.0);
        (steps.wb * (steps.gain * v).min(1.0)).min(1.0)
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

    type Sharpen = f32;

    fn sharpening(&self) -> Option<f32> {
        let amount = self.config.sharpen;
        (amount > 0.0).then_some(amount)
    }

    #[inline(always)]
    fn encode_for_sharpening(&self, v: f32) -> f32 {
        srgb::encode(v)
    }

    #[inline(always)]
    fn luma(e: [f32; 3]) -> f32 {
        let l = super::LUMA;
        l[0] * e[0] + l[1] * e[1] + l[2] * e[2]
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
    fn sharpened_code8(e: f32, detail: f32) -> f32 {
        let v = (e + detail).clamp(0.0, 1.0);
        // `OutputSample::from_encoded` for `u8`: a half added, truncated.
        ((v * 255.0 + 0.5) as u32) as f32
    }

    #[inline(always)]
    fn code_of(v: f32) -> u32 {
        v as u32
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
}

/// Rows of the sharpening stage's ring: the encoded rows above, at and below an output row.
const SHARPEN_ROWS: usize = 3;

/// Elements of one row of the sharpening ring: the three encoded planes and their luma.
fn sharpen_slot_len(w: usize) -> usize {
    4 * w
}

/// Scratch elements the schedule uses: five padded mosaic rows, one planar RGB row and, with
/// sharpening, its ring (within [`super::scratch_len`] plus the engine's sharpening rows for
/// every width it takes).
fn scratch_needed(w: usize, sharpen: bool) -> usize {
    MOSAIC_ROWS * Halves::new(w).len() + 3 * w + sharpen_part(w, sharpen)
}

/// Elements of the sharpening ring, 0 without sharpening.
fn sharpen_part(w: usize, sharpen: bool) -> usize {
    match sharpen {
        true => SHARPEN_ROWS * sharpen_slot_len(w),
        false => 0,
    }
}

/// Runs rows `rows` of `raw` through `path` into `out` on the planar schedule; the caller
/// has checked [`takes`], the rows and the output's size.
#[inline(always)]
pub(super) fn run<A: Planar, O: OutputSample>(
    path: &A,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
    encode: impl Fn(&A, &[A::P], Halves, &mut [O]),
) -> Result<(), IspError> {
    let mosaic = raw.mosaic();
    let (w, h, pattern) = (mosaic.width(), mosaic.height(), mosaic.pattern());
    let halves = Halves::new(w);
    let row_len = halves.len();
    let needed = scratch_needed(w, path.sharpening().is_some());
    if scratch.len() < needed {
        return Err(IspError::BufferTooSmall {
            needed,
            provided: scratch.len(),
        });
    }
    let (ring, rest) = scratch.split_at_mut(MOSAIC_ROWS * row_len);
    let (planes, sharpen_ring) = rest.split_at_mut(3 * w);
    let steps = path.steps(raw);
    let knee = path.knee();
    let method = path.method();
    let mut tags = [usize::MAX; MOSAIC_ROWS];
    emit_rows(
        path,
        h,
        halves,
        rows,
        planes,
        sharpen_ring,
        out,
        encode,
        // Inlined, so that it is compiled for the entry's target features (a closure out of
        // line is compiled for the baseline target).
        #[inline(always)]
        |y: usize, planes: &mut [A::P]| {
            for dm in -2..=2isize {
                let my = reflect(y as isize + dm, h);
                let slot = my % MOSAIC_ROWS;
                if tags[slot] != my {
                    let row = &mut ring[slot * row_len..(slot + 1) * row_len];
                    prepare_row::<A>(path.dpc(), raw, my, steps[my & 1], halves, row);
                    tags[slot] = my;
                }
            }
            let ring: &[A::P] = ring;
            let source: [&[A::P]; 5] = core::array::from_fn(|k| {
                let slot = reflect(y as isize + k as isize - 2, h) % MOSAIC_ROWS;
                &ring[slot * row_len..(slot + 1) * row_len]
            });
            demosaic_row(method, source, halves, pattern, y, planes);
            if let Some(knee) = knee {
                highlights_row::<A>(knee, source, halves, planes);
            }
            Ok(())
        },
    )
}

/// Writes output rows `rows`, each from demosaiced planes that `produce(y, planes)` fills for
/// frame row `y`: through the colour matrix and the encoding, or with sharpening on, each
/// row encoded into `sharpen_ring` (rows produced in order, each once) and the output row
/// sharpened from the encoded rows above, at and below it (reflected at the frame's edges).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn emit_rows<A: Planar, O: OutputSample>(
    path: &A,
    h: usize,
    halves: Halves,
    rows: Range<usize>,
    planes: &mut [A::P],
    sharpen_ring: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
    encode: impl Fn(&A, &[A::P], Halves, &mut [O]),
    mut produce: impl FnMut(usize, &mut [A::P]) -> Result<(), IspError>,
) -> Result<(), IspError> {
    let w = halves.even + halves.odd;
    let matrix = path.matrix();
    let Some(amount) = path.sharpening() else {
        for y in rows.clone() {
            produce(y, planes)?;
            matrix_row::<A>(matrix.as_ref(), planes, w);
            encode(path, planes, halves, out.row_mut(y - rows.start));
        }
        return Ok(());
    };
    let slot_len = sharpen_slot_len(w);
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
            matrix_row::<A>(matrix.as_ref(), planes, w);
            let encoded = &mut sharpen_ring[slot * slot_len..(slot + 1) * slot_len];
            encode_for_sharpening(path, planes, encoded, w);
            tags[slot] = v;
        }
        let ring: &[A::P] = sharpen_ring;
        let encoded = taps.map(|v| {
            let slot = v % SHARPEN_ROWS;
            &ring[slot * slot_len..(slot + 1) * slot_len]
        });
        sharpen_row::<A>(amount, encoded, halves, planes);
        interleave_codes::<A, O>(planes, halves, out.row_mut(y - rows.start));
    }
    Ok(())
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

/// A row of linear planes (after [`matrix_row`]) into one row of the sharpening ring: the
/// encoded planes, then the luma of each pixel.
#[inline(always)]
fn encode_for_sharpening<A: Planar>(path: &A, planes: &[A::P], slot: &mut [A::P], w: usize) {
    let (encoded, luma) = slot.split_at_mut(3 * w);
    for (e, v) in encoded.iter_mut().zip(&planes[..3 * w]) {
        *e = path.encode_for_sharpening(*v);
    }
    let (r, rest) = encoded.split_at(w);
    let (g, b) = rest.split_at(w);
    for (((y, r), g), b) in luma[..w].iter_mut().zip(r).zip(g).zip(b) {
        *y = A::luma([*r, *g, *b]);
    }
}

/// The sharpening stage on the middle row of three ring rows (`rows`: above, at, below),
/// into `codes` (three planes of 8-bit codes, halves as the planes). A site's neighbours
/// left and right are in the other half: for the even column `2i` the odd sites `i - 1` and
/// `i`, for the odd column `2i + 1` the even sites `i` and `i + 1`. The sites whose
/// neighbour lies past the frame's edge (reflect-101) are done one by one, the rest in one
/// loop per half over equal-length slices, which vectorises.
#[inline(always)]
fn sharpen_row<A: Planar>(
    amount: A::Sharpen,
    rows: [&[A::P]; 3],
    halves: Halves,
    codes: &mut [A::P],
) {
    let (ne, no) = (halves.even, halves.odd);
    let w = ne + no;
    let luma = rows.map(|row| row[3 * w..4 * w].split_at(ne));
    let centre = rows[1];
    // Interior even sites 1..even_end, odd sites 0..odd_end.
    let even_end = if ne > no { ne - 1 } else { ne };
    let odd_end = if ne > no { no } else { no - 1 };
    let (r, rest) = codes[..3 * w].split_at_mut(w);
    let (g, b) = rest.split_at_mut(w);
    let (r_even, r_odd) = r.split_at_mut(ne);
    let (g_even, g_odd) = g.split_at_mut(ne);
    let (b_even, b_odd) = b.split_at_mut(ne);
    if even_end > 1 {
        let n = even_end - 1;
        // Site i + 1 of the even half: odd i to the left, odd i + 1 to the right.
        let taps = luma.map(|(even, odd)| [&odd[..n], &even[1..1 + n], &odd[1..1 + n]]);
        let channels = [0, 1, 2].map(|c| &centre[c * w + 1..c * w + 1 + n]);
        sharpen_span::<A>(
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
        sharpen_span::<A>(
            amount,
            taps,
            channels,
            [&mut r_odd[..n], &mut g_odd[..n], &mut b_odd[..n]],
        );
    }
    // The edge sites: column 0, and the last column or two.
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
            codes[c * w + i] = A::sharpened_code8(centre[c * w + i], detail);
        }
    };
    edge(0);
    for x in [2 * even_end, 2 * odd_end + 1] {
        if x > 0 && x < w {
            edge(x);
        }
    }
}

/// [`sharpen_row`]'s loop over `n` sites of one half: `luma[row][column]` the luma of the
/// rows above, at and below, at the columns left, at and right of each site, `channels` the
/// sites' encoded channels, `codes` their 8-bit codes.
#[inline(always)]
fn sharpen_span<A: Planar>(
    amount: A::Sharpen,
    luma: [[&[A::P]; 3]; 3],
    channels: [&[A::P]; 3],
    codes: [&mut [A::P]; 3],
) {
    let [r, g, b] = codes;
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
        r[i] = A::sharpened_code8(cr[i], detail);
        g[i] = A::sharpened_code8(cg[i], detail);
        b[i] = A::sharpened_code8(cb[i], detail);
    }
}

/// Three planes of 8-bit codes (from [`sharpen_row`]) interleaved into an output row.
#[inline(always)]
fn interleave_codes<A: Planar, O: OutputSample>(codes: &[A::P], halves: Halves, out: &mut [O]) {
    interleave(codes, halves, out, |v: A::P| O::from_code(A::code_of(v)));
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

/// [`run_directional`] out of line, compiled for the baseline target.
// Out of line in both builds: inlined into the entries with the other methods' loops, it
// slowed the float path's MHC from 33 to 38 ms (LLVM compiled the shared stages worse).
#[inline(never)]
pub(super) fn run_directional_general<A: Planar, O: OutputSample>(
    path: &A,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    run_directional::<A, O, LANES>(path, raw, rows, scratch, out, encode_row)
}

/// [`run_directional`] out of line, compiled for AVX2 (and FMA, for the float path's
/// encoder, [`encode_row_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
pub(super) fn run_directional_avx2<A: Planar, O: OutputSample>(
    path: &A,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let encode = |path: &A, planes: &[A::P], halves: Halves, out: &mut [O]| {
        encode_row_avx2(path, planes, halves, out)
    };
    run_directional::<A, O, LANES>(path, raw, rows, scratch, out, encode)
}

/// [`run_directional`] out of line, compiled for AVX-512 (F, BW, VL, DQ).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
#[inline(never)]
pub(super) fn run_directional_avx512<A: Planar, O: OutputSample>(
    path: &A,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let encode = |path: &A, planes: &[A::P], halves: Halves, out: &mut [O]| {
        encode_row_avx512(path, planes, halves, out)
    };
    run_directional::<A, O, LANES_AVX512>(path, raw, rows, scratch, out, encode)
}

/// The red, green and blue planes of a row of planes, each `halves.even + halves.odd` long.
#[inline(always)]
fn colour_planes<P>(planes: &[P], halves: Halves) -> [&[P]; 3] {
    let w = halves.even + halves.odd;
    [0, 1, 2].map(|c| &planes[c * w..(c + 1) * w])
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

/// [`run`] with the directional method: the method's stream reads the prepared rows (as
/// split rows, so it only pads them) and writes planes, which the colour matrix and the
/// encoding take as they take the other methods'. A band starts the stream again 12 rows
/// above its first row, as the general engine does. `L` is the sites per block of the
/// integer method's vector loops: one vector of `i32` of the build's widest ISA.
#[inline(always)]
fn run_directional<A: Planar, O: OutputSample, const L: usize>(
    path: &A,
    raw: &RawFrame<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
    encode: impl Fn(&A, &[A::P], Halves, &mut [O]),
) -> Result<(), IspError> {
    let mosaic = raw.mosaic();
    let (w, h, pattern) = (mosaic.width(), mosaic.height(), mosaic.pattern());
    let halves = Halves::new(w);
    let too_wide = IspError::InvalidParameter {
        name: "width",
        allowed: "a size that fits in memory",
    };
    let part = super::directional_len::<A::Directional>(Method::Directional, w).ok_or(too_wide)?;
    let needed = part
        .checked_add(halves.len() + 3 * w + sharpen_part(w, path.sharpening().is_some()))
        .ok_or(too_wide)?;
    if scratch.len() < needed {
        return Err(IspError::BufferTooSmall {
            needed,
            provided: scratch.len(),
        });
    }
    let (part, rest) = scratch.split_at_mut(part);
    let (prepared, rest) = rest.split_at_mut(halves.len());
    let (planes, sharpen_ring) = rest.split_at_mut(3 * w);
    let Some(mut stream) =
        Stream::<A::Directional>::new(w, h, pattern, A::directional_planes(part))?
    else {
        // The stream takes every frame at least 2 pixels wide and high, and `takes` asked
        // for more.
        return Err(IspError::InvalidParameter {
            name: "size",
            allowed: "at least 2 pixels wide and high for the directional method",
        });
    };
    let steps = path.steps(raw);
    let knee = path.knee();
    emit_rows(
        path,
        h,
        halves,
        rows,
        planes,
        sharpen_ring,
        out,
        encode,
        // Inlined, so that it is compiled for the entry's target features (a closure out of
        // line is compiled for the baseline target).
        #[inline(always)]
        |y: usize, planes: &mut [A::P]| {
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
                    prepare_row::<A>(path.dpc(), raw, my, steps[my & 1], halves, prepared);
                }
                let source = read.map(|_| halves.unpadded(&*prepared));
                if stream.next_output() == Some(y) {
                    stream.step::<L>(source, Some(OutputRow::Planes(&mut *planes)));
                    break;
                }
                stream.step::<L>(source, None);
            }
            if let Some(knee) = knee {
                directional_highlights::<A>(knee, &stream, y, halves, planes);
            }
            Ok(())
        },
    )
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

/// Raw row `my` through defect correction and the pointwise stage into the halves of `dst`.
#[inline(always)]
fn prepare_row<A: Planar>(
    dpc_config: &dpc::DpcConfig<'_>,
    raw: &RawFrame<'_>,
    my: usize,
    steps: [A::Steps; 2],
    halves: Halves,
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
        let even = &mut dst[1 + x0 / 2..1 + x0 / 2 + pairs.len() / 2];
        for (e, pair) in even.iter_mut().zip(pairs.chunks_exact(2)) {
            *e = A::pointwise(steps[0], pair[0]);
        }
        let odd = &mut dst[o + 1 + x0 / 2..o + 1 + x0 / 2 + pairs.len() / 2];
        for (d, pair) in odd.iter_mut().zip(pairs.chunks_exact(2)) {
            *d = A::pointwise(steps[1], pair[1]);
        }
        if n % 2 == 1 {
            // The last column of an odd width.
            dst[1 + (x0 + n - 1) / 2] = A::pointwise(steps[0], corrected[n - 1]);
        }
    }
    halves.pad(dst);
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

#[cfg(test)]
mod tests {
    use super::{CcmSplit, FixedPipeline, Planar};
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
                    FixedPipeline::colour_matrix(&split, rgb),
                    ccm::apply_u16(&m, CCM_FRAC_BITS, rgb),
                    "{m:?} {rgb:?}"
                );
            }
        }
    }
}
