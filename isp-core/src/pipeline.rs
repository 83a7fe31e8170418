//! The raw-to-sRGB pipeline: every stage in order, a float reference path and a fixed-point
//! firmware path, run over a band of rows at a time in caller-provided line buffers.
//!
//! # Float reference semantics
//!
//! For a raw sample `raw` at `(x, y)` with the black level `black` of its CFA position and the
//! frame's `white`, the float path ([`FloatPipeline`]) computes exactly:
//!
//! ```text
//! raw' = dpc(raw)                                   defective pixels replaced (integer, dpc module)
//! x    = clamp(lsc(x, y) * max(raw' - black, 0) / (white - black), 0, 1)
//!        or, with noise reduction on (strength > 0 and a noise profile):
//! x    = clamp(lsc(x, y) * nr(clamp(max(raw' - black, 0) / (white - black), 0, 1)), 0, 1)
//! x    = min(gain * x, 1)                           ISO / digital gain
//! x_c  = min(wb_c * x_c, 1)                         white balance per CFA colour, clipped at white
//! rgb  = demosaic(x)                                reflect-101 borders, clamped to [0, 1]
//! rgb  = highlights(rgb, x)                         colour near clipping fades to neutral (highlights module)
//! rgb  = undistort(rgb)                             lens distortion and lateral colour, off by default
//! lin  = clamp(CCM * rgb, 0, 1)
//! lin  = tone(lin)                                  saturation, contrast, curve (tone module)
//! e    = srgb_oetf(lin)
//! e    = Y + chroma(e - Y)                          chroma noise reduction, off by default
//! e_c  = clamp(e_c + s * (Y - blur(Y)), 0, 1)      sharpening, off (s = 0) by default
//! out  = round(255 * e)                             or 65535 for 16-bit; f32 output unrounded
//! ```
//!
//! in `f32`, with `nr` the noise reduction of [`crate::denoise`] over the whole normalised
//! mosaic (non-local means on its 2x2 blocks, distances in units of the profile's variance), `lsc` the bilinear interpolation of the Q4.12 grid (exactly `q / 4096` per
//! node), `undistort` the 1/32-pixel bilinear resampling of [`crate::distortion`] (OpenCV's
//! `cv2.undistort`, black where the lens saw nothing; with a lateral-colour correction composed
//! in, red and blue read where [`crate::lateral_colour`] moves green's source position, in
//! the same blend), and `srgb_oetf` the exact IEC 61966-2-1
//! curve ([`crate::srgb::encode`]). Sharpening is an unsharp mask on luma in the encoded
//! domain (where ISPs sharpen, so the overshoot is even to the eye): `Y = 0.2126 e_r + 0.7152
//! e_g + 0.0722 e_b` (Rec. 709 luma), `blur` the 3x3 binomial kernel `[1 2 1]^T [1 2 1] / 16`
//! over it with reflect-101 borders, and the same luma detail added to each channel, so hue
//! is kept. `chroma` is the edge-aware mean of each pixel's chroma `e - Y` over its
//! neighbours, horizontal then vertical ([`crate::chroma`]), which keeps `Y`; with it on, the
//! value sharpened and clamped is `Y + chroma(e - Y)` unclamped. Each stage that is off (no defects, no grid, gain 1, gains
//! 1, no distortion, strength 0, identity matrix, neutral tone) is skipped, and skipping it
//! changes nothing. Noise reduction filters whole 2x2 blocks, so it needs a mosaic of even
//! width and height (and refuses a linear frame).
//!
//! A [`LinearFrame`] (already demosaiced, as a DNG's LinearRaw) runs the same per channel:
//! `raw` is the channel's sample with that channel's black and white level, `wb_c` its gain,
//! `lsc` the grid's gain at the pixel's 2x2 position for all three channels, and there is no
//! defect correction (asking for it is an error) and no demosaicing; the highlight stage's
//! neighbourhood is the pixel itself (`run_linear`, or `run_input` with an [`Input`]).
//!
//! # Fixed-point path
//!
//! [`FixedPipeline`] computes the same with integers: linear pixels are `u16` with 65535 = 1.0
//! from black level subtraction on; normalisation by a Q16 reciprocal of `white - black`; the
//! shading gain in Q4.16 interpolated from the Q4.12 grid; ISO gain and white-balance gains in
//! unsigned Q16 (so a gained sample is the float one to well under a code, which the
//! highlight stage needs: it turns a bright neighbour's relative error into a dark channel's
//! absolute one); demosaicing with the integer kernels;
//! noise reduction with tabled stabilised values, Q15 weights and 64-bit sums ([`crate::denoise`]); distortion
//! correction with the same mesh positions and integer weights over 1024; the CCM in signed Q4.16; saturation as a Q16 matrix; contrast and
//! curve through [`ToneLut`]; encoding through [`EncodeLut`] (at 16 bits first when
//! sharpening or chroma noise reduction, which then run on 16-bit codes with Q16 luma weights,
//! a Q12 amount and Q12 chroma weights, and reduce to the output depth last). Every step rounds to nearest and
//! saturates. Its 8-bit output is within 1 LSB of the float path on at least 99.9% of pixels
//! and 2 LSB everywhere (tested over Kodak and McMaster as 12-bit raw and over random frames),
//! for highlight knees up to 0.99. Nearer 1 the highlight fade's slope, `1 / (1 - knee)`,
//! multiplies the half-code rounding of the fixed path's gained samples, and sharpening
//! multiplies it again: a knee of 0.9977 with sharpening 1.37 put one sample of a random
//! linear frame 3 LSB off (float 254, fixed 251); with the knee at 0.995 or sharpening off the
//! same frame was within 2.
//!
//! # Streaming
//!
//! [`FloatPipeline::run`] and [`FixedPipeline::run`] produce any band of output rows
//! `rows.start..rows.end` from the raw frame (which stays in caller memory). Every row is a
//! function of the frame alone, never of what was computed before, so running a frame in
//! bands of any height gives bit-identical output to running it whole; a band recomputes the
//! rows of context above and below it (12 for the directional method, the search radius and
//! patch for noise reduction).
//!
//! # The schedule
//!
//! Every configuration, on both paths, runs on one schedule (`pipeline/planar.rs`'s module docs): rows
//! split into even and odd columns with reflected padding, so each stage is a loop over
//! contiguous slices with constants fixed per loop, which the compiler vectorises; noise
//! reduction streams offset by offset over packed rows ([`crate::denoise`]); distortion
//! correction interpolates its mesh per row. Rings of rows live in the caller's scratch:
//! [`IspConfig::scratch_len`] gives the total for a frame size ([`scratch_len`] is the base,
//! `16 * width + 20`; noise reduction, the directional method and distortion add their own
//! rings). [`FixedPipeline::run_input_avx2`] and [`FloatPipeline::run_input_avx2`] are the
//! same entry compiled for AVX2, `run_input_avx512` for AVX-512 F/BW/VL/DQ (x86-64, unsafe to
//! call without the features, so check them first, as `camsim` does). The earlier general
//! streaming engine survives only as `run_input_general`, the reference the tests compare
//! the schedule with bit for bit (not used at run time).
//!
//! Per-sample powers on the float path (tone's curve, sRGB encoding for sharpening and chroma
//! noise reduction) are a vectorisable estimate (`math::pow_estimate`), not `powf`: the sRGB encoding within
//! 2.5e-7 of the exact curve, tone's channel within 2e-6 (both tested). Speed, measured with `camsim bench isp --config
//! docs/bench/demo-camera.toml --threads 1` on a 2592x1968 frame: `docs/performance.md`.
//!
//! ```
//! use isp_core::frame::{RawFrame, RgbViewMut};
//! use isp_core::pipeline::{scratch_len, FixedPipeline, FloatPipeline, IspConfig};
//! use isp_core::CfaPattern;
//! // A flat grey 12-bit frame, black 256, white 4095.
//! let data = [2176u16; 8 * 6];
//! let raw = RawFrame::new(&data, 8, 6, 8, 12, CfaPattern::Rggb, [256; 4], 4095).unwrap();
//! let config = IspConfig::default();
//! let mut scratch = vec![0.0f32; scratch_len(8).unwrap()];
//! let mut rgb = [0u8; 8 * 6 * 3];
//! let mut out = RgbViewMut::new(&mut rgb, 8, 6, 24).unwrap();
//! FloatPipeline::new(&config).unwrap().run(&raw, 0..6, &mut scratch, &mut out).unwrap();
//! // (2176 - 256) / (4095 - 256) = 0.5 linear is 188 in sRGB.
//! assert!(rgb.iter().all(|v| *v == 188));
//! let fixed = FixedPipeline::new(&config, 8).unwrap();
//! let mut scratch16 = vec![0u16; scratch_len(8).unwrap()];
//! let mut rgb2 = [0u8; 8 * 6 * 3];
//! let mut out2 = RgbViewMut::new(&mut rgb2, 8, 6, 24).unwrap();
//! fixed.run(&raw, 0..6, &mut scratch16, &mut out2).unwrap();
//! assert_eq!(rgb, rgb2);
//! ```

use core::ops::Range;

use crate::chroma::{self, LUMA, LUMA_Q16};
use crate::demosaic::directional::{
    self, Arithmetic, Fixed, Float, OutputRow, SourceRow, Stream, LANES,
};
use crate::demosaic::{self, reflect, Method};
use crate::distortion::LensDistortion;
use crate::dpc::{self, DpcConfig};
use crate::frame::{LinearFrame, RawFrame, RgbViewMut, Sample};
use crate::lsc::{LensShading, MAX_GRID_SIDE};
use crate::noise::NoiseProfile;
use crate::srgb::{self, EncodeLut, EncodeThresholds8};
use crate::tone::{Tone, ToneLut};
use crate::{ccm, denoise, highlights, wb, CfaPattern, IspError};

mod planar;

/// Largest ISO / digital gain (exclusive).
pub const MAX_GAIN: f32 = 64.0;
/// Fractional bits of the fixed path's gains (ISO and white balance).
pub const GAIN_FRAC_BITS: u32 = 16;
/// Fractional bits of the fixed path's CCM.
/// Fractional bits of the fixed path's CCM: signed Q4.16. Finer than PiSP's Q4.10 because
/// coefficients that cancel (`1.3 R - 0.3 G` on a dark red next to bright green) leave a
/// near-black result whose error is the coefficients' error times the bright input: 10 bits
/// cost up to 3 LSB of 8-bit sRGB there, 16 bits under 0.1.
pub const CCM_FRAC_BITS: u32 = 16;
/// Fractional bits of the fixed path's saturation matrix.
pub const SATURATION_FRAC_BITS: u32 = 16;
/// Rows of prepared mosaic the ring holds (the widest demosaic window).
const MOSAIC_ROWS: usize = 5;
/// Rows of demosaiced RGB the ring holds (and of distortion-corrected RGB with the correction on).
const RGB_ROWS: usize = 3;
/// Rows of encoded RGB the sharpening ring holds (its window).
const SHARPEN_ROWS: usize = 3;
/// `u16` scratch elements per `u32` of the fixed path's noise-reduction work (its sums take
/// twice as many).
const FIXED_WORK_RATIO: usize = 2;
/// Largest sharpening amount.
pub const MAX_SHARPEN: f32 = 4.0;
/// Split rows the chroma stage keeps: its vertical window, the row being split and the
/// vertical pass's output.
const CHROMA_ROWS: usize = chroma::TAPS + 2;
/// Fractional bits of the fixed path's sharpening amount.
const SHARPEN_FRAC_BITS: u32 = 12;
/// Raw samples defect correction handles per chunk (a stack buffer, so the float path needs no
/// `u16` scratch).
const CHUNK: usize = 256;

