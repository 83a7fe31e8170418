//! The processing options of `camsim isp`, from the command line and from a TOML file
//! (`--config isp.toml`), merged: a flag given on the command line wins over the file, the file
//! over the default. The file uses the flags' names as keys and TOML types for the values, and
//! can also hold what is too long for a flag: a lens-shading grid and a static defect list.
//!
//! ```toml
//! pattern = "GRBG"
//! bits = 12
//! black-level = 64                 # or four, one per 2x2 CFA position row by row (three, R G B, for a linear DNG)
//! white-level = 4095
//! gain = 1.5
//! wb = [2.1, 1.0, 1.6]             # or: awb = "grey-world"
//! ccm = [[1.6, -0.4, -0.2], [-0.3, 1.5, -0.2], [0.0, -0.5, 1.5]]
//! demosaic = "mhc"
//! denoise = 1.5                    # noise reduction, a multiplier on the profile's default (1); 0 is off
//! denoise-search = "wide"          # "wide" (5x5 search, the default) or "fast" (3x3, for video and firmware)
//! chroma-denoise = 1               # chroma noise reduction after encoding, [0, 4]; 0 is off
//! noise-profile = [0.0032, 1.2e-5]  # var = S x + O (x: fraction of white above black); or six, S, O per R G B
//! highlight-knee = 0.9             # clipped colour fades to neutral above it; 1 is off
//! sharpen = 0.5                    # unsharp mask on luma, [0, 4]; 0 is off
//! dpc-threshold = 400
//! defects = [[10, 20], [11, 20]]   # static defective pixels, [x, y]
//! look = "vivid"
//! path = "fixed"
//! out-bits = 16
//! distortion = [-0.28, 0.09, 0.002, -0.001, -0.01]   # k1, k2, p1, p2[, k3] (OpenCV order)
//! camera-matrix = [690.0, 690.0, 383.5, 255.5]       # fx, fy, cx, cy in pixels
//!
//! [lsc]                            # lens shading gains, grid-width x grid-height nodes
//! grid-width = 3
//! grid-height = 2
//! gains = [[1.4, 1.3, 1.3, 1.5], [1.0, 1.0, 1.0, 1.0], [1.4, 1.3, 1.3, 1.5],
//!          [1.4, 1.3, 1.3, 1.5], [1.0, 1.0, 1.0, 1.0], [1.4, 1.3, 1.3, 1.5]]
//! ```
//!
//! Each `gains` entry is one node, row by row from the top-left, with four gains in `[0, 16)`
//! for the 2x2 CFA positions row by row.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use isp_core::demosaic::Method;
use isp_core::denoise::Search;
use isp_core::dpc::Defect;
use isp_core::noise::NoiseProfile;
use isp_core::tone::Look;
use isp_core::wb::AwbMethod;
use isp_core::CfaPattern;
use toml::{Spanned, Value};

/// Where a refused option was given.
#[derive(Debug, Clone, PartialEq)]
pub enum Place {
    /// On the command line, e.g. `--wb`.
    Flag(String),
    /// In a config file, at a line and key (both unknown for a file that does not parse).
    File {
        /// The file.
        file: PathBuf,
        /// The line of the key's value.
        line: Option<usize>,
        /// The key.
        key: Option<String>,
    },
}

/// What is wrong with an option.
#[derive(Debug, Clone, PartialEq)]
pub enum Problem {
    /// The value is not one the option allows.
    NotAllowed {
        /// What is allowed.
        allowed: String,
        /// The value given.
        got: String,
    },
    /// Refused for a reason in words (a wrong type, an unknown key, a component's refusal).
    Invalid(String),
}

/// A refused processing option: where it was given and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct OptionError {
    /// Where.
    pub place: Place,
    /// What.
    pub problem: Problem,
}

impl OptionError {
    fn not_allowed(what: &str, allowed: impl Into<String>, got: impl std::fmt::Display) -> Self {
        Self {
            place: Place::Flag(what.to_owned()),
            problem: Problem::NotAllowed {
                allowed: allowed.into(),
                got: got.to_string(),
            },
        }
    }

    fn invalid(what: &str, reason: impl std::fmt::Display) -> Self {
        Self {
            place: Place::Flag(what.to_owned()),
            problem: Problem::Invalid(reason.to_string()),
        }
    }
}

