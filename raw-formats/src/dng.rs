//! Raw DNG files: a writer for camsim's captures and a reader for uncompressed CFA DNGs.
//!
//! The writer makes a little-endian, single-strip, 16-bit uncompressed CFA DNG (version
//! 1.4) with the tags a raw converter needs: CFA pattern, black and white level, one or two
//! colour matrices with their calibration illuminants, and the as-shot neutral. LibRaw (rawpy)
//! reads these files; the oracle suite checks it.
//!
//! The reader takes what camsim writes and the common case of other writers: either byte
//! order, the raw image in IFD 0 or in a SubIFD (NewSubfileType 0), uncompressed samples of 8
//! to 16 bits in strips (narrower than 16 bits packed most significant bit first, each row
//! starting on a byte boundary), cropped to the ActiveArea so masked borders never reach the
//! image, a 2x2 CFA of R, G, B, black level as one value or one per 2x2 position. Compressed,
//! tiled or linear DNGs are refused with an error that says so. Every offset and count is
//! checked against the file, so a damaged file gives an error, never a panic.
//!
//! A file's colour tags are held as the file states them in [`DngColour`], which is also the
//! one place that converts them to and from isp-core's [`Calibration`].
//!
//! ```
//! use raw_formats::dng::{ColourCalibration, Dng, DngColour, Illuminant};
//! use raw_formats::RawImage;
//! use isp_core::CfaPattern;
//! let image = RawImage::new(4, 2, CfaPattern::Grbg, 10, [64; 4], 1023,
//!     (0..8).map(|i| 100 * i).collect()).unwrap();
//! let dng = Dng {
//!     image,
//!     camera_model: "camsim test".into(),
//!     colour: DngColour {
//!         calibrations: vec![ColourCalibration::new(
//!             Illuminant::D65,
//!             [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
//!         )],
//!         as_shot_neutral: Some([0.5, 1.0, 0.8]),
//!         ..DngColour::default()
//!     },
//! };
//! let bytes = dng.encode().unwrap();
//! assert_eq!(Dng::decode(&bytes).unwrap(), dng);
//! ```

use std::path::Path;

use isp_core::ccm::Calibration;
use isp_core::colour::{self, Mat3};
use isp_core::CfaPattern;

use crate::error::{FormatError, Result};
use crate::raw_image::RawImage;

/// A calibration illuminant by its EXIF LightSource code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Illuminant {
    /// Standard light A (code 17), 2856 K.
    A,
    /// D50 (code 23).
    D50,
    /// D55 (code 20).
    D55,
    /// D65 (code 21).
    D65,
    /// D75 (code 22).
    D75,
    /// Any other code, kept as read.
    Other(u16),
}

impl Illuminant {
    /// The EXIF LightSource code.
    pub fn code(self) -> u16 {
        match self {
            Illuminant::A => 17,
            Illuminant::D50 => 23,
            Illuminant::D55 => 20,
            Illuminant::D65 => 21,
            Illuminant::D75 => 22,
            Illuminant::Other(c) => c,
        }
    }

    /// From an EXIF LightSource code.
    pub fn from_code(code: u16) -> Self {
        match code {
            17 => Illuminant::A,
            23 => Illuminant::D50,
            20 => Illuminant::D55,
            21 => Illuminant::D65,
            22 => Illuminant::D75,
            c => Illuminant::Other(c),
        }
    }

    /// Correlated colour temperature in kelvin, for the codes that have one.
    pub fn cct_k(self) -> Option<f64> {
        match self {
            Illuminant::A => Some(2856.0),
            Illuminant::D50 => Some(5003.0),
            Illuminant::D55 => Some(5503.0),
            Illuminant::D65 => Some(6504.0),
            Illuminant::D75 => Some(7504.0),
            Illuminant::Other(_) => None,
        }
    }

    /// By the name the spectral tables and the command line use (`A`, `D50`, `D65`, ...).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "A" => Some(Illuminant::A),
            "D50" => Some(Illuminant::D50),
            "D55" => Some(Illuminant::D55),
            "D65" => Some(Illuminant::D65),
            "D75" => Some(Illuminant::D75),
            _ => None,
        }
    }
}

/// One of a DNG's (at most two) colour calibrations, as the file states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourCalibration {
    /// CalibrationIlluminant1/2.
    pub illuminant: Illuminant,
    /// ColorMatrix1/2: XYZ to reference camera RGB.
    pub color_matrix: Mat3,
    /// ForwardMatrix1/2 (white-balanced camera RGB to XYZ D50), if the file has it.
    pub forward_matrix: Option<Mat3>,
    /// CameraCalibration1/2 (reference to this individual camera), if the file has it.
    pub camera_calibration: Option<Mat3>,
}

