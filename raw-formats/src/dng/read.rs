//! The DNG reader: finds the CFA image, decodes its strips or tiles, linearises it, crops it to
//! the active area and reads its levels, colour tags and framing.

use isp_core::colour::Mat3;
use isp_core::noise::NoiseProfile;
use isp_core::CfaPattern;

use super::tags::*;
use super::tiff::{Ifd, Tiff};
use super::{cfa_codes, ColourCalibration, Crop, Dng, DngColour, Framing, Illuminant};
use super::{opcodes, Orientation, Processing, CALIBRATION_TAGS};
use crate::error::{FormatError, Result};
use crate::{dct_jpeg, lossless_jpeg};

/// What a NoiseProfile tag may hold.
const NOISE_PROFILE_VALUES: &str =
    "2 or 6 values (S, O per colour plane), each finite and in [0, 1], S and O not both 0";
use crate::raw_image::RawImage;

/// How a strip's or tile's bytes hold its samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Coding {
    /// Compression 1: `bits` per sample, most significant bit first, rows byte-aligned;
    /// 16-bit samples in the file's byte order.
    Uncompressed { bits: u32, little: bool },
    /// Compression 7: a lossless JPEG per strip or tile, or a sequential DCT JPEG of one
    /// component (Blackmagic's lossy CinemaDNG), told apart by its frame header.
    LosslessJpeg,
    /// Compression 34892: a baseline (lossy) JPEG of 8-bit samples per strip or tile, as
    /// Adobe's converter writes for lossy DNGs (its LinearizationTable restores linear values).
    LossyJpeg,
}

/// One strip or tile: where its bytes are and which pixels it covers (a tile may reach past
/// the image's right and bottom edges; those samples are padding).
#[derive(Debug, Clone, Copy)]
struct Segment {
    offset: usize,
    len: usize,
    x: usize,
    y: usize,
    width: usize,
    height: usize,
}

impl Dng {
    /// Parses a file's bytes.
    pub fn decode(data: &[u8]) -> Result<Dng> {
        let file = Tiff::new(data)?;
        let first = file.u32_at(4)? as usize;
        let ifd0 = file.ifd(first)?;
        if ifd0.get(DNG_VERSION).is_none() {
            return Err(FormatError::NotFormat {
                format: "DNG",
                reason: "no DNGVersion tag",
            });
        }
        // The raw image: IFD 0 if it is the CFA image, else the SubIFD that is.
        let mut raw_ifd = None;
        if file.is_raw_image(&ifd0)? {
            raw_ifd = Some(ifd0.clone());
        } else if let Some(sub) = ifd0.get(SUB_IFDS) {
            for offset in file.values(sub)?.into_iter().take(16) {
                let ifd = file.ifd(offset as usize)?;
                if file.is_raw_image(&ifd)? {
                    raw_ifd = Some(ifd);
                    break;
                }
            }
        }
        let raw_ifd = raw_ifd.ok_or(FormatError::NoCfaImage)?;
        file.read_raw(&raw_ifd, &ifd0)
    }
}

