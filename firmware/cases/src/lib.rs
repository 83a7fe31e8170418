//! What the firmware example (`firmware/cortex-m`) runs on an emulated Cortex-M core, and what
//! the host runs to compare: a deterministic 10-bit Bayer frame, the pipeline configurations
//! (each demosaic method with and without the camera's stages, the float path, distortion,
//! sharpening, 16-bit output), and optics-core's fixed-point focus and depth-of-field functions
//! over a grid of lenses. Each case reports an FNV-1a checksum of its output bytes.
//!
//! `#![no_std]` and heap-free: the caller owns every buffer, so the same code runs from static
//! buffers on the target and from vectors on the host. Each case can also be timed with a
//! caller's clock (the target's SysTick), split into construction and the run.
//!
//! ```
//! use firmware_cases::{run_case, Buffers, CASES};
//! let (w, h) = (16, 12);
//! let mut mosaic = vec![0u16; w * h];
//! let mut out8 = vec![0u8; 3 * w * h];
//! let mut out16 = vec![0u16; 3 * w * h];
//! let mut scratch = vec![0u16; 1 << 15];
//! let mut scratch_f32 = vec![0f32; 1 << 14];
//! let mut buffers = Buffers {
//!     mosaic: &mut mosaic,
//!     out8: &mut out8,
//!     out16: &mut out16,
//!     scratch: &mut scratch,
//!     scratch_f32: &mut scratch_f32,
//! };
//! let outcome = run_case(&CASES[0], w, h, &mut buffers, &mut || 0).unwrap();
//! assert_ne!(outcome.checksum, 0);
//! ```
#![no_std]
#![deny(unsafe_code)] // allowed only where the C API case calls the C functions
#![warn(missing_docs)]

use core::fmt;

use isp_core::demosaic::Method;
use isp_core::denoise::Search;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::lateral_colour::{LateralColour, NODES};
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
use isp_core::tone::Look;
use isp_core::{CfaPattern, IspError};
use optics_core::fixed_point::{self, Dioptres, FNumber, Mm};
use optics_core::{Distance, OpticsError};

/// The frame's bit depth.
pub const BIT_DEPTH: u8 = 10;
/// The frame's black level, every channel.
pub const BLACK_LEVEL: u16 = 64;
/// The frame's white level.
pub const WHITE_LEVEL: u16 = 1023;
/// The frame's colour filter layout.
pub const PATTERN: CfaPattern = CfaPattern::Rggb;
/// White-balance gains (a warm light, as `docs/bench/demo-camera.toml`).
pub const WB_GAINS: [f32; 3] = [1.9, 1.0, 1.6];
/// Camera RGB to linear sRGB (as `docs/bench/demo-camera.toml`).
pub const CCM: [[f32; 3]; 3] = [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]];

/// The static defect map: pixels the input makes hot or dead, inside a 48x36 frame so every
/// frame size the firmware runs has all of them. Sorted by row, then column.
pub const STATIC_DEFECTS: [Defect; 6] = [
    Defect { y: 3, x: 5 },
    Defect { y: 10, x: 40 },
    Defect { y: 17, x: 22 },
    Defect { y: 22, x: 7 },
    Defect { y: 29, x: 30 },
    Defect { y: 33, x: 45 },
];

/// Lens shading grid side lengths.
const LSC_GRID: (usize, usize) = (9, 7);
/// The lens shading grid: `1 + 0.5 r^2` in Q4.12 (r = 1 in the corners), the same for the four
/// CFA channels, built at compile time.
pub const LSC_GAINS: [u16; LSC_GRID.0 * LSC_GRID.1 * 4] = lsc_gains();

const fn lsc_gains() -> [u16; LSC_GRID.0 * LSC_GRID.1 * 4] {
    let (gw, gh) = LSC_GRID;
    let mut gains = [0u16; LSC_GRID.0 * LSC_GRID.1 * 4];
    let mut i = 0;
    while i < gw * gh {
        // r^2 in 1/(cx^2 * cy^2) units, kept integer: dx in units of 1/cx, dy of 1/cy.
        let (cx, cy) = ((gw - 1) / 2, (gh - 1) / 2);
        let dx = (i % gw).abs_diff(cx);
        let dy = (i / gw).abs_diff(cy);
        let r2_num = dx * dx * cy * cy + dy * dy * cx * cx;
        let r2_den = 2 * cx * cx * cy * cy;
        let gain = 4096 + (2048 * r2_num + r2_den / 2) / r2_den;
        let mut c = 0;
        while c < 4 {
            gains[4 * i + c] = gain as u16;
            c += 1;
        }
        i += 1;
    }
    gains
}

/// Which pipeline runs a case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    /// The fixed-point firmware path.
    Fixed,
    /// The float reference path.
    Float,
}