/// Everything the pipeline does to a frame. [`IspConfig::default`] is the plainest pipeline:
/// no defects, no shading grid, gains 1, bilinear, no distortion correction, no denoise,
/// identity CCM, neutral tone.
#[derive(Debug, Clone, Copy)]
pub struct IspConfig<'a> {
    /// Defective pixel correction.
    pub dpc: DpcConfig<'a>,
    /// Lens shading grid, or `None`.
    pub lsc: Option<LensShading<'a>>,
    /// ISO / digital gain, `[0, 64)`.
    pub gain: f32,
    /// White-balance gains, RGB, each `[0, 16)`.
    pub wb_gains: [f32; 3],
    /// Demosaicing method.
    pub demosaic: Method,
    /// Lens distortion correction, or `None`.
    pub distortion: Option<LensDistortion>,
    /// Noise reduction's strength, a multiplier on the default the noise profile sets:
    /// `[0, 4]`, 0 off, 1 the default ([`crate::denoise`]). Needs [`IspConfig::noise`], a
    /// mosaic input of even width and height.
    pub denoise: f32,
    /// Noise reduction's search window: [`denoise::Search::Wide`] (5x5 packed pixels, the
    /// default) or [`denoise::Search::Fast`] (3x3, for firmware and video).
    pub denoise_search: denoise::Search,
    /// The raw's noise profile, which drives noise reduction.
    pub noise: Option<NoiseProfile>,
    /// Highlight knee, `[0, 1]`: a demosaiced pixel whose largest channel, or largest 3x3
    /// white-balanced raw sample around it, is above the knee fades to neutral, fully at the
    /// clip level 1 ([`crate::highlights`]); 1 is off.
    pub highlight_knee: f32,
    /// Camera RGB (white-balanced) to linear sRGB, coefficients in `[-8, 8)`.
    pub ccm: [[f32; 3]; 3],
    /// Photo-finishing.
    pub tone: Tone,
    /// Sharpening: the amount of an unsharp mask on luma after encoding, `[0, 4]` (0 is off;
    /// 1 adds the luma's full difference from its 3x3 blur).
    pub sharpen: f32,
    /// Chroma noise reduction's strength, `[0, 4]` (0 is off, 1 the default ranges of
    /// [`crate::chroma`]).
    pub chroma_denoise: f32,
}

/// The identity matrix.
pub const IDENTITY: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

impl Default for IspConfig<'_> {
    fn default() -> Self {
        Self {
            dpc: DpcConfig::default(),
            lsc: None,
            gain: 1.0,
            wb_gains: [1.0; 3],
            demosaic: Method::Bilinear,
            distortion: None,
            denoise: 0.0,
            denoise_search: denoise::Search::Wide,
            noise: None,
            highlight_knee: 1.0,
            ccm: IDENTITY,
            tone: Tone::default(),
            sharpen: 0.0,
            chroma_denoise: 0.0,
        }
    }
}

impl IspConfig<'_> {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), IspError> {
        self.dpc.validate()?;
        if !(0.0..MAX_GAIN).contains(&self.gain) {
            return Err(IspError::InvalidParameter {
                name: "gain",
                allowed: "[0, 64)",
            });
        }
        wb::validate_gains(self.wb_gains)?;
        if !(0.0..=denoise::MAX_STRENGTH).contains(&self.denoise) {
            return Err(IspError::InvalidParameter {
                name: "denoise strength",
                allowed: "[0, 4] (0 off, 1 the noise profile's default)",
            });
        }
        if self.denoise > 0.0 && self.noise.is_none() {
            return Err(IspError::InvalidParameter {
                name: "denoise",
                allowed: "0 without a noise profile (noise reduction follows the profile)",
            });
        }
        if !(0.0..=1.0).contains(&self.highlight_knee) {
            return Err(IspError::InvalidParameter {
                name: "highlight knee",
                allowed: "[0, 1] (1 is off)",
            });
        }
        if !(0.0..=MAX_SHARPEN).contains(&self.sharpen) {
            return Err(IspError::InvalidParameter {
                name: "sharpen",
                allowed: "[0, 4] (0 is off)",
            });
        }
        chroma::FloatParams::new(self.chroma_denoise)?;
        ccm::validate(&self.ccm)?;
        self.tone.validate()
    }

    /// The distortion correction, if it is on and changes anything.
    fn active_distortion(&self) -> Option<&LensDistortion> {
        self.distortion.as_ref().filter(|d| !d.is_identity())
    }

    /// Scratch elements either path needs for a `width` x `height` frame with this
    /// configuration (the larger of [`FloatPipeline::scratch_len`] and
    /// [`FixedPipeline::scratch_len`]; see the module docs for what it holds). With
    /// distortion on, this evaluates the lens model at every mesh node twice.
    pub fn scratch_len(&self, width: usize, height: usize) -> Option<usize> {
        let shape = config_shape(
            self.demosaic,
            (self.denoise > 0.0 && self.noise.is_some()).then_some(self.denoise_search),
            self.lsc.is_some(),
            self.active_distortion(),
            Detail::of(self.sharpen > 0.0, self.chroma_denoise > 0.0),
            width,
            height,
        );
        let float = shape.scratch_len::<f32, f32, f32, f32, f32, f32>()?;
        let fixed = shape.scratch_len::<u16, i32, u32, u64, u32, i32>()?;
        Some(float.max(fixed))
    }
}

/// The stages after encoding that read neighbouring rows, and so keep a ring of encoded rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Detail {
    /// Neither: each row is finished as it is demosaiced.
    Off,
    /// Sharpening alone: a ring of three encoded rows.
    Sharpen,
    /// Chroma noise reduction (and sharpening, if on): a ring of split rows.
    Chroma,
}

impl Detail {
    fn of(sharpen: bool, chroma: bool) -> Self {
        match (sharpen, chroma) {
            (_, true) => Self::Chroma,
            (true, false) => Self::Sharpen,
            (false, false) => Self::Off,
        }
    }

    /// Elements of a path's scratch (of type `T`, the chroma stage's split rows of type `D`)
    /// for the ring.
    fn len<T, D>(self, width: usize) -> Option<usize> {
        match self {
            Self::Off => Some(0),
            Self::Sharpen => width.checked_mul(3 * SHARPEN_ROWS),
            Self::Chroma => {
                let ratio = core::mem::size_of::<D>().div_ceil(core::mem::size_of::<T>());
                // The encoded row, and the split rows (plus alignment).
                width
                    .checked_mul(chroma::SPLIT * CHROMA_ROWS * ratio)?
                    .checked_add(ratio - 1)?
                    .checked_add(width.checked_mul(3)?)
            }
        }
    }
}

/// Elements of a path's scratch beyond [`scratch_len`] for the directional method's rings,
/// the rows of the stages after encoding and noise reduction (`denoise`: the path's scratch
/// elements per work element, when it is on).
fn extra_len<A: Arithmetic, C>(
    method: Method,
    detail: Detail,
    denoise: Option<(denoise::Search, usize)>,
    width: usize,
) -> Option<usize> {
    directional_len::<A>(method, width)?
        .checked_add(detail.len::<A::T, C>(width)?)?
        .checked_add(denoise_len(denoise, width)?)
}

/// Elements of a path's scratch for noise reduction when it is on (with its search and
/// `work_ratio` scratch elements per work element): the stream's samples, the filtered pair
/// of mosaic rows, the filter's output planes and the stream's work (plus alignment).
fn denoise_len(denoise: Option<(denoise::Search, usize)>, width: usize) -> Option<usize> {
    let Some((search, ratio)) = denoise else {
        return Some(0);
    };
    let packed = width / 2;
    let (samples, work, sums) = denoise::scratch_len(search, packed)?;
    let work = work.checked_mul(ratio)?.checked_add(ratio - 1)?;
    let sums = sums.checked_mul(2 * ratio)?.checked_add(2 * ratio - 1)?;
    samples
        .checked_add(width.checked_mul(2)?)?
        .checked_add(packed.checked_mul(4)?)?
        .checked_add(work)?
        .checked_add(sums)
}

/// Elements of a path's scratch (of type `A::T`) that hold the directional method's ring
/// buffers (of type `A::E`, so an `i32` takes two `u16`, plus one for alignment), 0 for
/// another method.
fn directional_len<A: Arithmetic>(method: Method, width: usize) -> Option<usize> {
    if method != Method::Directional {
        return Some(0);
    }
    let planes = directional::scratch_len(width)?;
    let (t, e) = (core::mem::size_of::<A::T>(), core::mem::size_of::<A::E>());
    if t == e {
        return Some(planes);
    }
    planes.checked_mul(e.div_ceil(t))?.checked_add(1)
}

fn engine_scratch_len(
    distortion: Option<&LensDistortion>,
    extra: usize,
    width: usize,
    height: usize,
) -> Option<usize> {
    let base = engine_base(width)?.checked_add(extra)?;
    match distortion {
        None => Some(base),
        Some(d) => d
            .window_rows(width, height)
            .checked_mul(3)?
            .checked_mul(width)?
            .checked_add(base),
    }
}

/// Scratch elements (`f32` for the float path, `u16` for the fixed path) either path needs for
/// a frame `width` pixels wide with the plainest stages (defect correction, levels, gains,
/// nearest, bilinear or MHC, highlights, colour matrix, 8-bit or 16-bit output): `16 * width
/// + 20` (five prepared rows, a row of planes, and the row function's rows for nearest and
/// small frames). For the other stages see [`IspConfig::scratch_len`].
pub const fn scratch_len(width: usize) -> Option<usize> {
    match width.checked_mul(16) {
        Some(v) => v.checked_add(20),
        None => None,
    }
}

/// The general engine's base scratch: five mosaic rows and three of RGB.
const fn engine_base(width: usize) -> Option<usize> {
    width.checked_mul(MOSAIC_ROWS + 3 * RGB_ROWS)
}

/// What the pipeline develops: a Bayer mosaic, or a linear frame that is already demosaiced
/// (a DNG's LinearRaw), which skips defect correction and demosaicing; every other stage is the
/// same. `run` takes a mosaic, `run_linear` a linear frame, `run_input` either.
#[derive(Debug, Clone, Copy)]
pub enum Input<'a> {
    /// A raw CFA mosaic.
    Mosaic(RawFrame<'a>),
    /// Linear RGB, three samples per pixel.
    Linear(LinearFrame<'a>),
}

impl Input<'_> {
    /// Width in pixels.
    pub fn width(&self) -> usize {
        match self {
            Self::Mosaic(raw) => raw.mosaic().width(),
            Self::Linear(frame) => frame.width(),
        }
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        match self {
            Self::Mosaic(raw) => raw.mosaic().height(),
            Self::Linear(frame) => frame.height(),
        }
    }
}

impl<'a> From<&RawFrame<'a>> for Input<'a> {
    fn from(raw: &RawFrame<'a>) -> Self {
        Self::Mosaic(*raw)
    }
}

impl<'a> From<RawFrame<'a>> for Input<'a> {
    fn from(raw: RawFrame<'a>) -> Self {
        Self::Mosaic(raw)
    }
}