impl std::fmt::Display for OptionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (&self.place, &self.problem) {
            (Place::Flag(flag), Problem::NotAllowed { allowed, got }) => {
                write!(f, "{flag} must be {allowed} (got {got})")
            }
            (Place::Flag(flag), Problem::Invalid(reason)) => write!(f, "{flag}: {reason}"),
            (Place::File { file, line, key }, problem) => {
                write!(f, "{}", file.display())?;
                if let Some(line) = line {
                    write!(f, ":{line}")?;
                }
                if let Some(key) = key {
                    write!(f, ": {key}")?;
                }
                match problem {
                    Problem::NotAllowed { allowed, got } => {
                        write!(f, ": must be {allowed} (got {got})")
                    }
                    Problem::Invalid(reason) => write!(f, ": {reason}"),
                }
            }
        }
    }
}

impl std::error::Error for OptionError {}

/// The result type of the option parsers.
pub type Result<T> = std::result::Result<T, OptionError>;

/// How white balance is set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WhiteBalance {
    /// Fixed gains R, G, B.
    Gains([f32; 3]),
    /// Estimated from the frame.
    Auto(AwbMethod),
}

/// A lens shading grid: sides in nodes and Q4.12 gains, `[node][CFA position]` row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadingGrid {
    /// Nodes across.
    pub width: usize,
    /// Nodes down.
    pub height: usize,
    /// `width * height * 4` gains in Q4.12.
    pub gains_q12: Vec<u16>,
}

/// Every processing option, each `None` where its source did not set it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IspOptions {
    /// CFA pattern.
    pub pattern: Option<CfaPattern>,
    /// Bits of raw data per sample.
    pub bits: Option<u8>,
    /// Black level: one value, four (per 2x2 CFA position) or three (per channel, linear).
    pub black_level: Option<Vec<u16>>,
    /// White level.
    pub white_level: Option<u16>,
    /// ISO / digital gain.
    pub gain: Option<f32>,
    /// White balance.
    pub white_balance: Option<WhiteBalance>,
    /// Colour matrix.
    pub ccm: Option<[[f32; 3]; 3]>,
    /// Demosaicing method.
    pub demosaic: Option<Method>,
    /// Denoise strength.
    pub denoise: Option<f32>,
    /// Noise reduction's search window (wide, the default, or fast).
    pub denoise_search: Option<Search>,
    /// The raw's noise profile (else the file's, else estimated from the frame).
    pub noise_profile: Option<NoiseProfile>,
    /// Dynamic defective-pixel threshold.
    pub dpc_threshold: Option<u16>,
    /// Static defective pixels, sorted.
    pub defects: Option<Vec<Defect>>,
    /// Lens shading grid.
    pub lsc: Option<ShadingGrid>,
    /// Look.
    pub look: Option<Look>,
    /// Fixed-point path (else float).
    pub fixed: Option<bool>,
    /// Output depth.
    pub out_bits: Option<u8>,
    /// Distortion coefficients in OpenCV's order `[k1, k2, p1, p2, k3]`.
    pub distortion: Option<[f64; 5]>,
    /// Camera matrix `[fx, fy, cx, cy]`.
    pub camera_matrix: Option<[f64; 4]>,
    /// The output's framing: the file's recommended crop, or the whole active area.
    pub crop: Option<CropChoice>,
    /// Whether a DNG's BaselineExposure is applied (as gain).
    pub baseline_exposure: Option<bool>,
    /// Highlight knee in `[0, 1]` (1 is off): colour fades to neutral above it.
    pub highlight_knee: Option<f32>,
    /// Sharpening amount in `[0, 4]` (0 is off): an unsharp mask on luma after encoding.
    pub sharpen: Option<f32>,
    /// Chroma noise reduction's strength in `[0, 4]` (0 is off).
    pub chroma_denoise: Option<f32>,
    /// A tuning file from `camsim tune`, applied under every other option
    /// ([`crate::tune::options_for`]).
    pub tuning: Option<std::path::PathBuf>,
}

/// Which part of the raw's active area the developed image shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CropChoice {
    /// The file's DefaultCrop, as Adobe's raw converters frame it (the whole active area if
    /// the file has none).
    #[default]
    Default,
    /// The whole active area, as LibRaw frames it.
    Active,
}