/// The stages a case turns on beyond black level, white balance, the colour matrix and sRGB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stages {
    /// Dynamic defect detection (threshold 64 codes).
    pub dynamic_defects: bool,
    /// Highlight recovery with a knee at 0.9.
    pub highlights: bool,
    /// The static defect map ([`STATIC_DEFECTS`]).
    pub static_defects: bool,
    /// Lens shading ([`LSC_GAINS`]).
    pub lsc: bool,
    /// Raw noise reduction at strength 1 with [`noise_profile`].
    pub denoise: bool,
    /// Raw noise reduction's fast setting (3x3 search) in place of the default, where it is
    /// on.
    pub fast_denoise: bool,
    /// Chroma noise reduction at strength 1.
    pub chroma_denoise: bool,
    /// The vivid look (saturation 1.3, contrast 1.15).
    pub tone: bool,
    /// Sharpening, amount 0.5.
    pub sharpen: bool,
    /// Barrel distortion corrected (k1 = -0.15).
    pub distortion: bool,
    /// Lateral colour corrected (red 1 % larger than green at the corners, blue 1 % smaller),
    /// in the distortion's resampling when that is on.
    pub lateral_colour: bool,
}

/// One configuration the firmware runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// The image pipeline on the frame.
    Pipeline {
        /// The case's name, as the firmware prints it.
        name: &'static str,
        /// Float or fixed.
        path: Path,
        /// The demosaic method.
        method: Method,
        /// The stages on.
        stages: Stages,
        /// Output depth, 8 or 16.
        out_bits: u8,
    },
    /// The C API (isp-ffi's `extern "C"` functions, as a C caller links them) with the
    /// configuration of `isp-ffi/examples/develop.c`, in bands of 16 rows.
    CApi {
        /// The case's name.
        name: &'static str,
    },
    /// optics-core's fixed-point focus and depth of field over [`LENSES`] and [`SUBJECTS_MM`].
    Optics {
        /// The case's name.
        name: &'static str,
    },
    /// The ISP's lens corrections derived from a prescription at start-up
    /// ([`lens_corrections_checksum`]): what a camera does once when a lens is fitted.
    LensCorrections {
        /// The case's name.
        name: &'static str,
    },
}

const PLAIN: Stages = Stages {
    dynamic_defects: false,
    highlights: false,
    static_defects: false,
    lsc: false,
    denoise: false,
    fast_denoise: false,
    chroma_denoise: false,
    tone: false,
    sharpen: false,
    distortion: false,
    lateral_colour: false,
};
/// The camera's configuration: every stage the demo camera runs
/// (`docs/bench/demo-camera.toml`), as `camsim demo` develops.
const CAMERA: Stages = Stages {
    dynamic_defects: true,
    highlights: true,
    static_defects: true,
    lsc: true,
    denoise: true,
    chroma_denoise: true,
    tone: true,
    ..PLAIN
};

const fn fixed(name: &'static str, method: Method, stages: Stages) -> Case {
    Case::Pipeline {
        name,
        path: Path::Fixed,
        method,
        stages,
        out_bits: 8,
    }
}

/// Every case, in the order the firmware runs them.
pub const CASES: [Case; 26] = [
    fixed("fixed-nearest", Method::Nearest, PLAIN),
    fixed("fixed-bilinear", Method::Bilinear, PLAIN),
    fixed("fixed-mhc", Method::Mhc, PLAIN),
    fixed("fixed-directional", Method::Directional, PLAIN),
    fixed(
        "fixed-mhc-dpc-highlights",
        Method::Mhc,
        Stages {
            dynamic_defects: true,
            highlights: true,
            ..PLAIN
        },
    ),
    // One stage at a time on MHC, for each stage's cost in the camera's configuration.
    fixed(
        "fixed-mhc+static-defects",
        Method::Mhc,
        Stages {
            static_defects: true,
            ..PLAIN
        },
    ),
    fixed("fixed-mhc+lsc", Method::Mhc, Stages { lsc: true, ..PLAIN }),
    fixed(
        "fixed-mhc+denoise",
        Method::Mhc,
        Stages {
            denoise: true,
            ..PLAIN
        },
    ),
    fixed(
        "fixed-mhc+chroma-denoise",
        Method::Mhc,
        Stages {
            chroma_denoise: true,
            ..PLAIN
        },
    ),
    fixed(
        "fixed-mhc+tone",
        Method::Mhc,
        Stages {
            tone: true,
            ..PLAIN
        },
    ),
    fixed("fixed-nearest-camera", Method::Nearest, CAMERA),
    fixed("fixed-bilinear-camera", Method::Bilinear, CAMERA),
    fixed("fixed-mhc-camera", Method::Mhc, CAMERA),
    fixed(
        "fixed-mhc-camera-fast",
        Method::Mhc,
        Stages {
            fast_denoise: true,
            ..CAMERA
        },
    ),
    fixed("fixed-directional-camera", Method::Directional, CAMERA),
    fixed(
        "fixed-mhc-camera-sharpen",
        Method::Mhc,
        Stages {
            sharpen: true,
            ..CAMERA
        },
    ),
    fixed(
        "fixed-mhc-distortion",
        Method::Mhc,
        Stages {
            distortion: true,
            ..PLAIN
        },
    ),
    fixed(
        "fixed-mhc+lateral-colour",
        Method::Mhc,
        Stages {
            lateral_colour: true,
            ..PLAIN
        },
    ),
    fixed(
        "fixed-mhc-distortion+lateral-colour",
        Method::Mhc,
        Stages {
            distortion: true,
            lateral_colour: true,
            ..PLAIN
        },
    ),
    Case::Pipeline {
        name: "fixed-mhc-camera-16bit",
        path: Path::Fixed,
        method: Method::Mhc,
        stages: CAMERA,
        out_bits: 16,
    },
    Case::Pipeline {
        name: "float-mhc",
        path: Path::Float,
        method: Method::Mhc,
        stages: PLAIN,
        out_bits: 8,
    },
    Case::Pipeline {
        name: "float-mhc-camera",
        path: Path::Float,
        method: Method::Mhc,
        stages: CAMERA,
        out_bits: 8,
    },
    Case::Pipeline {
        name: "float-mhc-camera-16bit",
        path: Path::Float,
        method: Method::Mhc,
        stages: CAMERA,
        out_bits: 16,
    },
    Case::CApi {
        name: "c-api-mhc-camera-bands",
    },
    Case::Optics {
        name: "optics-fixed-focus-dof",
    },
    Case::LensCorrections {
        name: "optics-tessar-corrections",
    },
];