impl<'a> From<&LinearFrame<'a>> for Input<'a> {
    fn from(frame: &LinearFrame<'a>) -> Self {
        Self::Linear(*frame)
    }
}

impl<'a> From<LinearFrame<'a>> for Input<'a> {
    fn from(frame: LinearFrame<'a>) -> Self {
        Self::Linear(frame)
    }
}

/// An output sample: `u8` or `u16` sRGB, or `f32` in `[0, 1]` (float path only).
pub trait OutputSample: Copy + 'static {
    /// Bits of an integer code, or 0 for `f32`.
    const BITS: u8;
    /// From an encoded value in `[0, 1]` (the float path): rounded for integers.
    fn from_encoded(v: f32) -> Self;
    /// From an integer code of [`Self::BITS`] bits (the fixed path).
    fn from_code(v: u32) -> Self;
    /// The samples as bytes, where they are bytes (`u8`): for encoders that write bytes.
    #[doc(hidden)]
    fn as_bytes_mut(_samples: &mut [Self]) -> Option<&mut [u8]> {
        None
    }
}

impl OutputSample for u8 {
    const BITS: u8 = 8;
    #[inline]
    fn from_encoded(v: f32) -> Self {
        // v is in [0, 1]: adding a half and truncating rounds half away from zero.
        (v * 255.0 + 0.5) as u8
    }
    #[inline]
    fn from_code(v: u32) -> Self {
        v.min(255) as u8
    }
    fn as_bytes_mut(samples: &mut [Self]) -> Option<&mut [u8]> {
        Some(samples)
    }
}

impl OutputSample for u16 {
    const BITS: u8 = 16;
    #[inline]
    fn from_encoded(v: f32) -> Self {
        (v * 65535.0 + 0.5) as u16
    }
    #[inline]
    fn from_code(v: u32) -> Self {
        v.min(65535) as u16
    }
}

impl OutputSample for f32 {
    const BITS: u8 = 0;
    #[inline]
    fn from_encoded(v: f32) -> Self {
        v
    }
    #[inline]
    fn from_code(v: u32) -> Self {
        v as f32
    }
}

/// What differs between the float and the fixed path.
trait Path {
    type P: Sample;
    /// The directional method's arithmetic on this path's samples.
    type Directional: Arithmetic<T = Self::P>;
    /// The directional method's ring buffers in a part of this path's scratch
    /// ([`directional_len`] elements).
    fn directional_planes(part: &mut [Self::P]) -> &mut [<Self::Directional as Arithmetic>::E];
    fn method(&self) -> Method;
    fn dpc(&self) -> &DpcConfig<'_>;
    /// Distortion correction, if on.
    fn distortion(&self) -> Option<&LensDistortion>;
    /// Noise reduction's arithmetic (for a raw of one pattern), work and sums' types.
    type Nlm<'a>: denoise::Nlm<S = Self::P, W = Self::NrWork, A = Self::NrSum>
    where
        Self: 'a;
    type NrWork: Copy + Default + 'static;
    type NrSum: Copy + Default + bytemuck::Pod + 'static;
    /// Noise reduction's arithmetic for a raw of `pattern` and its search, when it is on.
    fn nlm(&self, pattern: CfaPattern) -> Option<(Self::Nlm<'_>, denoise::Search)>;
    /// Noise reduction's work in a part of this path's scratch.
    fn nr_work(part: &mut [Self::P]) -> &mut [Self::NrWork];
    /// Noise reduction's sums in a part of this path's scratch.
    fn nr_sums(part: &mut [Self::P]) -> &mut [Self::NrSum];
    /// Black-level subtraction alone, for noise reduction: pixels `x0..x0 + out.len()` of
    /// row `y` as fractions of white above black, clamped to `[0, 1]`.
    fn normalise_span(
        &self,
        raw: &RawFrame<'_>,
        y: usize,
        x0: usize,
        dpc: &[u16],
        out: &mut [Self::P],
    );
    /// Shading, ISO gain and white balance on mosaic row `y` normalised by
    /// [`Path::normalise_span`] (and noise-reduced), in place.
    fn gains_row(&self, raw: &RawFrame<'_>, y: usize, row: &mut [Self::P]);
    /// Pointwise stages for pixels `x0..x0 + out.len()` of row `y`, from corrected raw samples.
    fn mosaic_span(
        &self,
        raw: &RawFrame<'_>,
        y: usize,
        x0: usize,
        dpc: &[u16],
        out: &mut [Self::P],
    );
    /// Pointwise stages for every pixel of row `y` of a linear frame (`out`: 3 per pixel).
    fn linear_span(&self, frame: &LinearFrame<'_>, y: usize, out: &mut [Self::P]);
    /// Whether the highlight stage is on.
    fn highlights_on(&self) -> bool;
    /// The largest of the 3x3 raw samples around a pixel.
    fn brightest(neighbourhood: [Self::P; 9]) -> Self::P;
    /// The highlight stage on a demosaiced pixel whose 3x3 raw neighbourhood peaks at
    /// `brightest`.
    fn highlights(&self, rgb: [Self::P; 3], brightest: Self::P) -> [Self::P; 3];
    /// CCM, tone and encoding of a row of linear RGB into `out` (a row of the output).
    fn finish_row<O: OutputSample>(&self, row: &[Self::P], out: &mut [O]);
    /// As [`Path::finish_row`] up to the encoding, into `out` in this path's encoded domain
    /// (`f32` in `[0, 1]`, 16-bit codes), for the sharpening stage.
    fn encoded_row(&self, row: &[Self::P], out: &mut [Self::P]);
    /// Sharpens the middle row of `rows` (encoded, [`Path::encoded_row`]) into `out`.
    fn sharpen_row<O: OutputSample>(&self, rows: [&[Self::P]; 3], out: &mut [O]);
    /// The stages after encoding that read neighbouring rows.
    fn detail_stages(&self) -> Detail;
    /// The chroma stage's split elements (`f32`, `i32`).
    type Chroma: Copy + 'static;
    /// The chroma stage's rows in a part of this path's scratch.
    fn chroma_rows(part: &mut [Self::P]) -> &mut [Self::Chroma];
    /// Encodes a row of linear RGB as [`Path::encoded_row`] (into `encoded`), splits it into
    /// luma and chroma (into `split`) and runs the chroma stage's horizontal pass into `out`.
    fn chroma_split_row(
        &self,
        row: &[Self::P],
        encoded: &mut [Self::P],
        split: &mut [Self::Chroma],
        out: &mut [Self::Chroma],
    ) -> Result<(), IspError>;
    /// The chroma stage's vertical pass for the middle row of `rows` (from
    /// [`Path::chroma_split_row`]) into `work`, then luma plus chroma, sharpened if that is
    /// on, into `out`.
    fn chroma_row<O: OutputSample>(
        &self,
        rows: [&[Self::Chroma]; chroma::TAPS],
        work: &mut [Self::Chroma],
        out: &mut [O],
    ) -> Result<(), IspError>;
}

/// Walks the middle row of three encoded rows (`N` elements a pixel: RGB, or the chroma
/// stage's luma and chroma) for the sharpening stage: `emit(x, pixel, luma, blurred)` with
/// `blurred` the luma's 3x3 binomial sum around it (16 times the blur: weights 1 2 1 in each
/// direction), reflect-101 at the frame's edges (the caller reflects the rows).
#[inline(always)]
fn sharpen_pixels<const N: usize, V: Copy, L: Copy + core::ops::Add<Output = L>>(
    rows: [&[V]; 3],
    luma: impl Fn([V; N]) -> L,
    mut emit: impl FnMut(usize, [V; N], L, L),
) {
    let w = rows[1].len() / N;
    if w == 0 {
        return;
    }
    let pixel = |row: &[V], x: usize| -> [V; N] { core::array::from_fn(|i| row[N * x + i]) };
    // The luma of rows -1, 0, 1 at column x weighted 1 2 1, and the middle row's own.
    let column = |x: usize| {
        let mid = luma(pixel(rows[1], x));
        (
            luma(pixel(rows[0], x)) + mid + mid + luma(pixel(rows[2], x)),
            mid,
        )
    };
    // Columns x - 1, x and x + 1, slid along the row.
    let mut window = [column(reflect(-1, w)), column(0), column(reflect(1, w))];
    for x in 0..w {
        if x > 0 {
            window = [window[1], window[2], column(reflect(x as isize + 1, w))];
        }
        let blurred = window[0].0 + window[1].0 + window[1].0 + window[2].0;
        emit(x, pixel(rows[1], x), window[1].1, blurred);
    }
}

/// The float reference path.
#[derive(Debug, Clone, Copy)]
pub struct FloatPipeline<'a> {
    config: IspConfig<'a>,
    /// The exact 8-bit encoding as thresholds.
    codes8: EncodeThresholds8,
    /// Chroma noise reduction's parameters, when it is on.
    chroma: Option<chroma::FloatParams>,
    /// Noise reduction's parameters, when it is on.
    denoise: Option<denoise::FloatParams>,
}

impl<'a> FloatPipeline<'a> {
    /// A checked pipeline.
    pub fn new(config: &IspConfig<'a>) -> Result<Self, IspError> {
        config.validate()?;
        Ok(Self {
            config: *config,
            codes8: EncodeThresholds8::new(),
            chroma: chroma::FloatParams::new(config.chroma_denoise)?,
            denoise: match (&config.noise, config.denoise > 0.0) {
                (Some(profile), true) => Some(denoise::FloatParams::new(
                    profile,
                    config.denoise,
                    config.denoise_search,
                )?),
                _ => None,
            },
        })
    }

    /// Scratch elements [`FloatPipeline::run`] needs for a `width` x `height` frame (see
    /// [`IspConfig::scratch_len`]).
    pub fn scratch_len(&self, width: usize, height: usize) -> Option<usize> {
        let c = &self.config;
        scratch_for::<Self>(&config_shape(
            c.demosaic,
            self.denoise.map(|_| c.denoise_search),
            c.lsc.is_some(),
            c.active_distortion(),
            self.detail_stages(),
            width,
            height,
        ))
    }

    /// Scratch elements [`FloatPipeline::run_input_general`] needs (the reference engine).
    #[doc(hidden)]
    pub fn general_scratch_len(&self, width: usize, height: usize) -> Option<usize> {
        let c = &self.config;
        let denoise = (c.denoise > 0.0).then_some((c.denoise_search, 1));
        let detail = Detail::of(c.sharpen > 0.0, c.chroma_denoise > 0.0);
        let extra = extra_len::<Float<f32>, f32>(c.demosaic, detail, denoise, width)?;
        engine_scratch_len(c.active_distortion(), extra, width, height)
    }

    /// Runs output rows `rows` of `raw` into `out` (exactly `rows.len()` rows of the frame's
    /// width), with `scratch` of at least [`IspConfig::scratch_len`] elements.
    pub fn run<O: OutputSample>(
        &self,
        raw: &RawFrame<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.run_input(Input::Mosaic(*raw), rows, scratch, out)
    }

    /// As [`FloatPipeline::run`] for a linear (already demosaiced) frame.
    pub fn run_linear<O: OutputSample>(
        &self,
        frame: &LinearFrame<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.run_input(Input::Linear(*frame), rows, scratch, out)
    }

    /// As [`FloatPipeline::run`] for either kind of frame.
    pub fn run_input<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        planar::run_general(self, input, rows, scratch, out)
    }

    /// As [`FloatPipeline::run_input`], compiled for AVX2 and FMA: the same output, faster
    /// (the schedule's loops run eight lanes wide, and the 8-bit encoding evaluates the curve
    /// eight samples at a time, `srgb::avx2`; FMA only there, so every other result is the
    /// same).
    ///
    /// # Safety
    ///
    /// The CPU must support AVX2 and FMA (a function with a target feature is unsafe to call
    /// from code compiled without it). Check first with `is_x86_feature_detected!` for
    /// "avx2" and "fma".
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub fn run_input_avx2<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        planar::run_avx2(self, input, rows, scratch, out)
    }

