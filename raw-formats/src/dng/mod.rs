//! Raw DNG files: a reader for camera DNGs and a writer for camsim's captures.
//!
//! The reader ([`Dng::decode`]) follows the DNG 1.4 specification for raws: either byte
//! order; the raw image in IFD 0 or any SubIFD (NewSubfileType 0); a 2x2 CFA of R, G, B
//! (PhotometricInterpretation 32803) or LinearRaw (34892: already demosaiced, three samples per
//! pixel, which [`RawImage`] holds as a linear frame); samples of 8 to 16 bits, uncompressed
//! (narrower than 16 bits packed most significant bit first, rows starting on a byte
//! boundary), lossless JPEG (Compression 7, [`crate::lossless_jpeg`]) or lossy JPEG (34892,
//! 8-bit baseline, decoded by `jpeg-decoder`); strips or tiles (edge tiles padded);
//! LinearizationTable; BlackLevel with any BlackLevelRepeatDim (per sample for LinearRaw) and
//! BlackLevelDeltaH/V; WhiteLevel; ActiveArea (masked borders never reach the image);
//! OpcodeList2's MapTable and MapPolynomial, applied to the samples on the list's
//! black-to-white 0..=65535 scale (Adobe's lossy DNGs map their JPEG codes to linear so).
//! DefaultCrop and Orientation are read into [`Framing`] for the developer to apply to its
//! output. Anything else (other compressions, monochrome or planar LinearRaw, non-Bayer CFAs)
//! is refused with an error naming the tag and its value. Every offset and count is checked
//! against the file, and every buffer is sized only after the file has been shown to hold
//! enough bytes for it, so a damaged file gives an error, never a panic or a huge allocation.
//!
//! The writer ([`Dng::encode`], [`Dng::encode_with`]) makes a CFA or LinearRaw DNG (version
//! 1.4) in either byte order, uncompressed at 8 to 16 bits, lossless-JPEG or (8-bit samples)
//! lossy-JPEG compressed, in one strip or in tiles, with the tags a raw converter needs: CFA pattern, black and white level, one or two
//! colour matrices with their calibration illuminants, the as-shot neutral, and the framing.
//! LibRaw (rawpy) reads these files; the oracle suite checks it.
//!
//! A file's colour tags are held as the file states them in [`DngColour`], which is also the
//! one place that converts them to and from isp-core's [`Calibration`].
//!
//! ```
//! use raw_formats::dng::{ColourCalibration, Dng, DngColour, EncodeOptions, Illuminant, Storage};
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
//!     framing: Default::default(),
//!     processing: Default::default(),
//! };
//! let bytes = dng.encode().unwrap();
//! assert_eq!(Dng::decode(&bytes).unwrap(), dng);
//! let compressed = EncodeOptions { storage: Storage::LosslessJpeg { components: 2, predictor: 1 },
//!     ..EncodeOptions::default() };
//! assert_eq!(Dng::decode(&dng.encode_with(&compressed).unwrap()).unwrap(), dng);
//! ```

use std::path::Path;

use isp_core::ccm::Calibration;
use isp_core::colour::{self, Mat3};
use isp_core::CfaPattern;

use crate::error::{FormatError, Result};
pub use crate::framing::{Crop, Orientation};
use crate::raw_image::RawImage;

pub mod opcodes;
mod read;
mod tiff;
pub(crate) mod write;