impl Case {
    /// The case's name.
    pub const fn name(&self) -> &'static str {
        match self {
            Self::Pipeline { name, .. }
            | Self::CApi { name }
            | Self::Optics { name }
            | Self::LensCorrections { name } => name,
        }
    }
}

/// The noise profile noise reduction uses: `camsim demo --iso 1600`'s, as in
/// `docs/bench/demo-camera.toml`.
pub fn noise_profile() -> Result<NoiseProfile, IspError> {
    NoiseProfile::uniform(0.0008, 4.3295e-6)
}

/// The pipeline configuration of `stages` with `method`, for a `width` x `height` frame (the
/// distortion's camera matrix is centred on it).
pub fn config(
    method: Method,
    stages: Stages,
    width: usize,
    height: usize,
) -> Result<IspConfig<'static>, CaseError> {
    let distortion = match stages.distortion {
        true => {
            let (w, h) = (width as f64, height as f64);
            let model = BrownConrady::from_opencv([-0.15, 0.0, 0.0, 0.0, 0.0])?;
            Some(
                LensDistortion::new(w, w, (w - 1.0) / 2.0, (h - 1.0) / 2.0, model)?
                    .fitted(width, height),
            )
        }
        false => None,
    };
    let distortion = match (stages.lateral_colour, distortion) {
        (false, lens) => lens,
        (true, lens) => {
            let centre = [(width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0];
            // Scales from 1 at the centre to 1.01 (red) and 0.99 (blue) at the corners,
            // linear in r^2 as a lens's lateral colour mostly is.
            let curve = |k: usize, corner: f64| 1.0 + (corner - 1.0) * k as f64 / 16.0;
            let red: [f64; NODES] = core::array::from_fn(|k| curve(k, 1.01));
            let blue: [f64; NODES] = core::array::from_fn(|k| curve(k, 0.99));
            let lca = LateralColour::new(width, height, centre, None, &red, &blue)?;
            Some(match lens {
                Some(lens) => lens.with_lateral_colour(lca),
                None => LensDistortion::lateral_colour_only(lca),
            })
        }
    };
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: if stages.static_defects {
                &STATIC_DEFECTS
            } else {
                &[]
            },
            dynamic_threshold: stages.dynamic_defects.then_some(64),
        },
        lsc: match stages.lsc {
            true => Some(LensShading::new(LSC_GRID.0, LSC_GRID.1, &LSC_GAINS)?),
            false => None,
        },
        wb_gains: WB_GAINS,
        demosaic: method,
        distortion,
        denoise: if stages.denoise { 1.0 } else { 0.0 },
        denoise_search: if stages.fast_denoise {
            Search::Fast
        } else {
            Search::Wide
        },
        noise: Some(noise_profile()?),
        highlight_knee: if stages.highlights { 0.9 } else { 1.0 },
        ccm: CCM,
        tone: if stages.tone {
            Look::Vivid.tone()
        } else {
            Look::Neutral.tone()
        },
        sharpen: if stages.sharpen { 0.5 } else { 0.0 },
        chroma_denoise: if stages.chroma_denoise { 1.0 } else { 0.0 },
        ..IspConfig::default()
    };
    config.validate()?;
    Ok(config)
}

/// The next value of a xorshift32 generator (Marsaglia 2003, shifts 13, 17, 5).
fn xorshift32(state: &mut u32) -> u32 {
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    *state
}