impl Tiff<'_> {
    /// The first value of `tag`, if present.
    fn first(&self, ifd: &Ifd, tag: u16) -> Result<Option<f64>> {
        match ifd.get(tag) {
            Some(e) => Ok(self.numbers(e)?.first().copied()),
            None => Ok(None),
        }
    }

    /// The strips or tiles and how their bytes are coded.
    fn segments(&self, ifd: &Ifd, width: usize, height: usize) -> Result<Vec<Segment>> {
        let tiled = ifd.get(TILE_WIDTH).is_some() || ifd.get(TILE_OFFSETS).is_some();
        let (offsets, counts, cell_w, cell_h) = if tiled {
            let tile_w = self.one(ifd, TILE_WIDTH, "TileWidth")? as usize;
            let tile_h = self.one(ifd, TILE_LENGTH, "TileLength")? as usize;
            if tile_w == 0 || tile_h == 0 || tile_w > 65535 || tile_h > 65535 {
                return Err(FormatError::OutOfRange {
                    field: "tile size",
                    value: format!("{tile_w} x {tile_h}"),
                    allowed: "1..=65535 on each side".into(),
                });
            }
            (
                self.values(Self::required(ifd, TILE_OFFSETS, "TileOffsets")?)?,
                self.values(Self::required(ifd, TILE_BYTE_COUNTS, "TileByteCounts")?)?,
                tile_w,
                tile_h,
            )
        } else {
            // RowsPerStrip defaults to the whole image (TIFF 6.0: 2^32 - 1).
            let rows = self
                .first(ifd, ROWS_PER_STRIP)?
                .map_or(height, |r| (r as usize).clamp(1, height));
            (
                self.values(Self::required(ifd, STRIP_OFFSETS, "StripOffsets")?)?,
                self.values(Self::required(ifd, STRIP_BYTE_COUNTS, "StripByteCounts")?)?,
                width,
                rows,
            )
        };
        let across = width.div_ceil(cell_w);
        let down = height.div_ceil(cell_h);
        let needed = across * down;
        let (offsets_name, counts_name) = if tiled {
            ("TileOffsets entries", "TileByteCounts entries")
        } else {
            ("StripOffsets entries", "StripByteCounts entries")
        };
        if offsets.len() < needed {
            return Err(FormatError::SizeMismatch {
                what: offsets_name,
                found: offsets.len(),
                expected: needed,
            });
        }
        if counts.len() < needed {
            return Err(FormatError::SizeMismatch {
                what: counts_name,
                found: counts.len(),
                expected: needed,
            });
        }
        let mut segments = Vec::with_capacity(needed);
        for i in 0..needed {
            let (x, y) = ((i % across) * cell_w, (i / across) * cell_h);
            // Strips end at the image's bottom; tiles keep their full size (padded).
            let height = if tiled {
                cell_h
            } else {
                cell_h.min(height - y)
            };
            self.bytes(offsets[i] as usize, counts[i] as usize)?;
            segments.push(Segment {
                offset: offsets[i] as usize,
                len: counts[i] as usize,
                x,
                y,
                width: cell_w,
                height,
            });
        }
        Ok(segments)
    }

    /// Decodes one segment's samples (`spp` per pixel) into `out` (resized only once the bytes
    /// are known to hold that many); returns the samples from one decoded row to the next,
    /// which is the segment's width times `spp` except for a lossy JPEG coded only as large as
    /// the image part of an edge tile.
    fn decode_segment(
        &self,
        segment: &Segment,
        coding: Coding,
        spp: usize,
        out: &mut Vec<u16>,
    ) -> Result<usize> {
        let bytes = self.bytes(segment.offset, segment.len)?;
        let row_samples = segment.width * spp;
        let samples = row_samples * segment.height;
        match coding {
            Coding::Uncompressed { bits, little } => {
                let row_bytes = (row_samples * bits as usize).div_ceil(8);
                let needed = row_bytes * segment.height;
                if bytes.len() < needed {
                    return Err(FormatError::SizeMismatch {
                        what: "bytes in a strip or tile",
                        found: bytes.len(),
                        expected: needed,
                    });
                }
                out.clear();
                out.reserve(samples);
                for row in bytes[..needed].chunks_exact(row_bytes) {
                    match bits {
                        8 => out.extend(row.iter().map(|v| u16::from(*v))),
                        16 => out.extend(row.chunks_exact(2).map(|b| {
                            if little {
                                u16::from_le_bytes([b[0], b[1]])
                            } else {
                                u16::from_be_bytes([b[0], b[1]])
                            }
                        })),
                        _ => unpack_msb_first(row, bits, row_samples, out),
                    }
                }
                Ok(row_samples)
            }
            Coding::LosslessJpeg if dct_jpeg::is_dct(bytes) => {
                let frame = dct_jpeg::frame(bytes)?;
                // Each 8x8 block costs at least two bits (its DC and end-of-block codes), so
                // the bytes bound the count.
                if frame.sample_count() != samples
                    || frame.block_count() > bytes.len().saturating_mul(4)
                {
                    return Err(FormatError::SizeMismatch {
                        what: "DCT JPEG samples in a strip or tile",
                        found: frame.sample_count(),
                        expected: samples,
                    });
                }
                out.clear();
                out.resize(samples, 0);
                dct_jpeg::decode(bytes, out)?;
                Ok(row_samples)
            }
            Coding::LosslessJpeg => {
                let frame = lossless_jpeg::frame(bytes)?;
                // Each sample costs at least one bit, so the bytes bound the count.
                if frame.sample_count() != samples || samples > bytes.len().saturating_mul(8) {
                    return Err(FormatError::SizeMismatch {
                        what: "lossless JPEG samples in a strip or tile",
                        found: frame.sample_count(),
                        expected: samples,
                    });
                }
                out.clear();
                out.resize(samples, 0);
                lossless_jpeg::decode(bytes, out)?;
                Ok(row_samples)
            }
            Coding::LossyJpeg => {
                let (width, decoded) = decode_lossy_jpeg(bytes, segment, spp)?;
                out.clear();
                out.extend(decoded.iter().map(|v| u16::from(*v)));
                Ok(width * spp)
            }
        }
    }

    pub(super) fn read_raw(&self, ifd: &Ifd, ifd0: &Ifd) -> Result<Dng> {
        let width = self.one(ifd, IMAGE_WIDTH, "ImageWidth")? as usize;
        let height = self.one(ifd, IMAGE_LENGTH, "ImageLength")? as usize;
        if width == 0 || height == 0 || width > 65535 || height > 65535 {
            return Err(FormatError::OutOfRange {
                field: "image size",
                value: format!("{width} x {height}"),
                allowed: "1..=65535".into(),
            });
        }
        // A CFA image has one sample per pixel; a LinearRaw one (already demosaiced) three.
        let linear = self.first(ifd, PHOTOMETRIC)? == Some(f64::from(LINEAR_RAW_PHOTOMETRIC));
        let spp = self.first(ifd, SAMPLES_PER_PIXEL)?.unwrap_or(1.0);
        if spp != if linear { 3.0 } else { 1.0 } {
            return Err(FormatError::Unsupported {
                field: "SamplesPerPixel",
                value: spp.to_string(),
                supported: "1 for a CFA image, 3 (RGB) for a LinearRaw one",
            });
        }
        let spp = spp as usize;
        if linear {
            let planar = self.first(ifd, PLANAR_CONFIGURATION)?.unwrap_or(1.0);
            if planar != 1.0 {
                return Err(FormatError::Unsupported {
                    field: "PlanarConfiguration",
                    value: planar.to_string(),
                    supported: "1 (a pixel's samples together)",
                });
            }
        }
        let all_bits = self.values(Self::required(ifd, BITS_PER_SAMPLE, "BitsPerSample")?)?;
        let bits = all_bits.first().copied().unwrap_or(0);
        if !(8..=16).contains(&bits) {
            return Err(FormatError::SampleBits { bits });
        }
        if all_bits.iter().any(|b| *b != bits) {
            return Err(FormatError::Unsupported {
                field: "BitsPerSample",
                value: format!("{all_bits:?}"),
                supported: "the same depth for every sample",
            });
        }
        let compression = self.first(ifd, COMPRESSION)?.unwrap_or(1.0) as u32;
        let coding = match compression {
            1 => Coding::Uncompressed {
                bits,
                little: self.little,
            },
            7 => Coding::LosslessJpeg,
            34892 if bits == 8 => Coding::LossyJpeg,
            34892 => {
                return Err(FormatError::Unsupported {
                    field: "BitsPerSample with Compression 34892 (lossy JPEG)",
                    value: bits.to_string(),
                    supported: "8",
                })
            }
            value => return Err(FormatError::Compression { value }),
        };
        let pattern = if linear {
            CfaPattern::Rggb
        } else {
            self.cfa_pattern(ifd)?
        };

        // Each sample takes at least one bit of the file (a Huffman code per difference in
        // lossless JPEG), or in lossy JPEG (Compression 34892, or 7 with a DCT frame) each 8x8
        // block of a component at least two (its DC and end-of-block codes): a header cannot
        // claim more. (A smooth lossy file can hold well under a bit per sample; a clean-clone
        // run found one.) Each segment's decoder checks its own kind's bound.
        let total = width * height * spp;
        let samples_per_bit = if matches!(coding, Coding::LossyJpeg | Coding::LosslessJpeg) {
            32
        } else {
            1
        };
        if total > self.data.len().saturating_mul(8 * samples_per_bit) {
            return Err(FormatError::SizeMismatch {
                what: "bytes for the image's samples",
                found: self.data.len(),
                expected: total.div_ceil(8 * samples_per_bit),
            });
        }
        let segments = self.segments(ifd, width, height)?;
        let mut raw = vec![0u16; total];
        let mut scratch = Vec::new();
        for segment in &segments {
            let stride = self.decode_segment(segment, coding, spp, &mut scratch)?;
            let cols = segment.width.min(width - segment.x) * spp;
            let rows = segment.height.min(height - segment.y);
            if stride < cols || scratch.len() < rows * stride {
                return Err(FormatError::SizeMismatch {
                    what: "decoded samples of a strip or tile",
                    found: scratch.len(),
                    expected: rows * cols,
                });
            }
            for r in 0..rows {
                let to = ((segment.y + r) * width + segment.x) * spp;
                raw[to..to + cols].copy_from_slice(&scratch[r * stride..r * stride + cols]);
            }
        }

        // OpcodeList1 applies to the samples as stored (DNG 1.4, chapter 7): its bad pixels are
        // found now, in stored coordinates. (Bad-pixel opcodes are for CFA images.)
        let lists = self.opcode_lists(ifd)?;
        let mut bad_stored = Vec::new();
        if !linear {
            bad_pixels_of(&lists[0], &raw, width, height, |v| v, &mut bad_stored);
        }

        // LinearizationTable maps stored codes to linear values (the last entry for codes
        // past its end, as the DNG SDK does).
        let mut max_code = ((1u32 << bits) - 1) as f64;
        if let Some(e) = ifd.get(LINEARIZATION_TABLE) {
            let table: Vec<u16> = self
                .values(e)?
                .into_iter()
                .map(|v| v.min(65535) as u16)
                .collect();
            let last = *table.last().ok_or(FormatError::Missing {
                field: "LinearizationTable values",
                tag: Some(LINEARIZATION_TABLE),
            })?;
            for v in raw.iter_mut() {
                *v = table.get(usize::from(*v)).copied().unwrap_or(last);
            }
            max_code = 65535.0;
        }

        // The crop also gives the active area's corner, which moves the stored coordinates of
        // OpcodeList1 into it.
        let area = ifd.get(ACTIVE_AREA).map(|e| self.values(e)).transpose()?;
        let (left, top) = match area.as_deref() {
            Some([top, left, ..]) => (*left as usize, *top as usize),
            _ => (0, 0),
        };
        let (width, height, mut raw) = match &area {
            Some(area) => crop_to_active_area(raw, width, height, spp, area)?,
            None => (width, height, raw),
        };

        let whites = match ifd.get(WHITE_LEVEL) {
            Some(e) => self.numbers(e)?,
            None => vec![max_code],
        };
        let white = whites.iter().copied().fold(f64::NAN, f64::max);
        let level = |v: f64, field: &'static str| -> Result<u16> {
            if v.is_finite() && (0.0..=max_code).contains(&v) {
                Ok(v.round() as u16)
            } else {
                Err(FormatError::OutOfRange {
                    field,
                    value: v.to_string(),
                    allowed: format!("0..={max_code}"),
                })
            }
        };
        let white_level = level(white, "WhiteLevel")?;
        let black_level = self.black_levels(ifd, width, height, spp, &mut raw, white_level)?;
        if linear && whites.len() == 3 && whites.iter().any(|w| *w != white) {
            // Channels that clip lower are stretched to the common white: the pipeline holds
            // one white level per frame.
            for (c, w) in whites.iter().enumerate() {
                let own = level(*w, "WhiteLevel")?;
                let b = f64::from(black_level[c]);
                if f64::from(own) <= b {
                    return Err(FormatError::OutOfRange {
                        field: "WhiteLevel",
                        value: own.to_string(),
                        allowed: format!("above the channel's black level {b}"),
                    });
                }
                let scale = (f64::from(white_level) - b) / (f64::from(own) - b);
                for v in raw.iter_mut().skip(c).step_by(3) {
                    *v = (b + (f64::from(*v) - b).max(0.0) * scale)
                        .round()
                        .min(f64::from(white_level)) as u16;
                }
            }
        }
        // The significant bits: those the white level needs (8 at least).
        let significant = (16 - white_level.leading_zeros()).clamp(8, 16) as u8;
        let mut image = if linear {
            RawImage::linear_rgb(
                width,
                height,
                significant,
                [black_level[0], black_level[1], black_level[2]],
                white_level,
                raw,
            )?
        } else {
            RawImage::new(
                width,
                height,
                pattern,
                significant,
                black_level,
                white_level,
                raw,
            )?
        };
        apply_stage2_maps(&mut image, &lists[1]);
        // Applied: the image holds their result, and a writer must not store them again.
        let mut lists = lists;
        lists[1].retain(|op| !is_map(op));
        let framing = self.framing(ifd, ifd0, width, height)?;
        // OpcodeLists 2 and 3 apply in the active area, to samples scaled so black is 0 and
        // white 65535 (the DNG SDK's stage 2): a FixBadPixelsConstant there compares on that
        // scale.
        let mut bad = Vec::new();
        for [x, y] in bad_stored {
            if (left..left + width).contains(&x) && (top..top + height).contains(&y) {
                bad.push([x - left, y - top]);
            }
        }
        let span = (f64::from(white_level) - f64::from(black_level[0])).max(1.0);
        let scaled = |v: u16| {
            ((f64::from(v) - f64::from(black_level[0])) * 65535.0 / span)
                .round()
                .clamp(0.0, 65535.0) as u16
        };
        if !linear {
            for list in &lists[1..] {
                bad_pixels_of(list, &image.samples, width, height, scaled, &mut bad);
            }
        }
        let mut bad_pixels: Vec<isp_core::dpc::Defect> = bad
            .into_iter()
            .map(|[x, y]| isp_core::dpc::Defect {
                x: x as u16,
                y: y as u16,
            })
            .collect();
        bad_pixels.sort_unstable();
        bad_pixels.dedup();
        let processing = Processing {
            baseline_exposure: self
                .first(ifd0, BASELINE_EXPOSURE)?
                .filter(|v| v.is_finite()),
            opcode_lists: lists,
            bad_pixels,
            noise_profile: self.noise_profile(ifd, ifd0)?,
            // Informative: a malformed one is left out, not a reason to refuse the file.
            exposure_time_s: self
                .first(ifd0, EXPOSURE_TIME)
                .ok()
                .flatten()
                .filter(|v| v.is_finite() && *v > 0.0),
            iso: self
                .first(ifd0, ISO_SPEED_RATINGS)
                .ok()
                .flatten()
                .filter(|v| (1.0..=65535.0).contains(v))
                .map(|v| v as u16),
        };
        let colour = self.colour(ifd0)?;
        let camera_model = self
            .text(ifd0, UNIQUE_CAMERA_MODEL)
            .or_else(|| self.text(ifd0, MODEL))
            .unwrap_or_default();
        Ok(Dng {
            image,
            camera_model,
            colour,
            framing,
            processing,
        })
    }

    /// OpcodeList1, 2 and 3 of the raw IFD (empty where absent).
    fn opcode_lists(&self, ifd: &Ifd) -> Result<[Vec<opcodes::Opcode>; 3]> {
        let mut lists: [Vec<opcodes::Opcode>; 3] = Default::default();
        for (list, tag) in lists.iter_mut().zip(OPCODE_LISTS) {
            if let Some(e) = ifd.get(tag) {
                *list = opcodes::parse(self.raw_bytes(e)?)?;
            }
        }
        Ok(lists)
    }

    fn cfa_pattern(&self, ifd: &Ifd) -> Result<CfaPattern> {
        let dim = ifd
            .get(CFA_REPEAT_PATTERN_DIM)
            .map(|e| self.values(e))
            .transpose()?
            .unwrap_or(vec![2, 2]);
        if dim != [2, 2] {
            return Err(FormatError::Unsupported {
                field: "CFARepeatPatternDim",
                value: format!("{dim:?}"),
                supported: "only 2x2",
            });
        }
        let codes = self.values(Self::required(ifd, CFA_PATTERN, "CFAPattern")?)?;
        [
            CfaPattern::Rggb,
            CfaPattern::Bggr,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
        ]
        .into_iter()
        .find(|p| {
            cfa_codes(*p)
                .iter()
                .map(|c| u32::from(*c))
                .eq(codes.iter().copied())
        })
        .ok_or(FormatError::Unsupported {
            field: "CFAPattern",
            value: format!("{codes:?}"),
            supported: "a Bayer pattern of R (0), G (1), B (2)",
        })
    }

    /// The black level per 2x2 position. BlackLevel repeats over BlackLevelRepeatDim rows and
    /// columns, and BlackLevelDeltaH/V add one value per column and row of the active area
    /// (DNG 1.4). A pattern a 2x2 block holds (repeats of 1 or 2, integer values, no deltas)
    /// is returned as is; any other is subtracted from the samples here, down to a uniform
    /// black that is returned, so the ISP sees the same signal above black. A LinearRaw image
    /// (`spp` 3) has one value per sample in each repeat cell; one cell of integers without
    /// deltas is returned as each channel's black (R, G, B, G).
    fn black_levels(
        &self,
        ifd: &Ifd,
        width: usize,
        height: usize,
        spp: usize,
        raw: &mut [u16],
        white: u16,
    ) -> Result<[u16; 4]> {
        let repeat = match ifd.get(BLACK_LEVEL_REPEAT_DIM) {
            Some(e) => self.values(e)?,
            None => vec![1, 1],
        };
        let (rows, cols) = match repeat[..] {
            [r, c] if (1..=256).contains(&r) && (1..=256).contains(&c) => (r as usize, c as usize),
            _ => {
                return Err(FormatError::Unsupported {
                    field: "BlackLevelRepeatDim",
                    value: format!("{repeat:?}"),
                    supported: "two values, rows and columns, each 1..=256",
                })
            }
        };
        let values = match ifd.get(BLACK_LEVEL) {
            Some(e) => self.numbers(e)?,
            None => vec![0.0; rows * cols * spp],
        };
        if values.len() != rows * cols * spp || !values.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(FormatError::Unsupported {
                field: "BlackLevel",
                value: format!("{} values", values.len()),
                supported:
                    "BlackLevelRepeatDim rows x columns x SamplesPerPixel non-negative values",
            });
        }
        let delta = |tag: u16, name: &'static str, n: usize| -> Result<Option<Vec<f64>>> {
            let Some(e) = ifd.get(tag) else {
                return Ok(None);
            };
            let v = self.numbers(e)?;
            if v.len() != n || !v.iter().all(|d| d.is_finite()) {
                return Err(FormatError::SizeMismatch {
                    what: name,
                    found: v.len(),
                    expected: n,
                });
            }
            Ok(v.iter().any(|d| *d != 0.0).then_some(v))
        };
        let delta_h = delta(
            BLACK_LEVEL_DELTA_H,
            "BlackLevelDeltaH values (one per column)",
            width,
        )?;
        let delta_v = delta(
            BLACK_LEVEL_DELTA_V,
            "BlackLevelDeltaV values (one per row)",
            height,
        )?;
        let at = |x: usize, y: usize, s: usize| values[((y % rows) * cols + x % cols) * spp + s];
        let simple = rows <= if spp == 1 { 2 } else { 1 }
            && cols <= if spp == 1 { 2 } else { 1 }
            && delta_h.is_none()
            && delta_v.is_none()
            && values.iter().all(|v| v.fract() == 0.0);
        let checked = |black: f64| -> Result<u16> {
            if black < f64::from(white) {
                Ok(black as u16)
            } else {
                Err(FormatError::OutOfRange {
                    field: "BlackLevel",
                    value: black.to_string(),
                    allowed: format!("below the white level {white}"),
                })
            }
        };
        if simple && spp == 1 {
            let mut black = [0u16; 4];
            for (p, b) in black.iter_mut().enumerate() {
                *b = checked(at(p % 2, p / 2, 0))?;
            }
            return Ok(black);
        }
        if simple {
            let [r, g, b] = [0, 1, 2].map(|s| checked(at(0, 0, s)));
            let g = g?;
            return Ok([r?, g, b?, g]);
        }
        let black_at = |x: usize, y: usize, s: usize| {
            at(x, y, s)
                + delta_h.as_ref().map_or(0.0, |d| d[x])
                + delta_v.as_ref().map_or(0.0, |d| d[y])
        };
        let mut floor = f64::INFINITY;
        for y in 0..height {
            for x in 0..width {
                for s in 0..spp {
                    floor = floor.min(black_at(x, y, s));
                }
            }
        }
        let base = checked(floor.max(0.0).floor())?;
        for (y, row) in raw.chunks_exact_mut(width * spp).enumerate() {
            for (i, v) in row.iter_mut().enumerate() {
                let above = f64::from(*v) - black_at(i / spp, y, i % spp) + f64::from(base);
                *v = above.round().clamp(0.0, 65535.0) as u16;
            }
        }
        Ok([base; 4])
    }

    /// DefaultCrop (relative to the active area) and Orientation.
    fn framing(&self, ifd: &Ifd, ifd0: &Ifd, width: usize, height: usize) -> Result<Framing> {
        let pair = |tag: u16| -> Result<Option<[f64; 2]>> {
            let Some(e) = ifd.get(tag) else {
                return Ok(None);
            };
            match self.numbers(e)?[..] {
                [a, b] if a.is_finite() && b.is_finite() && a >= 0.0 && b >= 0.0 => {
                    Ok(Some([a, b]))
                }
                ref v => Err(FormatError::Unsupported {
                    field: "DefaultCropOrigin/Size",
                    value: format!("{v:?}"),
                    supported: "two non-negative values",
                }),
            }
        };
        let default_crop = match (pair(DEFAULT_CROP_ORIGIN)?, pair(DEFAULT_CROP_SIZE)?) {
            (origin, Some(size)) => {
                let [left, top] = origin.unwrap_or([0.0, 0.0]);
                let crop = Crop {
                    left: left.round() as usize,
                    top: top.round() as usize,
                    width: size[0].round() as usize,
                    height: size[1].round() as usize,
                };
                crop.check(width, height)?;
                Some(crop)
            }
            _ => None,
        };
        // Orientation belongs to IFD 0 (the raw IFD's copy, if any, is ignored, as the DNG
        // SDK does).
        let orientation = match self.first(ifd0, ORIENTATION)? {
            Some(v) => Orientation::from_tiff(v as u32)?,
            None => Orientation::Normal,
        };
        Ok(Framing {
            default_crop,
            orientation,
        })
    }

    /// NoiseProfile, from the raw IFD (where DNG 1.3 puts it) or else IFD 0 (where writers
    /// whose raw is a SubIFD often leave it): 2 values for every plane or 6, one pair per
    /// colour plane (red, green, blue).
    fn noise_profile(&self, ifd: &Ifd, ifd0: &Ifd) -> Result<Option<NoiseProfile>> {
        let Some(e) = ifd.get(NOISE_PROFILE).or_else(|| ifd0.get(NOISE_PROFILE)) else {
            return Ok(None);
        };
        let v = self.numbers(e)?;
        NoiseProfile::from_pairs(&v)
            .map(Some)
            .map_err(|_| FormatError::Unsupported {
                field: "NoiseProfile",
                value: format!("{v:?}"),
                supported: NOISE_PROFILE_VALUES,
            })
    }

    /// The colour tags, which live in IFD 0.
    fn colour(&self, ifd0: &Ifd) -> Result<DngColour> {
        let matrix = |tag: u16, name: &'static str| -> Result<Option<Mat3>> {
            let Some(e) = ifd0.get(tag) else {
                return Ok(None);
            };
            let v = self.numbers(e)?;
            if v.len() != 9 || !v.iter().all(|x| x.is_finite()) {
                return Err(FormatError::Unsupported {
                    field: name,
                    value: format!("{} values", v.len()),
                    supported: "9 finite values (3-channel CFA)",
                });
            }
            Ok(Some(std::array::from_fn(|i| {
                std::array::from_fn(|j| v[3 * i + j])
            })))
        };
        let mut calibrations = Vec::new();
        for (tags, name) in CALIBRATION_TAGS
            .iter()
            .zip(["ColorMatrix1", "ColorMatrix2"])
        {
            if let Some(color_matrix) = matrix(tags.color_matrix, name)? {
                let illuminant = self.first(ifd0, tags.illuminant)?.unwrap_or(0.0);
                calibrations.push(ColourCalibration {
                    illuminant: Illuminant::from_code(illuminant.clamp(0.0, 65535.0) as u16),
                    color_matrix,
                    forward_matrix: matrix(tags.forward_matrix, "ForwardMatrix")?,
                    camera_calibration: matrix(tags.camera_calibration, "CameraCalibration")?,
                });
            }
        }
        let triple = |tag: u16, name: &'static str| -> Result<Option<[f64; 3]>> {
            let Some(e) = ifd0.get(tag) else {
                return Ok(None);
            };
            let v = self.numbers(e)?;
            if v.len() != 3 || !v.iter().all(|x| x.is_finite() && *x > 0.0) {
                return Err(FormatError::Unsupported {
                    field: name,
                    value: format!("{v:?}"),
                    supported: "3 positive values",
                });
            }
            Ok(Some([v[0], v[1], v[2]]))
        };
        Ok(DngColour {
            calibrations,
            analog_balance: triple(ANALOG_BALANCE, "AnalogBalance")?,
            as_shot_neutral: triple(AS_SHOT_NEUTRAL, "AsShotNeutral")?,
            as_shot_white_xy: match ifd0.get(AS_SHOT_WHITE_XY) {
                None => None,
                Some(e) => match self.numbers(e)?.as_slice() {
                    [x, y] if *x > 0.0 && *y > 0.0 && x + y < 1.0 => Some([*x, *y]),
                    v => {
                        return Err(FormatError::Unsupported {
                            field: "AsShotWhiteXY",
                            value: format!("{v:?}"),
                            supported: "a chromaticity x, y > 0 with x + y < 1",
                        })
                    }
                },
            },
        })
    }
}