impl ColourCalibration {
    /// A calibration with only a colour matrix.
    pub fn new(illuminant: Illuminant, color_matrix: Mat3) -> Self {
        Self {
            illuminant,
            color_matrix,
            forward_matrix: None,
            camera_calibration: None,
        }
    }

    /// The DNG ColorMatrix for a measured camera-to-XYZ matrix: its inverse (XYZ to camera),
    /// scaled so the calibration illuminant's white (`white_xyz`) has a largest camera channel
    /// of 1, Adobe's convention.
    pub fn from_camera_to_xyz(
        illuminant: Illuminant,
        camera_to_xyz: &Mat3,
        white_xyz: [f64; 3],
    ) -> Result<Self> {
        let xyz_to_camera =
            colour::mat3_inverse(camera_to_xyz).map_err(|source| FormatError::Colour {
                field: "camera-to-XYZ matrix",
                source,
            })?;
        let cam = colour::mat3_mul_vec(&xyz_to_camera, white_xyz);
        let peak = cam.iter().copied().fold(0.0, f64::max);
        let scaled = xyz_to_camera.map(|r| r.map(|v| v / peak.max(1e-12)));
        Ok(Self::new(illuminant, scaled))
    }
}

/// A camera's colour metadata as a DNG states it. [`DngColour::to_calibration`] is the one
/// conversion to isp-core's [`Calibration`]; [`ColourCalibration::from_camera_to_xyz`] the
/// one conversion from a measured matrix.
///
/// ForwardMatrix, CameraCalibration and AnalogBalance are read and written but not yet used
/// by [`DngColour::to_calibration`], which follows ColorMatrix alone.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DngColour {
    /// ColorMatrix1/2 with their illuminants (and the matrices that go with them), at most two.
    pub calibrations: Vec<ColourCalibration>,
    /// AnalogBalance, if the file has it.
    pub analog_balance: Option<[f64; 3]>,
    /// AsShotNeutral: the white balance as shot, the illuminant's colour in camera RGB.
    pub as_shot_neutral: Option<[f64; 3]>,
}

impl DngColour {
    /// isp-core's calibration from the colour matrices (each inverted to camera-to-XYZ, at its
    /// illuminant's temperature); `None` when the file has none. A single matrix is used at
    /// every temperature, whatever its illuminant (the DNG specification allows it without
    /// one); two need illuminants of known temperature to be interpolated.
    pub fn to_calibration(&self) -> Result<Option<Calibration>> {
        let to_xyz = |c: &ColourCalibration| {
            colour::mat3_inverse(&c.color_matrix).map_err(|source| FormatError::Colour {
                field: "ColorMatrix",
                source,
            })
        };
        let cct = |c: &ColourCalibration| {
            c.illuminant.cct_k().ok_or(FormatError::Unsupported {
                field: "calibration illuminant code",
                value: c.illuminant.code().to_string(),
                supported:
                    "with two colour matrices, A, D50, D55, D65 or D75 (a known temperature)",
            })
        };
        let calibration = match self.calibrations.as_slice() {
            [] => return Ok(None),
            // One matrix holds at every temperature; the temperature only labels it.
            [c] => Calibration::single(c.illuminant.cct_k().unwrap_or(6504.0), to_xyz(c)?),
            [a, b] => Calibration::new([cct(a)?, cct(b)?], [to_xyz(a)?, to_xyz(b)?]),
            _ => return Ok(None),
        };
        calibration.map(Some).map_err(|source| FormatError::Colour {
            field: "colour matrices",
            source,
        })
    }

    /// White-balance gains (green 1) from the as-shot neutral.
    pub fn as_shot_gains(&self) -> Option<[f32; 3]> {
        self.as_shot_neutral
            .map(|n| [(n[1] / n[0]) as f32, 1.0, (n[1] / n[2]) as f32])
    }
}

/// A raw CFA frame with its colour metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Dng {
    /// The raw frame (size, pattern, levels, samples).
    pub image: RawImage,
    /// Make/model text (UniqueCameraModel).
    pub camera_model: String,
    /// Colour tags.
    pub colour: DngColour,
}