/// Fills `mosaic` (`width * height` samples, row-major) with the test frame: a smooth
/// gradient, a bright disc that clips, fine stripes and a diagonal edge, under a warm light
/// (red 0.55, blue 0.65 of green), with noise of up to 15 codes, and the static defects hot
/// or dead. Deterministic: the same frame on every target.
pub fn fill_mosaic(mosaic: &mut [u16], width: usize, height: usize) -> Result<(), CaseError> {
    if width < 8 || height < 8 || width > 4096 || height > 4096 {
        return Err(CaseError::Size);
    }
    let Some(pixels) = mosaic.get_mut(..width * height) else {
        return Err(CaseError::BufferTooSmall("mosaic"));
    };
    let mut seed = 0x2545_f491_u32;
    let range = u32::from(WHITE_LEVEL - BLACK_LEVEL);
    for (i, sample) in pixels.iter_mut().enumerate() {
        let (x, y) = (i % width, i / width);
        // Scene radiance in 1/1024 of full scale.
        let mut level = (200 + 600 * x / width + 150 * y / height) as u32;
        let (dx, dy) = (
            (4 * x) as i64 - (3 * width) as i64,
            (4 * y) as i64 - height as i64,
        );
        if dx * dx + dy * dy < (height * height) as i64 {
            level = 1400; // the disc: clips in every channel
        }
        if x < width / 4 && y > height / 2 {
            level = if (x / 2) % 2 == 0 { 900 } else { 150 };
        }
        if x + y < width / 3 {
            level /= 3;
        }
        let channel_gain = match (y % 2, x % 2) {
            (0, 0) => 55, // red
            (1, 1) => 65, // blue
            _ => 100,
        };
        let noise = xorshift32(&mut seed) % 31;
        let value = (level * channel_gain / 100 * range / 1024 + noise).saturating_sub(15);
        *sample = BLACK_LEVEL + value.min(range) as u16;
    }
    for (k, defect) in STATIC_DEFECTS.iter().enumerate() {
        let (x, y) = (usize::from(defect.x), usize::from(defect.y));
        if x < width && y < height {
            pixels[y * width + x] = if k % 2 == 0 { WHITE_LEVEL } else { 0 };
        }
    }
    Ok(())
}

/// FNV-1a, 32 bits, over bytes: the checksum the firmware prints.
#[derive(Debug, Clone, Copy)]
pub struct Fnv1a(u32);

impl Default for Fnv1a {
    fn default() -> Self {
        Self(0x811c_9dc5)
    }
}

impl Fnv1a {
    /// Adds bytes.
    pub fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0 ^ u32::from(*b)).wrapping_mul(0x0100_0193);
        }
    }

    /// Adds a 16-bit sample, little-endian.
    pub fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }

    /// Adds a 64-bit value, little-endian.
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }

    /// The checksum.
    pub fn finish(self) -> u32 {
        self.0
    }
}

/// The checksum of an image of `bits`-bit samples: one byte per sample at 8 bits, two
/// (little-endian) at 16, so a host's image of `u16` samples hashes as the target's `u8` one.
pub fn image_checksum(samples: impl IntoIterator<Item = u16>, bits: u8) -> u32 {
    let mut hash = Fnv1a::default();
    for v in samples {
        match bits {
            8 => hash.bytes(&[v as u8]),
            _ => hash.u16(v),
        }
    }
    hash.finish()
}

/// The buffers a case runs in, owned by the caller: the mosaic, `3 * width * height` output
/// samples of each depth, and the pipelines' scratch (at least
/// [`IspConfig::scratch_len`] elements for the case).
#[derive(Debug)]
pub struct Buffers<'a> {
    /// The input mosaic, at least `width * height`.
    pub mosaic: &'a mut [u16],
    /// 8-bit output, at least `3 * width * height`.
    pub out8: &'a mut [u8],
    /// 16-bit output, at least `3 * width * height`.
    pub out16: &'a mut [u16],
    /// The fixed path's scratch.
    pub scratch: &'a mut [u16],
    /// The float path's scratch.
    pub scratch_f32: &'a mut [f32],
}

/// A case's result: its checksum, and the caller's clock read around construction
/// (`FixedPipeline::new` or `FloatPipeline::new`; the optics case has none) and the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outcome {
    /// FNV-1a of the output.
    pub checksum: u32,
    /// Clock ticks constructing the pipeline took.
    pub construct_ticks: u64,
    /// Clock ticks the run took.
    pub run_ticks: u64,
}

/// Why a case could not run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaseError {
    /// The pipeline refused.
    Isp(IspError),
    /// optics-core refused.
    Optics(OpticsError),
    /// A buffer is smaller than the case needs.
    BufferTooSmall(&'static str),
    /// The frame size is outside 8..=4096 each way.
    Size,
    /// The C API returned this status.
    CApi(isp_ffi::CamsimStatus),
}

impl From<IspError> for CaseError {
    fn from(e: IspError) -> Self {
        Self::Isp(e)
    }
}

impl From<OpticsError> for CaseError {
    fn from(e: OpticsError) -> Self {
        Self::Optics(e)
    }
}