/// Appends the pixels (column, row) that `list`'s FixBadPixelsConstant (a sample equal to the
/// constant, on the scale `scale` gives) and FixBadPixelsList (points, and rectangles clipped to
/// the image) name in a `width` x `height` image.
fn bad_pixels_of(
    list: &[opcodes::Opcode],
    raw: &[u16],
    width: usize,
    height: usize,
    scale: impl Fn(u16) -> u16,
    out: &mut Vec<[usize; 2]>,
) {
    for op in list {
        match op {
            opcodes::Opcode::FixBadPixelsConstant { constant, .. } => {
                for (i, v) in raw.iter().enumerate() {
                    if u32::from(scale(*v)) == *constant {
                        out.push([i % width, i / width]);
                    }
                }
            }
            opcodes::Opcode::FixBadPixelsList { points, rects, .. } => {
                for [row, col] in points {
                    let (x, y) = (*col as usize, *row as usize);
                    if x < width && y < height {
                        out.push([x, y]);
                    }
                }
                for [top, left, bottom, right] in rects {
                    let (bottom, right) =
                        ((*bottom as usize).min(height), (*right as usize).min(width));
                    for y in *top as usize..bottom {
                        for x in *left as usize..right {
                            out.push([x, y]);
                        }
                    }
                }
            }
            _ => {}
        }
    }
}