// Tags, by number (TIFF 6.0 and DNG 1.4).
const NEW_SUBFILE_TYPE: u16 = 254;
const IMAGE_WIDTH: u16 = 256;
const IMAGE_LENGTH: u16 = 257;
const BITS_PER_SAMPLE: u16 = 258;
const COMPRESSION: u16 = 259;
const PHOTOMETRIC: u16 = 262;
const MAKE: u16 = 271;
const MODEL: u16 = 272;
const STRIP_OFFSETS: u16 = 273;
const ORIENTATION: u16 = 274;
const SAMPLES_PER_PIXEL: u16 = 277;
const ROWS_PER_STRIP: u16 = 278;
const STRIP_BYTE_COUNTS: u16 = 279;
const PLANAR_CONFIGURATION: u16 = 284;
const SOFTWARE: u16 = 305;
const TILE_WIDTH: u16 = 322;
const SUB_IFDS: u16 = 330;
const CFA_REPEAT_PATTERN_DIM: u16 = 33421;
const CFA_PATTERN: u16 = 33422;
const DNG_VERSION: u16 = 50706;
const DNG_BACKWARD_VERSION: u16 = 50707;
const UNIQUE_CAMERA_MODEL: u16 = 50708;
const BLACK_LEVEL_REPEAT_DIM: u16 = 50713;
const BLACK_LEVEL: u16 = 50714;
const WHITE_LEVEL: u16 = 50717;
const ACTIVE_AREA: u16 = 50829;
const COLOR_MATRIX_1: u16 = 50721;
const COLOR_MATRIX_2: u16 = 50722;
const CAMERA_CALIBRATION_1: u16 = 50723;
const CAMERA_CALIBRATION_2: u16 = 50724;
const ANALOG_BALANCE: u16 = 50727;
const AS_SHOT_NEUTRAL: u16 = 50728;
const CALIBRATION_ILLUMINANT_1: u16 = 50778;
const CALIBRATION_ILLUMINANT_2: u16 = 50779;
const FORWARD_MATRIX_1: u16 = 50964;
const FORWARD_MATRIX_2: u16 = 50965;

const CFA_PHOTOMETRIC: u32 = 32803;

// Field types.
const BYTE: u16 = 1;
const ASCII: u16 = 2;
const SHORT: u16 = 3;
const LONG: u16 = 4;
const RATIONAL: u16 = 5;
const SRATIONAL: u16 = 10;

fn type_size(t: u16) -> Option<usize> {
    match t {
        1 | 2 | 6 | 7 => Some(1),
        3 | 8 => Some(2),
        4 | 9 | 11 | 13 => Some(4),
        5 | 10 | 12 => Some(8),
        _ => None,
    }
}

/// An entry to write: tag, type, count and its bytes (little-endian).
struct Entry {
    tag: u16,
    kind: u16,
    count: u32,
    bytes: Vec<u8>,
}