impl CropChoice {
    /// The name the command line and config file use.
    pub fn name(self) -> &'static str {
        match self {
            CropChoice::Default => "default",
            CropChoice::Active => "active",
        }
    }
}

impl IspOptions {
    /// Each option from `self` where set, else from `fallback`.
    pub fn or(self, fallback: IspOptions) -> IspOptions {
        IspOptions {
            pattern: self.pattern.or(fallback.pattern),
            bits: self.bits.or(fallback.bits),
            black_level: self.black_level.or(fallback.black_level),
            white_level: self.white_level.or(fallback.white_level),
            gain: self.gain.or(fallback.gain),
            white_balance: self.white_balance.or(fallback.white_balance),
            ccm: self.ccm.or(fallback.ccm),
            demosaic: self.demosaic.or(fallback.demosaic),
            denoise: self.denoise.or(fallback.denoise),
            denoise_search: self.denoise_search.or(fallback.denoise_search),
            noise_profile: self.noise_profile.or(fallback.noise_profile),
            dpc_threshold: self.dpc_threshold.or(fallback.dpc_threshold),
            defects: self.defects.or(fallback.defects),
            lsc: self.lsc.or(fallback.lsc),
            look: self.look.or(fallback.look),
            fixed: self.fixed.or(fallback.fixed),
            out_bits: self.out_bits.or(fallback.out_bits),
            distortion: self.distortion.or(fallback.distortion),
            camera_matrix: self.camera_matrix.or(fallback.camera_matrix),
            crop: self.crop.or(fallback.crop),
            baseline_exposure: self.baseline_exposure.or(fallback.baseline_exposure),
            highlight_knee: self.highlight_knee.or(fallback.highlight_knee),
            sharpen: self.sharpen.or(fallback.sharpen),
            chroma_denoise: self.chroma_denoise.or(fallback.chroma_denoise),
            tuning: self.tuning.or(fallback.tuning),
        }
    }
}

/// Parses a CFA pattern name; `what` names the option in the error.
pub fn pattern(text: &str, what: &str) -> Result<CfaPattern> {
    text.parse().map_err(|_| {
        OptionError::not_allowed(what, "one of RGGB, BGGR, GRBG, GBRG", format!("{text:?}"))
    })
}

/// Parses the name of a noise-reduction search window: `wide` or `fast`.
pub fn denoise_search(text: &str, what: &str) -> Result<Search> {
    Search::from_name(text)
        .map_err(|_| OptionError::not_allowed(what, "wide or fast", format!("{text:?}")))
}

/// Parses the name of a demosaicing method the pipeline runs.
pub fn demosaic(text: &str, what: &str) -> Result<Method> {
    text.parse().map_err(|_| {
        OptionError::not_allowed(
            what,
            "one of nearest, bilinear, mhc, directional",
            format!("{text:?}"),
        )
    })
}

/// Parses a look name.
pub fn look(text: &str, what: &str) -> Result<Look> {
    text.parse().map_err(|e| OptionError::invalid(what, e))
}

/// Parses an AWB method name.
pub fn awb(text: &str, what: &str) -> Result<AwbMethod> {
    AwbMethod::from_name(text).map_err(|e| OptionError::invalid(what, e))
}

/// `float` or `fixed`, as whether the fixed path runs.
pub fn path(text: &str, what: &str) -> Result<bool> {
    match text {
        "float" => Ok(false),
        "fixed" => Ok(true),
        other => Err(OptionError::not_allowed(
            what,
            "float or fixed",
            format!("{other:?}"),
        )),
    }
}

/// `default` or `active`.
pub fn crop(text: &str, what: &str) -> Result<CropChoice> {
    [CropChoice::Default, CropChoice::Active]
        .into_iter()
        .find(|c| c.name() == text)
        .ok_or_else(|| OptionError::not_allowed(what, "default or active", format!("{text:?}")))
}

/// 8 or 16.
pub fn out_bits(bits: u8, what: &str) -> Result<u8> {
    match bits {
        8 | 16 => Ok(bits),
        b => Err(OptionError::not_allowed(what, "8 or 16", b)),
    }
}

/// Checks a count of finite numbers against the allowed counts.
pub fn count_of(values: Vec<f64>, what: &str, counts: &[usize]) -> Result<Vec<f64>> {
    if counts.contains(&values.len()) && values.iter().all(|v| v.is_finite()) {
        Ok(values)
    } else {
        let counts: Vec<String> = counts.iter().map(|c| c.to_string()).collect();
        Err(OptionError::not_allowed(
            what,
            format!("{} finite numbers", counts.join(" or ")),
            values.len(),
        ))
    }
}