    /// As [`FloatPipeline::run_input`], compiled for AVX-512 (F, BW, VL and DQ): the same
    /// output, the schedule's loops sixteen lanes wide.
    ///
    /// # Safety
    ///
    /// The CPU must support those features. Check first with `is_x86_feature_detected!` for
    /// each of "avx512f", "avx512bw", "avx512vl" and "avx512dq".
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
    pub fn run_input_avx512<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        planar::run_avx512(self, input, rows, scratch, out)
    }

    /// As [`FloatPipeline::run_input`] on the general streaming engine, the reference the
    /// tests check the schedule against (with [`FloatPipeline::general_scratch_len`]
    /// elements of scratch); not a runtime path.
    #[doc(hidden)]
    pub fn run_input_general<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [f32],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        run_rows(self, input, rows, scratch, out)
    }
}

impl FloatPipeline<'_> {
    /// Normalisation, shading, ISO gain and white balance of one sample `d` above black, out
    /// of `range` (white minus black), with the shading gain and white-balance gain at it.
    #[inline]
    fn pointwise(&self, d: u16, range: f32, shading: Option<f32>, wb: f32) -> f32 {
        self.gains(d as f32 / range, shading, wb)
    }

    /// Shading, ISO gain and white balance of a normalised sample `v`.
    #[inline]
    fn gains(&self, mut v: f32, shading: Option<f32>, wb: f32) -> f32 {
        let c = &self.config;
        if let Some(s) = shading {
            v *= s;
        }
        v = v.clamp(0.0, 1.0);
        if c.gain != 1.0 {
            v = (c.gain * v).min(1.0);
        }
        if wb != 1.0 {
            v = (wb * v).min(1.0);
        }
        v
    }
}

impl Path for FloatPipeline<'_> {
    type P = f32;
    type Directional = Float<f32>;

    fn directional_planes(part: &mut [f32]) -> &mut [f32] {
        part
    }

    fn method(&self) -> Method {
        self.config.demosaic
    }

    fn dpc(&self) -> &DpcConfig<'_> {
        &self.config.dpc
    }

    fn distortion(&self) -> Option<&LensDistortion> {
        self.config.active_distortion()
    }

    type Nlm<'a>
        = denoise::FloatNlm
    where
        Self: 'a;
    type NrWork = f32;
    type NrSum = f32;

    fn nlm(&self, pattern: CfaPattern) -> Option<(denoise::FloatNlm, denoise::Search)> {
        self.denoise
            .map(|p| (p.for_pattern(pattern), self.config.denoise_search))
    }

    fn nr_work(part: &mut [f32]) -> &mut [f32] {
        part
    }

    fn nr_sums(part: &mut [f32]) -> &mut [f32] {
        part
    }

    fn normalise_span(
        &self,
        raw: &RawFrame<'_>,
        y: usize,
        x0: usize,
        dpc: &[u16],
        out: &mut [f32],
    ) {
        let white = raw.white_level() as f32;
        for (i, (o, &r)) in out.iter_mut().zip(dpc).enumerate() {
            let black = raw.black_at(x0 + i, y);
            *o = (r.saturating_sub(black) as f32 / (white - black as f32)).clamp(0.0, 1.0);
        }
    }

    fn gains_row(&self, raw: &RawFrame<'_>, y: usize, row: &mut [f32]) {
        let c = &self.config;
        let mosaic = raw.mosaic();
        let (w, h, pattern) = (mosaic.width(), mosaic.height(), mosaic.pattern());
        for (x, v) in row.iter_mut().enumerate() {
            let shading = c.lsc.as_ref().map(|lsc| lsc.gain_f32(x, y, w, h));
            *v = self.gains(*v, shading, c.wb_gains[pattern.colour_at(x, y).index()]);
        }
    }

    fn mosaic_span(&self, raw: &RawFrame<'_>, y: usize, x0: usize, dpc: &[u16], out: &mut [f32]) {
        let c = &self.config;
        let mosaic = raw.mosaic();
        let (w, h) = (mosaic.width(), mosaic.height());
        let white = raw.white_level() as f32;
        let pattern = mosaic.pattern();
        let Some(lsc) = &c.lsc else {
            // Without shading every sample of one CFA position takes the same steps: the
            // constants of the row's two positions are fetched once (as in the fixed path).
            let steps: [(u16, f32, f32); 2] = core::array::from_fn(|i| {
                let (x, black) = (x0 + i, raw.black_at(x0 + i, y));
                (
                    black,
                    white - black as f32,
                    c.wb_gains[pattern.colour_at(x, y).index()],
                )
            });
            for (o, r) in out.chunks_mut(2).zip(dpc.chunks(2)) {
                for ((o, r), &(black, range, wb)) in o.iter_mut().zip(r).zip(&steps) {
                    *o = self.pointwise(r.saturating_sub(black), range, None, wb);
                }
            }
            return;
        };
        for (i, (o, &r)) in out.iter_mut().zip(dpc).enumerate() {
            let x = x0 + i;
            let black = raw.black_at(x, y);
            let shading = Some(lsc.gain_f32(x, y, w, h));
            let wb = c.wb_gains[pattern.colour_at(x, y).index()];
            *o = self.pointwise(r.saturating_sub(black), white - black as f32, shading, wb);
        }
    }

    fn linear_span(&self, frame: &LinearFrame<'_>, y: usize, out: &mut [f32]) {
        let c = &self.config;
        let (w, h) = (frame.width(), frame.height());
        let (black, white) = (frame.black_level(), frame.white_level());
        for (x, (px, raw)) in out
            .chunks_exact_mut(3)
            .zip(frame.row(y).chunks_exact(3))
            .enumerate()
        {
            let shading = c.lsc.as_ref().map(|lsc| lsc.gain_f32(x, y, w, h));
            for ch in 0..3 {
                let range = (white[ch] - black[ch]) as f32;
                let d = raw[ch].saturating_sub(black[ch]);
                px[ch] = self.pointwise(d, range, shading, c.wb_gains[ch]);
            }
        }
    }

    fn highlights_on(&self) -> bool {
        self.config.highlight_knee < 1.0
    }

    #[inline(always)]
    fn brightest(neighbourhood: [f32; 9]) -> f32 {
        neighbourhood.iter().fold(0.0f32, |a, b| a.max(*b))
    }

    #[inline]
    fn highlights(&self, rgb: [f32; 3], brightest: f32) -> [f32; 3] {
        highlights::neutralise_f32(rgb, brightest, self.config.highlight_knee)
    }

    fn finish_row<O: OutputSample>(&self, row: &[f32], out: &mut [O]) {
        let c = &self.config;
        let encode = |v: f32| {
            if O::BITS == 8 {
                // The exact curve's code, found among thresholds (srgb module).
                O::from_code(u32::from(self.codes8.code(v)))
            } else {
                O::from_encoded(srgb::encode_estimated(v))
            }
        };
        // Every switch is decided once per row, so the loop holds only the stages that run.
        let ccm_on = c.ccm != IDENTITY;
        let tone_on = !(c.tone.saturation_is_identity() && c.tone.curve_is_identity());
        if !tone_on {
            // The common camera pipeline: colour matrix (or none) and encoding, in a loop of
            // its own: with the stages that call out in it, the pixel went through the stack
            // in pieces and was read back whole, a store-forwarding stall per pixel.
            let pixels = out.chunks_exact_mut(3);
            if ccm_on {
                for (px, rgb) in pixels.zip(row.chunks_exact(3)) {
                    let lin = ccm::apply_f32(&c.ccm, [rgb[0], rgb[1], rgb[2]]);
                    for (o, v) in px.iter_mut().zip(lin) {
                        *o = encode(v);
                    }
                }
            } else {
                for (o, v) in out.iter_mut().zip(row) {
                    *o = encode(*v);
                }
            }
            return;
        }
        for (px, rgb) in out.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
            for (o, v) in px
                .iter_mut()
                .zip(self.linear_pixel([rgb[0], rgb[1], rgb[2]]))
            {
                *o = encode(v);
            }
        }
    }

    fn encoded_row(&self, row: &[f32], out: &mut [f32]) {
        for (px, rgb) in out.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
            for (o, v) in px
                .iter_mut()
                .zip(self.linear_pixel([rgb[0], rgb[1], rgb[2]]))
            {
                *o = srgb::encode_estimated(v);
            }
        }
    }

    fn sharpen_row<O: OutputSample>(&self, rows: [&[f32]; 3], out: &mut [O]) {
        let amount = self.config.sharpen;
        let luma = |p: [f32; 3]| LUMA[0] * p[0] + LUMA[1] * p[1] + LUMA[2] * p[2];
        sharpen_pixels(rows, luma, |x, e, y, blurred| {
            let detail = amount * (y - blurred * (1.0 / 16.0));
            for (o, v) in out[3 * x..3 * x + 3].iter_mut().zip(e) {
                *o = O::from_encoded((v + detail).clamp(0.0, 1.0));
            }
        });
    }

    fn detail_stages(&self) -> Detail {
        Detail::of(self.config.sharpen > 0.0, self.config.chroma_denoise > 0.0)
    }

    type Chroma = f32;

    fn chroma_rows(part: &mut [f32]) -> &mut [f32] {
        part
    }

    fn chroma_split_row(
        &self,
        row: &[f32],
        encoded: &mut [f32],
        split: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), IspError> {
        let Some(params) = &self.chroma else {
            return Ok(());
        };
        self.encoded_row(row, encoded);
        chroma::split_row_f32(encoded, split)?;
        chroma::horizontal_f32(params, split, out)
    }

    fn chroma_row<O: OutputSample>(
        &self,
        rows: [&[f32]; chroma::TAPS],
        work: &mut [f32],
        out: &mut [O],
    ) -> Result<(), IspError> {
        let Some(params) = &self.chroma else {
            return Ok(());
        };
        chroma::vertical_f32(params, rows, work)?;
        let work: &[f32] = work;
        let mut emit = |x: usize, detail: f32| {
            let p = &work[chroma::SPLIT * x..chroma::SPLIT * (x + 1)];
            for (o, c) in out[3 * x..3 * x + 3].iter_mut().zip(&p[1..]) {
                *o = O::from_encoded((p[0] + c + detail).clamp(0.0, 1.0));
            }
        };
        let amount = self.config.sharpen;
        if amount == 0.0 {
            (0..work.len() / chroma::SPLIT).for_each(|x| emit(x, 0.0));
        } else {
            let r = chroma::RADIUS;
            let rows = [rows[r - 1], rows[r], rows[r + 1]];
            sharpen_pixels(
                rows,
                |p: [f32; 4]| p[0],
                |x, _, y, blurred| emit(x, amount * (y - blurred * (1.0 / 16.0))),
            );
        }
        Ok(())
    }
}