/// Appends `width` samples of `bits` bits (9..=15), packed most significant bit first, from one
/// row's bytes (which hold at least `width * bits` bits).
pub(super) fn unpack_msb_first(row: &[u8], bits: u32, width: usize, out: &mut Vec<u16>) {
    let mask = (1u32 << bits) - 1;
    let (mut acc, mut held) = (0u32, 0u32);
    let mut bytes = row.iter();
    for _ in 0..width {
        while held < bits {
            // The caller sized the row for `width` samples; a missing byte reads as zero.
            acc = (acc << 8) | u32::from(bytes.next().copied().unwrap_or(0));
            held += 8;
        }
        held -= bits;
        out.push(((acc >> held) & mask) as u16);
        acc &= (1 << held) - 1;
    }
}

/// The samples inside ActiveArea (`[top, left, bottom, right]`): the masked borders around it
/// never reach the image. The CFA pattern and black levels are relative to its top-left corner.
fn crop_to_active_area(
    raw: Vec<u16>,
    width: usize,
    height: usize,
    spp: usize,
    area: &[u32],
) -> Result<(usize, usize, Vec<u16>)> {
    let [top, left, bottom, right] = match area {
        [t, l, b, r] => [*t, *l, *b, *r].map(|v| v as usize),
        _ => {
            return Err(FormatError::Unsupported {
                field: "ActiveArea value count",
                value: area.len().to_string(),
                supported: "4: top, left, bottom, right",
            })
        }
    };
    if !(top < bottom && bottom <= height && left < right && right <= width) {
        return Err(FormatError::OutOfRange {
            field: "ActiveArea",
            value: format!("{area:?}"),
            allowed: format!("top < bottom <= {height}, left < right <= {width}"),
        });
    }
    if (top, left, bottom, right) == (0, 0, height, width) {
        return Ok((width, height, raw));
    }
    let (w, h) = (right - left, bottom - top);
    let mut out = Vec::with_capacity(w * h * spp);
    for row in raw.chunks_exact(width * spp).skip(top).take(h) {
        out.extend_from_slice(&row[left * spp..right * spp]);
    }
    Ok((w, h, out))
}

