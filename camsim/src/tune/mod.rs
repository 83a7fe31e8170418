//! `camsim tune`: a camera's tuning from its own captures, in the file layout Raspberry Pi's
//! Camera Tuning Tool reads, checked end to end against the simulator ([`simulate`]).
//!
//! A capture folder holds DNGs named
//! - `<anything>_<CCT>k_<lux>l.dng`: a ColorChecker 24 under a light of that colour
//!   temperature (at least two lights; three or more give the white-balance locus its curve);
//! - `alsc_<CCT>k_<n>.dng`: flat fields (a diffuser in front of the lens) under a light, at
//!   least one frame at each of at least two colour temperatures;
//! - `dark_<n>.dng`: dark frames (cap on), optional;
//! - `ptc_<ISO>_<level>_<a|b>.dng`: photon-transfer pairs, two frames of one flat field at
//!   each level, optional; a pair whose level is `dark` (or whose signal is under 1 % of the
//!   range) is that ISO's dark pair and fixes the noise offset, as EMVA 1288 takes it.
//!
//! Other files are listed as ignored. Everything is read and checked before any fit: files
//! that do not decode, sizes, patterns, bit depths or white levels that differ, too few
//! lights or flat fields, a chart not found, or a chart shot clipped or too dark (the patches
//! named) refuse the whole set, naming the file.
//!
//! The fits, in the order each needs the one before:
//! 1. black level per CFA position from the dark frames (robust mean), else the DNGs'
//!    BlackLevel with a warning; a warning also when the two disagree by more than 1 DN;
//! 2. defects: hot pixels from the averaged darks, dead and stuck ones from the averaged flats
//!    (a quarter off the median of the eight nearest same-colour neighbours);
//! 3. lens shading from the flats: per colour a degree-6 polynomial fitted to 16-pixel block
//!    means (defects out), read at the grid's nodes; the luminance table (green) averaged
//!    over colour temperatures, a colour table per colour temperature (red and blue relative
//!    to green, 1 where the frame is brightest), as Raspberry Pi's tool keeps them apart;
//! 4. the noise profile `var = S x + O` per ISO and colour from photon-transfer pairs
//!    (EMVA 1288: half the variance of each pair's difference against its mean, the offset
//!    from the dark pair), else from the chart patches' spatial variance (with a quadratic term
//!    that takes the fixed-pattern PRNU out) and the dark frames of the charts' ISO: O from
//!    the darks' temporal variance (half that of a pair's difference; one dark's spatial
//!    variance, DSNU included, with a warning), the patches' intercept pinned to the darks'
//!    spatial variance; without darks the intercept is O, with a warning;
//! 5. per chart shot: the chart found (or `--chart`), its patches sampled after black, shading
//!    and defects, the light's colour from the five brighter greys;
//! 6. the white-balance locus through the lights' colours and its transverse bounds;
//! 7. a colour matrix per colour temperature: white-balanced camera RGB to linear sRGB, rows
//!    summing to one, the mean CIEDE2000 over the 24 patches minimised ([`mod@reference`] for the
//!    target: the chart under the shot's light adapted to D65, the light a CIE illuminant the
//!    name gives, else a blackbody or daylight of its CCT), and the DNG ColorMatrix/ForwardMatrix pair for the coolest and warmest light.

pub mod chart;
pub mod fit;
pub mod reference;
pub mod report;
pub mod simulate;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use isp_core::colour;
use raw_formats::dng::{ColourCalibration, Dng, Illuminant};
use raw_formats::RawImage;
use serde::{Deserialize, Serialize};

use chart::{ChartMap, Corners, Mosaic};
use fit::{FlatModel, Locus, TransferPoint};

use crate::Error;

/// The tuning file's schema version.
pub const SCHEMA_VERSION: u32 = 1;

/// What a capture file is, from its name.
#[derive(Debug, Clone, PartialEq)]
pub enum CaptureKind {
    /// A ColorChecker shot.
    Chart {
        /// Colour temperature, K.
        cct: f64,
        /// Illuminance, lux, as named.
        lux: f64,
    },
    /// A flat field.
    Flat {
        /// Colour temperature, K.
        cct: f64,
    },
    /// A dark frame.
    Dark,
    /// One frame of a photon-transfer pair.
    Transfer {
        /// ISO.
        iso: f64,
        /// The level's label.
        level: String,
        /// `a` or `b`.
        side: char,
    },
}

/// Reads a capture's kind from its file name; `None` for names of no kind (ignored).
pub fn classify(name: &str) -> Option<CaptureKind> {
    let stem = name
        .strip_suffix(".dng")
        .or_else(|| name.strip_suffix(".DNG"))?;
    let parts: Vec<&str> = stem.split('_').collect();
    let number = |s: &str, suffix: char| -> Option<f64> {
        let digits = s
            .strip_suffix(suffix)
            .or_else(|| s.strip_suffix(suffix.to_ascii_uppercase()))?;
        let v: f64 = digits.parse().ok()?;
        (v.is_finite() && v > 0.0).then_some(v)
    };
    match parts.as_slice() {
        ["dark", n] if n.parse::<u32>().is_ok() => Some(CaptureKind::Dark),
        ["alsc", cct, n] if n.parse::<u32>().is_ok() => {
            number(cct, 'k').map(|cct| CaptureKind::Flat { cct })
        }
        ["ptc", iso, level, side] if *side == "a" || *side == "b" => {
            let iso: f64 = iso.parse().ok()?;
            (iso.is_finite() && iso > 0.0).then(|| CaptureKind::Transfer {
                iso,
                level: level.to_string(),
                side: side.chars().next().unwrap_or('a'),
            })
        }
        [.., cct, lux]
            if parts.len() >= 3
                && parts[0] != "alsc"
                && parts[0] != "ptc"
                && parts[0] != "dark" =>
        {
            Some(CaptureKind::Chart {
                cct: number(cct, 'k')?,
                lux: number(lux, 'l')?,
            })
        }
        _ => None,
    }
}

/// One capture, read.
#[derive(Debug, Clone)]
pub struct Capture {
    /// Its file.
    pub path: PathBuf,
    /// Its kind.
    pub kind: CaptureKind,
    /// Its raw frame.
    pub raw: RawImage,
    /// The ISO its DNG says it was shot at (ISOSpeedRatings), if it says.
    pub iso: Option<u16>,
    /// The exposure its DNG says (ExposureTime), seconds, if it says.
    pub exposure_s: Option<f64>,
}

/// Settings of a tuning run.
#[derive(Debug, Clone, PartialEq)]
pub struct TuneSettings {
    /// The capture folder.
    pub captures: PathBuf,
    /// The chart's corners in every chart shot, instead of finding it.
    pub chart: Option<Corners>,
    /// Lens-shading grid nodes across and down.
    pub grid: (usize, usize),
}

impl TuneSettings {
    /// Defaults for a folder: the chart found, a 17 x 13 shading grid (16 x 12 cells, as
    /// Raspberry Pi's tables).
    pub fn new(captures: impl Into<PathBuf>) -> Self {
        TuneSettings {
            captures: captures.into(),
            chart: None,
            grid: (17, 13),
        }
    }
}