impl FloatPipeline<'_> {
    /// CCM and tone of one pixel.
    #[inline]
    fn linear_pixel(&self, rgb: [f32; 3]) -> [f32; 3] {
        let c = &self.config;
        let lin = if c.ccm != IDENTITY {
            ccm::apply_f32(&c.ccm, rgb)
        } else {
            rgb
        };
        if c.tone.saturation_is_identity() && c.tone.curve_is_identity() {
            lin
        } else {
            c.tone.apply_estimated(lin)
        }
    }
}

/// The fixed-point firmware path: parameters quantised once; the sRGB encoding reads `static`
/// tables (computed when the library is built), the tone curve a 12 KiB table built here.
#[derive(Debug, Clone)]
pub struct FixedPipeline<'a> {
    dpc: DpcConfig<'a>,
    lsc: Option<LensShading<'a>>,
    method: Method,
    distortion: Option<LensDistortion>,
    gain_q16: Option<u64>,
    wb_q16: Option<[u64; 3]>,
    /// Noise reduction's parameters and search, when it is on.
    denoise: Option<(denoise::FixedParams, denoise::Search)>,
    highlights: Option<highlights::KneeQ16>,
    ccm_q: Option<[[i32; 3]; 3]>,
    saturation_q: Option<[[i32; 3]; 3]>,
    tone_lut: Option<ToneLut>,
    encode: EncodeLut,
    /// The sharpening amount in Q12, when it is on.
    sharpen_q12: Option<i64>,
    /// Chroma noise reduction's parameters, when it is on.
    chroma: Option<chroma::FixedParams>,
    /// The 16-bit encoding sharpening and chroma noise reduction run on, when either is on.
    encode16: Option<EncodeLut>,
}

fn to_q16(v: f32) -> u64 {
    (f64::from(v) * (1u64 << GAIN_FRAC_BITS) as f64 + 0.5) as u64
}

impl<'a> FixedPipeline<'a> {
    /// A checked pipeline writing `out_bits`-bit sRGB (8 or 16).
    pub fn new(config: &IspConfig<'a>, out_bits: u8) -> Result<Self, IspError> {
        config.validate()?;
        let identity_q = ccm::quantise(&IDENTITY, CCM_FRAC_BITS);
        let ccm_q = ccm::quantise(&config.ccm, CCM_FRAC_BITS);
        Ok(Self {
            dpc: config.dpc,
            lsc: config.lsc,
            method: config.demosaic,
            distortion: config.active_distortion().copied(),
            gain_q16: (config.gain != 1.0).then(|| to_q16(config.gain)),
            wb_q16: (config.wb_gains != [1.0; 3]).then(|| config.wb_gains.map(to_q16)),
            denoise: match (&config.noise, config.denoise > 0.0) {
                (Some(profile), true) => Some((
                    denoise::FixedParams::new(profile, config.denoise, config.denoise_search)?,
                    config.denoise_search,
                )),
                _ => None,
            },
            highlights: (config.highlight_knee < 1.0)
                .then(|| highlights::KneeQ16::new(config.highlight_knee)),
            ccm_q: (ccm_q != identity_q).then_some(ccm_q),
            saturation_q: (!config.tone.saturation_is_identity())
                .then(|| ccm::quantise(&config.tone.saturation_matrix(), SATURATION_FRAC_BITS)),
            tone_lut: (!config.tone.curve_is_identity()).then(|| ToneLut::new(&config.tone)),
            encode: EncodeLut::new(out_bits)?,
            sharpen_q12: (config.sharpen > 0.0).then(|| {
                (f64::from(config.sharpen) * f64::from(1u32 << SHARPEN_FRAC_BITS) + 0.5) as i64
            }),
            chroma: chroma::FixedParams::new(config.chroma_denoise)?,
            encode16: match config.sharpen > 0.0 || config.chroma_denoise > 0.0 {
                true => Some(EncodeLut::new(16)?),
                false => None,
            },
        })
    }

    /// Scratch elements [`FixedPipeline::run`] needs for a `width` x `height` frame (see
    /// [`IspConfig::scratch_len`]).
    pub fn scratch_len(&self, width: usize, height: usize) -> Option<usize> {
        scratch_for::<Self>(&config_shape(
            self.method,
            self.denoise.as_ref().map(|(_, search)| *search),
            self.lsc.is_some(),
            self.distortion.as_ref(),
            self.detail_stages(),
            width,
            height,
        ))
    }

    /// Scratch elements [`FixedPipeline::run_input_general`] needs (the reference engine).
    #[doc(hidden)]
    pub fn general_scratch_len(&self, width: usize, height: usize) -> Option<usize> {
        let denoise = self
            .denoise
            .as_ref()
            .map(|(_, search)| (*search, FIXED_WORK_RATIO));
        let extra =
            extra_len::<Fixed<u16>, i32>(self.method, self.detail_stages(), denoise, width)?;
        engine_scratch_len(self.distortion.as_ref(), extra, width, height)
    }

    /// Runs output rows `rows` of `raw` into `out` (exactly `rows.len()` rows of the frame's
    /// width, samples of the depth given to [`FixedPipeline::new`]), with `scratch` of at least
    /// [`IspConfig::scratch_len`] elements.
    pub fn run<O: OutputSample>(
        &self,
        raw: &RawFrame<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.run_input(Input::Mosaic(*raw), rows, scratch, out)
    }

    /// As [`FixedPipeline::run`] for a linear (already demosaiced) frame.
    pub fn run_linear<O: OutputSample>(
        &self,
        frame: &LinearFrame<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.run_input(Input::Linear(*frame), rows, scratch, out)
    }

    /// As [`FixedPipeline::run`] for either kind of frame.
    pub fn run_input<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.check_output_depth::<O>()?;
        planar::run_general(self, input, rows, scratch, out)
    }

    /// As [`FixedPipeline::run_input`], compiled for AVX2: the same output, faster (the
    /// schedule's loops run 8 to 16 lanes wide).
    ///
    /// # Safety
    ///
    /// The CPU must support AVX2 and FMA (a function with a target feature is unsafe to call
    /// from code compiled without it; FMA for the float path's encoder, which the schedule
    /// shares). Check first with `is_x86_feature_detected!` for "avx2" and "fma".
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub fn run_input_avx2<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.check_output_depth::<O>()?;
        planar::run_avx2(self, input, rows, scratch, out)
    }

    /// As [`FixedPipeline::run_input`], compiled for AVX-512 (F, BW, VL and DQ): the same
    /// output, the schedule's loops sixteen lanes wide, the 8-bit encoding a search in
    /// registers (`srgb::avx512`).
    ///
    /// # Safety
    ///
    /// The CPU must support those features. Check first with `is_x86_feature_detected!` for
    /// each of "avx512f", "avx512bw", "avx512vl" and "avx512dq".
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
    pub fn run_input_avx512<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.check_output_depth::<O>()?;
        planar::run_avx512(self, input, rows, scratch, out)
    }

    /// As [`FixedPipeline::run_input`] on the general streaming engine, the reference the
    /// tests check the schedule against (with [`FixedPipeline::general_scratch_len`]
    /// elements of scratch); not a runtime path.
    #[doc(hidden)]
    pub fn run_input_general<O: OutputSample>(
        &self,
        input: Input<'_>,
        rows: Range<usize>,
        scratch: &mut [u16],
        out: &mut RgbViewMut<'_, O>,
    ) -> Result<(), IspError> {
        self.check_output_depth::<O>()?;
        run_rows(self, input, rows, scratch, out)
    }
}

impl FixedPipeline<'_> {
    /// Output samples must have the depth the encoding table was built for.
    fn check_output_depth<O: OutputSample>(&self) -> Result<(), IspError> {
        let max = match O::BITS {
            8 => 255,
            16 => 65535,
            _ => 0,
        };
        if max != self.encode.max() {
            return Err(IspError::InvalidParameter {
                name: "output",
                allowed: "u8 or u16 samples of the depth the pipeline was built for",
            });
        }
        Ok(())
    }
}

/// The Q16 reciprocal of a black-to-white `range`, so `65535 * d / range` is one multiply.
fn recip_q16(range: u16) -> u64 {
    let range = u64::from(range);
    ((65535u64 << 16) + range / 2) / range
}

impl FixedPipeline<'_> {
    /// Normalisation (by `recip`, [`recip_q16`]), shading (Q4.16), ISO gain and the white
    /// balance of `colour` on one sample `d` above black, in 16-bit linear units.
    #[inline]
    fn pointwise(&self, d: u16, recip: u64, shading: Option<u64>, colour: usize) -> u16 {
        let mut t = u64::from(d) * recip;
        if let Some(s) = shading {
            t = (t >> 16) * s;
        }
        self.gains_q16(((t + (1 << 15)) >> 16).min(65535), colour)
    }

    /// ISO gain and the white balance of `colour` on a 16-bit linear sample.
    #[inline]
    fn gains_q16(&self, mut v: u64, colour: usize) -> u16 {
        if let Some(g) = self.gain_q16 {
            v = ((v * g + (1 << 15)) >> GAIN_FRAC_BITS).min(65535);
        }
        if let Some(wb) = &self.wb_q16 {
            v = ((v * wb[colour] + (1 << 15)) >> GAIN_FRAC_BITS).min(65535);
        }
        v as u16
    }
}

