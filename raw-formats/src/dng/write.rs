//! The DNG writer: one IFD holding the CFA or LinearRaw image, in either byte order,
//! uncompressed (8 to 16 bits, packed most significant bit first), lossless-JPEG or (8-bit
//! samples) lossy-JPEG compressed, in strips or tiles.

use std::borrow::Cow;
use std::path::Path;

use isp_core::colour::Mat3;

use super::tags::*;
use super::{cfa_codes, Dng, CALIBRATION_TAGS};
use crate::error::{FormatError, Result};
use crate::lossless_jpeg::{self, Frame};

/// How the writer stores the samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// Compression 1 at `bits` per sample (8..=16; below 16 packed most significant bit
    /// first, each row starting on a byte boundary). The image's samples must fit.
    Uncompressed {
        /// Bits per sample.
        bits: u8,
    },
    /// Compression 7: each strip or tile a lossless JPEG, its precision the image's bit
    /// depth. With 2 components a tile of width W is coded W/2 wide with its two CFA
    /// columns interleaved (as Adobe's converter writes; W must be even), with 1 as a plain
    /// greyscale frame. A linear image is coded with 3 (its pixels' R, G, B interleaved).
    LosslessJpeg {
        /// 1 or 2 for a CFA image, 3 for a linear one.
        components: u8,
        /// Predictor 1..=7.
        predictor: u8,
    },
    /// Compression 34892: each strip or tile a baseline JPEG at `quality` (1..=100), RGB coded
    /// as YCbCr (chroma not subsampled) for a linear image, greyscale for a CFA one. The samples must be 8-bit (a
    /// lossy DNG's LinearizationTable maps them to linear values).
    LossyJpeg {
        /// JPEG quality, 1..=100.
        quality: u8,
    },
}

/// How [`Dng::encode_with`] lays the file out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EncodeOptions {
    /// Sample storage.
    pub storage: Storage,
    /// Tile width and height (each a multiple of 16, as DNG requires), or `None` for one strip.
    pub tile: Option<(u32, u32)>,
    /// Byte order: `II` (true) or `MM`.
    pub little_endian: bool,
}

impl Default for EncodeOptions {
    /// 16-bit uncompressed samples in one little-endian strip.
    fn default() -> Self {
        Self {
            storage: Storage::Uncompressed { bits: 16 },
            tile: None,
            little_endian: true,
        }
    }
}

/// An entry's values, typed so either byte order can be written.
pub(crate) enum Values {
    Bytes(Vec<u8>),
    Undefined(Vec<u8>),
    Ascii(Vec<u8>),
    Short(Vec<u16>),
    Long(Vec<u32>),
    Rational(Vec<(u32, u32)>),
    SRational(Vec<(i32, i32)>),
    Double(Vec<f64>),
}

pub(crate) struct Entry {
    pub(crate) tag: u16,
    pub(crate) values: Values,
}

impl Entry {
    fn kind_and_count(&self) -> (u16, usize) {
        match &self.values {
            Values::Bytes(v) => (BYTE, v.len()),
            Values::Undefined(v) => (UNDEFINED, v.len()),
            Values::Ascii(v) => (ASCII, v.len()),
            Values::Short(v) => (SHORT, v.len()),
            Values::Long(v) => (LONG, v.len()),
            Values::Rational(v) => (RATIONAL, v.len()),
            Values::SRational(v) => (SRATIONAL, v.len()),
            Values::Double(v) => (DOUBLE, v.len()),
        }
    }

    fn bytes(&self, little: bool) -> Vec<u8> {
        let u16b = |v: u16| u16_bytes(v, little);
        let u32b = |v: u32| u32_bytes(v, little);
        match &self.values {
            Values::Bytes(v) | Values::Undefined(v) | Values::Ascii(v) => v.clone(),
            Values::Short(v) => v.iter().flat_map(|x| u16b(*x)).collect(),
            Values::Long(v) => v.iter().flat_map(|x| u32b(*x)).collect(),
            Values::Rational(v) => v
                .iter()
                .flat_map(|(n, d)| [u32b(*n), u32b(*d)].concat())
                .collect(),
            Values::SRational(v) => v
                .iter()
                .flat_map(|(n, d)| [u32b(*n as u32), u32b(*d as u32)].concat())
                .collect(),
            Values::Double(v) => v
                .iter()
                .flat_map(|x| {
                    if little {
                        x.to_le_bytes()
                    } else {
                        x.to_be_bytes()
                    }
                })
                .collect(),
        }
    }
}