use tags::*;
pub use write::{EncodeOptions, Storage};

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

    /// Correlated colour temperature in kelvin, for the codes that have one: the CIE
    /// illuminants' own (A, B, C, D50..D75), and for EXIF 2.3's descriptive light sources a
    /// nominal value, as raw converters assign them (daylight, flash and fine weather 5500 K,
    /// cloudy 6500 K, shade 7500 K, tungsten 2850 K, ISO studio tungsten 3200 K; each
    /// fluorescent class the middle of its JIS Z 9112 range). `None` for unknown (0), other
    /// (255) and unassigned codes.
    pub fn cct_k(self) -> Option<f64> {
        match self {
            Illuminant::A => Some(2856.0),
            Illuminant::D50 => Some(5003.0),
            Illuminant::D55 => Some(5503.0),
            Illuminant::D65 => Some(6504.0),
            Illuminant::D75 => Some(7504.0),
            Illuminant::Other(code) => match code {
                1 | 4 | 9 => Some(5500.0),
                3 => Some(2850.0),
                10 => Some(6500.0),
                11 => Some(7500.0),
                // Daylight (D), day white (N), cool white (W), white (WW), warm white (L).
                12 => Some((5700.0 + 7100.0) / 2.0),
                13 => Some((4600.0 + 5500.0) / 2.0),
                2 | 14 => Some((3900.0 + 4500.0) / 2.0),
                15 => Some((3200.0 + 3700.0) / 2.0),
                16 => Some((2600.0 + 3250.0) / 2.0),
                18 => Some(4874.0),
                19 => Some(6774.0),
                24 => Some(3200.0),
                _ => None,
            },
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
/// conversion to isp-core's [`Calibration`], which combines the tags as the DNG
/// specification's "Mapping Camera Color Space to CIE XYZ Space" says;
/// [`ColourCalibration::from_camera_to_xyz`] the one conversion from a measured matrix.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DngColour {
    /// ColorMatrix1/2 with their illuminants (and the matrices that go with them), at most two.
    pub calibrations: Vec<ColourCalibration>,
    /// AnalogBalance, if the file has it.
    pub analog_balance: Option<[f64; 3]>,
    /// AsShotNeutral: the white balance as shot, the illuminant's colour in camera RGB.
    pub as_shot_neutral: Option<[f64; 3]>,
    /// AsShotWhiteXY: the white balance as shot, as a chromaticity (the alternative to
    /// AsShotNeutral).
    pub as_shot_white_xy: Option<[f64; 2]>,
}

impl DngColour {
    /// isp-core's calibration from the colour tags; `None` when the file has no ColorMatrix.
    /// Two calibrations under illuminants of known, distinct temperatures are interpolated;
    /// otherwise the first is used at every temperature, whatever its illuminant (the DNG
    /// specification allows a profile without one). CameraCalibration defaults to identity,
    /// AnalogBalance to ones; ForwardMatrix is used when every calibration used has one.
    pub fn to_calibration(&self) -> Result<Option<Calibration>> {
        let colour_error =
            |field: &'static str| move |source| FormatError::Colour { field, source };
        let temperatures = match self.calibrations.as_slice() {
            [a, b] => match (a.illuminant.cct_k(), b.illuminant.cct_k()) {
                (Some(ta), Some(tb)) if ta != tb => Some([ta, tb]),
                _ => None,
            },
            _ => None,
        };
        let (first, used) = match (self.calibrations.as_slice(), temperatures) {
            ([], _) => return Ok(None),
            ([a, b], Some(_)) => (a, [a, b]),
            ([a, ..], _) => (a, [a, a]),
        };
        let mut calibration = match temperatures {
            Some(t) => Calibration::from_color_matrices(t, used.map(|c| c.color_matrix)),
            // One matrix holds at every temperature; the temperature only labels it.
            None => Calibration::from_color_matrix(
                first.illuminant.cct_k().unwrap_or(6504.0),
                first.color_matrix,
            ),
        }
        .map_err(colour_error("ColorMatrix"))?;
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        calibration = calibration
            .with_camera_calibration(used.map(|c| c.camera_calibration.unwrap_or(identity)))
            .map_err(colour_error("CameraCalibration"))?;
        if let [Some(a), Some(b)] = used.map(|c| c.forward_matrix) {
            calibration = calibration
                .with_forward_matrices([a, b])
                .map_err(colour_error("ForwardMatrix"))?;
        }
        if let Some(balance) = self.analog_balance {
            calibration = calibration
                .with_analog_balance(balance)
                .map_err(colour_error("AnalogBalance"))?;
        }
        Ok(Some(calibration))
    }

    /// White-balance gains (green 1) as shot: from AsShotNeutral, else from AsShotWhiteXY
    /// through the calibration ([`Calibration::xy_to_neutral`]); `None` when the file states
    /// neither (or only a white without a ColorMatrix to place it).
    pub fn as_shot_gains(&self) -> Result<Option<[f32; 3]>> {
        let neutral = match (self.as_shot_neutral, self.as_shot_white_xy) {
            (Some(n), _) => n,
            (None, Some(xy)) => match self.to_calibration()? {
                Some(c) => c.xy_to_neutral(xy).map_err(|source| FormatError::Colour {
                    field: "AsShotWhiteXY",
                    source,
                })?,
                None => return Ok(None),
            },
            (None, None) => return Ok(None),
        };
        Ok(Some([
            (neutral[1] / neutral[0]) as f32,
            1.0,
            (neutral[1] / neutral[2]) as f32,
        ]))
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
    /// The recommended crop and which way is up.
    pub framing: Framing,
    /// Processing the file asks for beyond levels and colour.
    pub processing: Processing,
}

/// What a DNG asks a raw converter to do beyond levels and colour.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Processing {
    /// BaselineExposure (IFD 0): the exposure, in EV, that makes the camera's rendering
    /// "normal" (DNG 1.4); converters apply it by default.
    pub baseline_exposure: Option<f64>,
    /// OpcodeList1 (applied to the raw as stored), OpcodeList2 (after linearisation, before
    /// demosaicing) and OpcodeList3 (after demosaicing), from the raw IFD.
    pub opcode_lists: [Vec<opcodes::Opcode>; 3],
    /// The defective pixels FixBadPixelsConstant and FixBadPixelsList name, in the image's
    /// coordinates (inside the active area), sorted by row then column without duplicates:
    /// the static defect map for isp-core's defect correction. Found by the reader, which
    /// holds the samples at the stage each list applies to.
    pub bad_pixels: Vec<isp_core::dpc::Defect>,
    /// NoiseProfile (tag 51041, in the raw IFD or IFD 0): the variance of a sample as `S x + O`
    /// with `x` in units of the white level above black, one pair for every colour or one per
    /// colour (red, green, blue) as the file states it. The writer stores one pair when every
    /// colour has the same.
    pub noise_profile: Option<isp_core::noise::NoiseProfile>,
    /// ExposureTime (EXIF tag 33434, in IFD 0 as PiDNG writes it), seconds: how the frame
    /// was shot, which tuning tools (Raspberry Pi's among them) read.
    pub exposure_time_s: Option<f64>,
    /// ISOSpeedRatings (EXIF tag 34855, in IFD 0), the ISO the frame was shot at.
    pub iso: Option<u16>,
}

/// How the file says its image is framed, for the developer to apply to its output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Framing {
    /// DefaultCropOrigin/Size, in pixels of the active area (DefaultScale 1), if the file has
    /// them.
    pub default_crop: Option<Crop>,
    /// Orientation (tag 274 in IFD 0).
    pub orientation: Orientation,
}