/// The tuning file (TOML), schema [`SCHEMA_VERSION`]. Colours are R, G, B; CFA positions the
/// 2x2 block row by row; grids row-major, node `i` on pixel `i (width - 1) / (nodes - 1)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tuning {
    /// Schema version.
    pub version: u32,
    /// The camera model the DNGs name.
    pub camera: String,
    /// Frame width, pixels.
    pub width: usize,
    /// Frame height, pixels.
    pub height: usize,
    /// CFA pattern (`RGGB`, ...).
    pub pattern: String,
    /// ADC bits.
    pub bits: u8,
    /// White level, DN.
    pub white_level: u16,
    /// Black level per CFA position.
    pub black_level: BlackLevel,
    /// Noise profile per ISO.
    pub noise: Vec<NoiseEntry>,
    /// Defective pixels.
    pub defects: Defects,
    /// Lens shading.
    pub shading: ShadingTables,
    /// White-balance locus.
    pub awb: AwbLocus,
    /// A colour matrix per colour temperature.
    pub ccm: Vec<CcmEntry>,
    /// The DNG colour tags the tuning implies.
    pub dng: DngMatrices,
}

/// Black level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlackLevel {
    /// DN per CFA position.
    pub values: [f64; 4],
    /// `dark frames` or `DNG BlackLevel`.
    pub source: String,
}

/// The noise at one ISO: `variance = scale x + offset` with `x` the signal as a fraction of
/// `white - black` (the DNG NoiseProfile model), per colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseEntry {
    /// ISO (0 when the captures do not say).
    pub iso: f64,
    /// S per colour.
    pub scale: [f64; 3],
    /// O per colour.
    pub offset: [f64; 3],
    /// `photon transfer`, `chart patches and dark frames` or (no darks at that ISO) `chart
    /// patches`.
    pub source: String,
}

/// Defective pixels as `[x, y]`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Defects {
    /// Read high in the dark.
    pub hot: Vec<[usize; 2]>,
    /// Read black in the light.
    pub dead: Vec<[usize; 2]>,
    /// Read neither black nor the light.
    pub stuck: Vec<[usize; 2]>,
}

/// Lens-shading gains: channel `c`'s gain at a node is `luminance x colour[c]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShadingTables {
    /// Nodes across.
    pub grid_width: usize,
    /// Nodes down.
    pub grid_height: usize,
    /// Luminance gains (1 where the frame is brightest), averaged over colour temperatures.
    pub luminance: Vec<f64>,
    /// Colour tables per colour temperature.
    pub colour: Vec<ColourTable>,
}

/// Red and blue gains relative to green at one colour temperature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColourTable {
    /// Colour temperature, K.
    pub cct: f64,
    /// Red over green.
    pub red: Vec<f64>,
    /// Blue over green.
    pub blue: Vec<f64>,
}

/// The white-balance locus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwbLocus {
    /// `b = c0 + c1 r + c2 r^2`, `r = R / (R + G + B)`, `b = B / (R + G + B)` of the light.
    pub coefficients: [f64; 3],
    /// Largest distance allowed below (less blue than) the locus.
    pub transverse_negative: f64,
    /// Largest distance allowed above it.
    pub transverse_positive: f64,
    /// The measured lights.
    pub points: Vec<AwbPoint>,
}

/// One light on the locus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwbPoint {
    /// Colour temperature, K.
    pub cct: f64,
    /// Red gain (green over red).
    pub red_gain: f64,
    /// Blue gain (green over blue).
    pub blue_gain: f64,
}

/// A colour matrix at one colour temperature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CcmEntry {
    /// Colour temperature, K.
    pub cct: f64,
    /// White-balanced camera RGB to linear sRGB, rows summing to one.
    pub matrix: [[f64; 3]; 3],
    /// Mean CIEDE2000 over the 24 patches after the fit.
    pub delta_e_mean: f64,
    /// Largest.
    pub delta_e_max: f64,
}

/// ColorMatrix and ForwardMatrix for two calibration illuminants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DngMatrices {
    /// EXIF LightSource codes of calibration 1 and 2.
    pub illuminants: [u16; 2],
    /// Their colour temperatures, K.
    pub ccts: [f64; 2],
    /// ColorMatrix1/2: XYZ to camera.
    pub color_matrix: [[[f64; 3]; 3]; 2],
    /// ForwardMatrix1/2: white-balanced camera to XYZ D50.
    pub forward_matrix: [[[f64; 3]; 3]; 2],
}

impl Tuning {
    /// The file's text.
    pub fn to_toml(&self) -> Result<String, Error> {
        toml::to_string(self).map_err(|e| Error::Message(format!("tuning file: {e}")))
    }

    /// Reads a tuning file, refusing other schema versions.
    pub fn from_toml(text: &str) -> Result<Tuning, Error> {
        let t: Tuning =
            toml::from_str(text).map_err(|e| Error::Message(format!("tuning file: {e}")))?;
        if t.version != SCHEMA_VERSION {
            return Err(Error::Option {
                option: "tuning file version",
                value: t.version.to_string(),
                allowed: SCHEMA_VERSION.to_string(),
            });
        }
        Ok(t)
    }

    /// The gain of colour `c` at pixel `(x, y)` at colour temperature `cct` (colour tables
    /// interpolated in mired, held at the ends).
    pub fn shading_gain(&self, x: f64, y: f64, c: usize, cct: f64) -> f64 {
        let s = &self.shading;
        let (gw, gh) = (s.grid_width, s.grid_height);
        let lum = fit::grid_at(&s.luminance, gw, gh, self.width, self.height, x, y);
        if c == 1 || s.colour.is_empty() {
            return lum;
        }
        let table = |t: &ColourTable| {
            let grid = if c == 0 { &t.red } else { &t.blue };
            fit::grid_at(grid, gw, gh, self.width, self.height, x, y)
        };
        lum * interpolate_mired(&s.colour, |t| t.cct, cct, table)
    }

    /// The colour matrix at `cct`, interpolated in mired between the fitted ones.
    pub fn ccm_at(&self, cct: f64) -> [[f64; 3]; 3] {
        std::array::from_fn(|r| {
            std::array::from_fn(|k| {
                interpolate_mired(&self.ccm, |e| e.cct, cct, |e| e.matrix[r][k])
            })
        })
    }

    /// The locus as fitted.
    pub fn locus(&self) -> Option<Locus> {
        Locus::fit(
            &self
                .awb
                .points
                .iter()
                .map(|p| (p.cct, [1.0 / p.red_gain, 1.0, 1.0 / p.blue_gain]))
                .collect::<Vec<_>>(),
        )
        .map(|l| Locus {
            coefficients: self.awb.coefficients,
            ..l
        })
    }

    /// White balance through the locus: the light's camera colour `neutral` (any scale) moved
    /// into the band around the locus; returns the gains (green 1) and the colour temperature.
    pub fn constrain_white(&self, neutral: [f64; 3]) -> Option<([f64; 3], f64)> {
        let locus = self.locus()?;
        let [r, b] = fit::chromaticity(neutral);
        let (on, d) = locus.project([r, b]);
        let limit = if d >= 0.0 {
            self.awb.transverse_positive
        } else {
            -self.awb.transverse_negative
        };
        let kept = if d.abs() <= limit.abs() { d } else { limit };
        // Move from the locus point along the normal by the kept distance.
        let slope = locus.coefficients[1] + 2.0 * locus.coefficients[2] * on[0];
        let norm = (1.0 + slope * slope).sqrt();
        let (nr, nb) = (-slope / norm, 1.0 / norm);
        let (rr, bb) = (on[0] + kept * nr, on[1] + kept * nb);
        let g = 1.0 - rr - bb;
        if !(rr > 0.0 && bb > 0.0 && g > 0.0) {
            return None;
        }
        Some(([g / rr, 1.0, g / bb], locus.cct_at(on[0])))
    }
}

