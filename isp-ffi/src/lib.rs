//! The C API of isp-core's fixed-point pipeline, for camera firmware written in C.
//!
//! - **Configuration from plain structs.** [`CamsimIspConfig`] holds every option as numbers
//!   (and pointers to the caller's static defect list and lens shading grid);
//!   [`camsim_isp_config_default`] fills the identity.
//! - **No allocation.** The pipeline lives in storage the caller provides
//!   ([`camsim_isp_pipeline_size`] and [`camsim_isp_pipeline_align`] bytes), and each run gets
//!   scratch the caller provides ([`camsim_isp_scratch_len`] `uint16_t` elements).
//! - **Row bands.** [`camsim_isp_run_rows`] develops any range of output rows, so a frame can
//!   be processed in bands as lines arrive, or split across cores.
//! - **Status codes.** Every function returns a [`CamsimStatus`]; [`camsim_status_message`]
//!   names it, and [`camsim_isp_config_error`] writes the one-line message (the command line's)
//!   for a configuration that is refused.
//! - **No panic crosses the boundary.** The cores do not panic on any input; with the `std`
//!   feature (the host's library) a panic would still be caught and returned as
//!   `CAMSIM_STATUS_PANIC`.
//!
//! The header is `include/camsim_isp.h` (cbindgen); `examples/develop.c` develops a frame.
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

use core::ffi::c_char;
use core::mem::{align_of, size_of};

use isp_core::demosaic::Method;
use isp_core::denoise::Search;
use isp_core::dpc::{Defect, DpcConfig};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, IspConfig};
use isp_core::tone::{Tone, ToneCurve};
use isp_core::{CfaPattern, IspError};

/// What a call did.
#[repr(C)]
#[allow(non_camel_case_types)] // C's names for C's callers
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CamsimStatus {
    /// Done.
    CAMSIM_STATUS_OK = 0,
    /// A parameter is outside its range (see [`camsim_isp_config_error`] for which).
    CAMSIM_STATUS_INVALID_PARAMETER = 1,
    /// A buffer (scratch, output, storage) is smaller than needed.
    CAMSIM_STATUS_BUFFER_TOO_SMALL = 2,
    /// A required pointer is NULL.
    CAMSIM_STATUS_NULL_POINTER = 3,
    /// The pipeline storage is not aligned to [`camsim_isp_pipeline_align`].
    CAMSIM_STATUS_MISALIGNED = 4,
    /// A bug: the library panicked (caught at the boundary; host builds only).
    CAMSIM_STATUS_PANIC = 5,
}
use CamsimStatus::*;

impl From<IspError> for CamsimStatus {
    fn from(e: IspError) -> Self {
        match e {
            IspError::InvalidParameter { .. } => CAMSIM_STATUS_INVALID_PARAMETER,
            IspError::BufferTooSmall { .. } => CAMSIM_STATUS_BUFFER_TOO_SMALL,
        }
    }
}

/// Nearest neighbour (2x2 superpixel) demosaicing.
pub const CAMSIM_DEMOSAIC_NEAREST: u32 = 0;
/// Bilinear demosaicing.
pub const CAMSIM_DEMOSAIC_BILINEAR: u32 = 1;
/// Malvar-He-Cutler demosaicing.
pub const CAMSIM_DEMOSAIC_MHC: u32 = 2;
/// The directional (high-quality) demosaicing.
pub const CAMSIM_DEMOSAIC_DIRECTIONAL: u32 = 3;

/// Noise reduction's default search: 5x5 packed pixels (10x10 mosaic pixels), for stills.
pub const CAMSIM_DENOISE_WIDE: u32 = 0;
/// Noise reduction's fast search: 3x3 packed pixels, for firmware and video.
pub const CAMSIM_DENOISE_FAST: u32 = 1;