/// Tag numbers and field types (TIFF 6.0 and DNG 1.4).
pub(crate) mod tags {
    pub(crate) const NEW_SUBFILE_TYPE: u16 = 254;
    pub(crate) const IMAGE_WIDTH: u16 = 256;
    pub(crate) const IMAGE_LENGTH: u16 = 257;
    pub(crate) const BITS_PER_SAMPLE: u16 = 258;
    pub(crate) const COMPRESSION: u16 = 259;
    pub(crate) const PHOTOMETRIC: u16 = 262;
    pub(crate) const MAKE: u16 = 271;
    pub(crate) const MODEL: u16 = 272;
    pub(crate) const STRIP_OFFSETS: u16 = 273;
    pub(crate) const ORIENTATION: u16 = 274;
    pub(crate) const SAMPLES_PER_PIXEL: u16 = 277;
    pub(crate) const ROWS_PER_STRIP: u16 = 278;
    pub(crate) const STRIP_BYTE_COUNTS: u16 = 279;
    pub(crate) const PLANAR_CONFIGURATION: u16 = 284;
    pub(crate) const SOFTWARE: u16 = 305;
    pub(crate) const TILE_WIDTH: u16 = 322;
    pub(crate) const TILE_LENGTH: u16 = 323;
    pub(crate) const TILE_OFFSETS: u16 = 324;
    pub(crate) const TILE_BYTE_COUNTS: u16 = 325;
    pub(crate) const SUB_IFDS: u16 = 330;
    pub(crate) const CFA_REPEAT_PATTERN_DIM: u16 = 33421;
    pub(crate) const CFA_PATTERN: u16 = 33422;
    pub(crate) const DNG_VERSION: u16 = 50706;
    pub(crate) const DNG_BACKWARD_VERSION: u16 = 50707;
    pub(crate) const UNIQUE_CAMERA_MODEL: u16 = 50708;
    pub(crate) const LINEARIZATION_TABLE: u16 = 50712;
    pub(crate) const BLACK_LEVEL_REPEAT_DIM: u16 = 50713;
    pub(crate) const BLACK_LEVEL: u16 = 50714;
    pub(crate) const BLACK_LEVEL_DELTA_H: u16 = 50715;
    pub(crate) const BLACK_LEVEL_DELTA_V: u16 = 50716;
    pub(crate) const WHITE_LEVEL: u16 = 50717;
    pub(crate) const DEFAULT_CROP_ORIGIN: u16 = 50719;
    pub(crate) const DEFAULT_CROP_SIZE: u16 = 50720;
    pub(crate) const ACTIVE_AREA: u16 = 50829;
    pub(crate) const BASELINE_EXPOSURE: u16 = 50730;
    pub(crate) const EXPOSURE_TIME: u16 = 33434;
    pub(crate) const ISO_SPEED_RATINGS: u16 = 34855;
    pub(crate) const OPCODE_LISTS: [u16; 3] = [51008, 51009, 51022];
    pub(crate) const COLOR_MATRIX_1: u16 = 50721;
    pub(crate) const COLOR_MATRIX_2: u16 = 50722;
    pub(crate) const CAMERA_CALIBRATION_1: u16 = 50723;
    pub(crate) const CAMERA_CALIBRATION_2: u16 = 50724;
    pub(crate) const ANALOG_BALANCE: u16 = 50727;
    pub(crate) const AS_SHOT_NEUTRAL: u16 = 50728;
    pub(crate) const AS_SHOT_WHITE_XY: u16 = 50729;
    pub(crate) const CALIBRATION_ILLUMINANT_1: u16 = 50778;
    pub(crate) const CALIBRATION_ILLUMINANT_2: u16 = 50779;
    pub(crate) const FORWARD_MATRIX_1: u16 = 50964;
    pub(crate) const FORWARD_MATRIX_2: u16 = 50965;
    pub(crate) const NOISE_PROFILE: u16 = 51041;

    pub(crate) const CFA_PHOTOMETRIC: u32 = 32803;
    pub(crate) const LINEAR_RAW_PHOTOMETRIC: u32 = 34892;

    // Field types.
    pub(crate) const BYTE: u16 = 1;
    pub(crate) const ASCII: u16 = 2;
    pub(crate) const SHORT: u16 = 3;
    pub(crate) const LONG: u16 = 4;
    pub(crate) const RATIONAL: u16 = 5;
    pub(crate) const UNDEFINED: u16 = 7;
    pub(crate) const SRATIONAL: u16 = 10;
    pub(crate) const DOUBLE: u16 = 12;
}