/// The lens-correction derivation's errors are the two crates' own, kept apart.
impl From<isp_core::lens_correction::LensCorrectionError> for CaseError {
    fn from(e: isp_core::lens_correction::LensCorrectionError) -> Self {
        use isp_core::lens_correction::LensCorrectionError;
        match e {
            LensCorrectionError::Optics(e) => Self::Optics(e),
            LensCorrectionError::Isp(e) => Self::Isp(e),
        }
    }
}

impl fmt::Display for CaseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Isp(e) => write!(f, "{e}"),
            Self::Optics(e) => write!(f, "{e}"),
            Self::BufferTooSmall(which) => write!(f, "the {which} buffer is too small"),
            Self::Size => f.write_str("the frame must be 8..=4096 pixels each way"),
            Self::CApi(status) => write!(f, "the C API returned {status:?}"),
        }
    }
}

/// Runs `case` on a `width` x `height` test frame ([`fill_mosaic`]) in `buffers`, reading
/// `clock` before and after construction and the run.
pub fn run_case(
    case: &Case,
    width: usize,
    height: usize,
    buffers: &mut Buffers<'_>,
    clock: &mut dyn FnMut() -> u64,
) -> Result<Outcome, CaseError> {
    if let Case::CApi { .. } = case {
        return c_api_case(width, height, buffers, clock);
    }
    let (path, method, stages, out_bits) = match *case {
        Case::Pipeline {
            path,
            method,
            stages,
            out_bits,
            ..
        } => (path, method, stages, out_bits),
        _ => {
            let t0 = clock();
            let checksum = match case {
                Case::LensCorrections { .. } => lens_corrections_checksum(width, height)?,
                _ => optics_checksum()?,
            };
            let t1 = clock();
            return Ok(Outcome {
                checksum,
                construct_ticks: 0,
                run_ticks: t1.wrapping_sub(t0),
            });
        }
    };
    fill_mosaic(buffers.mosaic, width, height)?;
    let pixels = width * height;
    let raw = RawFrame::new(
        &buffers.mosaic[..pixels],
        width,
        height,
        width,
        BIT_DEPTH,
        PATTERN,
        [BLACK_LEVEL; 4],
        WHITE_LEVEL,
    )?;
    let config = config(method, stages, width, height)?;
    let Some(need) = config.scratch_len(width, height) else {
        return Err(CaseError::Size);
    };
    let (out8, out16) = match (
        buffers.out8.get_mut(..3 * pixels),
        buffers.out16.get_mut(..3 * pixels),
    ) {
        (Some(a), Some(b)) => (a, b),
        _ => return Err(CaseError::BufferTooSmall("output")),
    };
    let rows = 0..height;
    let t0 = clock();
    let (t1, t2) = match path {
        Path::Fixed => {
            let pipeline = FixedPipeline::new(&config, out_bits)?;
            let t1 = clock();
            let Some(scratch) = buffers.scratch.get_mut(..need) else {
                return Err(CaseError::BufferTooSmall("scratch"));
            };
            match out_bits {
                8 => pipeline.run(
                    &raw,
                    rows,
                    scratch,
                    &mut RgbViewMut::new(out8, width, height, 3 * width)?,
                )?,
                _ => pipeline.run(
                    &raw,
                    rows,
                    scratch,
                    &mut RgbViewMut::new(out16, width, height, 3 * width)?,
                )?,
            }
            (t1, clock())
        }
        Path::Float => {
            let pipeline = FloatPipeline::new(&config)?;
            let t1 = clock();
            let Some(scratch) = buffers.scratch_f32.get_mut(..need) else {
                return Err(CaseError::BufferTooSmall("float scratch"));
            };
            match out_bits {
                8 => pipeline.run(
                    &raw,
                    rows,
                    scratch,
                    &mut RgbViewMut::new(out8, width, height, 3 * width)?,
                )?,
                _ => pipeline.run(
                    &raw,
                    rows,
                    scratch,
                    &mut RgbViewMut::new(out16, width, height, 3 * width)?,
                )?,
            }
            (t1, clock())
        }
    };
    let checksum = match out_bits {
        8 => image_checksum(out8.iter().map(|v| u16::from(*v)), 8),
        _ => image_checksum(out16.iter().copied(), 16),
    };
    Ok(Outcome {
        checksum,
        construct_ticks: t1.wrapping_sub(t0),
        run_ticks: t2.wrapping_sub(t1),
    })
}