pub(crate) fn short(tag: u16, values: &[u16]) -> Entry {
    Entry {
        tag,
        values: Values::Short(values.to_vec()),
    }
}

pub(crate) fn long(tag: u16, values: &[u32]) -> Entry {
    Entry {
        tag,
        values: Values::Long(values.to_vec()),
    }
}

pub(crate) fn bytes(tag: u16, values: &[u8]) -> Entry {
    Entry {
        tag,
        values: Values::Bytes(values.to_vec()),
    }
}

fn ascii(tag: u16, text: &str) -> Entry {
    let mut b: Vec<u8> = text.bytes().filter(|c| *c != 0).collect();
    b.push(0);
    Entry {
        tag,
        values: Values::Ascii(b),
    }
}

/// Rationals with denominator 10000 (four decimals, as Adobe's DNG files carry).
pub(crate) fn srational(tag: u16, values: &[f64]) -> Entry {
    Entry {
        tag,
        values: Values::SRational(
            values
                .iter()
                .map(|v| {
                    let n = (v * 10000.0)
                        .round()
                        .clamp(i32::MIN as f64, i32::MAX as f64) as i32;
                    (n, 10000)
                })
                .collect(),
        ),
    }
}

pub(crate) fn rational(tag: u16, values: &[f64]) -> Entry {
    Entry {
        tag,
        values: Values::Rational(
            values
                .iter()
                .map(|v| {
                    (
                        (v * 1e6).round().clamp(0.0, u32::MAX as f64) as u32,
                        1_000_000,
                    )
                })
                .collect(),
        ),
    }
}

/// A `u16` in the file's byte order.
fn u16_bytes(v: u16, little: bool) -> [u8; 2] {
    if little {
        v.to_le_bytes()
    } else {
        v.to_be_bytes()
    }
}

/// A `u32` in the file's byte order.
fn u32_bytes(v: u32, little: bool) -> [u8; 4] {
    if little {
        v.to_le_bytes()
    } else {
        v.to_be_bytes()
    }
}

/// Packs one row of samples at `bits` bits, most significant bit first, into whole bytes.
pub(crate) fn pack_row(row: &[u16], bits: u32, out: &mut Vec<u8>) {
    let (mut acc, mut held) = (0u64, 0u32);
    for v in row {
        acc = (acc << bits) | u64::from(*v);
        held += bits;
        while held >= 8 {
            held -= 8;
            out.push((acc >> held) as u8);
        }
    }
    if held > 0 {
        out.push((acc << (8 - held)) as u8);
    }
}

impl Dng {
    /// Checks sizes, levels and colour tags before writing.
    fn check(&self) -> Result<()> {
        let image = &self.image;
        image.check()?;
        if image.width > 65535 || image.height > 65535 {
            return Err(FormatError::OutOfRange {
                field: "DNG size",
                value: format!("{} x {}", image.width, image.height),
                allowed: "1..=65535 on each side".into(),
            });
        }
        if self.colour.calibrations.len() > 2 {
            return Err(FormatError::OutOfRange {
                field: "colour matrix count",
                value: self.colour.calibrations.len().to_string(),
                allowed: "0..=2 (ColorMatrix1/2)".into(),
            });
        }
        if let Some(crop) = self.framing.default_crop {
            crop.check(image.width, image.height)?;
        }
        Ok(())
    }

    /// The file's bytes: 16-bit uncompressed samples in one little-endian strip.
    pub fn encode(&self) -> Result<Vec<u8>> {
        self.encode_with(&EncodeOptions::default())
    }