/// Interpolates `value` of entries keyed by `cct` linearly in reciprocal temperature.
pub(crate) fn interpolate_mired<T>(
    entries: &[T],
    cct: impl Fn(&T) -> f64,
    at: f64,
    value: impl Fn(&T) -> f64,
) -> f64 {
    let mut sorted: Vec<&T> = entries.iter().collect();
    sorted.sort_by(|a, b| cct(a).total_cmp(&cct(b)));
    match sorted.as_slice() {
        [] => 0.0,
        [one] => value(one),
        _ => {
            let m = 1e6 / at;
            // Mired falls as CCT rises.
            if m >= 1e6 / cct(sorted[0]) {
                return value(sorted[0]);
            }
            if m <= 1e6 / cct(sorted[sorted.len() - 1]) {
                return value(sorted[sorted.len() - 1]);
            }
            for w in sorted.windows(2) {
                let (ma, mb) = (1e6 / cct(w[0]), 1e6 / cct(w[1]));
                if m <= ma && m >= mb {
                    let t = (ma - m) / (ma - mb);
                    return value(w[0]) + t * (value(w[1]) - value(w[0]));
                }
            }
            value(sorted[sorted.len() - 1])
        }
    }
}

/// A chart shot as tuned: where the chart was, its patches, the light.
#[derive(Debug, Clone)]
pub struct ChartShot {
    /// The file.
    pub path: PathBuf,
    /// Colour temperature from the name, K.
    pub cct: f64,
    /// The chart's corners, pixels.
    pub corners: Corners,
    /// Whether they were found (not given).
    pub found: bool,
    /// Patch means per colour, black subtracted and shading corrected, DN.
    pub patches: Vec<[f64; 3]>,
    /// The light's camera colour (green 1).
    pub neutral: [f64; 3],
    /// Per-patch CIEDE2000 of the plain white-balanced camera RGB (no matrix).
    pub delta_e_before: Vec<f64>,
    /// After the fitted matrix.
    pub delta_e_after: Vec<f64>,
}

/// What a tuning run produced, beside the file.
#[derive(Debug, Clone)]
pub struct Tuned {
    /// The tuning.
    pub tuning: Tuning,
    /// Warnings to show (disagreements, ignored files).
    pub warnings: Vec<String>,
    /// The chart shots.
    pub charts: Vec<ChartShot>,
    /// The photon-transfer points per ISO and colour (mean DN, variance DN^2).
    pub transfer: Vec<(f64, [Vec<TransferPoint>; 3])>,
    /// Each flat field after the tuning's shading correction: per colour temperature and
    /// colour, the residual (corrected block mean over the frame's mean, less 1) on a grid of
    /// 32 x 32-pixel blocks, `blocks_across` wide.
    pub shading_residual: Vec<ShadingResidual>,
}

/// A flat field's residual after correction ([`Tuned::shading_residual`]).
#[derive(Debug, Clone)]
pub struct ShadingResidual {
    /// Colour temperature, K.
    pub cct: f64,
    /// Blocks across.
    pub blocks_across: usize,
    /// Residual per colour, row-major blocks.
    pub residual: [Vec<f64>; 3],
}

fn refuse(path: &Path, message: impl Into<String>) -> Error {
    Error::Message(message.into()).in_file(path)
}

/// Reads and checks a capture folder: every file decodes, all frames agree in size, pattern,
/// bits and white level, and there are enough lights and flat fields. Returns the captures and
/// the names ignored.
pub fn read_captures(
    dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<Capture>, Vec<String>), Error> {
    let entries = std::fs::read_dir(dir).map_err(|e| raw_formats::FormatError::io(dir, e))?;
    let mut names: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    names.sort();
    let mut captures: Vec<Capture> = Vec::new();
    let mut ignored = Vec::new();
    for path in names {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        if !path.is_file() {
            continue;
        }
        let Some(kind) = classify(&name) else {
            ignored.push(name);
            continue;
        };
        progress(&format!("reading {name}"));
        let dng = Dng::read(&path).map_err(Error::from)?;
        let raw = dng.image;
        if raw.samples_per_pixel != 1 {
            return Err(refuse(
                &path,
                "not a CFA mosaic (a linear or demosaiced DNG cannot be tuned)",
            ));
        }
        if let Some(first) = captures.first() {
            let f = &first.raw;
            let mismatch = |what: &str, a: String, b: String| {
                refuse(
                    &path,
                    format!(
                        "{what} {a} differs from {b} in {} (one camera mode per tuning set)",
                        first.path.display()
                    ),
                )
            };
            if (raw.width, raw.height) != (f.width, f.height) {
                return Err(mismatch(
                    "size",
                    format!("{}x{}", raw.width, raw.height),
                    format!("{}x{}", f.width, f.height),
                ));
            }
            if raw.pattern != f.pattern {
                return Err(mismatch(
                    "CFA pattern",
                    raw.pattern.name().into(),
                    f.pattern.name().into(),
                ));
            }
            if raw.bits != f.bits {
                return Err(mismatch(
                    "bit depth",
                    raw.bits.to_string(),
                    f.bits.to_string(),
                ));
            }
            if raw.white_level != f.white_level {
                return Err(mismatch(
                    "white level",
                    raw.white_level.to_string(),
                    f.white_level.to_string(),
                ));
            }
        } else if raw.width < 64 || raw.height < 64 {
            return Err(refuse(
                &path,
                format!(
                    "{}x{} is too small to tune (64x64 at least)",
                    raw.width, raw.height
                ),
            ));
        }
        captures.push(Capture {
            path,
            kind,
            raw,
            iso: dng.processing.iso,
            exposure_s: dng.processing.exposure_time_s,
        });
    }
    let charts: Vec<f64> = captures
        .iter()
        .filter_map(|c| match c.kind {
            CaptureKind::Chart { cct, .. } => Some(cct),
            _ => None,
        })
        .collect();
    let flats: Vec<f64> = captures
        .iter()
        .filter_map(|c| match c.kind {
            CaptureKind::Flat { cct } => Some(cct),
            _ => None,
        })
        .collect();
    let distinct = |v: &[f64]| {
        let mut d: Vec<f64> = v.to_vec();
        d.sort_by(f64::total_cmp);
        d.dedup_by(|a, b| (*a - *b).abs() < 1.0);
        d.len()
    };
    if distinct(&charts) < 2 {
        return Err(refuse(
            dir,
            format!(
                "{} chart shot(s) at {} colour temperature(s); at least two lights are needed \
                 (files named <name>_<CCT>k_<lux>l.dng)",
                charts.len(),
                distinct(&charts)
            ),
        ));
    }
    if distinct(&flats) < 2 {
        return Err(refuse(
            dir,
            format!(
                "flat fields at {} colour temperature(s); at least two are needed (files named alsc_<CCT>k_<n>.dng)",
                distinct(&flats)
            ),
        ));
    }
    // Photon-transfer frames come in pairs.
    let mut pairs: BTreeMap<(u64, String), [bool; 2]> = BTreeMap::new();
    for c in &captures {
        if let CaptureKind::Transfer { iso, level, side } = &c.kind {
            let e = pairs.entry((iso.to_bits(), level.clone())).or_default();
            e[usize::from(*side == 'b')] = true;
        }
    }
    for ((iso, level), sides) in &pairs {
        if sides != &[true, true] {
            let missing = if sides[0] { 'b' } else { 'a' };
            return Err(refuse(
                dir,
                format!("ptc_{}_{level}_{missing}.dng is missing (photon-transfer frames come in pairs)", f64::from_bits(*iso)),
            ));
        }
    }
    Ok((captures, ignored))
}