fn short(tag: u16, values: &[u16]) -> Entry {
    Entry {
        tag,
        kind: SHORT,
        count: values.len() as u32,
        bytes: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

fn long(tag: u16, values: &[u32]) -> Entry {
    Entry {
        tag,
        kind: LONG,
        count: values.len() as u32,
        bytes: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

fn bytes(tag: u16, values: &[u8]) -> Entry {
    Entry {
        tag,
        kind: BYTE,
        count: values.len() as u32,
        bytes: values.to_vec(),
    }
}

fn ascii(tag: u16, text: &str) -> Entry {
    let mut b: Vec<u8> = text.bytes().filter(|c| *c != 0).collect();
    b.push(0);
    Entry {
        tag,
        kind: ASCII,
        count: b.len() as u32,
        bytes: b,
    }
}

/// Rationals with denominator 10000 (four decimals, as Adobe's DNG files carry).
fn srational(tag: u16, values: &[f64]) -> Entry {
    Entry {
        tag,
        kind: SRATIONAL,
        count: values.len() as u32,
        bytes: values
            .iter()
            .flat_map(|v| {
                let n = (v * 10000.0)
                    .round()
                    .clamp(i32::MIN as f64, i32::MAX as f64) as i32;
                [n.to_le_bytes(), 10000i32.to_le_bytes()].concat()
            })
            .collect(),
    }
}

fn rational(tag: u16, values: &[f64]) -> Entry {
    Entry {
        tag,
        kind: RATIONAL,
        count: values.len() as u32,
        bytes: values
            .iter()
            .flat_map(|v| {
                let n = (v * 1e6).round().clamp(0.0, u32::MAX as f64) as u32;
                [n.to_le_bytes(), 1_000_000u32.to_le_bytes()].concat()
            })
            .collect(),
    }
}

/// The CFA colour codes (0 red, 1 green, 2 blue) of a pattern's 2x2 block, row by row.
fn cfa_codes(pattern: CfaPattern) -> [u8; 4] {
    std::array::from_fn(|p| pattern.colour_at(p % 2, p / 2).index() as u8)
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
        Ok(())
    }

    /// The file's bytes.
    pub fn encode(&self) -> Result<Vec<u8>> {
        self.check()?;
        let (w, h) = (self.image.width as u32, self.image.height as u32);
        let strip_bytes = w as usize * h as usize * 2;
        let model = if self.camera_model.is_empty() {
            "camsim"
        } else {
            &self.camera_model
        };
        let mut entries = vec![
            long(NEW_SUBFILE_TYPE, &[0]),
            long(IMAGE_WIDTH, &[w]),
            long(IMAGE_LENGTH, &[h]),
            short(BITS_PER_SAMPLE, &[16]),
            short(COMPRESSION, &[1]),
            short(PHOTOMETRIC, &[CFA_PHOTOMETRIC as u16]),
            ascii(MAKE, "camsim"),
            ascii(MODEL, model),
            long(STRIP_OFFSETS, &[0]), // patched below
            short(ORIENTATION, &[1]),
            short(SAMPLES_PER_PIXEL, &[1]),
            long(ROWS_PER_STRIP, &[h]),
            long(STRIP_BYTE_COUNTS, &[strip_bytes as u32]),
            short(PLANAR_CONFIGURATION, &[1]),
            ascii(SOFTWARE, concat!("camsim ", env!("CARGO_PKG_VERSION"))),
            short(CFA_REPEAT_PATTERN_DIM, &[2, 2]),
            bytes(CFA_PATTERN, &cfa_codes(self.image.pattern)),
            bytes(DNG_VERSION, &[1, 4, 0, 0]),
            bytes(DNG_BACKWARD_VERSION, &[1, 1, 0, 0]),
            ascii(UNIQUE_CAMERA_MODEL, model),
        ];
        let black = self.image.black_level;
        if black.iter().all(|b| *b == black[0]) {
            entries.push(short(BLACK_LEVEL, &[black[0]]));
        } else {
            entries.push(short(BLACK_LEVEL_REPEAT_DIM, &[2, 2]));
            entries.push(short(BLACK_LEVEL, &black));
        }
        entries.push(short(WHITE_LEVEL, &[self.image.white_level]));
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
        entries.sort_by_key(|e| e.tag);

        // Layout: header, IFD, out-of-line values, then the strip.
        let ifd_len = 2 + 12 * entries.len() + 4;
        let mut out = Vec::with_capacity(8 + ifd_len + 256 + strip_bytes);
        out.extend_from_slice(b"II*\0");
        out.extend_from_slice(&8u32.to_le_bytes());
        let mut extra_offset = 8 + ifd_len;
        let extra_len: usize = entries
            .iter()
            .filter(|e| e.bytes.len() > 4)
            .map(|e| e.bytes.len().next_multiple_of(2))
            .sum();
        let strip_offset = (extra_offset + extra_len) as u32;
        for e in entries.iter_mut() {
            if e.tag == STRIP_OFFSETS {
                e.bytes = strip_offset.to_le_bytes().to_vec();
            }
        }
        out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        let mut extra = Vec::with_capacity(extra_len);
        for e in &entries {
            out.extend_from_slice(&e.tag.to_le_bytes());
            out.extend_from_slice(&e.kind.to_le_bytes());
            out.extend_from_slice(&e.count.to_le_bytes());
            if e.bytes.len() <= 4 {
                let mut inline = [0u8; 4];
                inline[..e.bytes.len()].copy_from_slice(&e.bytes);
                out.extend_from_slice(&inline);
            } else {
                out.extend_from_slice(&(extra_offset as u32).to_le_bytes());
                extra.extend_from_slice(&e.bytes);
                if e.bytes.len() % 2 == 1 {
                    extra.push(0);
                }
                extra_offset += e.bytes.len().next_multiple_of(2);
            }
        }
        out.extend_from_slice(&0u32.to_le_bytes()); // no next IFD
        out.extend_from_slice(&extra);
        debug_assert_eq!(out.len(), strip_offset as usize);
        for v in &self.image.samples {
            out.extend_from_slice(&v.to_le_bytes());
        }
        Ok(out)
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.encode().map_err(|e| e.in_file(path))?;
        std::fs::write(path, bytes).map_err(|e| FormatError::io(path, e))
    }

    /// Reads a file.
    pub fn read(path: &Path) -> Result<Dng> {
        let data = std::fs::read(path).map_err(|e| FormatError::io(path, e))?;
        Dng::decode(&data).map_err(|e| e.in_file(path))
    }

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
        if file.is_cfa_raw(&ifd0)? {
            raw_ifd = Some(ifd0.clone());
        } else if let Some(sub) = ifd0.get(SUB_IFDS) {
            for offset in file.values(sub)?.into_iter().take(16) {
                let ifd = file.ifd(offset as usize)?;
                if file.is_cfa_raw(&ifd)? {
                    raw_ifd = Some(ifd);
                    break;
                }
            }
        }
        let raw_ifd = raw_ifd.ok_or(FormatError::NoCfaImage)?;
        file.read_raw(&raw_ifd, &ifd0)
    }
}

/// A parsed IFD: entries as (tag, type, count, value-or-offset field position).
#[derive(Debug, Clone)]
struct Ifd {
    entries: Vec<(u16, u16, u32, usize)>,
}

impl Ifd {
    fn get(&self, tag: u16) -> Option<(u16, u32, usize)> {
        self.entries
            .iter()
            .find(|e| e.0 == tag)
            .map(|&(_, t, c, p)| (t, c, p))
    }
}

struct Tiff<'a> {
    data: &'a [u8],
    little: bool,
}

impl<'a> Tiff<'a> {
    fn new(data: &'a [u8]) -> Result<Self> {
        let little = match data.get(..4) {
            Some(b"II*\0") => true,
            Some(b"MM\0*") => false,
            _ => {
                return Err(FormatError::NotFormat {
                    format: "TIFF/DNG",
                    reason: "bad header",
                })
            }
        };
        Ok(Self { data, little })
    }

    fn bytes(&self, at: usize, n: usize) -> Result<&'a [u8]> {
        at.checked_add(n)
            .and_then(|end| self.data.get(at..end))
            .ok_or(FormatError::Truncated { offset: at, len: n })
    }

    fn array<const N: usize>(&self, at: usize) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        b.copy_from_slice(self.bytes(at, N)?);
        Ok(b)
    }

    fn u16_at(&self, at: usize) -> Result<u16> {
        let b: [u8; 2] = self.array(at)?;
        Ok(if self.little {
            u16::from_le_bytes(b)
        } else {
            u16::from_be_bytes(b)
        })
    }

    fn u32_at(&self, at: usize) -> Result<u32> {
        let b: [u8; 4] = self.array(at)?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn ifd(&self, at: usize) -> Result<Ifd> {
        let n = self.u16_at(at)? as usize;
        let mut entries = Vec::with_capacity(n);
        for i in 0..n {
            let p = at + 2 + 12 * i;
            entries.push((
                self.u16_at(p)?,
                self.u16_at(p + 2)?,
                self.u32_at(p + 4)?,
                p + 8,
            ));
        }
        Ok(Ifd { entries })
    }

    /// Where an entry's values start.
    fn value_offset(&self, kind: u16, count: u32, field: usize) -> Result<(usize, usize)> {
        let size = type_size(kind).ok_or(FormatError::FieldType { field_type: kind })?;
        let len = size
            .checked_mul(count as usize)
            .ok_or(FormatError::FieldTooLong { count })?;
        let at = if len <= 4 {
            field
        } else {
            self.u32_at(field)? as usize
        };
        self.bytes(at, len)?;
        Ok((at, size))
    }

    /// An entry's values as numbers (integers; rationals as numerator/denominator).
    fn numbers(&self, entry: (u16, u32, usize)) -> Result<Vec<f64>> {
        let (kind, count, field) = entry;
        if count > 1 << 24 {
            return Err(FormatError::FieldTooLong { count });
        }
        let (at, size) = self.value_offset(kind, count, field)?;
        (0..count as usize)
            .map(|i| {
                let p = at + i * size;
                Ok(match kind {
                    BYTE | 7 => self.data[p] as f64,
                    6 => self.data[p] as i8 as f64,
                    SHORT => self.u16_at(p)? as f64,
                    8 => self.u16_at(p)? as i16 as f64,
                    LONG | 13 => self.u32_at(p)? as f64,
                    9 => self.u32_at(p)? as i32 as f64,
                    RATIONAL => self.u32_at(p)? as f64 / self.u32_at(p + 4)? as f64,
                    SRATIONAL => self.u32_at(p)? as i32 as f64 / self.u32_at(p + 4)? as i32 as f64,
                    11 => f32::from_bits(self.u32_at(p)?) as f64,
                    _ => return Err(FormatError::FieldType { field_type: kind }),
                })
            })
            .collect()
    }

    fn values(&self, entry: (u16, u32, usize)) -> Result<Vec<u32>> {
        Ok(self
            .numbers(entry)?
            .into_iter()
            .map(|v| v.clamp(0.0, u32::MAX as f64) as u32)
            .collect())
    }

    fn one(&self, ifd: &Ifd, tag: u16, name: &'static str) -> Result<u32> {
        let missing = FormatError::Missing {
            field: name,
            tag: Some(tag),
        };
        let entry = ifd.get(tag).ok_or(missing)?;
        self.values(entry)?
            .first()
            .copied()
            .ok_or(FormatError::Missing {
                field: name,
                tag: Some(tag),
            })
    }

    /// The entry `tag`, which must be present.
    fn required(ifd: &Ifd, tag: u16, name: &'static str) -> Result<(u16, u32, usize)> {
        ifd.get(tag).ok_or(FormatError::Missing {
            field: name,
            tag: Some(tag),
        })
    }

    fn text(&self, ifd: &Ifd, tag: u16) -> Option<String> {
        let (kind, count, field) = ifd.get(tag)?;
        if kind != ASCII {
            return None;
        }
        let (at, _) = self.value_offset(kind, count, field).ok()?;
        let b = &self.data[at..at + count as usize];
        let end = b.iter().position(|c| *c == 0).unwrap_or(b.len());
        Some(String::from_utf8_lossy(&b[..end]).into_owned())
    }

    fn is_cfa_raw(&self, ifd: &Ifd) -> Result<bool> {
        let subfile = ifd
            .get(NEW_SUBFILE_TYPE)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied())
            .unwrap_or(0);
        let photometric = ifd
            .get(PHOTOMETRIC)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied());
        Ok(subfile == 0 && photometric == Some(CFA_PHOTOMETRIC))
    }

    fn read_raw(&self, ifd: &Ifd, ifd0: &Ifd) -> Result<Dng> {
        let width = self.one(ifd, IMAGE_WIDTH, "ImageWidth")? as usize;
        let height = self.one(ifd, IMAGE_LENGTH, "ImageLength")? as usize;
        if width == 0 || height == 0 || width > 65535 || height > 65535 {
            return Err(FormatError::OutOfRange {
                field: "image size",
                value: format!("{width} x {height}"),
                allowed: "1..=65535".into(),
            });
        }
        let bits = self.one(ifd, BITS_PER_SAMPLE, "BitsPerSample")?;
        if !(8..=16).contains(&bits) {
            return Err(FormatError::SampleBits { bits });
        }
        let compression = ifd
            .get(COMPRESSION)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied())
            .unwrap_or(1);
        if compression != 1 {
            return Err(FormatError::Compression { value: compression });
        }
        if ifd.get(TILE_WIDTH).is_some() {
            return Err(FormatError::Tiled);
        }
        let samples = ifd
            .get(SAMPLES_PER_PIXEL)
            .map(|e| self.values(e))
            .transpose()?
            .and_then(|v| v.first().copied())
            .unwrap_or(1);
        if samples != 1 {
            return Err(FormatError::Unsupported {
                field: "SamplesPerPixel",
                value: samples.to_string(),
                supported: "a CFA image has 1",
            });
        }
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
        let pattern = [
            CfaPattern::Rggb,
            CfaPattern::Bggr,
            CfaPattern::Grbg,
            CfaPattern::Gbrg,
        ]
        .into_iter()
        .find(|p| {
            cfa_codes(*p)
                .iter()
                .map(|c| *c as u32)
                .eq(codes.iter().copied())
        })
        .ok_or(FormatError::Unsupported {
            field: "CFAPattern",
            value: format!("{codes:?}"),
            supported: "a Bayer pattern of R (0), G (1), B (2)",
        })?;

        let offsets = self.values(Self::required(ifd, STRIP_OFFSETS, "StripOffsets")?)?;
        let counts = self.values(Self::required(ifd, STRIP_BYTE_COUNTS, "StripByteCounts")?)?;
        if offsets.len() != counts.len() {
            return Err(FormatError::SizeMismatch {
                what: "StripByteCounts entries (one per StripOffsets entry)",
                found: counts.len(),
                expected: offsets.len(),
            });
        }
        // Rows start on a byte boundary; samples narrower than 16 bits are packed most
        // significant bit first whatever the byte order (TIFF 6.0, DNG 1.4 "Data packing").
        let row_bytes = (width * bits as usize).div_ceil(8);
        let needed = row_bytes * height;
        // Capacity bounded by the file: a damaged size cannot ask for gigabytes.
        let mut pixels = Vec::with_capacity(needed.min(self.data.len()));
        for (o, c) in offsets.iter().zip(&counts) {
            pixels.extend_from_slice(self.bytes(*o as usize, *c as usize)?);
            if pixels.len() >= needed {
                break;
            }
        }
        if pixels.len() < needed {
            return Err(FormatError::SizeMismatch {
                what: "strip bytes",
                found: pixels.len(),
                expected: needed,
            });
        }
        let mut raw = Vec::with_capacity(width * height);
        for row in pixels[..needed].chunks_exact(row_bytes) {
            match bits {
                8 => raw.extend(row.iter().map(|v| *v as u16)),
                16 => raw.extend(row.chunks_exact(2).map(|b| {
                    if self.little {
                        u16::from_le_bytes([b[0], b[1]])
                    } else {
                        u16::from_be_bytes([b[0], b[1]])
                    }
                })),
                _ => unpack_msb_first(row, bits, width, &mut raw),
            }
        }
        let (width, height, raw) = match ifd.get(ACTIVE_AREA) {
            Some(e) => {
                let area = self.values(e)?;
                crop_to_active_area(raw, width, height, &area)?
            }
            None => (width, height, raw),
        };

        let max = ((1u32 << bits) - 1) as u16;
        let white = match ifd.get(WHITE_LEVEL) {
            Some(e) => self
                .numbers(e)?
                .first()
                .copied()
                .ok_or(FormatError::Missing {
                    field: "WhiteLevel",
                    tag: Some(WHITE_LEVEL),
                })?,
            None => max as f64,
        };
        let black_values = match ifd.get(BLACK_LEVEL) {
            Some(e) => self.numbers(e)?,
            None => vec![0.0],
        };
        let black: [f64; 4] = match black_values.len() {
            1 => [black_values[0]; 4],
            4 => std::array::from_fn(|i| black_values[i]),
            n => {
                return Err(FormatError::Unsupported {
                    field: "BlackLevel value count",
                    value: n.to_string(),
                    supported: "1, or 4 for a 2x2 repeat",
                })
            }
        };
        let level = |v: f64, field: &'static str| -> Result<u16> {
            if v.is_finite() && (0.0..=max as f64).contains(&v) {
                Ok(v.round() as u16)
            } else {
                Err(FormatError::OutOfRange {
                    field,
                    value: v.to_string(),
                    allowed: format!("0..={max}"),
                })
            }
        };
        let white_level = level(white, "WhiteLevel")?;
        let mut black_level = [0u16; 4];
        for (b, v) in black_level.iter_mut().zip(black) {
            *b = level(v, "BlackLevel")?;
        }
        // The significant bits: those the white level needs (8 at least).
        let significant = (16 - white_level.leading_zeros()).clamp(8, 16) as u8;
        let image = RawImage::new(
            width,
            height,
            pattern,
            significant,
            black_level,
            white_level,
            raw,
        )?;

        // Colour tags live in IFD 0.
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
                let illuminant = ifd0
                    .get(tags.illuminant)
                    .map(|e| self.values(e))
                    .transpose()?
                    .and_then(|v| v.first().copied())
                    .unwrap_or(0);
                calibrations.push(ColourCalibration {
                    illuminant: Illuminant::from_code(illuminant as u16),
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
        let colour = DngColour {
            calibrations,
            analog_balance: triple(ANALOG_BALANCE, "AnalogBalance")?,
            as_shot_neutral: triple(AS_SHOT_NEUTRAL, "AsShotNeutral")?,
        };
        let camera_model = self
            .text(ifd0, UNIQUE_CAMERA_MODEL)
            .or_else(|| self.text(ifd0, MODEL))
            .unwrap_or_default();
        Ok(Dng {
            image,
            camera_model,
            colour,
        })
    }
}