/// Comma-separated numbers from a flag.
pub fn numbers(text: &str, what: &str, counts: &[usize]) -> Result<Vec<f64>> {
    let values: std::result::Result<Vec<f64>, _> =
        text.split(',').map(|s| s.trim().parse::<f64>()).collect();
    let values = values.map_err(|_| {
        OptionError::not_allowed(what, "comma-separated numbers", format!("{text:?}"))
    })?;
    count_of(values, what, counts)
}

/// Black levels as integers in `0..=65535`.
pub fn black_levels(values: Vec<f64>, what: &str) -> Result<Vec<u16>> {
    let values = count_of(values, what, &[1, 3, 4])?;
    values
        .iter()
        .map(|v| {
            (v.fract() == 0.0 && (0.0..=65535.0).contains(v))
                .then_some(*v as u16)
                .ok_or_else(|| OptionError::not_allowed(what, "whole numbers in 0..=65535", v))
        })
        .collect()
}

/// A 3x3 matrix from nine numbers, row by row.
pub fn matrix(values: Vec<f64>, what: &str) -> Result<[[f32; 3]; 3]> {
    let m = count_of(values, what, &[9])?;
    Ok(std::array::from_fn(|i| {
        std::array::from_fn(|j| m[3 * i + j] as f32)
    }))
}

/// Distortion coefficients `k1, k2, p1, p2[, k3]`.
pub fn distortion(values: Vec<f64>, what: &str) -> Result<[f64; 5]> {
    let d = count_of(values, what, &[4, 5])?;
    Ok([d[0], d[1], d[2], d[3], d.get(4).copied().unwrap_or(0.0)])
}

/// A noise profile: `S, O` for every colour, or `S_R, O_R, S_G, O_G, S_B, O_B` (the DNG
/// NoiseProfile's order), each in `[0, 1]` and no colour's pair both 0.
pub fn noise_profile(values: Vec<f64>, what: &str) -> Result<NoiseProfile> {
    let v = count_of(values, what, &[2, 6])?;
    NoiseProfile::from_pairs(&v).map_err(|_| {
        OptionError::not_allowed(
            what,
            "S,O or six values S,O per colour R, G, B; each in [0, 1], S and O not both 0",
            format!("{v:?}"),
        )
    })
}

/// Camera matrix entries `fx, fy, cx, cy`.
pub fn camera_matrix(values: Vec<f64>, what: &str) -> Result<[f64; 4]> {
    let c = count_of(values, what, &[4])?;
    Ok([c[0], c[1], c[2], c[3]])
}

/// The file's keys, each the name of a flag (or a table the command line has no flag for).
const KEYS: [&str; 25] = [
    "pattern",
    "bits",
    "black-level",
    "white-level",
    "gain",
    "wb",
    "awb",
    "ccm",
    "demosaic",
    "denoise",
    "denoise-search",
    "noise-profile",
    "dpc-threshold",
    "defects",
    "lsc",
    "look",
    "path",
    "out-bits",
    "distortion",
    "camera-matrix",
    "crop",
    "baseline-exposure",
    "highlight-knee",
    "sharpen",
    "chroma-denoise",
];

/// One value of the file, with where it is for error messages.
struct Field<'a> {
    key: String,
    value: &'a Spanned<Value>,
    file: &'a Path,
    text: &'a str,
}