/// Colour filter layout R G / G B.
pub const CAMSIM_CFA_RGGB: u32 = 0;
/// Colour filter layout B G / G R.
pub const CAMSIM_CFA_BGGR: u32 = 1;
/// Colour filter layout G R / B G.
pub const CAMSIM_CFA_GRBG: u32 = 2;
/// Colour filter layout G B / R G.
pub const CAMSIM_CFA_GBRG: u32 = 3;

/// A known bad pixel: row, then column.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct CamsimDefect {
    /// Row.
    pub y: u16,
    /// Column.
    pub x: u16,
}

// The static defect list is read in place as isp-core's `Defect`.
const _: () = assert!(size_of::<CamsimDefect>() == size_of::<Defect>());
const _: () = assert!(align_of::<CamsimDefect>() == align_of::<Defect>());

/// The pipeline's options, as [`isp_core::pipeline::IspConfig`] documents them. Pointers
/// (the defect list, the shading grid) must stay valid while a pipeline built from this
/// configuration is used.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct CamsimIspConfig {
    /// `CAMSIM_DEMOSAIC_*`.
    pub demosaic: u32,
    /// Output bits per sample: 8 (`uint8_t` output) or 16 (`uint16_t`).
    pub out_bits: u32,
    /// Digital gain, `[0, 64)`.
    pub gain: f32,
    /// White-balance gains R, G, B, each `[0, 16)`.
    pub wb_gains: [f32; 3],
    /// Camera RGB (white-balanced) to linear sRGB, row-major, each in `[-8, 8)`.
    pub ccm: [[f32; 3]; 3],
    /// Highlight knee, `[0, 1]`; 1 is off.
    pub highlight_knee: f32,
    /// Raw noise reduction's strength, `[0, 4]`; 0 is off. Needs the noise profile.
    pub denoise: f32,
    /// Raw noise reduction's search: `CAMSIM_DENOISE_WIDE` (the default) or
    /// `CAMSIM_DENOISE_FAST`.
    pub denoise_search: u32,
    /// Noise profile: variance = `noise_scale * signal + noise_offset` (signal in `[0, 1]`).
    pub noise_scale: f32,
    /// Noise profile's offset.
    pub noise_offset: f32,
    /// Chroma noise reduction's strength, `[0, 4]`; 0 is off.
    pub chroma_denoise: f32,
    /// Sharpening amount, `[0, 4]`; 0 is off.
    pub sharpen: f32,
    /// Saturation, `[0, 4]`; 1 is the identity.
    pub saturation: f32,
    /// Contrast exponent about mid grey, `[0.25, 4]`; 1 is the identity.
    pub contrast: f32,
    /// Dynamic defect detection threshold in raw codes; 0 is off.
    pub dpc_threshold: u32,
    /// Static defects sorted by row then column without duplicates, or NULL.
    pub static_defects: *const CamsimDefect,
    /// Entries of `static_defects`.
    pub static_defect_count: usize,
    /// Lens shading gains in Q4.12 (4096 is 1.0), four per node (the CFA's 2x2 positions)
    /// row-major over a `lsc_grid_width` x `lsc_grid_height` grid, or NULL for none.
    pub lsc_gains_q12: *const u16,
    /// Grid nodes across, `2..=64`.
    pub lsc_grid_width: u32,
    /// Grid nodes down, `2..=64`.
    pub lsc_grid_height: u32,
}

/// A raw Bayer frame in the caller's memory.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct CamsimRawFrame {
    /// Samples, row-major, `stride` apart.
    pub data: *const u16,
    /// Pixels across.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Samples from one row to the next (at least `width`).
    pub stride: u32,
    /// Bits per sample, 8..=16.
    pub bit_depth: u32,
    /// `CAMSIM_CFA_*`.
    pub pattern: u32,
    /// Black level of the four CFA positions (row-major in the 2x2 block).
    pub black_level: [u16; 4],
    /// White (clip) level.
    pub white_level: u16,
}

/// A built pipeline, in the caller's storage (opaque).
pub struct CamsimIspPipeline {
    pipeline: FixedPipeline<'static>,
    out_bits: u32,
}