    /// The samples of each strip or tile, coded as `options` says.
    fn segments(&self, options: &EncodeOptions) -> Result<Vec<Vec<u8>>> {
        let image = &self.image;
        let spp = usize::from(image.samples_per_pixel);
        let (cell_w, cell_h) = match options.tile {
            Some((w, h)) => {
                if w == 0 || h == 0 || w % 16 != 0 || h % 16 != 0 || w > 65535 || h > 65535 {
                    return Err(FormatError::OutOfRange {
                        field: "tile size",
                        value: format!("{w} x {h}"),
                        allowed: "multiples of 16, up to 65535".into(),
                    });
                }
                (w as usize, h as usize)
            }
            None => (image.width, image.height),
        };
        let across = image.width.div_ceil(cell_w);
        let down = image.height.div_ceil(cell_h);
        // One strip is the image itself; tiles are copied out, a tile past the image's edge
        // repeating its last column and row (padding a reader ignores; repeating keeps the
        // prediction cheap to code).
        let cells: Vec<Cow<[u16]>> = if options.tile.is_none() {
            vec![Cow::Borrowed(&image.samples)]
        } else {
            let mut cells = Vec::with_capacity(across * down);
            for ty in 0..down {
                for tx in 0..across {
                    let (x0, x1) = (tx * cell_w, ((tx + 1) * cell_w).min(image.width));
                    let mut cell = Vec::with_capacity(cell_w * cell_h * spp);
                    for y in ty * cell_h..(ty + 1) * cell_h {
                        let row = &image.samples[y.min(image.height - 1) * image.width * spp..];
                        cell.extend_from_slice(&row[x0 * spp..x1 * spp]);
                        let last = &row[(x1 - 1) * spp..x1 * spp];
                        for _ in x1 - x0..cell_w {
                            cell.extend_from_slice(last);
                        }
                    }
                    cells.push(Cow::Owned(cell));
                }
            }
            cells
        };
        cells
            .iter()
            .map(|cell| match options.storage {
                Storage::Uncompressed { bits } => {
                    let max = (1u32 << bits.clamp(1, 16)) - 1;
                    if !(8..=16).contains(&bits) || cell.iter().any(|v| u32::from(*v) > max) {
                        return Err(FormatError::OutOfRange {
                            field: "uncompressed bits per sample",
                            value: bits.to_string(),
                            allowed: "8..=16, enough for every sample".into(),
                        });
                    }
                    let mut out = Vec::new();
                    for row in cell.chunks_exact(cell_w * spp) {
                        match bits {
                            8 => out.extend(row.iter().map(|v| *v as u8)),
                            16 => out.extend(
                                row.iter()
                                    .flat_map(|v| u16_bytes(*v, options.little_endian)),
                            ),
                            _ => pack_row(row, u32::from(bits), &mut out),
                        }
                    }
                    Ok(out)
                }
                Storage::LosslessJpeg {
                    components,
                    predictor,
                } => {
                    let n = usize::from(components);
                    // Components that share a line: a CFA's columns, or a pixel's samples.
                    let columns = if spp == 1 { n } else { 1 };
                    let allowed = if spp == 1 { (1..=2).contains(&n) } else { n == spp };
                    if !allowed || cell_w % columns != 0 || cell_w / columns > 65535 {
                        return Err(FormatError::OutOfRange {
                            field: "lossless JPEG components",
                            value: components.to_string(),
                            allowed: "1, or 2 with an even strip or tile width, for a CFA image; 3 for a linear one".into(),
                        });
                    }
                    let frame = Frame {
                        precision: image.bits,
                        lines: cell_h as u16,
                        samples_per_line: (cell_w / columns) as u16,
                        components,
                    };
                    lossless_jpeg::encode(cell, frame, predictor, 0, 0)
                }
                Storage::LossyJpeg { quality } => {
                    if !(1..=100).contains(&quality) || cell.iter().any(|v| *v > 255) {
                        return Err(FormatError::OutOfRange {
                            field: "lossy JPEG storage",
                            value: format!("quality {quality}"),
                            allowed: "quality 1..=100 and 8-bit samples".into(),
                        });
                    }
                    let colour = if spp == 3 {
                        jpeg_encoder::ColorType::Rgb
                    } else {
                        jpeg_encoder::ColorType::Luma
                    };
                    let bytes: Vec<u8> = cell.iter().map(|v| *v as u8).collect();
                    let mut out = Vec::new();
                    let mut encoder = jpeg_encoder::Encoder::new(&mut out, quality);
                    // Chroma at full resolution: a raw is worth it, and upsampling is where
                    // JPEG decoders differ most.
                    encoder.set_sampling_factor(jpeg_encoder::SamplingFactor::R_4_4_4);
                    encoder
                        .encode(&bytes, cell_w as u16, cell_h as u16, colour)
                        .map_err(|e| FormatError::JpegEncode(e.to_string()))?;
                    Ok(out)
                }
            })
            .collect()
    }