/// The C API case: `isp-ffi/examples/develop.c`'s configuration and calls, from Rust.
#[allow(unsafe_code)]
fn c_api_case(
    width: usize,
    height: usize,
    buffers: &mut Buffers<'_>,
    clock: &mut dyn FnMut() -> u64,
) -> Result<Outcome, CaseError> {
    use core::mem::MaybeUninit;
    use isp_ffi::*;
    /// The example's static defects.
    const DEFECTS: [CamsimDefect; 3] = [
        CamsimDefect { y: 3, x: 5 },
        CamsimDefect { y: 10, x: 40 },
        CamsimDefect { y: 17, x: 22 },
    ];
    const BAND_ROWS: usize = 16;
    let check = |status: CamsimStatus| match status {
        CamsimStatus::CAMSIM_STATUS_OK => Ok(()),
        _ => Err(CaseError::CApi(status)),
    };
    fill_mosaic(buffers.mosaic, width, height)?;
    let pixels = width * height;
    let (w32, h32) = (width as u32, height as u32);
    let mut config = MaybeUninit::<CamsimIspConfig>::uninit();
    // SAFETY: a writable config, which the call fills.
    let mut config = unsafe {
        camsim_isp_config_default(config.as_mut_ptr());
        config.assume_init()
    };
    config.demosaic = CAMSIM_DEMOSAIC_MHC;
    config.wb_gains = WB_GAINS;
    config.ccm = CCM;
    config.highlight_knee = 0.9;
    config.denoise = 1.0;
    config.noise_scale = 0.0008;
    config.noise_offset = 4.3295e-6;
    config.chroma_denoise = 1.0;
    config.saturation = 1.3;
    config.contrast = 1.15;
    config.dpc_threshold = 64;
    config.static_defects = DEFECTS.as_ptr();
    config.static_defect_count = DEFECTS.len();
    let mut storage = MaybeUninit::<CamsimIspPipeline>::uninit();
    let mut pipeline = core::ptr::null();
    let t0 = clock();
    // SAFETY: storage of the pipeline's size and alignment; the config's defects are static.
    check(unsafe {
        camsim_isp_pipeline_init(
            storage.as_mut_ptr().cast(),
            core::mem::size_of::<CamsimIspPipeline>(),
            &config,
            &mut pipeline,
        )
    })?;
    let t1 = clock();
    let mut need = 0;
    // SAFETY: a built pipeline and a writable length.
    check(unsafe { camsim_isp_scratch_len(pipeline, w32, h32, &mut need) })?;
    if need > buffers.scratch.len() {
        return Err(CaseError::BufferTooSmall("scratch"));
    }
    let Some(out) = buffers.out8.get_mut(..3 * pixels) else {
        return Err(CaseError::BufferTooSmall("output"));
    };
    let frame = CamsimRawFrame {
        data: buffers.mosaic.as_ptr(),
        width: w32,
        height: h32,
        stride: w32,
        bit_depth: u32::from(BIT_DEPTH),
        pattern: CAMSIM_CFA_RGGB,
        black_level: [BLACK_LEVEL; 4],
        white_level: WHITE_LEVEL,
    };
    for (band, rows) in out.chunks_mut(BAND_ROWS * 3 * width).enumerate() {
        let first = (band * BAND_ROWS) as u32;
        let count = (rows.len() / (3 * width)) as u32;
        // SAFETY: the frame's data holds width * height samples; scratch and the band's rows
        // are valid for the lengths given and overlap nothing.
        check(unsafe {
            camsim_isp_run_rows(
                pipeline,
                &frame,
                first,
                count,
                buffers.scratch.as_mut_ptr(),
                need,
                rows.as_mut_ptr().cast(),
                rows.len(),
                3 * w32,
            )
        })?;
    }
    let t2 = clock();
    Ok(Outcome {
        checksum: image_checksum(out.iter().map(|v| u16::from(*v)), 8),
        construct_ticks: t1.wrapping_sub(t0),
        run_ticks: t2.wrapping_sub(t1),
    })
}

/// Lenses of the optics case: focal length, f-number and circle of confusion, in mm.
pub const LENSES: [(f64, f64, f64); 6] = [
    (4.38, 1.8, 0.002),
    (12.0, 2.0, 0.006),
    (35.0, 1.4, 0.02),
    (50.0, 2.8, 0.03),
    (85.0, 1.2, 0.03),
    (600.0, 4.0, 0.03),
];

/// Subject distances of the optics case in mm, from close focus to infinity (`None`); each
/// lens takes those beyond twice its focal length.
pub const SUBJECTS_MM: [Option<f64>; 7] = [
    Some(100.0),
    Some(300.0),
    Some(1250.0),
    Some(3000.0),
    Some(10_000.0),
    Some(100_000.0),
    None,
];

/// optics-core's fixed-point functions over [`LENSES`] and [`SUBJECTS_MM`]: vergence, sensor
/// distance, hyperfocal distance, depth of field, the circle of confusion of a point at half
/// the subject's vergence plus 0.2 D, and the limits back as distances; the checksum of
/// every result's bits.
pub fn optics_checksum() -> Result<u32, OpticsError> {
    let mut hash = Fnv1a::default();
    let distance_bits = |d: Distance<Mm>| match d {
        Distance::Finite(mm) => mm.to_bits(),
        Distance::Infinite => u64::MAX,
    };
    for (f, n, c) in LENSES {
        let (f, n, c) = (Mm::from_num(f), FNumber::from_num(n), Mm::from_num(c));
        let hyperfocal = fixed_point::hyperfocal(f, n, c)?;
        hash.u64(distance_bits(hyperfocal));
        for subject in SUBJECTS_MM {
            let distance = match subject {
                Some(mm) if Mm::from_num(mm) > f * 2 => Distance::Finite(Mm::from_num(mm)),
                Some(_) => continue,
                None => Distance::Infinite,
            };
            let focus = fixed_point::vergence(distance)?;
            hash.u64(focus.to_bits());
            hash.u64(fixed_point::sensor_distance(f, focus)?.to_bits());
            let dof = fixed_point::depth_of_field(f, n, c, focus)?;
            hash.u64(dof.near.to_bits());
            hash.u64(dof.far.to_bits());
            hash.u64(distance_bits(dof.hyperfocal));
            hash.u64(distance_bits(fixed_point::distance(dof.near)?));
            hash.u64(distance_bits(fixed_point::distance(dof.far)?));
            let point = focus / 2 + Dioptres::from_num(0.2);
            hash.u64(fixed_point::circle_of_confusion(f, n, focus, point)?.to_bits());
        }
    }
    Ok(hash.finish())
}