/// Runs `f`, turning a panic into `CAMSIM_STATUS_PANIC` where unwinding exists.
fn guarded(f: impl FnOnce() -> CamsimStatus) -> CamsimStatus {
    #[cfg(feature = "std")]
    {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or(CAMSIM_STATUS_PANIC)
    }
    #[cfg(not(feature = "std"))]
    {
        f()
    }
}

fn status(result: Result<(), CamsimStatus>) -> CamsimStatus {
    result.err().unwrap_or(CAMSIM_STATUS_OK)
}

/// The identity configuration: bilinear, 8-bit output, unit gains, identity matrix, every
/// optional stage off.
///
/// # Safety
///
/// `config` is NULL (nothing happens) or points to writable memory for one config.
#[no_mangle]
pub unsafe extern "C" fn camsim_isp_config_default(config: *mut CamsimIspConfig) {
    if config.is_null() {
        return;
    }
    let d = IspConfig::default();
    let value = CamsimIspConfig {
        demosaic: CAMSIM_DEMOSAIC_BILINEAR,
        out_bits: 8,
        gain: d.gain,
        wb_gains: d.wb_gains,
        ccm: d.ccm,
        highlight_knee: d.highlight_knee,
        denoise: 0.0,
        denoise_search: CAMSIM_DENOISE_WIDE,
        noise_scale: 0.0,
        noise_offset: 0.0,
        chroma_denoise: 0.0,
        sharpen: 0.0,
        saturation: 1.0,
        contrast: 1.0,
        dpc_threshold: 0,
        static_defects: core::ptr::null(),
        static_defect_count: 0,
        lsc_gains_q12: core::ptr::null(),
        lsc_grid_width: 0,
        lsc_grid_height: 0,
    };
    // SAFETY: non-null and writable, by the caller's contract.
    unsafe { config.write(value) };
}

/// The core's configuration of `c`, borrowing its arrays for `'a`.
///
/// # Safety
///
/// The pointers in `c` are NULL or valid for their counts for `'a`.
unsafe fn isp_config<'a>(c: &CamsimIspConfig) -> Result<(IspConfig<'a>, u8), IspError> {
    let invalid = |name, allowed| IspError::InvalidParameter { name, allowed };
    let demosaic = match c.demosaic {
        CAMSIM_DEMOSAIC_NEAREST => Method::Nearest,
        CAMSIM_DEMOSAIC_BILINEAR => Method::Bilinear,
        CAMSIM_DEMOSAIC_MHC => Method::Mhc,
        CAMSIM_DEMOSAIC_DIRECTIONAL => Method::Directional,
        _ => return Err(invalid("demosaic", "one of CAMSIM_DEMOSAIC_*")),
    };
    let out_bits = match c.out_bits {
        8 => 8,
        16 => 16,
        _ => return Err(invalid("out_bits", "8 or 16")),
    };
    let static_defects: &'a [Defect] = match (c.static_defects.is_null(), c.static_defect_count) {
        (_, 0) => &[],
        (true, _) => {
            return Err(invalid(
                "static_defects",
                "non-NULL when the count is not 0",
            ))
        }
        // SAFETY: non-null, valid for the count (the caller's contract); CamsimDefect has
        // Defect's layout (checked above at compile time).
        (false, n) => unsafe { core::slice::from_raw_parts(c.static_defects.cast::<Defect>(), n) },
    };
    let lsc = match c.lsc_gains_q12.is_null() {
        true => None,
        false => {
            let (w, h) = (c.lsc_grid_width as usize, c.lsc_grid_height as usize);
            if !(2..=isp_core::lsc::MAX_GRID_SIDE).contains(&w)
                || !(2..=isp_core::lsc::MAX_GRID_SIDE).contains(&h)
            {
                return Err(invalid("lens shading grid", "2..=64 nodes each way"));
            }
            // SAFETY: non-null and valid for 4 w h gains (the caller's contract).
            let gains = unsafe { core::slice::from_raw_parts(c.lsc_gains_q12, w * h * 4) };
            Some(LensShading::new(w, h, gains)?)
        }
    };
    let noise = match c.denoise > 0.0 {
        true => Some(NoiseProfile::uniform(c.noise_scale, c.noise_offset)?),
        false => None,
    };
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects,
            dynamic_threshold: match c.dpc_threshold {
                0 => None,
                t => Some(u16::try_from(t).map_err(|_| invalid("dpc_threshold", "0..=65535"))?),
            },
        },
        lsc,
        gain: c.gain,
        wb_gains: c.wb_gains,
        demosaic,
        distortion: None,
        denoise: c.denoise,
        denoise_search: match c.denoise_search {
            CAMSIM_DENOISE_WIDE => Search::Wide,
            CAMSIM_DENOISE_FAST => Search::Fast,
            _ => return Err(invalid("denoise_search", "one of CAMSIM_DENOISE_*")),
        },
        noise,
        highlight_knee: c.highlight_knee,
        ccm: c.ccm,
        tone: Tone {
            saturation: c.saturation,
            contrast: c.contrast,
            curve: ToneCurve::IDENTITY,
        },
        sharpen: c.sharpen,
        chroma_denoise: c.chroma_denoise,
    };
    config.validate()?;
    Ok((config, out_bits))
}