/// Whether `op` is a MapTable or MapPolynomial.
fn is_map(op: &opcodes::Opcode) -> bool {
    matches!(
        op,
        opcodes::Opcode::MapTable { .. } | opcodes::Opcode::MapPolynomial { .. }
    )
}

/// OpcodeList2's MapTable and MapPolynomial, in list order, on samples scaled so black is 0
/// and white 65535 (the DNG SDK's stage 2, where list 2 runs); the image then holds that
/// scale (16 bits, black 0). An image without them is left as it is. (A GainMap listed before
/// a map is applied after it, in the pipeline's shading stage.)
fn apply_stage2_maps(image: &mut RawImage, list: &[opcodes::Opcode]) {
    let maps: Vec<&opcodes::Opcode> = list.iter().filter(|op| is_map(op)).collect();
    if maps.is_empty() {
        return;
    }
    let spp = usize::from(image.samples_per_pixel);
    let (width, white, black) = (image.width, image.white_level, image.black_level);
    for (i, v) in image.samples.iter_mut().enumerate() {
        let (pixel, plane) = (i / spp, i % spp);
        let (x, y) = (pixel % width, pixel / width);
        let b = if spp == 1 {
            black[(y & 1) * 2 + (x & 1)]
        } else {
            black[plane]
        };
        let span = f64::from(white.saturating_sub(b).max(1));
        let scaled = (f64::from(v.saturating_sub(b)) * 65535.0 / span).round();
        let mut s = scaled.min(65535.0) as u16;
        for op in &maps {
            if let Some(mapped) = op.map_sample(x, y, plane, s) {
                s = mapped;
            }
        }
        *v = s;
    }
    image.black_level = [0; 4];
    image.white_level = 65535;
    image.bits = 16;
}