/// Laikin's Tessar f/4.5 (`camsim/lenses/tessar-f4.5.toml`, with its source): radius,
/// thickness, clear semi-diameter and glass per surface, mm, the stop fifth.
const TESSAR: [(f64, f64, f64, Option<&str>); 8] = [
    (33.85566, 7.08914, 16.36, Some("N-SK15")),
    (-253.37516, 5.21716, 15.2, None),
    (-53.12918, 2.286, 10.71, Some("F2")),
    (30.79242, 1.80086, 9.51, None),
    (0.0, 3.89636, 9.079866538191485, None),
    (-191.0207, 2.286, 10.94, Some("K10")),
    (33.0454, 8.60806, 13.0, Some("N-SK15")),
    (-38.65372, 86.4235, 14.12, None),
];
/// The Tessar's half field of view, degrees (its file's `field_deg`).
const TESSAR_HALF_FIELD_DEG: f64 = 20.5;
/// Radii of the relative-illumination table per colour: 9 from the centre to the corner.
const SHADING_RADII: usize = 9;
/// The shading grid the illumination fills: 9 x 7 nodes.
const SHADING_GRID: (usize, usize) = (9, 7);

/// The ISP's corrections for the Tessar on a `width` x `height` sensor that its field
/// fills diagonally (focused at infinity), derived from the prescription as a camera would
/// at start-up through isp-core's `lens_correction` (what `camsim demo --lens` and the
/// lens_render test run): the Brown-Conrady fit to its chief rays (and the distortion
/// mesh's window), red's and blue's lateral-colour scales at the stage's 17 nodes, and
/// relative illumination per colour at 9 radii (a 32 x 32 grid over the rear element per
/// radius: within about 1 % of a 200 x 200 grid's on the Tessar, where 16 x 16 is 6 % off)
/// made into a 9 x 7 RGGB shading grid. The checksum of every value's bits.
pub fn lens_corrections_checksum(width: usize, height: usize) -> Result<u32, CaseError> {
    use isp_core::lens_correction::{
        DistortionFit, IlluminationTable, LensCorrections, SensorFraming, RENDER_COLOURS_NM,
    };
    use optics_core::prescription::glass::{catalogue_glass, Medium, LAMBDA_D_NM};
    use optics_core::prescription::{Prescription, Shape, Surface};
    let mut surfaces = [Surface::new(Shape::Flat, 1.0, 1.0, Medium::Air); 8];
    for (s, &(radius, thickness, semi, glass)) in surfaces.iter_mut().zip(&TESSAR) {
        let medium = match glass {
            Some(name) => catalogue_glass(name)?.medium(),
            None => Medium::Air,
        };
        *s = match radius {
            0.0 => Surface::aperture_stop(semi, thickness),
            r => Surface::new(Shape::sphere_radius(r), semi, thickness, medium),
        };
    }
    let lens = Prescription::new(&surfaces)?;
    let half = TESSAR_HALF_FIELD_DEG.to_radians();
    let (w, h) = (width as f64, height as f64);
    let efl = lens.paraxial(RENDER_COLOURS_NM[1])?.efl;
    let pitch = 2.0 * efl * libm::tan(half) / libm::hypot(w, h);
    let film = lens.paraxial(LAMBDA_D_NM)?.bfl;
    let framing = SensorFraming::new(width, height, pitch, film)?;
    // Fit beyond the corner's field, so the mesh's outer nodes are fitted too.
    let fix = LensCorrections::derive(&lens, &framing, half * 1.4, DistortionFit::ChiefRays)?;
    let mut scratch = surfaces;
    let table: IlluminationTable<SHADING_RADII> =
        IlluminationTable::derive(&lens, &framing, 32, &mut scratch)?;
    let mut gains = [0u16; SHADING_GRID.0 * SHADING_GRID.1 * 4];
    table.fill_grid(
        &framing,
        CfaPattern::Rggb.block(),
        &mut gains,
        SHADING_GRID.0,
        SHADING_GRID.1,
    )?;
    let mut hash = Fnv1a::default();
    for v in [fix.focal_length_mm, fix.k[0], fix.k[1], fix.k[2]] {
        hash.u64(v.to_bits());
    }
    hash.u64(fix.distortion.window_rows(width, height) as u64);
    if let Some(lca) = fix.distortion.lateral_colour() {
        hash.u64(lca.reach_rows() as u64);
        for k in 0..NODES {
            for c in 0..2 {
                hash.u64(lca.node_scale(c, k).unwrap_or(0.0).to_bits());
            }
        }
    }
    for g in gains {
        hash.u64(u64::from(g));
    }
    Ok(hash.finish())
}