/// Appends `width` samples of `bits` bits (9..=15), packed most significant bit first, from one
/// row's bytes (which hold at least `width * bits` bits).
fn unpack_msb_first(row: &[u8], bits: u32, width: usize, out: &mut Vec<u16>) {
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
    let mut out = Vec::with_capacity(w * h);
    for row in raw.chunks_exact(width).skip(top).take(h) {
        out.extend_from_slice(&row[left..right]);
    }
    Ok((w, h, out))
}

/// The tags of calibration 1 and 2.
struct CalibrationTags {
    color_matrix: u16,
    illuminant: u16,
    forward_matrix: u16,
    camera_calibration: u16,
}

const CALIBRATION_TAGS: [CalibrationTags; 2] = [
    CalibrationTags {
        color_matrix: COLOR_MATRIX_1,
        illuminant: CALIBRATION_ILLUMINANT_1,
        forward_matrix: FORWARD_MATRIX_1,
        camera_calibration: CAMERA_CALIBRATION_1,
    },
    CalibrationTags {
        color_matrix: COLOR_MATRIX_2,
        illuminant: CALIBRATION_ILLUMINANT_2,
        forward_matrix: FORWARD_MATRIX_2,
        camera_calibration: CAMERA_CALIBRATION_2,
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Dng {
        Dng {
            image: RawImage::new(
                5,
                3,
                CfaPattern::Bggr,
                12,
                [10, 11, 12, 13],
                4095,
                (0..15).map(|i| i * 200).collect(),
            )
            .unwrap(),
            camera_model: "camsim nikon-5100".into(),
            colour: DngColour {
                calibrations: vec![
                    ColourCalibration::new(
                        Illuminant::A,
                        [[0.9, -0.2, 0.1], [-0.3, 1.2, 0.05], [0.0, 0.1, 0.7]],
                    ),
                    ColourCalibration::new(
                        Illuminant::D65,
                        [[1.1, -0.4, 0.0], [-0.5, 1.3, 0.2], [-0.1, 0.2, 0.9]],
                    ),
                ],
                as_shot_neutral: Some([0.45, 1.0, 0.7]),
                ..DngColour::default()
            },
        }
    }

    #[test]
    fn round_trip() {
        let d = sample();
        let bytes = d.encode().unwrap();
        let back = Dng::decode(&bytes).unwrap();
        assert_eq!(back.image, d.image);
        let c = &back.colour.calibrations[1];
        assert_eq!(c.illuminant, Illuminant::D65);
        assert!((c.color_matrix[1][1] - 1.3).abs() < 1e-4);
        assert!((back.colour.as_shot_neutral.unwrap()[0] - 0.45).abs() < 1e-6);
    }

    #[test]
    fn forward_matrix_camera_calibration_and_analog_balance_round_trip() {
        let mut d = sample();
        let m = [[0.5, 0.25, 0.125], [0.0, 1.0, 0.0], [0.1, 0.2, 0.7]];
        d.colour.calibrations[0].forward_matrix = Some(m);
        d.colour.calibrations[1].camera_calibration = Some(m);
        d.colour.analog_balance = Some([1.0, 0.5, 1.0]);
        let back = Dng::decode(&d.encode().unwrap()).unwrap();
        assert_eq!(back.colour, d.colour);
    }

    #[test]
    fn a_neutral_the_file_cannot_hold_is_refused_not_written() {
        // Found by the damaged-DNG fuzz body: a neutral of 1e-7 was written as 0 / 1e6,
        // which the reader then refused.
        let mut d = sample();
        d.colour.as_shot_neutral = Some([1e-7, 1.0, 0.7]);
        assert!(matches!(
            d.encode().unwrap_err(),
            FormatError::OutOfRange {
                field: "as-shot neutral",
                ..
            }
        ));
        d.colour.as_shot_neutral = Some([0.5, 5000.0, 0.7]);
        assert!(d.encode().is_err());
        d.colour.as_shot_neutral = Some([1e-6, 4294.0, 0.7]);
        let back = Dng::decode(&d.encode().unwrap()).unwrap();
        assert_eq!(back.colour.as_shot_neutral, Some([1e-6, 4294.0, 0.7]));
    }

    #[test]
    fn colour_converts_to_a_calibration_and_back() {
        let m = isp_core::colour::LINEAR_SRGB_TO_XYZ;
        let white = colour::xy_to_xyz(colour::D65_XY).unwrap();
        let c = ColourCalibration::from_camera_to_xyz(Illuminant::D65, &m, white).unwrap();
        // Adobe's scale: the illuminant's white has a largest camera channel of 1.
        let cam = colour::mat3_mul_vec(&c.color_matrix, white);
        assert!((cam.iter().copied().fold(0.0, f64::max) - 1.0).abs() < 1e-12);
        let colour = DngColour {
            calibrations: vec![c],
            as_shot_neutral: Some([0.5, 1.0, 0.8]),
            ..DngColour::default()
        };
        assert_eq!(colour.as_shot_gains(), Some([2.0, 1.0, 1.25]));
        let cal = colour.to_calibration().unwrap().unwrap();
        // The scale does not change the colour: the CCM for neutral gains is the identity.
        let ccm = cal.ccm(6504.0, [1.0; 3]).unwrap();
        for (i, row) in ccm.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 2e-3, "{ccm:?}");
            }
        }
        // One matrix without a known illuminant is used as is; two need temperatures.
        let unknown =
            ColourCalibration::new(Illuminant::Other(0), colour.calibrations[0].color_matrix);
        let single = DngColour {
            calibrations: vec![unknown],
            ..DngColour::default()
        };
        assert_eq!(single.to_calibration().unwrap(), Some(cal));
        let two = DngColour {
            calibrations: vec![unknown, colour.calibrations[0]],
            ..DngColour::default()
        };
        assert!(two.to_calibration().is_err());
        assert_eq!(DngColour::default().to_calibration().unwrap(), None);
    }

    /// Packs `values` of `bits` bits most significant bit first, as DNG writers do.
    fn pack(values: &[u16], bits: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let (mut acc, mut held) = (0u64, 0u32);
        for v in values {
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
        let (w, h, inner) = crop_to_active_area(raw.clone(), 5, 4, &[1, 2, 3, 5]).unwrap();
        assert_eq!((w, h, inner), (3, 2, vec![7, 8, 9, 12, 13, 14]));
        assert_eq!(
            crop_to_active_area(raw.clone(), 5, 4, &[0, 0, 4, 5])
                .unwrap()
                .2,
            raw
        );
        for bad in [[2, 0, 2, 5], [0, 0, 5, 5], [0, 3, 4, 3]] {
            assert!(
                crop_to_active_area(raw.clone(), 5, 4, &bad).is_err(),
                "{bad:?}"
            );
        }
        assert!(crop_to_active_area(raw, 5, 4, &[0, 0, 4]).is_err());
    }

    #[test]
    fn every_truncation_is_an_error() {
        let bytes = sample().encode().unwrap();
        for n in 0..bytes.len() {
            assert!(Dng::decode(&bytes[..n]).is_err(), "{n}");
        }
    }

    #[test]
    fn damaged_bytes_never_panic() {
        let bytes = sample().encode().unwrap();
        // A small xorshift: this crate has no random-number dependency.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..20000 {
            let mut b = bytes.clone();
            for _ in 0..1 + next() % 4 {
                let i = next() as usize % b.len();
                b[i] = next() as u8;
            }
            let _ = Dng::decode(&b);
        }
    }
}