/// Bytes of storage a pipeline takes.
#[no_mangle]
pub extern "C" fn camsim_isp_pipeline_size() -> usize {
    size_of::<CamsimIspPipeline>()
}

/// Alignment (bytes) the pipeline's storage needs.
#[no_mangle]
pub extern "C" fn camsim_isp_pipeline_align() -> usize {
    align_of::<CamsimIspPipeline>()
}

/// Checks `config` and builds a pipeline in `storage` (`storage_len` bytes, at least
/// [`camsim_isp_pipeline_size`], aligned to [`camsim_isp_pipeline_align`]); `*pipeline` then
/// points into it. Building quantises the parameters and, with contrast, fills a 12 KiB tone
/// table; do it once, not per frame.
///
/// # Safety
///
/// `storage` is valid for `storage_len` writable bytes, `config` for one config whose arrays
/// outlive the pipeline, and `pipeline` for one pointer; none of them overlap.
#[no_mangle]
pub unsafe extern "C" fn camsim_isp_pipeline_init(
    storage: *mut u8,
    storage_len: usize,
    config: *const CamsimIspConfig,
    pipeline: *mut *const CamsimIspPipeline,
) -> CamsimStatus {
    guarded(|| {
        status((|| {
            if storage.is_null() || config.is_null() || pipeline.is_null() {
                return Err(CAMSIM_STATUS_NULL_POINTER);
            }
            if storage_len < size_of::<CamsimIspPipeline>() {
                return Err(CAMSIM_STATUS_BUFFER_TOO_SMALL);
            }
            if !storage.cast::<CamsimIspPipeline>().is_aligned() {
                return Err(CAMSIM_STATUS_MISALIGNED);
            }
            // SAFETY: non-null and valid (the caller's contract); its arrays outlive the
            // pipeline, which is what 'static stands for here.
            let (config, out_bits): (IspConfig<'static>, u8) = unsafe { isp_config(&*config) }?;
            let built = CamsimIspPipeline {
                pipeline: FixedPipeline::new(&config, out_bits)?,
                out_bits: u32::from(out_bits),
            };
            let slot = storage.cast::<CamsimIspPipeline>();
            // SAFETY: large enough and aligned (checked), writable (the caller's contract).
            unsafe {
                slot.write(built);
                pipeline.write(slot);
            }
            Ok(())
        })())
    })
}

/// `uint16_t` scratch elements [`camsim_isp_run_rows`] needs for a `width` x `height`
/// frame, into `*len`.
///
/// # Safety
///
/// `pipeline` comes from [`camsim_isp_pipeline_init`]; `len` is valid for one write.
#[no_mangle]
pub unsafe extern "C" fn camsim_isp_scratch_len(
    pipeline: *const CamsimIspPipeline,
    width: u32,
    height: u32,
    len: *mut usize,
) -> CamsimStatus {
    guarded(|| {
        if pipeline.is_null() || len.is_null() {
            return CAMSIM_STATUS_NULL_POINTER;
        }
        // SAFETY: a pipeline built by camsim_isp_pipeline_init (the caller's contract).
        let p = unsafe { &*pipeline };
        match p.pipeline.scratch_len(width as usize, height as usize) {
            // SAFETY: valid for one write (the caller's contract).
            Some(n) => unsafe {
                len.write(n);
                CAMSIM_STATUS_OK
            },
            None => CAMSIM_STATUS_INVALID_PARAMETER,
        }
    })
}

/// Develops output rows `first_row..first_row + row_count` of `raw` into `out`: RGB samples
/// (`uint8_t` for 8-bit output, `uint16_t` for 16), `out_stride` samples from one row to the
/// next (at least `3 * width`), `out_len` samples in all; with `scratch` of `scratch_len`
/// elements (at least [`camsim_isp_scratch_len`]). Bands of any height give the same output
/// as one call for the whole frame.
///
/// # Safety
///
/// `pipeline` comes from [`camsim_isp_pipeline_init`]; `raw` points to a frame whose `data`
/// holds `stride * height` samples; `scratch` and `out` are valid for their lengths and
/// overlap nothing else.
#[no_mangle]
pub unsafe extern "C" fn camsim_isp_run_rows(
    pipeline: *const CamsimIspPipeline,
    raw: *const CamsimRawFrame,
    first_row: u32,
    row_count: u32,
    scratch: *mut u16,
    scratch_len: usize,
    out: *mut core::ffi::c_void,
    out_len: usize,
    out_stride: u32,
) -> CamsimStatus {
    guarded(|| {
        status((|| {
            if pipeline.is_null() || raw.is_null() || scratch.is_null() || out.is_null() {
                return Err(CAMSIM_STATUS_NULL_POINTER);
            }
            // SAFETY: valid, by the caller's contract.
            let (p, r) = unsafe { (&*pipeline, &*raw) };
            if r.data.is_null() {
                return Err(CAMSIM_STATUS_NULL_POINTER);
            }
            let pattern = match r.pattern {
                CAMSIM_CFA_RGGB => CfaPattern::Rggb,
                CAMSIM_CFA_BGGR => CfaPattern::Bggr,
                CAMSIM_CFA_GRBG => CfaPattern::Grbg,
                CAMSIM_CFA_GBRG => CfaPattern::Gbrg,
                _ => return Err(CAMSIM_STATUS_INVALID_PARAMETER),
            };
            let (w, h, stride) = (r.width as usize, r.height as usize, r.stride as usize);
            let samples = stride
                .checked_mul(h)
                .ok_or(CAMSIM_STATUS_INVALID_PARAMETER)?;
            let bit_depth =
                u8::try_from(r.bit_depth).map_err(|_| CAMSIM_STATUS_INVALID_PARAMETER)?;
            // SAFETY: `data` holds stride * height samples (the caller's contract).
            let data = unsafe { core::slice::from_raw_parts(r.data, samples) };
            let frame = RawFrame::new(
                data,
                w,
                h,
                stride,
                bit_depth,
                pattern,
                r.black_level,
                r.white_level,
            )?;
            let first = first_row as usize;
            let rows = first..first + row_count as usize;
            if rows.end > h {
                return Err(CAMSIM_STATUS_INVALID_PARAMETER);
            }
            // SAFETY: valid for scratch_len elements, exclusive (the caller's contract).
            let scratch = unsafe { core::slice::from_raw_parts_mut(scratch, scratch_len) };
            let out_stride = out_stride as usize;
            match p.out_bits {
                8 => {
                    // SAFETY: valid for out_len bytes, exclusive (the caller's contract).
                    let out = unsafe { core::slice::from_raw_parts_mut(out.cast::<u8>(), out_len) };
                    let mut view = RgbViewMut::new(out, w, rows.len(), out_stride)?;
                    p.pipeline.run(&frame, rows, scratch, &mut view)?;
                }
                _ => {
                    if !out.cast::<u16>().is_aligned() {
                        return Err(CAMSIM_STATUS_MISALIGNED);
                    }
                    // SAFETY: aligned (checked), valid for out_len u16, exclusive (the
                    // caller's contract).
                    let out =
                        unsafe { core::slice::from_raw_parts_mut(out.cast::<u16>(), out_len) };
                    let mut view = RgbViewMut::new(out, w, rows.len(), out_stride)?;
                    p.pipeline.run(&frame, rows, scratch, &mut view)?;
                }
            }
            Ok(())
        })())
    })
}

/// A status's name and meaning, as a static NUL-terminated string.
#[no_mangle]
pub extern "C" fn camsim_status_message(status: CamsimStatus) -> *const c_char {
    let text: &'static [u8] = match status {
        CAMSIM_STATUS_OK => b"ok\0",
        CAMSIM_STATUS_INVALID_PARAMETER => b"invalid parameter\0",
        CAMSIM_STATUS_BUFFER_TOO_SMALL => b"buffer too small\0",
        CAMSIM_STATUS_NULL_POINTER => b"a required pointer is NULL\0",
        CAMSIM_STATUS_MISALIGNED => b"storage is not aligned to camsim_isp_pipeline_align()\0",
        CAMSIM_STATUS_PANIC => b"internal error (a panic was caught)\0",
    };
    text.as_ptr().cast()
}