/// Tunes the camera whose captures `settings.captures` holds.
pub fn tune(settings: &TuneSettings, progress: &mut dyn FnMut(&str)) -> Result<Tuned, Error> {
    let (gw, gh) = settings.grid;
    if !(3..=64).contains(&gw) || !(3..=64).contains(&gh) {
        return Err(Error::Option {
            option: "--grid",
            value: format!("{gw}x{gh}"),
            allowed: "3..=64 nodes each way".into(),
        });
    }
    let (captures, ignored) = read_captures(&settings.captures, progress)?;
    let mut warnings: Vec<String> = ignored
        .iter()
        .map(|n| format!("{n}: ignored (not a chart, flat, dark or photon-transfer name)"))
        .collect();
    let first = &captures[0].raw;
    let (w, h, pattern) = (first.width, first.height, first.pattern);
    let white = f64::from(first.white_level);
    let of = |pred: &dyn Fn(&CaptureKind) -> bool| -> Vec<&Capture> {
        captures.iter().filter(|c| pred(&c.kind)).collect()
    };

    // 1. Black level.
    let darks = of(&|k| matches!(k, CaptureKind::Dark));
    let tag_black = first.black_level.map(f64::from);
    let (black, black_sigma, black_source) = if darks.is_empty() {
        warnings.push("no dark frames: the black level is the DNGs' BlackLevel tag".into());
        (tag_black, [1.0; 4], "DNG BlackLevel")
    } else {
        progress("black level from the dark frames");
        let frames: Vec<&[u16]> = darks.iter().map(|c| c.raw.samples.as_slice()).collect();
        let (b, s) = fit::black_level(&frames, w);
        if b.iter().zip(&tag_black).any(|(a, t)| (a - t).abs() > 1.0) {
            warnings.push(format!(
                "the dark frames' black level {:?} differs from the DNGs' BlackLevel {:?} by more than 1 DN; using the dark frames",
                b.map(|v| (v * 10.0).round() / 10.0),
                tag_black
            ));
        }
        (b, s, "dark frames")
    };
    let range = white - black.iter().fold(0.0f64, |a, &b| a.max(b));
    if range.is_nan() || range <= 0.0 {
        return Err(refuse(
            &captures[0].path,
            "the black level is at or above the white level",
        ));
    }

    // 2. Defects.
    progress("defects from the dark frames and flat fields");
    let mut defect_kind: BTreeMap<(usize, usize), u8> = BTreeMap::new(); // 0 hot, 1 dead, 2 stuck
    if !darks.is_empty() {
        let frames: Vec<&[u16]> = darks.iter().map(|c| c.raw.samples.as_slice()).collect();
        let mean = fit::average(&frames);
        for (x, y) in fit::hot_pixels(&mean, w, black, black_sigma, frames.len()) {
            defect_kind.insert((y, x), 0);
        }
    }
    let flats = of(&|k| matches!(k, CaptureKind::Flat { .. }));
    let mut flat_ccts: Vec<f64> = flats
        .iter()
        .filter_map(|c| match c.kind {
            CaptureKind::Flat { cct } => Some(cct),
            _ => None,
        })
        .collect();
    flat_ccts.sort_by(f64::total_cmp);
    flat_ccts.dedup_by(|a, b| (*a - *b).abs() < 1.0);
    let mut flat_means = Vec::new();
    for &cct in &flat_ccts {
        let frames: Vec<&[u16]> = flats
            .iter()
            .filter(|c| matches!(c.kind, CaptureKind::Flat { cct: k } if (k - cct).abs() < 1.0))
            .map(|c| c.raw.samples.as_slice())
            .collect();
        let mean = fit::average(&frames);
        let level = mean.iter().sum::<f64>() / mean.len() as f64 - black[0];
        if level < 0.05 * range {
            let path = &flats
                .iter()
                .find(|c| matches!(c.kind, CaptureKind::Flat { cct: k } if (k - cct).abs() < 1.0))
                .map(|c| c.path.clone())
                .unwrap_or_default();
            return Err(refuse(path, format!("the flat field at {cct} K is too dark to use (mean {:.1} % of the range; 5 % at least)", 100.0 * level / range)));
        }
        for (x, y, v, _median) in fit::flat_outliers(&mean, w, h, black) {
            defect_kind
                .entry((y, x))
                .or_insert(if v < 0.05 * range { 1 } else { 2 });
        }
        flat_means.push((cct, mean));
    }
    // A pixel high in the dark that reads the same in every flat (within 2 % of the range)
    // and below 90 % of it is stuck, not hot.
    if !darks.is_empty() && !flat_means.is_empty() {
        let frames: Vec<&[u16]> = darks.iter().map(|c| c.raw.samples.as_slice()).collect();
        let dark_mean = fit::average(&frames);
        for (&(y, x), kind) in defect_kind.iter_mut() {
            let i = y * w + x;
            let d = dark_mean[i];
            let same = flat_means
                .iter()
                .all(|(_, m)| (m[i] - d).abs() < 0.02 * range);
            if *kind == 0 && same && d - black[(y % 2) * 2 + x % 2] < 0.9 * range {
                *kind = 2;
            }
        }
    }
    // A mask, not the map: the fits below ask it of every pixel of every frame.
    let mut defect_mask = vec![false; w * h];
    for &(y, x) in defect_kind.keys() {
        defect_mask[y * w + x] = true;
    }
    let is_defect = |x: usize, y: usize| defect_mask[y * w + x];

    // 3. Shading.
    progress("lens shading from the flat fields");
    let nodes = fit::grid_nodes(gw, gh, w, h);
    let mut lum_sum = vec![0.0f64; gw * gh];
    let mut colour_tables = Vec::new();
    for (cct, mean) in &flat_means {
        let value = |x: usize, y: usize| -> Option<f64> {
            (!is_defect(x, y)).then(|| mean[y * w + x] - black[(y % 2) * 2 + x % 2])
        };
        let models: Vec<FlatModel> = (0..3)
            .map(|c| {
                FlatModel::fit(w, h, pattern, c, &value).ok_or_else(|| {
                    Error::Message(format!("the flat field at {cct} K: its shading could not be fitted (too few clean blocks)"))
                })
            })
            .collect::<Result<_, _>>()?;
        // The brightest point of green: the reference where every gain is 1.
        let mut peak = (0.0f64, (w as f64 / 2.0, h as f64 / 2.0));
        for j in 0..=32 {
            for i in 0..=32 {
                let (x, y) = (i as f64 * w as f64 / 32.0, j as f64 * h as f64 / 32.0);
                let v = models[1].at(x, y);
                if v > peak.0 {
                    peak = (v, (x, y));
                }
            }
        }
        let (px, py) = peak.1;
        let reference: [f64; 3] = std::array::from_fn(|c| models[c].at(px, py));
        if reference.iter().any(|r| r.is_nan() || *r <= 0.0) {
            return Err(Error::Message(format!(
                "the flat field at {cct} K has no signal in some colour"
            )));
        }
        let mut red = Vec::with_capacity(nodes.len());
        let mut blue = Vec::with_capacity(nodes.len());
        for (k, &(x, y)) in nodes.iter().enumerate() {
            let (cx, cy) = (x + 0.5, y + 0.5);
            let v: [f64; 3] =
                std::array::from_fn(|c| models[c].at(cx, cy).max(reference[c] / 16.0));
            lum_sum[k] += reference[1] / v[1];
            red.push((v[1] / v[0]) * (reference[0] / reference[1]));
            blue.push((v[1] / v[2]) * (reference[2] / reference[1]));
        }
        colour_tables.push(ColourTable {
            cct: *cct,
            red,
            blue,
        });
    }
    let luminance: Vec<f64> = lum_sum
        .iter()
        .map(|v| v / flat_means.len() as f64)
        .collect();

    let mut tuning = Tuning {
        version: SCHEMA_VERSION,
        camera: String::new(),
        width: w,
        height: h,
        pattern: pattern.name().into(),
        bits: first.bits,
        white_level: first.white_level,
        black_level: BlackLevel {
            values: black,
            source: black_source.into(),
        },
        noise: Vec::new(),
        defects: Defects::default(),
        shading: ShadingTables {
            grid_width: gw,
            grid_height: gh,
            luminance,
            colour: colour_tables,
        },
        awb: AwbLocus {
            coefficients: [0.0; 3],
            transverse_negative: 0.0,
            transverse_positive: 0.0,
            points: Vec::new(),
        },
        ccm: Vec::new(),
        dng: DngMatrices {
            illuminants: [0; 2],
            ccts: [0.0; 2],
            color_matrix: [[[0.0; 3]; 3]; 2],
            forward_matrix: [[[0.0; 3]; 3]; 2],
        },
    };
    for (&(y, x), &kind) in &defect_kind {
        let list = match kind {
            0 => &mut tuning.defects.hot,
            1 => &mut tuning.defects.dead,
            _ => &mut tuning.defects.stuck,
        };
        list.push([x, y]);
    }
    if let Ok(dng) = Dng::read(&captures[0].path) {
        tuning.camera = dng.camera_model;
    }

    // 4. Noise from photon transfer.
    let mut transfer = Vec::new();
    let mut isos: Vec<f64> = captures
        .iter()
        .filter_map(|c| match c.kind {
            CaptureKind::Transfer { iso, .. } => Some(iso),
            _ => None,
        })
        .collect();
    isos.sort_by(f64::total_cmp);
    isos.dedup();
    for &iso in &isos {
        progress(&format!("photon transfer at ISO {iso}"));
        let mut levels: BTreeMap<String, [Option<&Capture>; 2]> = BTreeMap::new();
        for c in &captures {
            if let CaptureKind::Transfer {
                iso: i,
                level,
                side,
            } = &c.kind
            {
                if *i == iso {
                    levels.entry(level.clone()).or_default()[usize::from(*side == 'b')] = Some(c);
                }
            }
        }
        let mut points: [Vec<TransferPoint>; 3] = Default::default();
        let mut dark: [Option<TransferPoint>; 3] = [None; 3];
        for (level, pair) in &levels {
            let [Some(a), Some(b)] = pair else { continue };
            let p = fit::transfer_point(
                &a.raw.samples,
                &b.raw.samples,
                w,
                pattern,
                black,
                &is_defect,
            );
            let clipped = a
                .raw
                .samples
                .iter()
                .enumerate()
                .filter(|&(i, &v)| {
                    let (x, y) = (i % w, i / w);
                    let b = black[(y % 2) * 2 + x % 2];
                    f64::from(v) >= b + chart::SATURATION * (white - b) && !is_defect(x, y)
                })
                .count();
            if clipped > a.raw.samples.len() / 1000 {
                warnings.push(format!(
                    "{}: {clipped} clipped samples, left out of the photon transfer",
                    a.path.display()
                ));
                continue;
            }
            let is_dark = level == "dark" || p.iter().all(|q| q.mean < 0.01 * range);
            for c in 0..3 {
                if is_dark {
                    dark[c] = Some(p[c]);
                } else if p[c].mean < 0.9 * range {
                    points[c].push(p[c]);
                }
            }
        }
        let mut scale = [0.0; 3];
        let mut offset = [0.0; 3];
        for c in 0..3 {
            let (s, o) = fit::transfer_fit(&points[c], dark[c]).ok_or_else(|| {
                refuse(
                    &settings.captures,
                    format!("ISO {iso}: too few usable photon-transfer levels for colour {c} (two, or one and a dark pair)"),
                )
            })?;
            scale[c] = s / range;
            offset[c] = o / (range * range);
        }
        tuning.noise.push(NoiseEntry {
            iso,
            scale,
            offset,
            source: "photon transfer".into(),
        });
        transfer.push((iso, points));
    }

    // 5. Charts.
    let charts_in = of(&|k| matches!(k, CaptureKind::Chart { .. }));
    let mut shots = Vec::new();
    for c in &charts_in {
        let CaptureKind::Chart { cct, .. } = c.kind else {
            continue;
        };
        progress(&format!("chart in {}", c.path.display()));
        let m = Mosaic::of(&c.raw, black);
        let (corners, found) = match settings.chart {
            Some(k) => (k, false),
            None => (
                chart::detect(&m).map_err(|e| refuse(&c.path, e.to_string()))?,
                true,
            ),
        };
        let map = ChartMap::from_corners(&corners)
            .ok_or_else(|| refuse(&c.path, "the chart's corners do not make a quadrilateral"))?;
        if map.pitch_px() < 6.0 {
            return Err(refuse(
                &c.path,
                "the chart is too small to sample (patches under 6 pixels)",
            ));
        }
        let gain = |x: usize, y: usize, colour: usize| -> f64 {
            if is_defect(x, y) {
                f64::NAN
            } else {
                tuning.shading_gain(x as f64 + 0.5, y as f64 + 0.5, colour, cct)
            }
        };
        let patches = chart::sample_patches_corrected(&m, &map, 0.3, &gain);
        let clipped: Vec<usize> = patches
            .iter()
            .enumerate()
            .filter(|(_, p)| p.clipped * 200 > p.count.iter().sum::<usize>())
            .map(|(i, _)| i + 1)
            .collect();
        if !clipped.is_empty() {
            return Err(refuse(&c.path, format!("patches {clipped:?} are clipped (numbered 1..24 from dark skin); shoot it darker")));
        }
        let white_patch = patches[chart::NEUTRALS[0]].mean;
        if white_patch.iter().fold(f64::INFINITY, |a, &b| a.min(b)) < 0.05 * range {
            return Err(refuse(
                &c.path,
                format!(
                    "too dark to use: the white patch (19) reads {:.1} % of the range in its darkest colour (5 % at least)",
                    100.0 * white_patch.iter().fold(f64::INFINITY, |a, &b| a.min(b)) / range
                ),
            ));
        }
        let means: Vec<[f64; 3]> = patches.iter().map(|p| p.mean).collect();
        let mut neutral = [0.0; 3];
        for &g in &chart::NEUTRALS[..5] {
            for k in 0..3 {
                neutral[k] += means[g][k] / means[g][1] / 5.0;
            }
        }
        shots.push((c, cct, corners, found, means, neutral, patches));
    }

    // Noise from the chart patches when no photon transfer was given: one profile per ISO the
    // chart shots' DNGs give (ISOSpeedRatings), ISO 0 for shots that do not say. The dark
    // frames of that ISO pin the zero-signal end: their temporal variance is O, their spatial
    // variance the patches' intercept, so S is fitted with nothing to extrapolate.
    if tuning.noise.is_empty() {
        let mut isos: Vec<Option<u16>> = shots.iter().map(|s| s.0.iso).collect();
        isos.sort_unstable();
        isos.dedup();
        for iso in isos {
            let iso_name = iso.map_or("without an ISO tag".to_string(), |i| format!("ISO {i}"));
            let same_iso: Vec<&Capture> = darks.iter().copied().filter(|d| d.iso == iso).collect();
            let frames: Vec<&[u16]> = same_iso.iter().map(|c| c.raw.samples.as_slice()).collect();
            let dark = fit::dark_variance(&frames, w, pattern, &is_defect);
            let chart_exposures: Vec<f64> = shots
                .iter()
                .filter(|s| s.0.iso == iso)
                .filter_map(|s| s.0.exposure_s)
                .collect();
            let dark_exposures: Vec<f64> = same_iso.iter().filter_map(|c| c.exposure_s).collect();
            if let (Some(d), Some(c)) = (
                dark_exposures.iter().copied().reduce(f64::max),
                chart_exposures.iter().copied().reduce(f64::max),
            ) {
                let (lo, hi) = (
                    dark_exposures.iter().copied().fold(d, f64::min),
                    chart_exposures.iter().copied().fold(c, f64::min),
                );
                if d.max(c) > 2.0 * lo.min(hi) {
                    warnings.push(format!("{iso_name}: the darks ({lo:.4}-{d:.4} s) and the chart shots ({hi:.4}-{c:.4} s) differ in exposure by more than 2x; the noise offset from the darks misses or adds the dark charge of the difference"));
                }
            }
            match &dark {
                None => warnings.push(format!("{iso_name}: no dark frames; the noise offset O is the chart patches' fit extrapolated to zero signal (tens of percent off; shoot two darks at the charts' exposure)")),
                Some(d) if d.temporal.is_none() => warnings.push(format!("{iso_name}: one dark frame; the noise offset O is its spatial variance, which holds the fixed-pattern DSNU too (two darks give the temporal offset)")),
                Some(_) => {}
            }
            let mut scale = [0.0; 3];
            let mut offset = [0.0; 3];
            for c in 0..3 {
                let pts: Vec<TransferPoint> = shots
                    .iter()
                    .filter(|s| s.0.iso == iso)
                    .flat_map(|s| s.6.iter())
                    .map(|p| TransferPoint {
                        mean: p.mean[c],
                        variance: p.variance[c],
                    })
                    .filter(|p| p.mean > 0.0)
                    .collect();
                let fitted = match &dark {
                    Some(d) => fit::patch_scale_fit(&pts, d.spatial[c])
                        .map(|s| (s, d.temporal.unwrap_or(d.spatial)[c])),
                    None => fit::patch_noise_fit(&pts),
                };
                let (s, o) = fitted.ok_or_else(|| {
                    refuse(
                        &settings.captures,
                        "the chart patches do not fit a noise profile",
                    )
                })?;
                scale[c] = s / range;
                offset[c] = o / (range * range);
            }
            tuning.noise.push(NoiseEntry {
                iso: iso.map_or(0.0, f64::from),
                scale,
                offset,
                source: if dark.is_some() {
                    "chart patches and dark frames".into()
                } else {
                    "chart patches".into()
                },
            });
            if iso.is_none() {
                warnings.push("no photon-transfer pairs and chart shots without an ISO tag: their noise profile comes from the chart patches, written as ISO 0".into());
            }
        }
    }

    // 6. White-balance locus.
    progress("white-balance locus");
    let lights: Vec<(f64, [f64; 3])> = shots.iter().map(|s| (s.1, s.5)).collect();
    let locus = Locus::fit(&lights).ok_or_else(|| {
        refuse(
            &settings.captures,
            "the lights' colours do not make a locus (two at the same colour?)",
        )
    })?;
    let mut neg: f64 = 0.0;
    let mut pos: f64 = 0.0;
    for (_, n) in &lights {
        let (_, d) = locus.project(fit::chromaticity(*n));
        neg = neg.max(-d);
        pos = pos.max(d);
    }
    tuning.awb = AwbLocus {
        coefficients: locus.coefficients,
        // A margin around the measured lights, as Raspberry Pi's tool leaves one.
        transverse_negative: neg + 0.01,
        transverse_positive: pos + 0.01,
        points: lights
            .iter()
            .map(|(cct, n)| AwbPoint {
                cct: *cct,
                red_gain: 1.0 / n[0],
                blue_gain: 1.0 / n[2],
            })
            .collect(),
    };

    // 7. Colour matrices.
    let mut chart_shots = Vec::new();
    for (c, cct, corners, found, means, neutral, _) in &shots {
        progress(&format!("colour matrix at {cct} K"));
        let balanced: Vec<[f64; 3]> = means
            .iter()
            .map(|m| std::array::from_fn(|k| m[k] / neutral[k] / range))
            .collect();
        let stem = c
            .path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default();
        let (light, _) = reference::light_for_shot(stem, *cct)?;
        let target = reference::chart_srgb(&light)?;
        let fitted = fit::fit_ccm(&balanced, &target, &chart::NEUTRALS[..5])
            .ok_or_else(|| refuse(&c.path, "the colour matrix fit failed (patches all alike?)"))?;
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let before = fit::ccm_errors(&identity, fitted.scale, &balanced, &target);
        let mean = fitted.delta_e.iter().sum::<f64>() / fitted.delta_e.len() as f64;
        let max = fitted.delta_e.iter().fold(0.0f64, |a, &b| a.max(b));
        tuning.ccm.push(CcmEntry {
            cct: *cct,
            matrix: fitted.matrix,
            delta_e_mean: mean,
            delta_e_max: max,
        });
        chart_shots.push(ChartShot {
            path: c.path.clone(),
            cct: *cct,
            corners: *corners,
            found: *found,
            patches: means.clone(),
            neutral: *neutral,
            delta_e_before: before,
            delta_e_after: fitted.delta_e,
        });
    }
    tuning.ccm.sort_by(|a, b| a.cct.total_cmp(&b.cct));
    let shading_residual = flat_means
        .iter()
        .map(|(cct, mean)| residual_of(&tuning, mean, *cct, &is_defect))
        .collect();
    tuning.dng = dng_matrices(&tuning, &chart_shots)?;
    Ok(Tuned {
        tuning,
        warnings,
        charts: chart_shots,
        transfer,
        shading_residual,
    })
}