impl Field<'_> {
    fn place(&self) -> Place {
        let line = 1 + self.text[..self.value.span().start.min(self.text.len())]
            .matches('\n')
            .count();
        Place::File {
            file: self.file.to_owned(),
            line: Some(line),
            key: Some(self.key.clone()),
        }
    }

    fn error(&self, what: impl std::fmt::Display) -> OptionError {
        OptionError {
            place: self.place(),
            problem: Problem::Invalid(what.to_string()),
        }
    }

    fn string(&self) -> Result<&str> {
        self.value
            .get_ref()
            .as_str()
            .ok_or_else(|| self.error("expected a string"))
    }

    fn boolean(&self) -> Result<bool> {
        self.value
            .get_ref()
            .as_bool()
            .ok_or_else(|| self.error("expected true or false"))
    }

    fn integer(&self, max: i64) -> Result<i64> {
        match self.value.get_ref().as_integer() {
            Some(v) if (0..=max).contains(&v) => Ok(v),
            Some(v) => Err(OptionError {
                place: self.place(),
                problem: Problem::NotAllowed {
                    allowed: format!("in 0..={max}"),
                    got: v.to_string(),
                },
            }),
            None => Err(self.error("expected a whole number")),
        }
    }

    fn number(value: &Value) -> Option<f64> {
        value
            .as_float()
            .or_else(|| value.as_integer().map(|i| i as f64))
    }

    /// One finite number.
    fn scalar(&self) -> Result<f64> {
        Self::number(self.value.get_ref())
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.error("expected a number"))
    }

    /// A number, or an array of numbers or of arrays of numbers, flattened.
    fn numbers(&self) -> Result<Vec<f64>> {
        let mut out = Vec::new();
        let mut push = |v: &Value| -> Result<()> {
            out.push(Self::number(v).ok_or_else(|| self.error("expected numbers"))?);
            Ok(())
        };
        match self.value.get_ref() {
            Value::Array(items) => {
                for item in items {
                    match item {
                        Value::Array(inner) => inner.iter().try_for_each(&mut push)?,
                        v => push(v)?,
                    }
                }
            }
            v => push(v)?,
        }
        Ok(out)
    }

    /// A parser's result, its error placed at the file, line and key.
    fn check<T>(&self, result: Result<T>) -> Result<T> {
        result.map_err(|e| OptionError {
            place: self.place(),
            problem: e.problem,
        })
    }
}

/// Reads the options from a TOML file; errors name the file, the line and the key.
pub fn from_file(file: &Path) -> Result<IspOptions> {
    let whole_file = |problem: String| OptionError {
        place: Place::File {
            file: file.to_owned(),
            line: None,
            key: None,
        },
        problem: Problem::Invalid(problem),
    };
    let text = std::fs::read_to_string(file).map_err(|e| whole_file(e.to_string()))?;
    from_toml(&text, file)
}

/// The options in TOML `text` (from `file`, for messages).
pub fn from_toml(text: &str, file: &Path) -> Result<IspOptions> {
    let table: BTreeMap<String, Spanned<Value>> =
        toml::from_str(text).map_err(|e| OptionError {
            place: Place::File {
                file: file.to_owned(),
                line: None,
                key: None,
            },
            problem: Problem::Invalid(e.to_string()),
        })?;
    let mut options = IspOptions::default();
    let mut awb_seen = None;
    for (key, value) in &table {
        let f = Field {
            key: key.clone(),
            value,
            file,
            text,
        };
        match key.as_str() {
            "pattern" => options.pattern = Some(f.check(pattern(f.string()?, key))?),
            "bits" => options.bits = Some(f.integer(16)? as u8),
            "black-level" => options.black_level = Some(f.check(black_levels(f.numbers()?, key))?),
            "white-level" => options.white_level = Some(f.integer(65535)? as u16),
            "gain" => options.gain = Some(f.scalar()? as f32),
            "wb" => {
                let g = f.check(count_of(f.numbers()?, key, &[3]))?;
                options.white_balance =
                    Some(WhiteBalance::Gains([g[0] as f32, g[1] as f32, g[2] as f32]));
            }
            "awb" => awb_seen = Some(f.check(awb(f.string()?, key))?),
            "ccm" => options.ccm = Some(f.check(matrix(f.numbers()?, key))?),
            "demosaic" => options.demosaic = Some(f.check(demosaic(f.string()?, key))?),
            "denoise" => options.denoise = Some(f.scalar()? as f32),
            "denoise-search" => {
                options.denoise_search = Some(f.check(denoise_search(f.string()?, key))?)
            }
            "noise-profile" => {
                options.noise_profile = Some(f.check(noise_profile(f.numbers()?, key))?)
            }
            "dpc-threshold" => options.dpc_threshold = Some(f.integer(65535)? as u16),
            "defects" => options.defects = Some(defects(&f)?),
            "lsc" => options.lsc = Some(shading(&f)?),
            "look" => options.look = Some(f.check(look(f.string()?, key))?),
            "path" => options.fixed = Some(f.check(path(f.string()?, key))?),
            "out-bits" => options.out_bits = Some(f.check(out_bits(f.integer(16)? as u8, key))?),
            "distortion" => options.distortion = Some(f.check(distortion(f.numbers()?, key))?),
            "camera-matrix" => {
                options.camera_matrix = Some(f.check(camera_matrix(f.numbers()?, key))?)
            }
            "crop" => options.crop = Some(f.check(crop(f.string()?, key))?),
            "baseline-exposure" => options.baseline_exposure = Some(f.boolean()?),
            "highlight-knee" => options.highlight_knee = Some(f.scalar()? as f32),
            "sharpen" => options.sharpen = Some(f.scalar()? as f32),
            "chroma-denoise" => options.chroma_denoise = Some(f.scalar()? as f32),
            // Relative to the config file, as a user writing one beside the other expects.
            "tuning" => {
                let dir = file.parent().unwrap_or(std::path::Path::new("."));
                options.tuning = Some(dir.join(f.string()?));
            }
            other => {
                return Err(f.error(format!(
                    "unknown key {other:?}; known keys: {}",
                    KEYS.join(", ")
                )))
            }
        }
    }
    if let Some(method) = awb_seen {
        if options.white_balance.is_some() {
            let f = Field {
                key: "awb".into(),
                value: &table["awb"],
                file,
                text,
            };
            return Err(f.error("give wb or awb, not both"));
        }
        options.white_balance = Some(WhiteBalance::Auto(method));
    }
    Ok(options)
}