/// Writes why `config` is refused (the command line's one-line message, NUL-terminated,
/// truncated to `len - 1` bytes) into `buf`; returns the message's length without the NUL,
/// 0 when the configuration is valid.
///
/// # Safety
///
/// `config` is valid for one config (with valid arrays); `buf` is NULL or valid for `len`
/// bytes.
#[no_mangle]
pub unsafe extern "C" fn camsim_isp_config_error(
    config: *const CamsimIspConfig,
    buf: *mut c_char,
    len: usize,
) -> usize {
    if config.is_null() {
        return write_message(buf, len, "invalid config: must not be NULL");
    }
    // SAFETY: valid (the caller's contract); the borrow ends with this call.
    match unsafe { isp_config(&*config) } {
        Ok(_) => {
            write_message(buf, len, "");
            0
        }
        Err(e) => {
            let mut text = Message::default();
            let _ = core::fmt::write(&mut text, format_args!("{e}"));
            write_message(buf, len, text.as_str())
        }
    }
}

/// A fixed buffer for a message (no heap).
struct Message {
    bytes: [u8; 160],
    len: usize,
}

impl Default for Message {
    fn default() -> Self {
        Self {
            bytes: [0; 160],
            len: 0,
        }
    }
}

impl Message {
    fn as_str(&self) -> &str {
        core::str::from_utf8(&self.bytes[..self.len]).unwrap_or("invalid configuration")
    }
}

impl core::fmt::Write for Message {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let room = self.bytes.len() - self.len;
        // Whole characters only, so the text stays UTF-8.
        let mut take = s.len().min(room);
        while !s.is_char_boundary(take) {
            take -= 1;
        }
        self.bytes[self.len..self.len + take].copy_from_slice(&s.as_bytes()[..take]);
        self.len += take;
        Ok(())
    }
}

/// Copies `text` into `buf` (NUL-terminated, truncated to `len - 1`); returns `text.len()`.
fn write_message(buf: *mut c_char, len: usize, text: &str) -> usize {
    if !buf.is_null() && len > 0 {
        let n = text.len().min(len - 1);
        // SAFETY: buf is valid for len bytes (the caller's contract) and n + 1 <= len.
        unsafe {
            core::ptr::copy_nonoverlapping(text.as_ptr(), buf.cast::<u8>(), n);
            buf.add(n).write(0);
        }
    }
    text.len()
}