/// A flat field corrected by the tuning's shading at `cct`, in 32-pixel blocks.
fn residual_of(
    tuning: &Tuning,
    flat: &[f64],
    cct: f64,
    is_defect: &dyn Fn(usize, usize) -> bool,
) -> ShadingResidual {
    const BLOCK: usize = 32;
    let (w, h) = (tuning.width, tuning.height);
    let pattern = isp_core::CfaPattern::ALL
        .into_iter()
        .find(|p| p.name() == tuning.pattern)
        .unwrap_or(isp_core::CfaPattern::Rggb);
    let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    let mut residual: [Vec<f64>; 3] = Default::default();
    for (c, out) in residual.iter_mut().enumerate() {
        let mut means = Vec::with_capacity(bw * bh);
        for by in 0..bh {
            for bx in 0..bw {
                let (mut s, mut n) = (0.0, 0.0);
                for y in by * BLOCK..((by + 1) * BLOCK).min(h) {
                    for x in bx * BLOCK..((bx + 1) * BLOCK).min(w) {
                        if pattern.colour_at(x, y).index() != c || is_defect(x, y) {
                            continue;
                        }
                        let v = flat[y * w + x] - tuning.black_level.values[(y % 2) * 2 + x % 2];
                        s += v * tuning.shading_gain(x as f64 + 0.5, y as f64 + 0.5, c, cct);
                        n += 1.0;
                    }
                }
                means.push(if n > 0.0 { s / n } else { f64::NAN });
            }
        }
        let valid: Vec<f64> = means.iter().copied().filter(|v| v.is_finite()).collect();
        let overall = valid.iter().sum::<f64>() / valid.len().max(1) as f64;
        *out = means.iter().map(|m| m / overall - 1.0).collect();
    }
    ShadingResidual {
        cct,
        blocks_across: bw,
        residual,
    }
}