impl Path for FixedPipeline<'_> {
    type P = u16;
    type Directional = Fixed<u16>;

    fn directional_planes(part: &mut [u16]) -> &mut [i32] {
        // The part holds one element more than the planes need, for the alignment.
        bytemuck::pod_align_to_mut::<u16, i32>(part).1
    }

    fn method(&self) -> Method {
        self.method
    }

    fn dpc(&self) -> &DpcConfig<'_> {
        &self.dpc
    }

    fn distortion(&self) -> Option<&LensDistortion> {
        self.distortion.as_ref()
    }

    type Nlm<'a>
        = denoise::FixedNlm<'a>
    where
        Self: 'a;
    type NrWork = u32;
    type NrSum = u64;

    fn nlm(&self, pattern: CfaPattern) -> Option<(denoise::FixedNlm<'_>, denoise::Search)> {
        self.denoise
            .as_ref()
            .map(|(params, search)| (params.for_pattern(pattern), *search))
    }

    fn nr_work(part: &mut [u16]) -> &mut [u32] {
        // The part holds one element more than the work needs, for the alignment.
        bytemuck::pod_align_to_mut::<u16, u32>(part).1
    }

    fn nr_sums(part: &mut [u16]) -> &mut [u64] {
        // The part holds three elements more than the sums need, for the alignment.
        bytemuck::pod_align_to_mut::<u16, u64>(part).1
    }

    fn normalise_span(
        &self,
        raw: &RawFrame<'_>,
        y: usize,
        x0: usize,
        dpc: &[u16],
        out: &mut [u16],
    ) {
        let black = raw.black_level();
        let recip: [u64; 4] = core::array::from_fn(|p| recip_q16(raw.white_level() - black[p]));
        for (i, (o, &r)) in out.iter_mut().zip(dpc).enumerate() {
            let position = (y & 1) * 2 + ((x0 + i) & 1);
            let t = u64::from(r.saturating_sub(black[position])) * recip[position];
            *o = ((t + (1 << 15)) >> 16).min(65535) as u16;
        }
    }

    fn gains_row(&self, raw: &RawFrame<'_>, y: usize, row: &mut [u16]) {
        let mosaic = raw.mosaic();
        let (w, h, pattern) = (mosaic.width(), mosaic.height(), mosaic.pattern());
        let mut nodes = [0u32; 2 * MAX_GRID_SIDE];
        if let Some(lsc) = &self.lsc {
            lsc.row_nodes_q16(y, h, &mut nodes);
        }
        for (x, v) in row.iter_mut().enumerate() {
            let mut t = u64::from(*v);
            if let Some(lsc) = &self.lsc {
                t = ((t * lsc.gain_q16(&nodes, x, w) + (1 << 15)) >> 16).min(65535);
            }
            *v = self.gains_q16(t, pattern.colour_at(x, y).index());
        }
    }

    fn mosaic_span(&self, raw: &RawFrame<'_>, y: usize, x0: usize, dpc: &[u16], out: &mut [u16]) {
        let mosaic = raw.mosaic();
        let (w, h) = (mosaic.width(), mosaic.height());
        let pattern = mosaic.pattern();
        let recip: [u64; 4] =
            core::array::from_fn(|p| recip_q16(raw.white_level() - raw.black_level()[p]));
        let Some(lsc) = &self.lsc else {
            // Without shading every sample of one CFA position takes the same steps: the
            // constants of the row's two positions are fetched once.
            let black = raw.black_level();
            let steps: [(u16, u64, usize); 2] = core::array::from_fn(|i| {
                let x = x0 + i;
                let position = (y & 1) * 2 + (x & 1);
                let colour = pattern.colour_at(x, y).index();
                (black[position], recip[position], colour)
            });
            for (o, r) in out.chunks_mut(2).zip(dpc.chunks(2)) {
                for ((o, r), &(black, recip, colour)) in o.iter_mut().zip(r).zip(&steps) {
                    *o = self.pointwise(r.saturating_sub(black), recip, None, colour);
                }
            }
            return;
        };
        let mut nodes = [0u32; 2 * MAX_GRID_SIDE];
        lsc.row_nodes_q16(y, h, &mut nodes);
        for (i, (o, &r)) in out.iter_mut().zip(dpc).enumerate() {
            let x = x0 + i;
            let position = (y & 1) * 2 + (x & 1);
            let d = r.saturating_sub(raw.black_level()[position]);
            let shading = Some(lsc.gain_q16(&nodes, x, w));
            let colour = pattern.colour_at(x, y).index();
            *o = self.pointwise(d, recip[position], shading, colour);
        }
    }

    fn linear_span(&self, frame: &LinearFrame<'_>, y: usize, out: &mut [u16]) {
        let (w, h) = (frame.width(), frame.height());
        let (black, white) = (frame.black_level(), frame.white_level());
        let recip: [u64; 3] = core::array::from_fn(|c| recip_q16(white[c] - black[c]));
        let mut nodes = [0u32; 2 * MAX_GRID_SIDE];
        if let Some(lsc) = &self.lsc {
            lsc.row_nodes_q16(y, h, &mut nodes);
        }
        for (x, (px, raw)) in out
            .chunks_exact_mut(3)
            .zip(frame.row(y).chunks_exact(3))
            .enumerate()
        {
            let shading = self.lsc.as_ref().map(|lsc| lsc.gain_q16(&nodes, x, w));
            for c in 0..3 {
                px[c] = self.pointwise(raw[c].saturating_sub(black[c]), recip[c], shading, c);
            }
        }
    }

    fn highlights_on(&self) -> bool {
        self.highlights.is_some()
    }

    #[inline(always)]
    fn brightest(neighbourhood: [u16; 9]) -> u16 {
        neighbourhood.iter().fold(0, |a, b| a.max(*b))
    }

    #[inline]
    fn highlights(&self, rgb: [u16; 3], brightest: u16) -> [u16; 3] {
        match &self.highlights {
            Some(knee) => knee.neutralise(rgb, brightest),
            None => rgb,
        }
    }

    fn finish_row<O: OutputSample>(&self, row: &[u16], out: &mut [O]) {
        if self.saturation_q.is_none() && self.tone_lut.is_none() && O::BITS == 8 {
            // The common camera pipeline: colour matrix (or none) and 8-bit encoding only.
            let encode = |v: u16| O::from_code(self.encode.lookup(v));
            let pixels = out.chunks_exact_mut(3);
            match &self.ccm_q {
                Some(m) => {
                    for (px, rgb) in pixels.zip(row.chunks_exact(3)) {
                        let lin = ccm::apply_u16(m, CCM_FRAC_BITS, [rgb[0], rgb[1], rgb[2]]);
                        for (o, v) in px.iter_mut().zip(lin) {
                            *o = encode(v);
                        }
                    }
                }
                None => {
                    for (o, v) in out.iter_mut().zip(row) {
                        *o = encode(*v);
                    }
                }
            }
            return;
        }
        for (px, rgb) in out.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
            let lin = self.linear_pixel([rgb[0], rgb[1], rgb[2]]);
            for (o, v) in px.iter_mut().zip(lin) {
                *o = O::from_code(self.encode.lookup(v));
            }
        }
    }

    fn encoded_row(&self, row: &[u16], out: &mut [u16]) {
        let Some(encode16) = &self.encode16 else {
            return;
        };
        for (px, rgb) in out.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
            let lin = self.linear_pixel([rgb[0], rgb[1], rgb[2]]);
            // Codes of a 16-bit table fit u16.
            for (o, v) in px.iter_mut().zip(lin) {
                *o = encode16.lookup(v) as u16;
            }
        }
    }

    fn sharpen_row<O: OutputSample>(&self, rows: [&[u16]; 3], out: &mut [O]) {
        let Some(amount) = self.sharpen_q12 else {
            return;
        };
        // Luma < 2^16, so the column sums (x4) and the blur sums (x16) fit u32.
        let luma = |p: [u16; 3]| {
            (LUMA_Q16[0] * u32::from(p[0])
                + LUMA_Q16[1] * u32::from(p[1])
                + LUMA_Q16[2] * u32::from(p[2])
                + (1 << 15))
                >> 16
        };
        sharpen_pixels(rows, luma, |x, e, y, blurred| {
            let add = sharpen_add(amount, y, blurred);
            for (o, v) in out[3 * x..3 * x + 3].iter_mut().zip(e) {
                *o = code16_to_output((i64::from(v) + add).clamp(0, 65535));
            }
        });
    }

    fn detail_stages(&self) -> Detail {
        Detail::of(self.sharpen_q12.is_some(), self.chroma.is_some())
    }

    type Chroma = i32;

    fn chroma_rows(part: &mut [u16]) -> &mut [i32] {
        // The part holds one element more than the rows need, for the alignment.
        bytemuck::pod_align_to_mut::<u16, i32>(part).1
    }

    fn chroma_split_row(
        &self,
        row: &[u16],
        encoded: &mut [u16],
        split: &mut [i32],
        out: &mut [i32],
    ) -> Result<(), IspError> {
        let Some(params) = &self.chroma else {
            return Ok(());
        };
        self.encoded_row(row, encoded);
        chroma::split_row_u16(encoded, split)?;
        chroma::horizontal_i32(params, split, out)
    }

    fn chroma_row<O: OutputSample>(
        &self,
        rows: [&[i32]; chroma::TAPS],
        work: &mut [i32],
        out: &mut [O],
    ) -> Result<(), IspError> {
        let Some(params) = &self.chroma else {
            return Ok(());
        };
        chroma::vertical_i32(params, rows, work)?;
        let work: &[i32] = work;
        let mut emit = |x: usize, add: i64| {
            let p = &work[chroma::SPLIT * x..chroma::SPLIT * (x + 1)];
            for (o, c) in out[3 * x..3 * x + 3].iter_mut().zip(&p[1..]) {
                let v = i64::from(p[0]) + i64::from(*c) + add;
                *o = code16_to_output(v.clamp(0, 65535));
            }
        };
        match self.sharpen_q12 {
            None => (0..work.len() / chroma::SPLIT).for_each(|x| emit(x, 0)),
            Some(amount) => {
                let r = chroma::RADIUS;
                let rows = [rows[r - 1], rows[r], rows[r + 1]];
                // Luma is a 16-bit code, as the sharpening stage's own.
                sharpen_pixels(
                    rows,
                    |p: [i32; 4]| p[0] as u32,
                    |x, _, y, blurred| emit(x, sharpen_add(amount, y, blurred)),
                );
            }
        }
        Ok(())
    }
}

/// What the fixed path's sharpening adds to each 16-bit code: 16 times the detail (`luma`
/// against the 3x3 binomial sum `blurred`) times the Q12 amount, shifted by 4 + 12, rounding.
#[inline(always)]
fn sharpen_add(amount: i64, luma: u32, blurred: u32) -> i64 {
    let detail16 = 16 * i64::from(luma) - i64::from(blurred);
    (amount * detail16 + (1 << 15)) >> 16
}

/// A 16-bit code (`0..=65535`) at the output's depth: rounded to 8 bits, or as it is.
#[inline(always)]
fn code16_to_output<O: OutputSample>(v: i64) -> O {
    match O::BITS {
        8 => O::from_code(((v * 255 + 32767) / 65535) as u32),
        _ => O::from_code(v as u32),
    }
}

impl FixedPipeline<'_> {
    /// CCM and tone of one pixel.
    #[inline]
    fn linear_pixel(&self, mut lin: [u16; 3]) -> [u16; 3] {
        if let Some(m) = &self.ccm_q {
            lin = ccm::apply_u16(m, CCM_FRAC_BITS, lin);
        }
        if let Some(m) = &self.saturation_q {
            lin = ccm::apply_u16(m, SATURATION_FRAC_BITS, lin);
        }
        if let Some(lut) = &self.tone_lut {
            lin = lin.map(|v| lut.lookup(v));
        }
        lin
    }
}

/// Rows `first..first + len` of one stage are held in a ring of `slots` rows, row `r` in slot
/// `r % slots`: a sliding window, so rows shared by consecutive requests are kept.
#[derive(Debug, Clone, Copy, Default)]
struct RowWindow {
    first: usize,
    len: usize,
}

impl RowWindow {
    /// Makes rows `lo..=hi` (at most `slots` of them) held; returns the rows the caller must
    /// now compute, below and above the rows kept.
    fn request(&mut self, lo: usize, hi: usize, slots: usize) -> [Range<usize>; 2] {
        let (held_lo, held_end) = (self.first, self.first + self.len);
        if self.len > 0 && lo >= held_lo && hi < held_end {
            return [0..0, 0..0];
        }
        let touching = self.len > 0 && lo <= held_end && hi + 1 >= held_lo;
        let (mut a, mut b) = if touching {
            (lo.min(held_lo), (hi + 1).max(held_end))
        } else {
            (lo, hi + 1)
        };
        if b - a > slots {
            // Keep the held rows nearest the request, on the side it came from.
            if b == hi + 1 {
                a = b - slots;
            } else {
                b = a + slots;
            }
        }
        self.first = a;
        self.len = b - a;
        if touching {
            [a..held_lo.clamp(a, b), held_end.clamp(a, b)..b]
        } else {
            [a..b, 0..0]
        }
    }
}

/// Noise reduction in one run: the stream, and the filtered pair of mosaic rows (after the
/// gains) that the mosaic ring copies from.
struct Denoiser<'s, 'p, A: Path + 'p> {
    stream: denoise::Stream<'s, A::Nlm<'p>>,
    /// Mosaic rows `2 * pair_tag` and `2 * pair_tag + 1` (and the packing's temporary).
    pair: &'s mut [A::P],
    pair_tag: usize,
    /// The filter's four output planes.
    filtered: &'s mut [A::P],
}