/// Decodes a strip's or tile's baseline JPEG (Compression 34892) of `spp` 8-bit components
/// (3 coded as YCbCr, as libjpeg writes RGB): its width in pixels and the samples, a pixel's
/// together. The JPEG is the segment's size, or for an edge tile at least the image part of it
/// (some writers code only that); its header is checked against that before anything is
/// decoded, so a damaged file cannot make the decoder allocate more than the tile.
fn decode_lossy_jpeg(bytes: &[u8], segment: &Segment, spp: usize) -> Result<(usize, Vec<u8>)> {
    let damaged = |e: jpeg_decoder::Error| FormatError::LossyJpeg {
        problem: e.to_string(),
    };
    let mut decoder = jpeg_decoder::Decoder::new(bytes);
    decoder.read_info().map_err(damaged)?;
    let info = decoder.info().ok_or(FormatError::LossyJpeg {
        problem: "no frame header".into(),
    })?;
    let (w, h) = (usize::from(info.width), usize::from(info.height));
    let components = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => 1,
        jpeg_decoder::PixelFormat::RGB24 => 3,
        other => {
            return Err(FormatError::LossyJpeg {
                problem: format!("{other:?} samples (8-bit greyscale or RGB expected)"),
            })
        }
    };
    if components != spp || w > segment.width || h > segment.height || w == 0 || h == 0 {
        return Err(FormatError::SizeMismatch {
            what: "lossy JPEG width x height x components in a strip or tile",
            found: w * h * components,
            expected: segment.width * segment.height * spp,
        });
    }
    decoder.set_max_decoding_buffer_size(segment.width * segment.height * spp);
    let samples = decoder.decode().map_err(damaged)?;
    if samples.len() != w * h * spp {
        return Err(FormatError::SizeMismatch {
            what: "lossy JPEG samples in a strip or tile",
            found: samples.len(),
            expected: w * h * spp,
        });
    }
    Ok((w, samples))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Packs `values` of `bits` bits most significant bit first, with the writer's packer.
    fn pack(values: &[u16], bits: u32) -> Vec<u8> {
        let mut out = Vec::new();
        super::super::write::pack_row(values, bits, &mut out);
        out
    }

    #[test]
    fn packed_samples_unpack_most_significant_bit_first() {
        let mut out = Vec::new();
        unpack_msb_first(&[0xab, 0xc1, 0x23], 12, 2, &mut out);
        assert_eq!(out, [0xabc, 0x123]);
        for bits in 9..=15u32 {
            let max = (1u32 << bits) - 1;
            let values: Vec<u16> = (0..37u32)
                .map(|i| (i.wrapping_mul(2654435761) % (max + 1)) as u16)
                .collect();
            let mut out = Vec::new();
            unpack_msb_first(&pack(&values, bits), bits, values.len(), &mut out);
            assert_eq!(out, values, "{bits} bits");
        }
    }

    #[test]
    fn active_area_crops_the_masked_borders() {
        let raw: Vec<u16> = (0..20).collect(); // 5 x 4
        let (w, h, inner) = crop_to_active_area(raw.clone(), 5, 4, 1, &[1, 2, 3, 5]).unwrap();
        assert_eq!((w, h, inner), (3, 2, vec![7, 8, 9, 12, 13, 14]));
        assert_eq!(
            crop_to_active_area(raw.clone(), 5, 4, 1, &[0, 0, 4, 5])
                .unwrap()
                .2,
            raw
        );
        for bad in [[2, 0, 2, 5], [0, 0, 5, 5], [0, 3, 4, 3]] {
            assert!(
                crop_to_active_area(raw.clone(), 5, 4, 1, &bad).is_err(),
                "{bad:?}"
            );
        }
        assert!(crop_to_active_area(raw, 5, 4, 1, &[0, 0, 4]).is_err());
    }
}