/// ColorMatrix/ForwardMatrix for the warmest and coolest light: with `C` the colour matrix
/// (balanced camera to linear sRGB, D65) and `n` the light's camera colour, camera to XYZ
/// under the light is `B(D65 -> light) M_srgb C diag(1/n)`; the ColorMatrix is its inverse
/// scaled as Adobe does, the ForwardMatrix `B(D65 -> D50) M_srgb C`.
fn dng_matrices(tuning: &Tuning, shots: &[ChartShot]) -> Result<DngMatrices, Error> {
    let mut sorted: Vec<&ChartShot> = shots.iter().collect();
    sorted.sort_by(|a, b| a.cct.total_cmp(&b.cct));
    let pick = [sorted[0], sorted[sorted.len() - 1]];
    let d65 = colour::xy_to_xyz(colour::D65_XY)?;
    let d50 = colour::xy_to_xyz(colour::D50_XY)?;
    let mut out = DngMatrices {
        illuminants: [0; 2],
        ccts: [0.0; 2],
        color_matrix: [[[0.0; 3]; 3]; 2],
        forward_matrix: [[[0.0; 3]; 3]; 2],
    };
    for (k, shot) in pick.iter().enumerate() {
        let ccm = tuning.ccm_at(shot.cct);
        let srgb_to_xyz = colour::mat3_mul(&colour::LINEAR_SRGB_TO_XYZ, &ccm);
        let light_xy = reference::light_xy(shot.cct)?;
        let light = colour::xy_to_xyz(light_xy)?;
        let to_light = colour::bradford_adaptation(d65, light)?;
        let unbalance = [
            [1.0 / shot.neutral[0], 0.0, 0.0],
            [0.0, 1.0 / shot.neutral[1], 0.0],
            [0.0, 0.0, 1.0 / shot.neutral[2]],
        ];
        let camera_to_xyz =
            colour::mat3_mul(&to_light, &colour::mat3_mul(&srgb_to_xyz, &unbalance));
        let illuminant = nearest_illuminant(shot.cct);
        let cal = ColourCalibration::from_camera_to_xyz(illuminant, &camera_to_xyz, light)?;
        out.illuminants[k] = illuminant.code();
        out.ccts[k] = shot.cct;
        out.color_matrix[k] = cal.color_matrix;
        out.forward_matrix[k] =
            colour::mat3_mul(&colour::bradford_adaptation(d65, d50)?, &srgb_to_xyz);
    }
    Ok(out)
}