fn defects(f: &Field<'_>) -> Result<Vec<Defect>> {
    let items = f
        .value
        .get_ref()
        .as_array()
        .ok_or_else(|| f.error("expected a list of [x, y] pairs"))?;
    let mut out = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let pair = item.as_array().map(|p| p.as_slice());
        let coordinate = |v: &Value| v.as_integer().and_then(|i| u16::try_from(i).ok());
        match pair {
            Some([x, y]) => match (coordinate(x), coordinate(y)) {
                (Some(x), Some(y)) => out.push(Defect { x, y }),
                _ => {
                    return Err(f.error(format!(
                        "entry {i}: coordinates must be whole numbers in 0..=65535"
                    )))
                }
            },
            _ => return Err(f.error(format!("entry {i}: expected an [x, y] pair"))),
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
}

fn shading(f: &Field<'_>) -> Result<ShadingGrid> {
    let table = f
        .value
        .get_ref()
        .as_table()
        .ok_or_else(|| f.error("expected a table with grid-width, grid-height and gains"))?;
    let side = |key: &str| -> Result<usize> {
        match table.get(key).and_then(|v| v.as_integer()) {
            Some(n) if (2..=isp_core::lsc::MAX_GRID_SIDE as i64).contains(&n) => Ok(n as usize),
            _ => Err(f.error(format!(
                "{key} must be a whole number in 2..={}",
                isp_core::lsc::MAX_GRID_SIDE
            ))),
        }
    };
    let (width, height) = (side("grid-width")?, side("grid-height")?);
    if let Some(extra) = table
        .keys()
        .find(|k| !["grid-width", "grid-height", "gains"].contains(&k.as_str()))
    {
        return Err(f.error(format!(
            "unknown key {extra:?}; known keys: grid-width, grid-height, gains"
        )));
    }
    let nodes = table
        .get("gains")
        .and_then(|v| v.as_array())
        .ok_or_else(|| f.error("gains: expected a list of [g, g, g, g] nodes"))?;
    if nodes.len() != width * height {
        return Err(f.error(format!(
            "gains: expected {width} x {height} = {} nodes (got {})",
            width * height,
            nodes.len()
        )));
    }
    let mut gains_q12 = Vec::with_capacity(4 * nodes.len());
    for (i, node) in nodes.iter().enumerate() {
        let values: Option<Vec<f64>> = node
            .as_array()
            .filter(|n| n.len() == 4)
            .map(|n| n.iter().filter_map(Field::number).collect());
        match values {
            Some(v) if v.len() == 4 && v.iter().all(|g| (0.0..16.0).contains(g)) => {
                gains_q12.extend(v.iter().map(|g| (g * 4096.0).round().min(65535.0) as u16))
            }
            _ => return Err(f.error(format!("gains: node {i} must be four numbers in [0, 16)"))),
        }
    }
    Ok(ShadingGrid {
        width,
        height,
        gains_q12,
    })
}