/// The ring buffers of one run and how to fill them.
struct Engine<'s, 'p, A: Path> {
    path: &'p A,
    input: Input<'p>,
    /// The streaming methods' prepared mosaic rows, tagged with the row each holds; the
    /// directional method's prepared row, in its first row.
    mosaic_ring: &'s mut [A::P],
    mosaic_tags: [usize; MOSAIC_ROWS],
    /// The directional method, when it runs (it keeps its own rows).
    directional: Option<Stream<'s, A::Directional>>,
    /// Noise reduction, when it is on.
    denoiser: Option<Denoiser<'s, 'p, A>>,
    /// Demosaiced RGB, `demosaic_slots` rows.
    demosaic_ring: &'s mut [A::P],
    demosaic_slots: usize,
    demosaic_window: RowWindow,
    /// Distortion-corrected RGB (denoise's window when the correction is on), `RGB_ROWS`
    /// rows.
    corrected_ring: &'s mut [A::P],
    corrected_window: RowWindow,
    /// The scratch the run needs with distortion correction on, for the error when a lens
    /// bends rows further than the ring holds.
    needed: Option<usize>,
    provided: usize,
}

impl<'p, A: Path> Engine<'_, 'p, A> {
    /// Makes demosaiced rows `lo..=hi` held.
    fn demosaic_rows(&mut self, lo: usize, hi: usize) -> Result<(), IspError> {
        let (w, h) = (self.input.width(), self.input.height());
        for range in self.demosaic_window.request(lo, hi, self.demosaic_slots) {
            for ry in range {
                match self.input {
                    Input::Mosaic(raw) if self.directional.is_some() => {
                        self.directional_row(&raw, ry, w)?
                    }
                    Input::Mosaic(raw) => self.demosaic_row(&raw, ry, w, h)?,
                    Input::Linear(frame) => self.linear_row(&frame, ry, w),
                }
            }
        }
        Ok(())
    }

    /// Makes linear row `y` held (demosaiced, or distortion-corrected when the correction is
    /// on) and returns it.
    fn linear_rgb_row(&mut self, y: usize) -> Result<&[A::P], IspError> {
        let (w, h) = (self.input.width(), self.input.height());
        let Some(lens) = self.path.distortion() else {
            self.demosaic_rows(y, y)?;
            let slot = y % self.demosaic_slots;
            return Ok(&self.demosaic_ring[slot * 3 * w..(slot + 1) * 3 * w]);
        };
        for range in self.corrected_window.request(y, y, RGB_ROWS) {
            for v in range {
                let slot = v % RGB_ROWS;
                let Some(source) = lens.source_rows(v, w, h) else {
                    self.corrected_ring[slot * 3 * w..(slot + 1) * 3 * w].fill(A::P::default());
                    continue;
                };
                let (s0, s1) = (*source.start(), *source.end());
                if s1 - s0 + 1 > self.demosaic_slots {
                    return Err(IspError::BufferTooSmall {
                        needed: self.needed.unwrap_or(usize::MAX),
                        provided: self.provided,
                    });
                }
                self.demosaic_rows(s0, s1)?;
                let ring: &[A::P] = self.demosaic_ring;
                let slots = self.demosaic_slots;
                // Rows s0..=s1 fit the ring: their slots follow s0's, wrapping once.
                // correct_row reads only those rows; the clamp keeps this total anyway.
                let first = s0 % slots;
                let row = |ry: usize| {
                    let slot = first + ry.saturating_sub(s0).min(slots - 1);
                    let slot = if slot >= slots { slot - slots } else { slot };
                    &ring[slot * 3 * w..(slot + 1) * 3 * w]
                };
                let dst = &mut self.corrected_ring[slot * 3 * w..(slot + 1) * 3 * w];
                lens.correct_row_by_pixel(v, w, h, row, dst);
            }
        }
        let slot = y % RGB_ROWS;
        Ok(&self.corrected_ring[slot * 3 * w..(slot + 1) * 3 * w])
    }

    /// A linear frame's row, prepared as a demosaiced one is; the highlight stage sees the
    /// pixel's own channels (there is no raw neighbourhood).
    fn linear_row(&mut self, frame: &LinearFrame<'_>, ry: usize, w: usize) {
        let slot = ry % self.demosaic_slots;
        let out = &mut self.demosaic_ring[slot * 3 * w..(slot + 1) * 3 * w];
        self.path.linear_span(frame, ry, out);
        if self.path.highlights_on() {
            for px in out.chunks_exact_mut(3) {
                let rgb = [px[0], px[1], px[2]];
                let own: [A::P; 9] = core::array::from_fn(|i| rgb[i % 3]);
                px.copy_from_slice(&self.path.highlights(rgb, A::brightest(own)));
            }
        }
    }

    /// Row `my` of the raw frame through defect correction and the pointwise stages (and
    /// noise reduction, when it is on), into `dst`.
    fn prepare_row(
        path: &'p A,
        denoiser: &mut Option<Denoiser<'_, 'p, A>>,
        raw: &RawFrame<'_>,
        my: usize,
        dst: &mut [A::P],
    ) -> Result<(), IspError> {
        let Some(nr) = denoiser else {
            Self::corrected_row(raw, path.dpc(), my, dst, |x0, y, dpc, out| {
                path.mosaic_span(raw, y, x0, dpc, out)
            });
            return Ok(());
        };
        let w = raw.mosaic().width();
        let wp = w / 2;
        let j = my / 2;
        if nr.pair_tag != j {
            nr.pair_tag = usize::MAX;
            let Denoiser {
                stream,
                pair,
                filtered,
                ..
            } = nr;
            let (f01, f23) = filtered.split_at_mut(2 * wp);
            let (f0, f1) = f01.split_at_mut(wp);
            let (f2, f3) = f23.split_at_mut(wp);
            stream.row(
                j,
                |r, planes| {
                    // The pair holds the packed row's mosaic rows until the filter's output.
                    let (top, bottom) = pair.split_at_mut(w);
                    for (py, row) in [&mut *top, &mut *bottom].into_iter().enumerate() {
                        Self::corrected_row(raw, path.dpc(), 2 * r + py, row, |x0, y, dpc, out| {
                            path.normalise_span(raw, y, x0, dpc, out)
                        });
                    }
                    let [p0, p1, p2, p3] = planes;
                    for (k, (plane, row)) in
                        [(p0, &*top), (p1, &*top), (p2, &*bottom), (p3, &*bottom)]
                            .into_iter()
                            .enumerate()
                    {
                        for (v, pair) in plane.iter_mut().zip(row.chunks_exact(2)) {
                            *v = pair[k & 1];
                        }
                    }
                    Ok(())
                },
                [f0, f1, f2, f3],
            )?;
            for (py, row) in nr.pair.chunks_exact_mut(w).enumerate() {
                let [left, right] =
                    [2 * py, 2 * py + 1].map(|k| &nr.filtered[k * wp..(k + 1) * wp]);
                for ((pair, &a), &b) in row.chunks_exact_mut(2).zip(left).zip(right) {
                    pair[0] = a;
                    pair[1] = b;
                }
                path.gains_row(raw, 2 * j + py, row);
            }
            nr.pair_tag = j;
        }
        dst.copy_from_slice(&nr.pair[(my & 1) * w..(my & 1) * w + w]);
        Ok(())
    }

    /// Row `my` through defect correction, then `span(x0, my, corrected, out)` chunk by chunk.
    fn corrected_row(
        raw: &RawFrame<'_>,
        dpc: &DpcConfig<'_>,
        my: usize,
        dst: &mut [A::P],
        mut span: impl FnMut(usize, usize, &[u16], &mut [A::P]),
    ) {
        let mut corrected = [0u16; CHUNK];
        for x0 in (0..dst.len()).step_by(CHUNK) {
            let n = CHUNK.min(dst.len() - x0);
            dpc::correct_span(raw, dpc, my, x0, &mut corrected[..n]);
            span(x0, my, &corrected[..n], &mut dst[x0..x0 + n]);
        }
    }

    /// Demosaiced row `ry` by the directional method: the stream continues if `ry` is the row
    /// it writes next, else starts again at `ry` (reading the 12 rows above it first).
    fn directional_row(&mut self, raw: &RawFrame<'_>, ry: usize, w: usize) -> Result<(), IspError> {
        let Some(stream) = &mut self.directional else {
            return Ok(());
        };
        if stream.next_output() != Some(ry) {
            stream.restart(ry);
        }
        let slot = ry % self.demosaic_slots;
        let out = &mut self.demosaic_ring[slot * 3 * w..(slot + 1) * 3 * w];
        let prepared = &mut self.mosaic_ring[..w];
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
                Self::prepare_row(self.path, &mut self.denoiser, raw, my, prepared)?;
            }
            let source = read.map(|_| SourceRow::Interleaved(&*prepared));
            if stream.next_output() == Some(ry) {
                // The engine takes the configurations the planar schedule does not; eight
                // lanes per block in every build (its AVX-512 entry is not measured apart).
                stream.step::<LANES>(source, Some(OutputRow::Interleaved(&mut *out)));
                break;
            }
            stream.step::<LANES>(source, None);
        }
        if self.path.highlights_on() {
            let y = ry as isize;
            for (x, px) in out.chunks_exact_mut(3).enumerate() {
                let x = x as isize;
                let neighbourhood: [A::P; 9] = core::array::from_fn(|i| {
                    stream.sample(y + i as isize / 3 - 1, x + i as isize % 3 - 1)
                });
                let rgb = self
                    .path
                    .highlights([px[0], px[1], px[2]], A::brightest(neighbourhood));
                px.copy_from_slice(&rgb);
            }
        }
        Ok(())
    }

    fn demosaic_row(
        &mut self,
        raw: &RawFrame<'_>,
        ry: usize,
        w: usize,
        h: usize,
    ) -> Result<(), IspError> {
        for dm in -2..=2isize {
            let my = reflect(ry as isize + dm, h);
            let slot = my % MOSAIC_ROWS;
            if self.mosaic_tags[slot] == my {
                continue;
            }
            let dst = &mut self.mosaic_ring[slot * w..(slot + 1) * w];
            Self::prepare_row(self.path, &mut self.denoiser, raw, my, dst)?;
            self.mosaic_tags[slot] = my;
        }
        let ring: &[A::P] = self.mosaic_ring;
        let source: [&[A::P]; 5] = core::array::from_fn(|i| {
            let my = reflect(ry as isize + i as isize - 2, h);
            let slot = my % MOSAIC_ROWS;
            &ring[slot * w..(slot + 1) * w]
        });
        let slot = ry % self.demosaic_slots;
        let out = &mut self.demosaic_ring[slot * 3 * w..(slot + 1) * 3 * w];
        // The directional method streams only frames at least 2 pixels wide and high; on
        // thinner ones it is bilinear's line rule, as the whole-frame function is.
        let method = match self.path.method() {
            Method::Directional => Method::Bilinear,
            other => other,
        };
        demosaic::row(method, source, ry, h, raw.mosaic().pattern(), out)?;
        if self.path.highlights_on() {
            let [up, mid, down] = [source[1], source[2], source[3]];
            for (x, px) in out.chunks_exact_mut(3).enumerate() {
                let neighbourhood: [A::P; 9] = if x > 0 && x + 1 < w {
                    // Interior: the three columns without reflection.
                    let (u, m, d) = (&up[x - 1..x + 2], &mid[x - 1..x + 2], &down[x - 1..x + 2]);
                    [u[0], u[1], u[2], m[0], m[1], m[2], d[0], d[1], d[2]]
                } else {
                    let columns = [-1isize, 0, 1].map(|dx| reflect(x as isize + dx, w));
                    core::array::from_fn(|i| source[1 + i / 3][columns[i % 3]])
                };
                let rgb = self
                    .path
                    .highlights([px[0], px[1], px[2]], A::brightest(neighbourhood));
                px.copy_from_slice(&rgb);
            }
        }
        Ok(())
    }
}