    /// The file's bytes, laid out as `options` says.
    pub fn encode_with(&self, options: &EncodeOptions) -> Result<Vec<u8>> {
        self.encode_with_entries(options, Vec::new())
    }

    /// As [`Dng::encode_with`], with `extra` entries in the IFD (for tests of tags the writer
    /// does not otherwise write).
    pub(crate) fn encode_with_entries(
        &self,
        options: &EncodeOptions,
        extra: Vec<Entry>,
    ) -> Result<Vec<u8>> {
        let (entries, segments) = self.ifd_entries(options, extra)?;
        Ok(layout(entries, &segments, options.little_endian))
    }

    /// The file's bytes laid out as Adobe's DNG Converter and most cameras do: IFD 0 a small
    /// 8-bit RGB preview (each 2x2 CFA block one pixel, at most 256 wide) holding the tags that
    /// describe the camera (make, model, DNG version, orientation, colour, baseline exposure),
    /// and the raw image, stored as `options` says, in a SubIFD.
    pub fn encode_with_preview(&self, options: &EncodeOptions) -> Result<Vec<u8>> {
        let (entries, segments) = self.ifd_entries(options, Vec::new())?;
        let camera_wide = |tag: u16| {
            [
                MAKE,
                MODEL,
                ORIENTATION,
                SOFTWARE,
                DNG_VERSION,
                DNG_BACKWARD_VERSION,
                UNIQUE_CAMERA_MODEL,
                ANALOG_BALANCE,
                AS_SHOT_NEUTRAL,
                AS_SHOT_WHITE_XY,
                BASELINE_EXPOSURE,
                EXPOSURE_TIME,
                ISO_SPEED_RATINGS,
            ]
            .contains(&tag)
                || CALIBRATION_TAGS.iter().any(|c| {
                    [
                        c.color_matrix,
                        c.illuminant,
                        c.forward_matrix,
                        c.camera_calibration,
                    ]
                    .contains(&tag)
                })
        };
        let (mut ifd0, raw): (Vec<Entry>, Vec<Entry>) =
            entries.into_iter().partition(|e| camera_wide(e.tag));
        let image = &self.image;
        let step = (image.width / 2).div_ceil(256).max(1);
        let (pw, ph) = (
            (image.width / 2).div_ceil(step).max(1),
            (image.height / 2).div_ceil(step).max(1),
        );
        let mut preview = Vec::with_capacity(pw * ph * 3);
        let shift = image.bits.saturating_sub(8);
        for py in 0..ph {
            for px in 0..pw {
                let (x, y) = (
                    (px * step * 2).min(image.width - 1),
                    (py * step * 2).min(image.height - 1),
                );
                let mut rgb = [0u32; 3];
                let mut count = [0u32; 3];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (
                        (x + dx).min(image.width - 1),
                        (y + dy).min(image.height - 1),
                    );
                    let i = sy * image.width + sx;
                    if image.is_linear() {
                        for c in 0..3 {
                            rgb[c] += u32::from(image.samples[3 * i + c]);
                            count[c] += 1;
                        }
                    } else {
                        let c = image.pattern.colour_at(sx, sy).index();
                        rgb[c] += u32::from(image.samples[i]);
                        count[c] += 1;
                    }
                }
                for c in 0..3 {
                    preview.push(((rgb[c] / count[c].max(1)) >> shift).min(255) as u8);
                }
            }
        }
        let preview_len = preview.len() as u32;
        ifd0.extend([
            long(NEW_SUBFILE_TYPE, &[1]),
            long(IMAGE_WIDTH, &[pw as u32]),
            long(IMAGE_LENGTH, &[ph as u32]),
            short(BITS_PER_SAMPLE, &[8, 8, 8]),
            short(COMPRESSION, &[1]),
            short(PHOTOMETRIC, &[2]),
            long(STRIP_OFFSETS, &[0]),
            short(SAMPLES_PER_PIXEL, &[3]),
            long(ROWS_PER_STRIP, &[ph as u32]),
            long(STRIP_BYTE_COUNTS, &[preview_len]),
            short(PLANAR_CONFIGURATION, &[1]),
            long(SUB_IFDS, &[0]),
        ]);
        ifd0.sort_by_key(|e| e.tag);
        let preview = [preview];
        Ok(layout_ifds(
            vec![(ifd0, &preview), (raw, &segments)],
            options.little_endian,
        ))
    }

    /// The raw IFD's entries, sorted, with `extra` replacing any of the same tag, and the
    /// coded strips or tiles.
    fn ifd_entries(
        &self,
        options: &EncodeOptions,
        extra: Vec<Entry>,
    ) -> Result<(Vec<Entry>, Vec<Vec<u8>>)> {
        self.check()?;
        let image = &self.image;
        let (w, h) = (image.width as u32, image.height as u32);
        let segments = self.segments(options)?;
        let (bits, compression) = match options.storage {
            Storage::Uncompressed { bits } => (u16::from(bits), 1),
            Storage::LosslessJpeg { .. } => (u16::from(image.bits), 7),
            Storage::LossyJpeg { .. } => (8, 34892),
        };
        let linear = image.is_linear();
        let spp = u16::from(image.samples_per_pixel);
        let model = if self.camera_model.is_empty() {
            "camsim"
        } else {
            &self.camera_model
        };
        let counts: Vec<u32> = segments.iter().map(|s| s.len() as u32).collect();
        let zeros = vec![0u32; segments.len()]; // offsets, patched below
        let mut entries = vec![
            long(NEW_SUBFILE_TYPE, &[0]),
            long(IMAGE_WIDTH, &[w]),
            long(IMAGE_LENGTH, &[h]),
            short(BITS_PER_SAMPLE, &vec![bits; usize::from(spp)]),
            short(COMPRESSION, &[compression]),
            short(
                PHOTOMETRIC,
                &[if linear {
                    LINEAR_RAW_PHOTOMETRIC
                } else {
                    CFA_PHOTOMETRIC
                } as u16],
            ),
            ascii(MAKE, "camsim"),
            ascii(MODEL, model),
            short(ORIENTATION, &[self.framing.orientation.to_tiff()]),
            short(SAMPLES_PER_PIXEL, &[spp]),
            short(PLANAR_CONFIGURATION, &[1]),
            ascii(SOFTWARE, concat!("camsim ", env!("CARGO_PKG_VERSION"))),
            bytes(DNG_VERSION, &[1, 4, 0, 0]),
            // Lossy JPEG needs a 1.4 reader; the rest reads with 1.1.
            bytes(
                DNG_BACKWARD_VERSION,
                &[1, if compression == 34892 { 4 } else { 1 }, 0, 0],
            ),
            ascii(UNIQUE_CAMERA_MODEL, model),
        ];
        if !linear {
            entries.extend([
                short(CFA_REPEAT_PATTERN_DIM, &[2, 2]),
                bytes(CFA_PATTERN, &cfa_codes(image.pattern)),
            ]);
        }
        match options.tile {
            Some((tw, th)) => entries.extend([
                long(TILE_WIDTH, &[tw]),
                long(TILE_LENGTH, &[th]),
                long(TILE_OFFSETS, &zeros),
                long(TILE_BYTE_COUNTS, &counts),
            ]),
            None => entries.extend([
                long(STRIP_OFFSETS, &zeros),
                long(ROWS_PER_STRIP, &[h]),
                long(STRIP_BYTE_COUNTS, &counts),
            ]),
        }
        let black = image.black_level;
        if linear {
            // One repeat cell, a value per sample.
            entries.push(short(BLACK_LEVEL, &black[..3]));
            entries.push(short(WHITE_LEVEL, &[image.white_level; 3]));
        } else {
            if black.iter().all(|b| *b == black[0]) {
                entries.push(short(BLACK_LEVEL, &[black[0]]));
            } else {
                entries.push(short(BLACK_LEVEL_REPEAT_DIM, &[2, 2]));
                entries.push(short(BLACK_LEVEL, &black));
            }
            entries.push(short(WHITE_LEVEL, &[image.white_level]));
        }
        if let Some(crop) = self.framing.default_crop {
            entries.push(long(
                DEFAULT_CROP_ORIGIN,
                &[crop.left as u32, crop.top as u32],
            ));
            entries.push(long(
                DEFAULT_CROP_SIZE,
                &[crop.width as u32, crop.height as u32],
            ));
        }
        let matrix = |tag: u16, m: &Mat3| -> Result<Entry> {
            let flat: Vec<f64> = m.iter().flatten().copied().collect();
            if !flat.iter().all(|v| v.is_finite()) {
                return Err(FormatError::OutOfRange {
                    field: "colour matrix",
                    value: format!("{m:?}"),
                    allowed: "finite values".into(),
                });
            }
            Ok(srational(tag, &flat))
        };
        for (c, tags) in self.colour.calibrations.iter().zip(CALIBRATION_TAGS) {
            entries.push(matrix(tags.color_matrix, &c.color_matrix)?);
            entries.push(short(tags.illuminant, &[c.illuminant.code()]));
            if let Some(m) = &c.forward_matrix {
                entries.push(matrix(tags.forward_matrix, m)?);
            }
            if let Some(m) = &c.camera_calibration {
                entries.push(matrix(tags.camera_calibration, m)?);
            }
        }
        // Written as n / 1e6: a value that rounds to 0 or past u32 would not read back.
        let millionths = |field: &'static str, n: [f64; 3]| -> Result<()> {
            if n.iter().all(|v| (1e-6..=4294.0).contains(v)) {
                Ok(())
            } else {
                Err(FormatError::OutOfRange {
                    field,
                    value: format!("{n:?}"),
                    allowed: "[1e-6, 4294] (written in millionths)".into(),
                })
            }
        };
        if let Some(n) = self.colour.analog_balance {
            millionths("analog balance", n)?;
            entries.push(rational(ANALOG_BALANCE, &n));
        }
        if let Some(n) = self.colour.as_shot_neutral {
            millionths("as-shot neutral", n)?;
            entries.push(rational(AS_SHOT_NEUTRAL, &n));
        }
        if let Some(xy) = self.colour.as_shot_white_xy {
            if !xy.iter().all(|v| (1e-6..1.0).contains(v)) {
                return Err(FormatError::OutOfRange {
                    field: "as-shot white xy",
                    value: format!("{xy:?}"),
                    allowed: "a chromaticity in [1e-6, 1)".into(),
                });
            }
            entries.push(rational(AS_SHOT_WHITE_XY, &xy));
        }
        if let Some(ev) = self.processing.baseline_exposure {
            if !ev.is_finite() || ev.abs() > 100.0 {
                return Err(FormatError::OutOfRange {
                    field: "baseline exposure",
                    value: ev.to_string(),
                    allowed: "-100..=100 EV".into(),
                });
            }
            entries.push(srational(BASELINE_EXPOSURE, &[ev]));
        }
        if let Some(t) = self.processing.exposure_time_s {
            if !(t > 0.0 && t <= 4000.0) {
                return Err(FormatError::OutOfRange {
                    field: "exposure time",
                    value: t.to_string(),
                    allowed: "(0, 4000] s".into(),
                });
            }
            entries.push(rational(EXPOSURE_TIME, &[t]));
        }
        if let Some(iso) = self.processing.iso {
            entries.push(short(ISO_SPEED_RATINGS, &[iso]));
        }
        if let Some(p) = self.processing.noise_profile {
            let pairs: Vec<f64> = if p.is_uniform() {
                vec![p.scale()[0].into(), p.offset()[0].into()]
            } else {
                (0..3)
                    .flat_map(|c| [p.scale()[c].into(), p.offset()[c].into()])
                    .collect()
            };
            entries.push(Entry {
                tag: NOISE_PROFILE,
                values: Values::Double(pairs),
            });
        }
        for (list, tag) in self.processing.opcode_lists.iter().zip(OPCODE_LISTS) {
            if !list.is_empty() {
                entries.push(Entry {
                    tag,
                    values: Values::Undefined(super::opcodes::encode(list)),
                });
            }
        }
        entries.retain(|e| extra.iter().all(|x| x.tag != e.tag));
        entries.extend(extra);
        entries.sort_by_key(|e| e.tag);
        Ok((entries, segments))
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.encode().map_err(|e| e.in_file(path))?;
        std::fs::write(path, bytes).map_err(|e| FormatError::io(path, e))
    }
}