/// The EXIF light source nearest a colour temperature: A, D50, D55, D65, D75, or the
/// fluorescent classes in between.
fn nearest_illuminant(cct: f64) -> Illuminant {
    let candidates = [
        Illuminant::A,
        Illuminant::Other(15), // white fluorescent, 3450 K
        Illuminant::Other(14), // cool white fluorescent, 4200 K
        Illuminant::D50,
        Illuminant::D55,
        Illuminant::D65,
        Illuminant::D75,
    ];
    candidates
        .into_iter()
        .min_by(|a, b| {
            let d = |i: &Illuminant| (1e6 / i.cct_k().unwrap_or(5000.0) - 1e6 / cct).abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(Illuminant::D65)
}

/// Writes `text` to `path` whole or not at all: a temporary file beside it, then a rename.
pub fn write_atomically(path: &Path, text: &str) -> Result<(), Error> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| raw_formats::FormatError::io(parent, e))?;
    }
    let tmp = path.with_extension("toml.partial");
    std::fs::write(&tmp, text).map_err(|e| raw_formats::FormatError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| raw_formats::FormatError::io(path, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_classify_as_the_tuning_tool_names_them() {
        assert_eq!(
            classify("macbeth_2856k_800l.dng"),
            Some(CaptureKind::Chart {
                cct: 2856.0,
                lux: 800.0
            })
        );
        assert_eq!(
            classify("chart_D65_6504k_1000l.dng"),
            Some(CaptureKind::Chart {
                cct: 6504.0,
                lux: 1000.0
            })
        );
        assert_eq!(
            classify("alsc_3000k_1.dng"),
            Some(CaptureKind::Flat { cct: 3000.0 })
        );
        assert_eq!(classify("dark_2.dng"), Some(CaptureKind::Dark));
        assert_eq!(
            classify("ptc_400_3_b.dng"),
            Some(CaptureKind::Transfer {
                iso: 400.0,
                level: "3".into(),
                side: 'b'
            })
        );
        assert_eq!(classify("notes.txt"), None);
        assert_eq!(classify("holiday.dng"), None);
        assert_eq!(classify("alsc_3000k.dng"), None);
    }
}

/// What a tuning sets for one frame ([`options_for`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Applied {
    /// The ISP options: black level, defects, noise profile, white-balance gains, lens shading
    /// and colour matrix at the frame's colour temperature.
    pub options: crate::isp_options::IspOptions,
    /// The colour temperature the locus gave, K.
    pub cct: f64,
    /// The white balance through the locus (green 1).
    pub gains: [f32; 3],
    /// The ISO whose noise profile was taken.
    pub noise_iso: f64,
}