/// The schedule's shape for a run of `path` over rows `rows` of `input`, refusing what the
/// stages refuse: noise reduction on a linear frame or on a mosaic of odd width or height.
fn shape<A: planar::Planar>(
    path: &A,
    input: Input<'_>,
    rows: &Range<usize>,
) -> Result<planar::Shape, IspError> {
    let (w, h) = (input.width(), input.height());
    let denoise = match input {
        Input::Mosaic(raw) => path.nlm(raw.mosaic().pattern()).map(|(_, s)| s),
        Input::Linear(_) => match path.nlm(CfaPattern::Rggb) {
            Some(_) => {
                return Err(IspError::InvalidParameter {
                    name: "denoise",
                    allowed: "0 for a linear (already demosaiced) frame",
                })
            }
            None => None,
        },
    };
    if denoise.is_some() && (!w.is_multiple_of(2) || !h.is_multiple_of(2)) {
        return Err(IspError::InvalidParameter {
            name: "denoise",
            allowed: "0 for a mosaic of odd width or height (it filters whole 2x2 blocks)",
        });
    }
    // The rows the finish reads around the band: the chroma stage's three either side.
    let around = rows.start.saturating_sub(chroma::RADIUS)..(rows.end + chroma::RADIUS).min(h);
    Ok(planar::Shape {
        width: w,
        height: h,
        linear: matches!(input, Input::Linear(_)),
        method: path.method(),
        denoise,
        shading: planar::Planar::lsc(path).is_some(),
        distortion: path
            .distortion()
            .map(|lens| (lens.window_rows_in(w, h, around), lens.mesh_columns(w))),
        detail: path.detail_stages(),
    })
}

/// Scratch elements of `A`'s type the schedule needs for `shape`.
fn scratch_for<A: planar::Planar>(shape: &planar::Shape) -> Option<usize> {
    shape.scratch_len::<
        A::P,
        <A::Directional as Arithmetic>::E,
        A::NrWork,
        A::NrSum,
        A::Gain,
        A::Chroma,
    >()
}

/// The schedule's shape for a whole `width` x `height` mosaic with a configuration's stages.
fn config_shape(
    method: Method,
    denoise: Option<denoise::Search>,
    shading: bool,
    distortion: Option<&LensDistortion>,
    detail: Detail,
    width: usize,
    height: usize,
) -> planar::Shape {
    planar::Shape {
        width,
        height,
        linear: false,
        method,
        denoise,
        shading,
        distortion: distortion
            .map(|lens| (lens.window_rows(width, height), lens.mesh_columns(width))),
        detail,
    }
}

/// The checks every run makes before it touches the scratch: a linear frame without defect
/// correction, rows within the frame, an output of the frame's width and the rows' count.
fn check_rows<A: Path, O: OutputSample>(
    path: &A,
    input: Input<'_>,
    rows: &Range<usize>,
    out: &RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    let (w, h) = (input.width(), input.height());
    if matches!(input, Input::Linear(_)) && path.dpc().is_active() {
        return Err(IspError::InvalidParameter {
            name: "defect correction",
            allowed: "off for a linear (already demosaiced) frame",
        });
    }
    if rows.start >= rows.end || rows.end > h {
        return Err(IspError::InvalidParameter {
            name: "rows",
            allowed: "a non-empty range within the frame's height",
        });
    }
    if out.width() != w || out.height() != rows.len() {
        return Err(IspError::InvalidParameter {
            name: "output",
            allowed: "the frame's width and exactly as many rows as requested",
        });
    }
    Ok(())
}

/// The streaming engine both paths share; see the module docs.
fn run_rows<A: Path, O: OutputSample>(
    path: &A,
    input: Input<'_>,
    rows: Range<usize>,
    scratch: &mut [A::P],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    check_rows(path, input, &rows, out)?;
    let w = input.width();
    let h = input.height();
    let too_wide = IspError::InvalidParameter {
        name: "width",
        allowed: "a size that fits in memory",
    };
    let directional_part = match input {
        Input::Mosaic(_) => directional_len::<A::Directional>(path.method(), w).ok_or(too_wide)?,
        Input::Linear(_) => 0,
    };
    let detail = path.detail_stages();
    let detail_part = detail.len::<A::P, A::Chroma>(w).ok_or(too_wide)?;
    let nlm = match input {
        Input::Mosaic(raw) => path.nlm(raw.mosaic().pattern()),
        Input::Linear(_) => match path.nlm(CfaPattern::Rggb) {
            Some(_) => {
                return Err(IspError::InvalidParameter {
                    name: "denoise",
                    allowed: "0 for a linear (already demosaiced) frame",
                })
            }
            None => None,
        },
    };
    if nlm.is_some() && (!w.is_multiple_of(2) || !h.is_multiple_of(2)) {
        return Err(IspError::InvalidParameter {
            name: "denoise",
            allowed: "0 for a mosaic of odd width or height (it filters whole 2x2 blocks)",
        });
    }
    let work_ratio = core::mem::size_of::<A::NrWork>() / core::mem::size_of::<A::P>();
    let denoise_part =
        denoise_len(nlm.as_ref().map(|(_, s)| (*s, work_ratio)), w).ok_or(too_wide)?;
    let base = engine_base(w)
        .and_then(|b| {
            b.checked_add(directional_part)?
                .checked_add(detail_part)?
                .checked_add(denoise_part)
        })
        .ok_or(too_wide)?;
    if scratch.len() < base {
        return Err(IspError::BufferTooSmall {
            needed: base,
            provided: scratch.len(),
        });
    }
    let distortion = path.distortion();
    let provided = scratch.len();
    let (mosaic_ring, rest) = scratch.split_at_mut(MOSAIC_ROWS * w);
    // Without distortion correction the demosaiced ring is denoise's window; with it, a ring
    // of corrected rows is, and the demosaiced ring takes all the scratch left.
    let (window_ring, rest) = rest.split_at_mut(RGB_ROWS * 3 * w);
    let (planes, rest) = rest.split_at_mut(directional_part);
    let (detail_ring, rest) = rest.split_at_mut(detail_part);
    let (denoise_scratch, rest) = rest.split_at_mut(denoise_part);
    let denoiser = match nlm {
        Some((nlm, search)) => {
            let (samples, work, _) = denoise::scratch_len(search, w / 2).ok_or(too_wide)?;
            let (samples, more) = denoise_scratch.split_at_mut(samples);
            let (pair, more) = more.split_at_mut(2 * w);
            let (filtered, more) = more.split_at_mut(2 * w);
            let ratio = core::mem::size_of::<A::NrWork>().div_ceil(core::mem::size_of::<A::P>());
            let (work_part, sums_part) = more.split_at_mut(work * ratio + ratio - 1);
            let work = A::nr_work(work_part);
            let sums = A::nr_sums(sums_part);
            Some(Denoiser {
                stream: denoise::Stream::new(nlm, search, w / 2, h / 2, samples, work, sums)?,
                pair,
                pair_tag: usize::MAX,
                filtered,
            })
        }
        None => None,
    };
    let directional = match input {
        Input::Mosaic(raw) if directional_part > 0 => {
            Stream::new(w, h, raw.mosaic().pattern(), A::directional_planes(planes))?
        }
        _ => None,
    };
    let (demosaic_ring, demosaic_slots, corrected_ring): (_, _, &mut [A::P]) = match distortion {
        None => (window_ring, RGB_ROWS, &mut []),
        Some(_) => {
            let slots = rest.len() / (3 * w);
            (rest, slots, window_ring)
        }
    };
    let mut engine = Engine {
        path,
        input,
        mosaic_ring,
        mosaic_tags: [usize::MAX; MOSAIC_ROWS],
        directional,
        denoiser,
        demosaic_ring,
        demosaic_slots,
        demosaic_window: RowWindow::default(),
        corrected_ring,
        corrected_window: RowWindow::default(),
        needed: distortion.and_then(|lens| {
            let extra = directional_part + detail_part + denoise_part;
            engine_scratch_len(Some(lens), extra, w, h)
        }),
        provided,
    };
    match detail {
        Detail::Off => {
            for y in rows.clone() {
                path.finish_row(engine.linear_rgb_row(y)?, out.row_mut(y - rows.start));
            }
        }
        Detail::Sharpen => {
            let mut window = RowWindow::default();
            for y in rows.clone() {
                // The sharpening window: encoded rows y - 1 ..= y + 1.
                let taps = [-1isize, 0, 1].map(|dy| reflect(y as isize + dy, h));
                let (lo, hi) = (taps[0].min(y), taps[2].max(y));
                for range in window.request(lo, hi, SHARPEN_ROWS) {
                    for v in range {
                        let slot = v % SHARPEN_ROWS;
                        let row = engine.linear_rgb_row(v)?;
                        path.encoded_row(row, &mut detail_ring[slot * 3 * w..(slot + 1) * 3 * w]);
                    }
                }
                let ring: &[A::P] = detail_ring;
                let encoded =
                    taps.map(|v| &ring[(v % SHARPEN_ROWS) * 3 * w..(v % SHARPEN_ROWS + 1) * 3 * w]);
                path.sharpen_row(encoded, out.row_mut(y - rows.start));
            }
        }
        Detail::Chroma => {
            let (encoded, split_rows) = detail_ring.split_at_mut(3 * w);
            let split_rows = A::chroma_rows(split_rows);
            let len = chroma::SPLIT * w;
            let (ring, rest) = split_rows.split_at_mut(chroma::TAPS * len);
            let (split, rest) = rest.split_at_mut(len);
            let work = &mut rest[..len];
            let mut window = RowWindow::default();
            for y in rows.clone() {
                // The vertical pass's window: split rows y - RADIUS ..= y + RADIUS.
                let taps: [usize; chroma::TAPS] = core::array::from_fn(|k| {
                    reflect(y as isize + k as isize - chroma::RADIUS as isize, h)
                });
                let lo = taps.iter().fold(y, |m, v| m.min(*v));
                let hi = taps.iter().fold(y, |m, v| m.max(*v));
                for range in window.request(lo, hi, chroma::TAPS) {
                    for v in range {
                        let slot = (v % chroma::TAPS) * len;
                        let row = engine.linear_rgb_row(v)?;
                        let out = &mut ring[slot..slot + len];
                        path.chroma_split_row(row, encoded, split, out)?;
                    }
                }
                let ring: &[A::Chroma] = ring;
                let window_rows = taps.map(|v| &ring[(v % chroma::TAPS) * len..][..len]);
                path.chroma_row(window_rows, work, out.row_mut(y - rows.start))?;
            }
        }
    }
    Ok(())
}