/// A TIFF file: header, IFD, out-of-line values, then the segments (each starting on an even offset),
/// with the StripOffsets or TileOffsets entry pointing at them.
pub(crate) fn layout(entries: Vec<Entry>, segments: &[Vec<u8>], little: bool) -> Vec<u8> {
    layout_ifds(vec![(entries, segments)], little)
}

/// A TIFF file of several IFDs, each with its segments: the header, each IFD followed by its
/// out-of-line values, then every IFD's segments (each starting on an even offset). The
/// first IFD is IFD 0; the others are its SubIFDs, its SubIFDs entry patched to point at them,
/// as each IFD's StripOffsets or TileOffsets entry is at its segments.
pub(crate) fn layout_ifds(mut ifds: Vec<(Vec<Entry>, &[Vec<u8>])>, little: bool) -> Vec<u8> {
    let out_of_line = |entries: &[Entry]| -> usize {
        entries
            .iter()
            .map(|e| e.bytes(little).len())
            .filter(|n| *n > 4)
            .map(|n| n.next_multiple_of(2))
            .sum()
    };
    // Where each IFD starts, then where each segment starts.
    let mut at = 8;
    let mut ifd_offsets = Vec::with_capacity(ifds.len());
    for (entries, _) in &ifds {
        ifd_offsets.push(at as u32);
        at += 2 + 12 * entries.len() + 4 + out_of_line(entries);
    }
    for (entries, segments) in ifds.iter_mut() {
        let offsets: Vec<u32> = segments
            .iter()
            .map(|s| {
                let o = at as u32;
                at += s.len().next_multiple_of(2);
                o
            })
            .collect();
        for e in entries.iter_mut() {
            if e.tag == STRIP_OFFSETS || e.tag == TILE_OFFSETS {
                e.values = Values::Long(offsets.clone());
            }
        }
    }
    for e in ifds[0].0.iter_mut() {
        if e.tag == SUB_IFDS {
            e.values = Values::Long(ifd_offsets[1..].to_vec());
        }
    }
    let u16b = |v: u16| u16_bytes(v, little);
    let u32b = |v: u32| u32_bytes(v, little);
    let mut out = Vec::with_capacity(at);
    out.extend_from_slice(if little { b"II*\0" } else { b"MM\0*" });
    out.extend_from_slice(&u32b(8));
    for (entries, _) in &ifds {
        out.extend_from_slice(&u16b(entries.len() as u16));
        let mut extra_offset = out.len() + 12 * entries.len() + 4;
        let mut extra = Vec::new();
        for e in entries {
            let (kind, count) = e.kind_and_count();
            let b = e.bytes(little);
            out.extend_from_slice(&u16b(e.tag));
            out.extend_from_slice(&u16b(kind));
            out.extend_from_slice(&u32b(count as u32));
            if b.len() <= 4 {
                let mut inline = [0u8; 4];
                inline[..b.len()].copy_from_slice(&b);
                out.extend_from_slice(&inline);
            } else {
                out.extend_from_slice(&u32b(extra_offset as u32));
                extra.extend_from_slice(&b);
                if b.len() % 2 == 1 {
                    extra.push(0);
                }
                extra_offset += b.len().next_multiple_of(2);
            }
        }
        out.extend_from_slice(&0u32.to_le_bytes()); // no next IFD: SubIFDs are not chained
        out.extend_from_slice(&extra);
    }
    for (_, segments) in &ifds {
        for s in segments.iter() {
            out.extend_from_slice(s);
            if s.len() % 2 == 1 {
                out.push(0);
            }
        }
    }
    out
}