/// The CFA colour codes (0 red, 1 green, 2 blue) of a pattern's 2x2 block, row by row.
fn cfa_codes(pattern: CfaPattern) -> [u8; 4] {
    std::array::from_fn(|p| pattern.colour_at(p % 2, p / 2).index() as u8)
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

impl Dng {
    /// Reads a file.
    pub fn read(path: &Path) -> Result<Dng> {
        let data = std::fs::read(path).map_err(|e| FormatError::io(path, e))?;
        Dng::decode(&data).map_err(|e| e.in_file(path))
    }
}

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
            framing: Framing::default(),
            processing: Processing::default(),
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
        d.colour.as_shot_white_xy = Some([0.3125, 0.328125]);
        let back = Dng::decode(&d.encode().unwrap()).unwrap();
        assert_eq!(back.colour, d.colour);
    }

    /// Every colour tag reaches the calibration: the one `to_calibration` builds equals the
    /// one built from the tags by hand, ForwardMatrix only when both calibrations have one, and
    /// AsShotWhiteXY (without AsShotNeutral) gives the gains of the neutral the calibration
    /// places it at.
    #[test]
    fn colour_tags_combine_into_the_calibration() {
        let mut colour = sample().colour;
        let fm = [[0.6, 0.25, 0.1], [0.3, 0.7, 0.0], [0.05, 0.1, 0.65]];
        let cc = [[1.02, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.01, 0.97]];
        colour.calibrations[0].camera_calibration = Some(cc);
        colour.calibrations[0].forward_matrix = Some(fm);
        colour.analog_balance = Some([1.1, 1.0, 0.9]);
        let cms = [0, 1].map(|i| colour.calibrations[i].color_matrix);
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let by_hand = Calibration::from_color_matrices([2856.0, 6504.0], cms)
            .unwrap()
            .with_camera_calibration([cc, identity])
            .unwrap()
            .with_analog_balance([1.1, 1.0, 0.9])
            .unwrap();
        assert_eq!(colour.to_calibration().unwrap(), Some(by_hand));
        colour.calibrations[1].forward_matrix = Some(fm);
        let with_forward = by_hand.with_forward_matrices([fm, fm]).unwrap();
        assert_eq!(colour.to_calibration().unwrap(), Some(with_forward));

        colour.as_shot_neutral = None;
        colour.as_shot_white_xy = Some([0.4, 0.39]);
        let neutral = with_forward.xy_to_neutral([0.4, 0.39]).unwrap();
        let gains = colour.as_shot_gains().unwrap().unwrap();
        for (g, n) in gains.iter().zip(neutral) {
            assert!(
                (f64::from(*g) * n - 1.0).abs() < 1e-6,
                "{gains:?} {neutral:?}"
            );
        }
        // The neutral found for that white maps back to it.
        let xy = with_forward.neutral_to_xy(neutral).unwrap();
        assert!(
            (xy[0] - 0.4).abs() < 1e-9 && (xy[1] - 0.39).abs() < 1e-9,
            "{xy:?}"
        );
        colour.calibrations.clear();
        assert_eq!(colour.as_shot_gains().unwrap(), None);
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
        assert_eq!(colour.as_shot_gains().unwrap(), Some([2.0, 1.0, 1.25]));
        let cal = colour.to_calibration().unwrap().unwrap();
        // The scale does not change the colour: the CCM for neutral gains is the identity.
        let ccm = cal.ccm(colour::D65_XY, [1.0; 3]).unwrap();
        for (i, row) in ccm.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 2e-3, "{ccm:?}");
            }
        }
        // A matrix without a known illuminant is used as is, alone or first of two.
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
        assert_eq!(two.to_calibration().unwrap(), Some(cal));
        assert_eq!(DngColour::default().to_calibration().unwrap(), None);
    }

    /// Every storage the writer has, in strips and tiles (edge tiles padded), in both byte
    /// orders, decodes to the same frame.
    #[test]
    fn every_storage_layout_and_byte_order_round_trips() {
        let mut d = sample();
        // 37 x 21: tiles of 16 leave partial tiles on the right and at the bottom.
        let (w, h) = (37, 21);
        d.image = RawImage::new(
            w,
            h,
            CfaPattern::Grbg,
            14,
            [512; 4],
            16383,
            (0..w * h)
                .map(|i| ((i * 2654435761) % 16384) as u16)
                .collect(),
        )
        .unwrap();
        d.framing = Framing {
            default_crop: Some(Crop {
                left: 2,
                top: 1,
                width: 32,
                height: 18,
            }),
            orientation: Orientation::Rotate270,
        };
        let storages = [
            Storage::Uncompressed { bits: 16 },
            Storage::Uncompressed { bits: 14 },
            Storage::Uncompressed { bits: 15 },
            Storage::LosslessJpeg {
                components: 1,
                predictor: 1,
            },
            Storage::LosslessJpeg {
                components: 2,
                predictor: 6,
            },
        ];
        for storage in storages {
            for tile in [None, Some((16, 16)), Some((32, 48))] {
                for little_endian in [true, false] {
                    let options = EncodeOptions {
                        storage,
                        tile,
                        little_endian,
                    };
                    let two_components =
                        matches!(storage, Storage::LosslessJpeg { components: 2, .. });
                    if two_components && tile.is_none() {
                        // A 37-wide strip has no whole pairs of CFA columns.
                        assert!(d.encode_with(&options).is_err());
                        continue;
                    }
                    let bytes = d.encode_with(&options).unwrap();
                    let back = Dng::decode(&bytes).unwrap_or_else(|e| panic!("{options:?}: {e}"));
                    assert_eq!(back, d, "{options:?}");
                    // The same raw in a SubIFD behind an RGB preview in IFD 0.
                    let bytes = d.encode_with_preview(&options).unwrap();
                    let back =
                        Dng::decode(&bytes).unwrap_or_else(|e| panic!("SubIFD {options:?}: {e}"));
                    assert_eq!(back, d, "SubIFD {options:?}");
                }
            }
        }
        // Samples wider than the storage are refused, not truncated.
        let narrow = EncodeOptions {
            storage: Storage::Uncompressed { bits: 12 },
            ..EncodeOptions::default()
        };
        assert!(d.encode_with(&narrow).is_err());
    }

    /// A linear (already demosaiced) 37 x 21 image of `bits`-bit samples with its own black
    /// per channel.
    fn linear_sample(bits: u8) -> Dng {
        let (w, h) = (37, 21);
        let max = (1u32 << bits) - 1;
        let mut d = sample();
        d.image = RawImage::linear_rgb(
            w,
            h,
            bits,
            [3, 5, 7],
            max as u16,
            (0..w * h * 3)
                .map(|i| {
                    // Smooth enough for a lossy JPEG to keep: a gradient per channel.
                    let (x, y, c) = ((i / 3) % w, (i / 3) / w, i % 3);
                    ((x * 5 + y * 3 + c * 40) as u32 * max / 400).min(max) as u16
                })
                .collect(),
        )
        .unwrap();
        d.framing.orientation = Orientation::Rotate90;
        d
    }

    #[test]
    fn linear_raw_round_trips_in_every_lossless_storage() {
        let d = linear_sample(14);
        let storages = [
            Storage::Uncompressed { bits: 16 },
            Storage::Uncompressed { bits: 14 },
            Storage::LosslessJpeg {
                components: 3,
                predictor: 1,
            },
            Storage::LosslessJpeg {
                components: 3,
                predictor: 7,
            },
        ];
        for storage in storages {
            for tile in [None, Some((16, 16))] {
                for little_endian in [true, false] {
                    let options = EncodeOptions {
                        storage,
                        tile,
                        little_endian,
                    };
                    let bytes = d.encode_with(&options).unwrap();
                    let back = Dng::decode(&bytes).unwrap_or_else(|e| panic!("{options:?}: {e}"));
                    assert_eq!(back, d, "{options:?}");
                    let bytes = d.encode_with_preview(&options).unwrap();
                    assert_eq!(Dng::decode(&bytes).unwrap(), d, "SubIFD {options:?}");
                }
            }
        }
        // A CFA image's component counts do not fit a linear one.
        let two = EncodeOptions {
            storage: Storage::LosslessJpeg {
                components: 2,
                predictor: 1,
            },
            ..EncodeOptions::default()
        };
        assert!(d.encode_with(&two).is_err());
    }

    #[test]
    fn lossy_jpeg_decodes_to_the_samples_within_its_loss() {
        let d = linear_sample(8);
        for tile in [None, Some((16, 16)), Some((32, 16))] {
            let options = EncodeOptions {
                storage: Storage::LossyJpeg { quality: 95 },
                tile,
                little_endian: false,
            };
            let bytes = d.encode_with(&options).unwrap();
            let back = Dng::decode(&bytes).unwrap_or_else(|e| panic!("{options:?}: {e}"));
            assert!(back.image.is_linear() && back.image.samples.len() == d.image.samples.len());
            let worst = back
                .image
                .samples
                .iter()
                .zip(&d.image.samples)
                .map(|(a, b)| a.abs_diff(*b))
                .max()
                .unwrap();
            assert!(worst <= 8, "{options:?}: worst {worst}");
            assert_ne!(back.image.samples, vec![0; back.image.samples.len()]);
        }
        // Through a LinearizationTable, as Adobe's lossy DNGs store 8-bit codes.
        let table: Vec<u16> = (0..256u32).map(|v| (v * v) as u16).collect();
        let options = EncodeOptions {
            storage: Storage::LossyJpeg { quality: 100 },
            ..EncodeOptions::default()
        };
        let bytes = d
            .encode_with_entries(
                &options,
                vec![
                    write::short(LINEARIZATION_TABLE, &table),
                    write::short(WHITE_LEVEL, &[65025, 65025, 65025]),
                ],
            )
            .unwrap();
        let back = Dng::decode(&bytes).unwrap();
        assert_eq!(back.image.white_level, 65025);
        for (a, b) in back.image.samples.iter().zip(&d.image.samples) {
            let code = f64::from(*a).sqrt();
            assert!((code - f64::from(*b)).abs() <= 3.0, "{a} from {b}");
        }
        // Through OpcodeList2's MapPolynomial, as Adobe's converter maps them: on samples
        // scaled to 0..=65535 above black, after which the image holds that scale.
        let mut mapped = d.clone();
        mapped.processing.opcode_lists[1] = vec![opcodes::Opcode::MapPolynomial {
            region: opcodes::Region {
                area: [0, 0, 21, 37],
                plane: 0,
                planes: 3,
                row_pitch: 1,
                col_pitch: 1,
            },
            coefficients: vec![0.0, 0.2, 0.8],
        }];
        let plain = Dng::decode(&d.encode_with(&options).unwrap()).unwrap();
        let back = Dng::decode(&mapped.encode_with(&options).unwrap()).unwrap();
        assert_eq!(
            (back.image.white_level, back.image.black_level),
            (65535, [0; 4])
        );
        for (i, (m, p)) in back
            .image
            .samples
            .iter()
            .zip(&plain.image.samples)
            .enumerate()
        {
            let black = f64::from(d.image.black_level[i % 3]);
            let x =
                ((f64::from(*p) - black).max(0.0) * 65535.0 / (255.0 - black)).round() / 65535.0;
            let expected = ((0.2 * x + 0.8 * x * x) * 65535.0).round();
            assert_eq!(f64::from(*m), expected, "sample {i}");
        }
        // Samples past 8 bits cannot be stored so.
        assert!(linear_sample(12).encode_with(&options).is_err());
        // A 12-bit lossy JPEG is refused by name.
        let twelve = d
            .encode_with_entries(&options, vec![write::short(BITS_PER_SAMPLE, &[12, 12, 12])])
            .unwrap();
        let err = Dng::decode(&twelve).unwrap_err().to_string();
        assert!(err.contains("34892") && err.contains("12"), "{err}");
    }

    #[test]
    fn linear_levels_active_area_and_sample_counts() {
        let d = linear_sample(12);
        let options = EncodeOptions::default();
        let decode = |entries| Dng::decode(&d.encode_with_entries(&options, entries).unwrap());
        // ActiveArea crops whole pixels; per-channel whites are stretched to the largest.
        let back = decode(vec![
            write::long(ACTIVE_AREA, &[2, 3, 20, 35]),
            write::short(WHITE_LEVEL, &[4095, 2047, 4095]),
        ])
        .unwrap();
        assert_eq!((back.image.width, back.image.height), (32, 18));
        assert_eq!(back.image.white_level, 4095);
        let at =
            |img: &RawImage, x: usize, y: usize, c: usize| img.samples[(y * img.width + x) * 3 + c];
        assert_eq!(at(&back.image, 0, 0, 0), at(&d.image, 3, 2, 0));
        let (src, black) = (f64::from(at(&d.image, 3, 2, 1)), 5.0);
        let stretched =
            (black + (src.min(2047.0) - black) * (4095.0 - black) / (2047.0 - black)).round();
        assert_eq!(f64::from(at(&back.image, 0, 0, 1)), stretched.min(4095.0));
        // A black level per sample with a 2x2 repeat comes off the samples.
        let back = decode(vec![
            write::short(BLACK_LEVEL_REPEAT_DIM, &[2, 2]),
            write::short(
                BLACK_LEVEL,
                &[10, 20, 30, 11, 21, 31, 12, 22, 32, 13, 23, 33],
            ),
        ])
        .unwrap();
        assert_eq!(back.image.black_level, [10; 4]);
        let expected = |x: usize, y: usize, c: usize| {
            let black = [10, 20, 30][c] + (y % 2) * 2 + x % 2;
            (at(&d.image, x, y, c) as usize).saturating_sub(black) as u16 + 10
        };
        assert_eq!(at(&back.image, 1, 1, 2), expected(1, 1, 2));
        assert_eq!(at(&back.image, 4, 3, 0), expected(4, 3, 0));
        // LinearRaw needs three samples per pixel, interleaved.
        let err = decode(vec![write::short(SAMPLES_PER_PIXEL, &[4])]).unwrap_err();
        assert!(err.to_string().contains("SamplesPerPixel"), "{err}");
        let err = decode(vec![write::short(PLANAR_CONFIGURATION, &[2])]).unwrap_err();
        assert!(err.to_string().contains("PlanarConfiguration"), "{err}");
    }

    /// With a preview, IFD 0 is an 8-bit RGB image that is not the raw (NewSubFileType 1) and
    /// holds the camera-wide tags; the raw is found through SubIFDs with its opcodes.
    #[test]
    fn a_raw_in_a_sub_ifd_behind_a_preview_is_found() {
        let mut d = sample();
        d.processing.baseline_exposure = Some(0.5);
        d.processing.opcode_lists[2] = vec![opcodes::Opcode::Other {
            id: 99,
            optional: true,
        }];
        let bytes = d.encode_with_preview(&EncodeOptions::default()).unwrap();
        let file = tiff::Tiff::new(&bytes).unwrap();
        let ifd0 = file.ifd(file.u32_at(4).unwrap() as usize).unwrap();
        assert!(!file.is_raw_image(&ifd0).unwrap());
        assert!(ifd0.get(SUB_IFDS).is_some() && ifd0.get(COLOR_MATRIX_1).is_some());
        assert!(ifd0.get(OPCODE_LISTS[2]).is_none());
        assert_eq!(Dng::decode(&bytes).unwrap(), d);
        // Without the SubIFD pointer there is no raw to find.
        let mut broken = bytes.clone();
        let sub = (0..ifd0_count(&bytes))
            .map(|i| 10 + 12 * i)
            .find(|at| u16::from_le_bytes([bytes[*at], bytes[*at + 1]]) == SUB_IFDS)
            .unwrap();
        broken[sub..sub + 2].copy_from_slice(&65000u16.to_le_bytes()); // an unknown tag
        assert!(Dng::decode(&broken).is_err());
    }

    /// NoiseProfile round-trips as one pair or one per colour, in either byte order and with
    /// the raw in a SubIFD; a profile in IFD 0 is found for a raw in a SubIFD; a count other
    /// than 2 or 6, a negative, non-finite or too large term, or a zero pair is refused.
    #[test]
    fn noise_profile_round_trips_and_is_validated() {
        use isp_core::noise::NoiseProfile;
        let mut d = sample();
        for profile in [
            NoiseProfile::uniform(0.0032, 4.5e-6).unwrap(),
            NoiseProfile::new([0.003, 0.0032, 0.0035], [1e-6, 2e-6, 0.0]).unwrap(),
        ] {
            d.processing.noise_profile = Some(profile);
            for little_endian in [true, false] {
                let options = EncodeOptions {
                    little_endian,
                    ..EncodeOptions::default()
                };
                let back = Dng::decode(&d.encode_with(&options).unwrap()).unwrap();
                assert_eq!(back.processing.noise_profile, Some(profile));
                let back = Dng::decode(&d.encode_with_preview(&options).unwrap()).unwrap();
                assert_eq!(back.processing.noise_profile, Some(profile));
            }
        }
        let bytes = d.encode().unwrap();
        let file = tiff::Tiff::new(&bytes).unwrap();
        let ifd0 = file.ifd(file.u32_at(4).unwrap() as usize).unwrap();
        assert_eq!(
            file.numbers(ifd0.get(NOISE_PROFILE).unwrap())
                .unwrap()
                .len(),
            6
        );

        let with = |values: Vec<f64>| {
            let entry = write::Entry {
                tag: NOISE_PROFILE,
                values: write::Values::Double(values),
            };
            Dng::decode(
                &sample()
                    .encode_with_entries(&EncodeOptions::default(), vec![entry])
                    .unwrap(),
            )
        };
        let p = with(vec![0.01, 1e-5]).unwrap().processing.noise_profile;
        assert_eq!(p, Some(NoiseProfile::uniform(0.01, 1e-5).unwrap()));
        for bad in [
            vec![0.01],
            vec![0.01, 1e-5, 0.02, 1e-5],
            vec![-0.01, 1e-5],
            vec![0.01, f64::NAN],
            vec![0.01, f64::INFINITY],
            vec![2.0, 1e-5],
            vec![0.0, 0.0],
            vec![0.01, 1e-5, 0.0, 0.0, 0.01, 1e-5],
        ] {
            let e = with(bad.clone()).unwrap_err();
            assert!(e.to_string().contains("NoiseProfile"), "{bad:?}: {e}");
        }
    }

    fn ifd0_count(bytes: &[u8]) -> usize {
        usize::from(u16::from_le_bytes([bytes[8], bytes[9]]))
    }

    #[test]
    fn linearization_table_maps_every_code() {
        let d = sample();
        // A table shorter than the codes: codes past its end take its last value.
        let table: Vec<u16> = (0..2000u32).map(|v| (v * 3) as u16).collect();
        let bytes = d
            .encode_with_entries(
                &EncodeOptions::default(),
                vec![
                    write::short(LINEARIZATION_TABLE, &table),
                    write::short(WHITE_LEVEL, &[6000]),
                ],
            )
            .unwrap();
        let back = Dng::decode(&bytes).unwrap();
        let expected: Vec<u16> = d
            .image
            .samples
            .iter()
            .map(|v| table[usize::from(*v).min(1999)])
            .collect();
        assert_eq!(back.image.samples, expected);
        assert_eq!(back.image.white_level, 6000);
        assert_eq!(back.image.bits, 13);
    }

    #[test]
    fn black_level_repeats_and_deltas_are_taken_off_the_samples() {
        let mut d = sample();
        d.image.samples = vec![1000; 15]; // 5 x 3
        let options = EncodeOptions::default();
        // A 2x2 repeat of integers stays a per-position black level.
        let bytes = d
            .encode_with_entries(
                &options,
                vec![
                    write::short(BLACK_LEVEL_REPEAT_DIM, &[2, 2]),
                    write::short(BLACK_LEVEL, &[1, 2, 3, 4]),
                ],
            )
            .unwrap();
        let back = Dng::decode(&bytes).unwrap();
        assert_eq!(back.image.black_level, [1, 2, 3, 4]);
        assert_eq!(back.image.samples, d.image.samples);
        // A 1x3 repeat, with a delta per column and per row, comes off the samples down to
        // the smallest black, which the image keeps.
        let delta_h = [0.0, 1.0, 2.0, 3.0, 4.0];
        let delta_v = [0.0, 10.0, 20.0];
        let bytes = d
            .encode_with_entries(
                &options,
                vec![
                    write::short(BLACK_LEVEL_REPEAT_DIM, &[1, 3]),
                    write::short(BLACK_LEVEL, &[100, 110, 120]),
                    write::srational(BLACK_LEVEL_DELTA_H, &delta_h),
                    write::srational(BLACK_LEVEL_DELTA_V, &delta_v),
                ],
            )
            .unwrap();
        let back = Dng::decode(&bytes).unwrap();
        assert_eq!(back.image.black_level, [100; 4]);
        for (y, dv) in delta_v.iter().enumerate() {
            for (x, dh) in delta_h.iter().enumerate() {
                let black = [100.0, 110.0, 120.0][x % 3] + dh + dv;
                let expected = (1000.0 - black + 100.0) as u16;
                assert_eq!(back.image.samples[y * 5 + x], expected, "({x}, {y})");
            }
        }
        // Deltas of the wrong length are refused.
        let bytes = d
            .encode_with_entries(
                &options,
                vec![write::srational(BLACK_LEVEL_DELTA_H, &[1.0])],
            )
            .unwrap();
        assert!(Dng::decode(&bytes).is_err());
    }

    #[test]
    fn refusals_name_the_tag_and_value() {
        let d = sample();
        let with = |entries| {
            let bytes = d
                .encode_with_entries(&EncodeOptions::default(), entries)
                .unwrap();
            Dng::decode(&bytes).unwrap_err().to_string()
        };
        assert!(
            with(vec![write::short(COMPRESSION, &[52546])]).contains("Compression 52546 (JPEG XL)")
        );
        assert!(with(vec![write::short(ORIENTATION, &[9])]).contains("Orientation 9"));
        let crop = with(vec![
            write::long(DEFAULT_CROP_ORIGIN, &[4, 0]),
            write::long(DEFAULT_CROP_SIZE, &[4, 3]),
        ]);
        assert!(crop.contains("crop"), "{crop}");
    }

    #[test]
    fn exposure_time_and_iso_round_trip_in_ifd0() {
        let mut d = sample();
        d.processing.exposure_time_s = Some(1.0 / 250.0);
        d.processing.iso = Some(400);
        for bytes in [
            d.encode().unwrap(),
            d.encode_with_preview(&EncodeOptions::default()).unwrap(),
        ] {
            let back = Dng::decode(&bytes).unwrap();
            assert_eq!(back.processing.exposure_time_s, Some(0.004));
            assert_eq!(back.processing.iso, Some(400));
        }
        d.processing.exposure_time_s = Some(-1.0);
        assert!(d.encode().is_err(), "a negative exposure time is refused");
    }

    #[test]
    fn opcode_lists_and_baseline_exposure_round_trip() {
        use opcodes::Opcode;
        let mut d = sample();
        d.processing = Processing {
            baseline_exposure: Some(-0.35),
            opcode_lists: [
                vec![Opcode::FixBadPixelsList {
                    bayer_phase: 0,
                    points: vec![[1, 2]],
                    rects: vec![],
                }],
                vec![Opcode::Other {
                    id: 12,
                    optional: true,
                }],
                vec![],
            ],
            ..Processing::default()
        };
        for little_endian in [true, false] {
            let options = EncodeOptions {
                little_endian,
                ..EncodeOptions::default()
            };
            let back = Dng::decode(&d.encode_with(&options).unwrap()).unwrap();
            assert_eq!(back.processing.opcode_lists, d.processing.opcode_lists);
            assert_eq!(
                back.processing.baseline_exposure,
                d.processing.baseline_exposure
            );
            // The listed pixel, row 1 column 2, is the defect map.
            let defect = isp_core::dpc::Defect { y: 1, x: 2 };
            assert_eq!(back.processing.bad_pixels, [defect]);
        }
    }

    /// FixBadPixelsConstant and FixBadPixelsList name pixels in stored coordinates in
    /// OpcodeList1 (moved into the active area) and in active-area coordinates in
    /// OpcodeList2, where a constant compares on the 0..65535 scale of black to white.
    #[test]
    fn bad_pixel_opcodes_become_the_defect_map() {
        use isp_core::dpc::Defect;
        use opcodes::Opcode;
        let mut d = sample(); // 5 x 3, black 10..13, white 4095
        d.image.black_level = [0; 4];
        d.image.samples = vec![100; 15];
        d.image.samples[7] = 0; // (2, 1)
        d.image.samples[14] = 4095; // (4, 2): white, 65535 on the stage-2 scale
        d.processing.opcode_lists = [
            vec![
                Opcode::FixBadPixelsConstant {
                    constant: 0,
                    bayer_phase: 0,
                },
                Opcode::FixBadPixelsList {
                    bayer_phase: 0,
                    points: vec![[0, 0], [2, 9]], // the second is outside: dropped
                    rects: vec![],
                },
            ],
            vec![
                Opcode::FixBadPixelsConstant {
                    constant: 65535,
                    bayer_phase: 0,
                },
                Opcode::FixBadPixelsList {
                    bayer_phase: 0,
                    points: vec![],
                    rects: vec![[0, 3, 2, 9]], // clipped to columns 3..5, rows 0..2
                },
            ],
            vec![],
        ];
        let back = Dng::decode(&d.encode().unwrap()).unwrap();
        let mut expected: Vec<Defect> = [(0, 0), (2, 1), (4, 2), (3, 0), (4, 0), (3, 1), (4, 1)]
            .iter()
            .map(|&(x, y)| Defect { x, y })
            .collect();
        expected.sort();
        assert_eq!(back.processing.bad_pixels, expected);
        // With an active area starting at column 1, OpcodeList1's stored (0, 0) falls
        // outside it and its (2, 1) moves to (1, 1).
        let bytes = d
            .encode_with_entries(
                &EncodeOptions::default(),
                vec![write::long(ACTIVE_AREA, &[0, 1, 3, 5])],
            )
            .unwrap();
        let back = Dng::decode(&bytes).unwrap();
        assert!(back.processing.bad_pixels.contains(&Defect { x: 1, y: 1 }));
        assert!(!back.processing.bad_pixels.contains(&Defect { x: 0, y: 0 }));
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