/// The scratch every case needs at `width` x `height`, the most over [`CASES`]: fixed-path
/// (`u16`) and float-path (`f32`) elements.
pub fn scratch_needed(width: usize, height: usize) -> Result<(usize, usize), CaseError> {
    let (mut fixed, mut float) = (0, 0);
    for case in &CASES {
        if let Case::Pipeline {
            path,
            method,
            stages,
            ..
        } = *case
        {
            let need = config(method, stages, width, height)?
                .scratch_len(width, height)
                .ok_or(CaseError::Size)?;
            match path {
                Path::Fixed => fixed = fixed.max(need),
                Path::Float => float = float.max(need),
            }
        }
    }
    Ok((fixed, float))
}

/// The frame sizes a firmware runs every case at: two, so the host can take each case's
/// per-pixel slope between them.
pub const FIRMWARE_SIZES: [(usize, usize); 2] = [(64, 48), (128, 96)];
/// Pixels of the largest of [`FIRMWARE_SIZES`].
pub const FIRMWARE_MAX_PIXELS: usize = 128 * 96;
/// Fixed-path scratch elements for the largest frame: at least [`scratch_needed`]'s (a test
/// checks; [`run_case`] refuses a short buffer anyway).
pub const FIRMWARE_SCRATCH_U16: usize = 56 * 1024;
/// Float-path scratch elements for the largest frame, as [`FIRMWARE_SCRATCH_U16`].
pub const FIRMWARE_SCRATCH_F32: usize = 29 * 1024;

/// A firmware's whole run, the same on every core: every case at [`FIRMWARE_SIZES`] through
/// [`report`] with `clock`, then `calibrate` (which runs a loop of known length and returns its
/// instructions and the clock's ticks) as a `calibration <instructions> instructions <ticks>
/// ticks` line. With `only`, that case alone at 64x48 and its checksum (for a profile, where
/// the clock means nothing). Returns whether every case ran.
pub fn firmware_run(
    sink: &mut dyn fmt::Write,
    buffers: &mut Buffers<'_>,
    clock: &mut dyn FnMut() -> u64,
    only: Option<&str>,
    calibrate: &mut dyn FnMut() -> (u64, u64),
) -> Result<bool, fmt::Error> {
    if let Some(only) = only {
        let Some(case) = CASES.iter().find(|c| c.name() == only) else {
            writeln!(sink, "error {only} is not a case")?;
            return Ok(false);
        };
        return Ok(match run_case(case, 64, 48, buffers, clock) {
            Ok(o) => {
                writeln!(sink, "profiled {only} 64x48, checksum {:08x}", o.checksum)?;
                // The construction's ticks: times the board's instructions per tick (40 on
                // the MPS2 boards: the full run's calibration line) its start-up.
                writeln!(sink, "construction {} ticks", o.construct_ticks)?;
                true
            }
            Err(e) => {
                writeln!(sink, "error {only} {e}")?;
                false
            }
        });
    }
    let mut all_ran = true;
    for (w, h) in FIRMWARE_SIZES {
        all_ran &= report(sink, w, h, buffers, clock, true)?;
    }
    let (instructions, ticks) = calibrate();
    writeln!(
        sink,
        "calibration {instructions} instructions {ticks} ticks"
    )?;
    Ok(all_ran)
}

/// Runs every case at `width` x `height` and writes one line per case to `sink`:
/// `case <name> <width>x<height> <checksum in hex>`, then `ticks <name> <width>x<height>
/// <construction> <run>` when `timed` (the clock's ticks). A case that fails writes
/// `error <name> <message>` and the rest still run; returns whether every case ran.
pub fn report(
    sink: &mut dyn fmt::Write,
    width: usize,
    height: usize,
    buffers: &mut Buffers<'_>,
    clock: &mut dyn FnMut() -> u64,
    timed: bool,
) -> Result<bool, fmt::Error> {
    let mut all_ran = true;
    for case in &CASES {
        let name = case.name();
        match run_case(case, width, height, buffers, clock) {
            Ok(outcome) => {
                writeln!(
                    sink,
                    "case {name} {width}x{height} {:08x}",
                    outcome.checksum
                )?;
                if timed {
                    writeln!(
                        sink,
                        "ticks {name} {width}x{height} {} {}",
                        outcome.construct_ticks, outcome.run_ticks
                    )?;
                }
            }
            Err(e) => {
                all_ran = false;
                writeln!(sink, "error {name} {e}")?;
            }
        }
    }
    Ok(all_ran)
}