/// The ISP options a tuning implies for `raw`: the black level, the defect map, the noise
/// profile at the tuned ISO nearest `iso` (the lowest without one), the white balance
/// estimated by `awb` and moved into the locus's band, and the lens shading and colour matrix
/// interpolated at the colour temperature the locus gives. Refuses a frame of another size,
/// pattern or bit depth than the tuning's.
pub fn options_for(
    tuning: &Tuning,
    raw: &RawImage,
    awb: isp_core::wb::AwbMethod,
    iso: Option<f64>,
) -> Result<Applied, Error> {
    use crate::isp_options::{IspOptions, ShadingGrid, WhiteBalance};
    if (raw.width, raw.height, raw.pattern.name(), raw.bits)
        != (
            tuning.width,
            tuning.height,
            tuning.pattern.as_str(),
            tuning.bits,
        )
    {
        return Err(Error::Option {
            option: "--tuning",
            value: format!(
                "a tuning of {}x{} {} {}-bit",
                tuning.width, tuning.height, tuning.pattern, tuning.bits
            ),
            allowed: format!(
                "one of this frame's camera mode ({}x{} {} {}-bit)",
                raw.width,
                raw.height,
                raw.pattern.name(),
                raw.bits
            ),
        });
    }
    let black = tuning.black_dn();
    let frame = isp_core::frame::RawFrame::new(
        &raw.samples,
        raw.width,
        raw.height,
        raw.width,
        raw.bits,
        raw.pattern,
        black,
        tuning.white_level,
    )
    .map_err(|e| Error::in_stage("--tuning: the raw frame", e))?;
    let estimate = isp_core::wb::estimate(&frame, awb, &colour::LINEAR_SRGB_TO_XYZ)
        .map_err(|e| Error::in_stage("--awb", e))?;
    let neutral = estimate.neutral.map(f64::from);
    let (gains, cct) = tuning.constrain_white(neutral).ok_or(Error::Option {
        option: "--tuning",
        value: "its white-balance locus".into(),
        allowed: "a locus with at least two lights".into(),
    })?;
    let (gw, gh) = (tuning.shading.grid_width, tuning.shading.grid_height);
    let nodes = fit::grid_nodes(gw, gh, tuning.width, tuning.height);
    let mut gains_q12 = Vec::with_capacity(nodes.len() * 4);
    for &(x, y) in &nodes {
        for p in 0..4 {
            let c = raw.pattern.colour_at(p % 2, p / 2).index();
            let g = tuning.shading_gain(x + 0.5, y + 0.5, c, cct);
            gains_q12.push(
                (g * f64::from(isp_core::lsc::ONE_Q12))
                    .round()
                    .clamp(0.0, 65535.0) as u16,
            );
        }
    }
    let entry = tuning
        .noise
        .iter()
        .min_by(|a, b| {
            let d = |e: &NoiseEntry| iso.map_or(e.iso, |i| (e.iso - i).abs());
            d(a).total_cmp(&d(b))
        })
        .ok_or(Error::Option {
            option: "--tuning",
            value: "no noise profile".into(),
            allowed: "a tuning with at least one [[noise]] entry".into(),
        })?;
    let noise = isp_core::noise::NoiseProfile::new(
        entry.scale.map(|v| v as f32),
        entry.offset.map(|v| v as f32),
    )
    .map_err(|e| Error::in_stage("--tuning: the noise profile", e))?;
    let d = &tuning.defects;
    let mut defects: Vec<isp_core::dpc::Defect> = d
        .hot
        .iter()
        .chain(&d.dead)
        .chain(&d.stuck)
        .filter(|p| p[0] < raw.width && p[1] < raw.height)
        .map(|p| isp_core::dpc::Defect {
            x: p[0] as u16,
            y: p[1] as u16,
        })
        .collect();
    defects.sort();
    defects.dedup();
    let ccm = tuning.ccm_at(cct).map(|r| r.map(|v| v as f32));
    let gains32 = gains.map(|g| g as f32);
    Ok(Applied {
        options: IspOptions {
            black_level: Some(black.to_vec()),
            white_level: Some(tuning.white_level),
            white_balance: Some(WhiteBalance::Gains(gains32)),
            ccm: Some(ccm),
            noise_profile: Some(noise),
            defects: Some(defects),
            lsc: Some(ShadingGrid {
                width: gw,
                height: gh,
                gains_q12,
            }),
            ..IspOptions::default()
        },
        cct,
        gains: gains32,
        noise_iso: entry.iso,
    })
}

impl Tuning {
    /// The black level per CFA position in whole DN, as a frame's BlackLevel holds it.
    pub fn black_dn(&self) -> [u16; 4] {
        self.black_level
            .values
            .map(|v| v.round().clamp(0.0, f64::from(self.white_level)) as u16)
    }

    /// Reads and checks a tuning file (the error names it).
    pub fn read(path: &Path) -> Result<Tuning, Error> {
        let text =
            std::fs::read_to_string(path).map_err(|e| raw_formats::FormatError::io(path, e))?;
        Tuning::from_toml(&text).map_err(|e| e.in_file(path))
    }
}

/// The DNG BayerPhase of a pattern: the colour of the top-left pixel, green told apart by
/// its row (0 red, 1 green on a red row, 2 green on a blue row, 3 blue).
fn bayer_phase(pattern: isp_core::CfaPattern) -> u32 {
    use isp_core::CfaColour as Colour;
    match (pattern.colour_at(0, 0), pattern.colour_at(1, 0)) {
        (Colour::Red, _) => 0,
        (Colour::Green, Colour::Red) => 1,
        (Colour::Green, _) => 2,
        (Colour::Blue, _) => 3,
    }
}

/// Makes `dng` carry what `tuning` implies for its frame, as a camera whose firmware holds
/// the tuning would write it: BlackLevel per CFA position; ColorMatrix1/2 and
/// ForwardMatrix1/2 with their illuminants; AsShotNeutral from the white balance `awb`
/// estimates moved into the locus; NoiseProfile at the tuned ISO nearest `iso`; the defect
/// map as a FixBadPixelsList in OpcodeList1; the lens shading at the locus's colour
/// temperature as four GainMaps (one per CFA position) in OpcodeList2, on the tuning's grid.
/// Whatever `dng` carried of these is replaced; its samples are not touched. Returns what
/// the ISP options of the tuning are for this frame (as `camsim isp --tuning` takes them).
pub fn carry_in_dng(
    tuning: &Tuning,
    dng: &mut Dng,
    awb: isp_core::wb::AwbMethod,
    iso: Option<f64>,
) -> Result<Applied, Error> {
    use raw_formats::dng::opcodes::{GainMap, Opcode};
    let applied = options_for(tuning, &dng.image, awb, iso)?;
    let raw = &mut dng.image;
    raw.black_level = tuning.black_dn();
    raw.white_level = tuning.white_level;
    let (w, h) = (raw.width, raw.height);
    dng.colour.calibrations = (0..2)
        .map(|k| ColourCalibration {
            illuminant: Illuminant::from_code(tuning.dng.illuminants[k]),
            color_matrix: tuning.dng.color_matrix[k],
            forward_matrix: Some(tuning.dng.forward_matrix[k]),
            camera_calibration: None,
        })
        .collect();
    dng.colour.as_shot_neutral = Some(applied.gains.map(|g| 1.0 / f64::from(g)));
    dng.colour.as_shot_white_xy = None;
    dng.colour.analog_balance = None;
    dng.processing.noise_profile = applied.options.noise_profile;
    let mut points: Vec<[u32; 2]> = applied
        .options
        .defects
        .iter()
        .flatten()
        .map(|d| [u32::from(d.y), u32::from(d.x)])
        .collect();
    points.sort_unstable();
    let mut lists: [Vec<Opcode>; 3] = Default::default();
    if !points.is_empty() {
        lists[0].push(Opcode::FixBadPixelsList {
            bayer_phase: bayer_phase(raw.pattern),
            points,
            rects: Vec::new(),
        });
    }
    if let Some(grid) = &applied.options.lsc {
        // isp-core's grid puts node i on pixel i (w - 1) / (gw - 1); a GainMap's points sit at
        // fractions of the image whose pixel centres are (x + 0.5) / w.
        let (gw, gh) = (grid.width, grid.height);
        let spacing = |n: usize, g: usize| (n.max(2) - 1) as f64 / ((g - 1) as f64 * n as f64);
        for p in 0..4usize {
            lists[1].push(Opcode::GainMap(GainMap {
                area: [(p / 2) as u32, (p % 2) as u32, h as u32, w as u32],
                plane: 0,
                planes: 1,
                row_pitch: 2,
                col_pitch: 2,
                points: [gh as u32, gw as u32],
                spacing: [spacing(h, gh), spacing(w, gw)],
                origin: [0.5 / h as f64, 0.5 / w as f64],
                map_planes: 1,
                gains: grid
                    .gains_q12
                    .chunks_exact(4)
                    .map(|node| f32::from(node[p]) / f32::from(isp_core::lsc::ONE_Q12))
                    .collect(),
            }));
        }
    }
    dng.processing.opcode_lists = lists;
    dng.processing.bad_pixels = applied.options.defects.clone().unwrap_or_default();
    Ok(applied)
}
