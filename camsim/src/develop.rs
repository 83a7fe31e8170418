//! Developing a raw frame on the host: a [`RawImage`] (from a DNG or a PNG/PGM mosaic; a
//! LinearRaw DNG's already demosaiced frame skips defect correction and demosaicing) and
//! [`IspOptions`] (flags, a config file, a DNG's tags) become an isp-core [`IspConfig`], run
//! through the float or fixed pipeline to an sRGB [`Image`], with a report of the stages, the
//! AWB estimate and the time each stage costs. `camsim isp` and `camsim demo` both run it.
//!
//! Stage times come from ablation: the pipeline is fused (every stage runs per row in one
//! pass), so each stage's cost is the time of a run with it minus the time of a run without it,
//! stages added in pipeline order, each run timed best of three.

use std::path::Path;
use std::time::Instant;

use isp_core::ccm::Calibration;
use isp_core::colour::LINEAR_SRGB_TO_XYZ;
use isp_core::demosaic::Method;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::DpcConfig;
use isp_core::frame::{LinearFrame, RawFrame, RgbViewMut};
use isp_core::lsc::LensShading;
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, Input, IspConfig, OutputSample};
use isp_core::tone::Look;
use isp_core::wb::{self, AwbEstimate};
use isp_core::IspError;
use raw_formats::dng::opcodes::Opcode;
use raw_formats::dng::{Dng, Framing};
use raw_formats::framing::Orientation;
use raw_formats::{FormatError, Image, RawImage};

#[cfg(target_arch = "x86_64")]
use crate::demosaic::has_avx512;
use crate::error::Error;
use crate::isp_options::{CropChoice, IspOptions, ShadingGrid, WhiteBalance};

/// What a run did, for the printed report.
#[derive(Debug, Clone)]
pub struct IspReport {
    /// Stage names in the order run.
    pub stages: Vec<&'static str>,
    /// The AWB estimate, if AWB ran.
    pub awb: Option<AwbEstimate>,
    /// Gains used.
    pub wb_gains: [f32; 3],
    /// The distortion corrected and the input rows its window holds, if on.
    pub distortion: Option<(LensDistortion, usize)>,
    /// Whether the fixed-point path ran.
    pub fixed: bool,
    /// Milliseconds per stage (ablation), in pipeline order.
    pub stage_ms: Vec<(&'static str, f64)>,
    /// Milliseconds of the whole pipeline (one run).
    pub total_ms: f64,
    /// Threads the pipeline ran on.
    pub threads: usize,
    /// How the output was cropped and turned, when the file asked for either.
    pub framing: Option<String>,
    /// The file's BaselineExposure in EV, when applied.
    pub baseline_exposure: Option<f64>,
    /// The raw's noise profile and where it came from.
    pub noise: Noise,
}

/// The raw's noise profile (`var = S x + O`, [`isp_core::noise`]) as [`develop`] resolved it:
/// from `--noise-profile` (or the config file), else the file's NoiseProfile tag, else
/// estimated from the frame ([`crate::noise_estimate`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Noise {
    /// Given as an option.
    Option(NoiseProfile),
    /// The file's NoiseProfile tag.
    File(NoiseProfile),
    /// The tuning file's profile (`--tuning`).
    Tuning(NoiseProfile),
    /// Estimated from the frame (with how many level sets and how confidently).
    Estimated(crate::noise_estimate::NoiseEstimate),
    /// None could be had, and why.
    Unknown(String),
}

impl Default for Noise {
    fn default() -> Self {
        Noise::Unknown("not resolved".into())
    }
}

impl Noise {
    /// The profile, if there is one.
    pub fn profile(&self) -> Option<NoiseProfile> {
        match self {
            Noise::Option(p) | Noise::File(p) | Noise::Tuning(p) => Some(*p),
            Noise::Estimated(e) => Some(e.profile),
            Noise::Unknown(_) => None,
        }
    }

    /// Where it came from, as `--json` names it: `option`, `file`, `tuning`, `estimated` or
    /// `none`.
    pub fn source(&self) -> &'static str {
        match self {
            Noise::Option(_) => "option",
            Noise::File(_) => "file",
            Noise::Tuning(_) => "tuning",
            Noise::Estimated(..) => "estimated",
            Noise::Unknown(_) => "none",
        }
    }

    /// One line for the report.
    pub fn to_text(&self) -> String {
        let (p, from) = match self {
            Noise::Option(p) => (p, "from --noise-profile".to_string()),
            Noise::Tuning(p) => (p, "from the tuning file".to_string()),
            Noise::File(p) => (p, "from the file's NoiseProfile tag".to_string()),
            Noise::Estimated(e) => (
                &e.profile,
                format!(
                    "estimated from the frame, Foi et al. 2008's level sets ({}){}; --noise-profile S,O overrides",
                    e.sets,
                    if e.confident() {
                        String::new()
                    } else {
                        format!(
                            ", LOW CONFIDENCE: the frame's fine texture stands above its noise \
                             (cell variances spread {:.2}x noise's, over the {:.2} limit), so S \
                             likely reads high; noise reduction defaults to strength {}",
                            e.texture_spread,
                            crate::noise_estimate::TEXTURE_SPREAD_LIMIT,
                            e.default_strength()
                        )
                    }
                ),
            ),
            Noise::Unknown(why) => return format!("noise profile: none ({why})"),
        };
        let (s, o) = (p.scale(), p.offset());
        let values = if p.is_uniform() {
            format!("S {:.4e} O {:.4e}", s[0], o[0])
        } else {
            format!(
                "R S {:.4e} O {:.4e}, G S {:.4e} O {:.4e}, B S {:.4e} O {:.4e}",
                s[0], o[0], s[1], o[1], s[2], o[2]
            )
        };
        format!("noise profile: {values} (variance S x + O, x a fraction of white), {from}")
    }

    /// `{"source": ..., "scale": [R, G, B], "offset": [R, G, B]}`, or with `"reason"` when
    /// there is none; an estimate adds `level_sets`, `confidence` (`high`, or `low` outside the
    /// estimate's domain: texture above noise) and `texture_spread` with its limit.
    pub fn to_json(&self) -> serde_json::Value {
        // Each f32 as the shortest decimal that reads back to it, not its f64 widening.
        let decimal = |v: [f32; 3]| v.map(|x| x.to_string().parse::<f64>().unwrap_or(0.0));
        match self {
            Noise::Unknown(why) => serde_json::json!({
                "source": "none",
                "reason": why,
            }),
            Noise::Option(p) | Noise::File(p) | Noise::Tuning(p) => {
                serde_json::json!({
                    "source": self.source(),
                    "scale": decimal(p.scale()),
                    "offset": decimal(p.offset()),
                })
            }
            Noise::Estimated(e) => serde_json::json!({
                "source": self.source(),
                "scale": decimal(e.profile.scale()),
                "offset": decimal(e.profile.offset()),
                "level_sets": e.sets,
                "confidence": if e.confident() { "high" } else { "low" },
                "texture_spread": e.texture_spread,
                "texture_spread_limit": crate::noise_estimate::TEXTURE_SPREAD_LIMIT,
            }),
        }
    }
}

impl IspReport {
    /// The report as JSON (`camsim isp --json`): the path, stages, white balance (and the AWB
    /// estimate), the noise profile and its source, times in ms, threads, framing and
    /// baseline exposure.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "path": if self.fixed { "fixed" } else { "float" },
            "stages": self.stages,
            "wb_gains": self.wb_gains,
            "awb": self.awb.map(|a| serde_json::json!({
                "gains": a.gains,
                "cct_k": a.cct_k,
            })),
            "noise_profile": self.noise.to_json(),
            "total_ms": self.total_ms,
            "stage_ms": self.stage_ms.iter().map(|(n, ms)| (n.to_string(), serde_json::json!(ms)))
                .collect::<serde_json::Map<_, _>>(),
            "threads": self.threads,
            "framing": self.framing,
            "baseline_exposure_ev": self.baseline_exposure,
        })
    }

    /// The readable report.
    pub fn to_text(&self) -> String {
        let path = if self.fixed { "fixed" } else { "float" };
        let mut out = format!("path: {path}\nstages: {}\n", self.stages.join(" -> "));
        if let Some(a) = &self.awb {
            out += &format!(
                "awb: gains R {:.4} G {:.4} B {:.4}, estimated CCT {:.0} K\n",
                a.gains[0], a.gains[1], a.gains[2], a.cct_k
            );
        } else {
            out += &format!(
                "white balance: gains R {:.4} G {:.4} B {:.4}\n",
                self.wb_gains[0], self.wb_gains[1], self.wb_gains[2]
            );
        }
        if let Some((lens, window)) = &self.distortion {
            let [fx, fy, cx, cy] = lens.camera();
            let [k1, k2, p1, p2, k3] = lens.model().to_opencv();
            out += &format!(
                "distortion: k1 {k1} k2 {k2} p1 {p1} p2 {p2} k3 {k3}, camera fx {fx} fy {fy} cx {cx} cy {cy}, window {window} rows\n"
            );
        }
        out += &self.noise.to_text();
        out += "\n";
        if let Some(ev) = self.baseline_exposure {
            out += &format!(
                "baseline exposure: {ev:+.2} EV from the file, as gain {:.4} (--no-baseline-exposure turns it off)\n",
                2f64.powf(ev)
            );
        }
        if let Some(framing) = &self.framing {
            out += &format!("framing: {framing}\n");
        }
        let threads = match self.threads {
            1 => "1 thread".to_string(),
            n => format!("{n} threads"),
        };
        if self.stage_ms.is_empty() {
            out += &format!(
                "pipeline: {:.2} ms on {threads} (--stage-times for each stage's time)\n",
                self.total_ms
            );
            return out;
        }
        out += &format!("time per stage (ms, by ablation, best of three, {threads}):\n");
        for (name, ms) in &self.stage_ms {
            out += &format!("  {name:<28} {ms:>9.2}\n");
        }
        out += &format!(
            "  {:<28} {:>9.2}\n",
            "pipeline total (one run)", self.total_ms
        );
        out
    }
}

/// The demosaicing method `camsim isp` and `camsim demo` use unless told otherwise: the best
/// (and on the planar schedule still over 100 Mpix/s on one core).
pub const DEFAULT_METHOD: Method = Method::Directional;

/// The highlight knee `camsim isp` and `camsim demo` use unless told otherwise: the top tenth
/// of the white-balanced range fades to neutral, so clipped areas come out white.
pub const DEFAULT_HIGHLIGHT_KNEE: f32 = 0.9;

/// A raw frame to develop and what its file says beyond the samples.
#[derive(Debug, Clone)]
pub struct RawInput {
    /// The frame, with the levels and pattern the file states (defaults for a plain mosaic).
    pub raw: RawImage,
    /// Bits per sample of the file's container (16 for camsim's DNGs, 8 or 16 for PNG/PGM):
    /// the most `--bits` may claim.
    pub container_bits: u8,
    /// Options the file states (pattern, bits, levels, as-shot white balance).
    pub defaults: IspOptions,
    /// The file's colour calibration.
    pub calibration: Option<Calibration>,
    /// The file's recommended crop and orientation.
    pub framing: Framing,
    /// The file's BaselineExposure in EV, applied as gain unless turned off.
    pub baseline_exposure: Option<f64>,
    /// The file's NoiseProfile.
    pub noise_profile: Option<NoiseProfile>,
    /// The opcodes the file lists that the pipeline does not apply (all but the bad-pixel
    /// lists of a CFA image, OpcodeList2's GainMaps and the first WarpRectilinear of
    /// OpcodeList3 that OpenCV's model expresses; OpcodeList2's maps the reader has applied),
    /// by name and whether optional.
    pub opcodes_not_applied: Vec<(&'static str, bool)>,
}

impl RawInput {
    /// A frame whose file states nothing beyond its samples and depth (a PNG/PGM mosaic).
    pub fn plain(raw: RawImage) -> Self {
        Self {
            container_bits: raw.bits,
            raw,
            defaults: IspOptions::default(),
            calibration: None,
            framing: Framing::default(),
            baseline_exposure: None,
            noise_profile: None,
            opcodes_not_applied: Vec::new(),
        }
    }

    /// Reads a DNG, or a single-channel PNG/PGM mosaic (chosen by the extension).
    pub fn read(path: &Path) -> Result<Self, FormatError> {
        let is_dng = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("dng"));
        if !is_dng {
            return Ok(Self::plain(raw_formats::image::read_mosaic(path)?));
        }
        Self::from_dng(Dng::read(path)?, path)
    }

    /// A decoded DNG as a frame to develop (`path` names the file in errors): what
    /// [`RawInput::read`] does after reading, for callers that keep the file's other tags.
    pub fn from_dng(dng: Dng, path: &Path) -> Result<Self, FormatError> {
        // An opcode this pipeline does not know, that the file does not let a reader skip.
        let required_unknown =
            dng.processing
                .opcode_lists
                .iter()
                .flatten()
                .find_map(|op| match op {
                    Opcode::Other {
                        id,
                        optional: false,
                    } => Some(format!("{} (id {id})", op.name())),
                    _ => None,
                });
        if let Some(value) = required_unknown {
            return Err(FormatError::Unsupported {
                field: "DNG opcode not marked optional",
                value,
                supported: "GainMap, FixBadPixelsConstant, FixBadPixelsList, WarpRectilinear, MapTable and MapPolynomial are known; optional ones are skipped with a note",
            }
            .in_file(path));
        }
        let calibration = dng.colour.to_calibration().map_err(|e| e.in_file(path))?;
        // OpcodeList3's WarpRectilinear, where OpenCV's model (the pipeline's) expresses it.
        let (w, h) = (dng.image.width, dng.image.height);
        let as_opencv = |op| raw_formats::dng::opcodes::warp_as_opencv(op, w, h);
        let warp_op = dng.processing.opcode_lists[2]
            .iter()
            .find(|op| as_opencv(op).is_some());
        let warp = warp_op.and_then(as_opencv);
        let image = &dng.image;
        let linear = image.is_linear();
        let defaults = IspOptions {
            pattern: (!linear).then_some(image.pattern),
            bits: Some(image.bits),
            black_level: Some(if linear {
                image.black_level[..3].to_vec()
            } else {
                image.black_level.to_vec()
            }),
            white_level: Some(image.white_level),
            white_balance: dng
                .colour
                .as_shot_gains()
                .map_err(|e| e.in_file(path))?
                .map(WhiteBalance::Gains),
            // FixBadPixelsConstant/List, resolved by the reader into a defect map.
            defects: (!dng.processing.bad_pixels.is_empty())
                .then(|| dng.processing.bad_pixels.clone()),
            lsc: gain_map_shading(&dng),
            distortion: warp.map(|(k, _)| k),
            camera_matrix: warp.map(|(_, m)| m),
            ..IspOptions::default()
        };
        Ok(Self {
            raw: dng.image,
            container_bits: 16,
            defaults,
            calibration,
            framing: dng.framing,
            baseline_exposure: dng.processing.baseline_exposure,
            noise_profile: dng.processing.noise_profile,
            opcodes_not_applied: dng
                .processing
                .opcode_lists
                .iter()
                .enumerate()
                .flat_map(|(i, list)| list.iter().map(move |op| (i, op)))
                .filter(|(list, op)| {
                    // The reader resolves bad-pixel opcodes for a CFA image only.
                    let bad_pixels = !linear
                        && matches!(
                            op,
                            Opcode::FixBadPixelsConstant { .. } | Opcode::FixBadPixelsList { .. }
                        );
                    let shading = *list == 1 && matches!(op, Opcode::GainMap(g) if g.plane == 0);
                    let applied_warp = warp_op.is_some_and(|applied| std::ptr::eq(applied, *op));
                    !(bad_pixels || shading || applied_warp)
                })
                .map(|(_, op)| {
                    let optional = matches!(op, Opcode::Other { optional: true, .. });
                    (op.name(), optional)
                })
                .collect(),
        })
    }
}

/// Nodes on each side of the lens-shading grid made from a DNG's GainMaps: dense enough that
/// bilinear interpolation between nodes follows a smooth vignetting map to well under 1 %.
const GAIN_MAP_GRID: usize = 33;

/// OpcodeList2's GainMaps (the lens shading a phone or converter measured) as the pipeline's
/// lens-shading grid, in Q4.12.
fn gain_map_shading(dng: &Dng) -> Option<ShadingGrid> {
    let (w, h) = (dng.image.width, dng.image.height);
    let n = GAIN_MAP_GRID;
    let gains =
        raw_formats::dng::opcodes::shading_grid(&dng.processing.opcode_lists[1], w, h, n, n)?;
    Some(ShadingGrid {
        width: n,
        height: n,
        gains_q12: gains
            .iter()
            .map(|g| (f64::from(*g) * 4096.0).round().clamp(0.0, 65535.0) as u16)
            .collect(),
    })
}

/// Develops `input` with `options` (each unset option from the file's defaults, then the
/// built-in default) and `calibration` (else the file's): the report and the RGB image.
pub fn develop(
    input: &RawInput,
    options: &IspOptions,
    calibration: Option<Calibration>,
    run: RunOptions,
) -> Result<(IspReport, Image), Error> {
    with_prepared(input, options, calibration, |p| {
        let (mut report, rgb) = execute(p.input, &p.config, p.fixed, p.out_bits, run)?;
        report.awb = p.awb;
        report.baseline_exposure = p.baseline_ev;
        report.noise = p.noise.clone();
        let (rgb, framing) = frame(rgb, &input.framing, p.crop)?;
        report.framing = framing;
        Ok((report, rgb))
    })
}

/// What [`develop`] resolved from the options, the file and the defaults, ready to run.
#[derive(Debug, Clone)]
pub struct Prepared<'a> {
    /// The frame.
    pub input: Input<'a>,
    /// The pipeline's configuration.
    pub config: IspConfig<'a>,
    /// Whether the fixed-point path runs.
    pub fixed: bool,
    /// Output depth, 8 or 16.
    pub out_bits: u8,
    /// The AWB estimate, if AWB ran.
    pub awb: Option<AwbEstimate>,
    /// The file's BaselineExposure in EV, when applied.
    pub baseline_ev: Option<f64>,
    /// How to frame the output.
    pub crop: CropChoice,
    /// The raw's noise profile and where it came from.
    pub noise: Noise,
}

/// `options` with its tuning file's settings under them ([`crate::tune::options_for`]): an
/// automatic white balance (`--awb`, grey world when none is asked) is estimated and moved
/// into the tuning's locus; fixed gains (`--wb`) stay as given. Returns what the tuning chose.
fn apply_tuning(
    options: IspOptions,
    raw: &RawImage,
) -> Result<(IspOptions, Option<crate::tune::Applied>), Error> {
    let Some(path) = options.tuning.clone() else {
        return Ok((options, None));
    };
    let tuning = crate::tune::Tuning::read(&path)?;
    let method = match options.white_balance {
        Some(WhiteBalance::Auto(m)) => m,
        _ => isp_core::wb::AwbMethod::GreyWorld,
    };
    let applied =
        crate::tune::options_for(&tuning, raw, method, None).map_err(|e| e.in_file(&path))?;
    let mut options = options;
    if matches!(options.white_balance, Some(WhiteBalance::Auto(_))) {
        options.white_balance = None;
    }
    Ok((options.or(applied.options.clone()), Some(applied)))
}

/// Resolves `options` (each unset option from the file's defaults, then the built-in
/// default) and `calibration` for `input` as [`develop`] does, runs AWB if asked, and hands
/// the result to `then` (the configuration borrows what this function builds).
pub fn with_prepared<R>(
    input: &RawInput,
    options: &IspOptions,
    calibration: Option<Calibration>,
    then: impl FnOnce(Prepared<'_>) -> Result<R, Error>,
) -> Result<R, Error> {
    // A tuning file sits under the options given and over the file's own tags.
    let noise_given = options.noise_profile.is_some();
    let (options, tuned) = apply_tuning(options.clone(), &input.raw)?;
    let noise_from_tuning = tuned.is_some() && !noise_given;
    let options = options.or(input.defaults.clone());
    let calibration = calibration.or(input.calibration);
    let image = &input.raw;
    let linear = image.is_linear();
    let pattern = options.pattern.unwrap_or(image.pattern);
    let bits = options.bits.unwrap_or(input.container_bits);
    if !(8..=16).contains(&bits) || bits > input.container_bits {
        return Err(Error::Option {
            option: "--bits",
            value: bits.to_string(),
            allowed: format!(
                "8..=16 and at most the file's depth {}",
                input.container_bits
            ),
        });
    }
    let max = ((1u32 << bits) - 1) as u16;
    // The largest sample first: a max reduction vectorises (a `find` with its early exit ran
    // one sample at a time, 3 ms of a 12 MP frame); the first offender only on refusal.
    let largest = image.samples.iter().fold(0u16, |m, v| m.max(*v));
    if largest > max {
        let first = image.samples.iter().find(|v| **v > max).copied();
        return Err(Error::SampleRange {
            sample: first.unwrap_or(largest),
            bits,
        });
    }
    let black = options.black_level.clone().unwrap_or(vec![0]);
    // One per 2x2 CFA position, or per channel of a linear frame.
    let per_position = if linear { 3 } else { 4 };
    if black.len() != 1 && black.len() != per_position {
        return Err(Error::Option {
            option: "--black-level",
            value: format!("{black:?}"),
            allowed: if linear {
                "one value, or three (R, G, B) for a linear DNG".into()
            } else {
                "one value, or four (one per 2x2 CFA position)".into()
            },
        });
    }
    let black: [u16; 4] =
        std::array::from_fn(|i| black.get(i).or(black.last()).copied().unwrap_or(0));
    let white = options.white_level.unwrap_or(max);
    let (w, h) = (image.width, image.height);
    let frame_error =
        |e| Error::in_stage("raw frame (check --bits, --black-level, --white-level)", e);
    let raw: Input<'_> = if linear {
        let black = [black[0], black[1], black[2]];
        LinearFrame::new(&image.samples, w, h, 3 * w, bits, black, [white; 3])
            .map_err(frame_error)?
            .into()
    } else {
        RawFrame::new(&image.samples, w, h, w, bits, pattern, black, white)
            .map_err(frame_error)?
            .into()
    };

    // The tuning's white balance is reported as the AWB's: the locus's gains and CCT.
    let mut awb = tuned.map(|t| AwbEstimate {
        gains: t.gains,
        neutral: t.gains.map(|g| 1.0 / g),
        cct_k: t.cct,
    });
    let wb_gains = match options.white_balance {
        Some(WhiteBalance::Gains(g)) => g,
        Some(WhiteBalance::Auto(method)) => {
            let to_xyz = match &calibration {
                Some(c) => c.camera_to_xyz(6504.0)?,
                None => LINEAR_SRGB_TO_XYZ,
            };
            let mut est = match &raw {
                Input::Mosaic(raw) => wb::estimate(raw, method, &to_xyz),
                Input::Linear(frame) => wb::estimate_linear(frame, method, &to_xyz),
            }
            .map_err(|e| Error::in_stage("--awb", e))?;
            if let Some(c) = &calibration {
                est.cct_k = c.cct_of_neutral(est.neutral)?;
            }
            awb = Some(est);
            est.gains
        }
        None => [1.0; 3],
    };
    // With a calibration and no explicit matrix, the CCM follows the white balance.
    let ccm = match (options.ccm, &calibration) {
        (Some(m), _) => m,
        (None, Some(c)) => {
            c.ccm_for_white_balance(wb_gains)
                .map_err(|e| Error::in_stage("colour matrix from the calibration", e))?
                .ccm
        }
        (None, None) => isp_core::pipeline::IDENTITY,
    };
    let demosaic = options.demosaic.unwrap_or(DEFAULT_METHOD);
    let defects = options.defects.clone().unwrap_or_default();
    let lsc = options
        .lsc
        .as_ref()
        .map(|g| LensShading::new(g.width, g.height, &g.gains_q12))
        .transpose()
        .map_err(|e| Error::in_stage("lsc", e))?;
    let distortion = match options.distortion {
        Some(d) => {
            let [fx, fy, cx, cy] = options.camera_matrix.unwrap_or_else(|| {
                let f = w.max(h) as f64;
                [f, f, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0]
            });
            let model = BrownConrady::from_opencv(d).map_err(|source| Error::Optics {
                option: "--distortion",
                source,
            })?;
            Some(
                LensDistortion::new(fx, fy, cx, cy, model)
                    .map_err(|e| Error::in_stage("--camera-matrix", e))?
                    .fitted(w, h),
            )
        }
        None if options.camera_matrix.is_some() => {
            return Err(Error::Needs {
                option: "--camera-matrix",
                needs: "--distortion (the coefficients to correct)",
            })
        }
        None => None,
    };
    // BaselineExposure raises (or lowers) the whole raw, as the ISO gain stage does.
    let baseline_ev = input
        .baseline_exposure
        .filter(|_| options.baseline_exposure.unwrap_or(true));
    let exposure_gain = baseline_ev.map_or(1.0, |ev| 2f64.powf(ev) as f32);
    let noise = match (options.noise_profile, input.noise_profile, &raw) {
        (Some(p), _, _) if noise_from_tuning => Noise::Tuning(p),
        (Some(p), _, _) => Noise::Option(p),
        (None, Some(p), _) => Noise::File(p),
        (None, None, Input::Linear(_)) => Noise::Unknown(
            "a linear (demosaiced) frame is not estimated; give --noise-profile".into(),
        ),
        (None, None, Input::Mosaic(frame)) => match crate::noise_estimate::estimate(frame) {
            Ok(e) => Noise::Estimated(e),
            Err(e) => Noise::Unknown(format!("{e}; give --noise-profile")),
        },
    };
    // Noise reduction follows the profile by default, where it can run: a mosaic of whole
    // 2x2 blocks with a known profile; gentler where the estimate is not confident.
    let denoise = options.denoise.unwrap_or(match (&raw, noise.profile()) {
        (Input::Mosaic(frame), Some(_))
            if frame.mosaic().width().is_multiple_of(2)
                && frame.mosaic().height().is_multiple_of(2) =>
        {
            match &noise {
                Noise::Estimated(e) => e.default_strength(),
                _ => 1.0,
            }
        }
        _ => 0.0,
    });
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: options.dpc_threshold,
        },
        lsc,
        gain: options.gain.unwrap_or(1.0) * exposure_gain,
        wb_gains,
        demosaic,
        distortion,
        denoise,
        denoise_search: options.denoise_search.unwrap_or_default(),
        noise: noise.profile(),
        highlight_knee: options.highlight_knee.unwrap_or(DEFAULT_HIGHLIGHT_KNEE),
        ccm,
        tone: options.look.unwrap_or(Look::Neutral).tone(),
        sharpen: options.sharpen.unwrap_or(0.0),
        chroma_denoise: options
            .chroma_denoise
            .unwrap_or(default_chroma_denoise(denoise)),
    };
    config.validate()?;
    let fixed = options.fixed.unwrap_or(false);
    let out_bits = options.out_bits.unwrap_or(8);
    then(Prepared {
        input: raw,
        config,
        fixed,
        out_bits,
        awb,
        baseline_ev,
        crop: options.crop.unwrap_or_default(),
        noise,
    })
}

/// Chroma noise reduction's default strength: on (1) where raw noise reduction is on, since
/// what that leaves is what it takes out; off otherwise.
pub fn default_chroma_denoise(denoise: f32) -> f32 {
    if denoise > 0.0 {
        1.0
    } else {
        0.0
    }
}

/// Crops the developed image as `choice` and the file say, then turns it upright; with what
/// was done, if anything, for the report.
fn frame(
    rgb: Image,
    framing: &Framing,
    choice: CropChoice,
) -> Result<(Image, Option<String>), Error> {
    let (data, width, height, done) = frame_samples(
        rgb.data,
        rgb.width,
        rgb.height,
        rgb.channels,
        framing,
        choice,
    )?;
    let rgb = Image {
        width,
        height,
        data,
        ..rgb
    };
    Ok((rgb, done))
}

/// A developed image's samples (`width` x `height`, `channels` per pixel, any sample type)
/// framed as the file says and `choice` asks: the default crop, then turned upright. Returns
/// the samples, their width and height, and what was done in words (`None` for nothing).
pub fn frame_samples<T: Copy>(
    data: Vec<T>,
    width: usize,
    height: usize,
    channels: usize,
    framing: &Framing,
    choice: CropChoice,
) -> Result<(Vec<T>, usize, usize, Option<String>), Error> {
    let mut done = Vec::new();
    let (data, width, height) = match (choice, framing.default_crop) {
        (CropChoice::Default, Some(crop)) if (crop.width, crop.height) != (width, height) => {
            done.push(format!(
                "the file's default crop, {}x{} at ({}, {}) (--crop active keeps the whole {}x{})",
                crop.width, crop.height, crop.left, crop.top, width, height
            ));
            let data = raw_formats::framing::crop_samples(&data, width, channels, crop)?;
            (data, crop.width, crop.height)
        }
        _ => (data, width, height),
    };
    let (data, width, height) = match framing.orientation {
        Orientation::Normal => (data, width, height),
        o => {
            done.push(format!("turned upright (Orientation {})", o.to_tiff()));
            let turned = raw_formats::framing::orient_samples(&data, width, height, channels, o);
            if o.swaps_axes() {
                (turned, height, width)
            } else {
                (turned, width, height)
            }
        }
    };
    Ok((
        data,
        width,
        height,
        (!done.is_empty()).then(|| done.join("; ")),
    ))
}

/// The width and height [`frame_samples`] gives a `width` x `height` image: the default
/// crop's size where `choice` takes it, swapped where the orientation turns the image.
pub fn framed_size(
    width: usize,
    height: usize,
    framing: &Framing,
    choice: CropChoice,
) -> (usize, usize) {
    let (w, h) = match (choice, framing.default_crop) {
        (CropChoice::Default, Some(crop)) => (crop.width, crop.height),
        _ => (width, height),
    };
    if framing.orientation.swaps_axes() {
        (h, w)
    } else {
        (w, h)
    }
}

/// How [`execute`] runs the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunOptions {
    /// Bands run in parallel, one thread each (at least 1; bands give bit-identical output,
    /// so the image does not depend on it).
    pub threads: usize,
    /// Also time each stage by ablation: one more run per stage that is on.
    pub stage_times: bool,
}

impl Default for RunOptions {
    /// Every core, no stage times: one pass.
    fn default() -> Self {
        Self {
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            stage_times: false,
        }
    }
}

/// Runs the pipeline on `raw` (a mosaic, or a linear frame that skips demosaicing) with
/// `config` (float or fixed path, 8- or 16-bit output) once, on `run.threads` threads, and with
/// `run.stage_times` times each stage by ablation; returns the report (with no AWB estimate)
/// and the image.
pub fn execute(
    raw: Input<'_>,
    config: &IspConfig<'_>,
    fixed: bool,
    out_bits: u8,
    run: RunOptions,
) -> Result<(IspReport, Image), IspError> {
    let linear = matches!(raw, Input::Linear(_));
    let config = *config;
    let (distortion, wb_gains) = (config.distortion, config.wb_gains);
    let (w, h) = (raw.width(), raw.height());
    let threads = run.threads.max(1);
    let mut out = vec![0u16; w * h * 3];
    let total_ms = if out_bits == 8 {
        let mut out8 = vec![0u8; w * h * 3];
        let ms = Runner::new(&raw, &config, fixed, 8, threads)?.best_ms(&mut out8, 1)?;
        for (o, v) in out.iter_mut().zip(&out8) {
            *o = *v as u16;
        }
        ms
    } else {
        Runner::new(&raw, &config, fixed, 16, threads)?.best_ms(&mut out, 1)?
    };

    let stages = stage_names(&config, linear);
    let stage_ms = if run.stage_times {
        stage_times(&raw, &config, fixed, 8, threads, 3)?
    } else {
        Vec::new()
    };
    let report = IspReport {
        stages,
        awb: None,
        wb_gains,
        distortion: distortion
            .filter(|d| !d.is_identity())
            .map(|d| (d, d.window_rows(w, h))),
        fixed,
        stage_ms,
        total_ms,
        threads,
        framing: None,
        baseline_exposure: None,
        noise: Noise::default(),
    };
    let rgb = Image {
        width: w,
        height: h,
        channels: 3,
        bits: out_bits,
        data: out,
    };
    Ok((report, rgb))
}

/// Each stage's time by ablation, in pipeline order: the base (black level, demosaicing and
/// encoding), then each stage that is on, as the best of `repeats` runs with it and every stage
/// before it on, less the same for the stage before (at least 0: the pipeline is fused, so a
/// cheap stage can vanish in the noise). Runs the pipeline once per stage, `repeats` times.
pub fn stage_times(
    raw: &Input<'_>,
    config: &IspConfig<'_>,
    fixed: bool,
    out_bits: u8,
    threads: usize,
    repeats: u32,
) -> Result<Vec<(&'static str, f64)>, IspError> {
    let linear = matches!(raw, Input::Linear(_));
    let mut times = Vec::new();
    let mut previous = 0.0;
    for Step {
        name, config: c, ..
    } in &cumulative_steps(config, linear)
    {
        let ms = Runner::new(raw, c, fixed, out_bits, threads)?.time_ms(repeats)?;
        times.push((*name, (ms - previous).max(0.0)));
        previous = ms;
    }
    Ok(times)
}

/// One stage that is on, for ablation: its name, whether it runs after demosaicing, and the
/// configuration with it and every stage before it on.
struct Step<'a> {
    name: &'static str,
    after_demosaic: bool,
    config: IspConfig<'a>,
}

/// The stages `config` turns on, in pipeline order, each with the cumulative configuration up
/// to it; the first is the base that always runs (black level, demosaic unless `linear`,
/// encoding).
fn cumulative_steps<'a>(config: &IspConfig<'a>, linear: bool) -> Vec<Step<'a>> {
    let mut c = IspConfig {
        demosaic: config.demosaic,
        ..IspConfig::default()
    };
    let base = if linear {
        "black level+encode"
    } else {
        "black level+demosaic+encode"
    };
    let mut steps = vec![(base, true, false, c)];
    c.dpc = config.dpc;
    steps.push(("defective pixels", config.dpc.is_active(), false, c));
    c.denoise = config.denoise;
    c.noise = config.noise;
    steps.push(("denoise", config.denoise > 0.0, false, c));
    c.lsc = config.lsc;
    steps.push(("lens shading", config.lsc.is_some(), false, c));
    c.gain = config.gain;
    steps.push(("gain", config.gain != 1.0, false, c));
    c.wb_gains = config.wb_gains;
    steps.push(("white balance", config.wb_gains != [1.0; 3], false, c));
    c.highlight_knee = config.highlight_knee;
    steps.push(("highlights", config.highlight_knee < 1.0, true, c));
    c.distortion = config.distortion;
    let lens_on = config.distortion.is_some_and(|d| !d.is_identity());
    steps.push(("distortion correction", lens_on, true, c));
    c.ccm = config.ccm;
    steps.push((
        "colour matrix",
        config.ccm != isp_core::pipeline::IDENTITY,
        true,
        c,
    ));
    c.tone = config.tone;
    steps.push(("tone", config.tone != Look::Neutral.tone(), true, c));
    c.chroma_denoise = config.chroma_denoise;
    steps.push(("chroma denoise", config.chroma_denoise > 0.0, true, c));
    c.sharpen = config.sharpen;
    steps.push(("sharpening", config.sharpen > 0.0, true, c));
    steps
        .into_iter()
        .filter(|s| s.1)
        .map(|(name, _, after_demosaic, config)| Step {
            name,
            after_demosaic,
            config,
        })
        .collect()
}

/// The names of the stages `config` runs, in pipeline order (the report's list and `camsim
/// bench isp`'s), for a mosaic or, with `linear`, a frame that skips demosaicing.
pub fn stage_names(config: &IspConfig<'_>, linear: bool) -> Vec<&'static str> {
    let steps = cumulative_steps(config, linear);
    let mut stages = vec!["black level"];
    stages.extend(
        steps[1..]
            .iter()
            .filter(|s| !s.after_demosaic)
            .map(|s| s.name),
    );
    stages.push(if linear {
        "(linear input: no demosaicing)"
    } else {
        config.demosaic.name()
    });
    let after_encoding = ["chroma denoise", "sharpening"];
    let before_encoding = |s: &&Step| s.after_demosaic && !after_encoding.contains(&s.name);
    stages.extend(steps[1..].iter().filter(before_encoding).map(|s| s.name));
    stages.push("sRGB encode");
    stages.extend(
        steps[1..]
            .iter()
            .filter(|s| after_encoding.contains(&s.name))
            .map(|s| s.name),
    );
    stages
}

/// A built pipeline (float or fixed) and the scratch of each band, ready to run a frame
/// repeatedly: building (tables, scratch) is outside the time measured.
pub struct Runner<'a> {
    input: Input<'a>,
    path: PipelinePath<'a>,
    /// Output rows of each band, in order.
    bands: Vec<std::ops::Range<usize>>,
    /// Bits of each output sample (8 or 16).
    out_bits: u8,
}

// One value per run: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum PipelinePath<'a> {
    Float(FloatPipeline<'a>, Vec<Vec<f32>>),
    // Boxed: the fixed pipeline carries its tables.
    Fixed(Box<FixedPipeline<'a>>, Vec<Vec<u16>>),
}

impl<'a> Runner<'a> {
    /// The pipeline for `config` on `input`, split into `threads` bands of equal height (at
    /// most one per row); the fixed path writes `out_bits`-bit output (8 or 16), the float
    /// path any.
    pub fn new(
        input: &Input<'a>,
        config: &IspConfig<'a>,
        fixed: bool,
        out_bits: u8,
        threads: usize,
    ) -> Result<Self, IspError> {
        let (w, h) = (input.width(), input.height());
        let len = config.scratch_len(w, h).ok_or(IspError::InvalidParameter {
            name: "frame size",
            allowed: "a scratch length that fits usize",
        })?;
        let count = threads.clamp(1, h.max(1));
        let per_band = h.div_ceil(count).max(1);
        let bands: Vec<_> = (0..h)
            .step_by(per_band)
            .map(|start| start..(start + per_band).min(h))
            .collect();
        let path = if fixed {
            let scratch = bands.iter().map(|_| vec![0u16; len]).collect();
            PipelinePath::Fixed(Box::new(FixedPipeline::new(config, out_bits)?), scratch)
        } else {
            let scratch = bands.iter().map(|_| vec![0f32; len]).collect();
            PipelinePath::Float(FloatPipeline::new(config)?, scratch)
        };
        Ok(Self {
            input: *input,
            path,
            bands,
            out_bits,
        })
    }

    /// [`Runner::best_ms`] into an output of the runner's depth that is then dropped: for
    /// timing alone.
    pub fn time_ms(&mut self, repeats: u32) -> Result<f64, IspError> {
        let samples = 3 * self.input.width() * self.input.height();
        if self.out_bits == 8 {
            self.best_ms(&mut vec![0u8; samples], repeats)
        } else {
            self.best_ms(&mut vec![0u16; samples], repeats)
        }
    }

    /// Threads (bands) each run uses.
    pub fn threads(&self) -> usize {
        self.bands.len()
    }

    /// Runs the whole frame into `out` (`3 * width * height` samples) `repeats` times (at
    /// least once) and returns the fastest run in milliseconds.
    pub fn best_ms<O: OutputSample + Default + Send>(
        &mut self,
        out: &mut [O],
        repeats: u32,
    ) -> Result<f64, IspError> {
        let mut best = f64::INFINITY;
        for _ in 0..repeats.max(1) {
            let start = Instant::now();
            self.run(out)?;
            best = best.min(start.elapsed().as_secs_f64() * 1e3);
        }
        Ok(best)
    }

    /// One run of every band, in parallel when there are several.
    fn run<O: OutputSample + Send>(&mut self, out: &mut [O]) -> Result<(), IspError> {
        let input = self.input;
        let w = input.width();
        if out.len() != 3 * w * input.height() {
            return Err(IspError::InvalidParameter {
                name: "output",
                allowed: "3 * width * height samples",
            });
        }
        let bands = &self.bands;
        match &mut self.path {
            PipelinePath::Float(p, scratch) => {
                let p = &*p;
                parallel(bands, w, scratch, out, |rows, s, view| {
                    float_dispatch(p, input, rows, s, view)
                })
            }
            PipelinePath::Fixed(p, scratch) => {
                let p = &**p;
                parallel(bands, w, scratch, out, |rows, s, view| {
                    fixed_dispatch(p, input, rows, s, view)
                })
            }
        }
    }
}

/// The fixed pipeline in the fastest build this CPU runs: the AVX-512 build, else the AVX2
/// build where the CPU has it (bit-identical output, tested in isp-core), the baseline build
/// otherwise; as `demosaic::directional_dispatch` chooses.
fn fixed_dispatch<O: OutputSample>(
    pipeline: &FixedPipeline<'_>,
    input: Input<'_>,
    rows: std::ops::Range<usize>,
    scratch: &mut [u16],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY: the CPU has just been found to support the four features
        // `run_input_avx512` is compiled for.
        return unsafe { pipeline.run_input_avx512(input, rows, scratch, out) };
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU has just been found to support AVX2 and FMA, the target features
        // `run_input_avx2` is compiled for.
        return unsafe { pipeline.run_input_avx2(input, rows, scratch, out) };
    }
    pipeline.run_input(input, rows, scratch, out)
}

/// Whether the CPU has AVX2 and FMA, the features of the pipelines' `run_input_avx2`.
#[cfg(target_arch = "x86_64")]
fn has_avx2_fma() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

/// The float pipeline in the fastest build this CPU runs, as [`fixed_dispatch`].
fn float_dispatch<O: OutputSample>(
    pipeline: &FloatPipeline<'_>,
    input: Input<'_>,
    rows: std::ops::Range<usize>,
    scratch: &mut [f32],
    out: &mut RgbViewMut<'_, O>,
) -> Result<(), IspError> {
    #[cfg(target_arch = "x86_64")]
    if has_avx512() {
        // SAFETY: as in `fixed_dispatch`.
        return unsafe { pipeline.run_input_avx512(input, rows, scratch, out) };
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU has just been found to support AVX2 and FMA, the target features
        // `run_input_avx2` is compiled for.
        return unsafe { pipeline.run_input_avx2(input, rows, scratch, out) };
    }
    pipeline.run_input(input, rows, scratch, out)
}

/// Runs `job` on each band (rows of a frame `w` pixels wide) with its scratch and its rows of
/// `out`: on this thread for one band, else one scoped thread per band. The first error wins.
fn parallel<S: Send, O: OutputSample + Send>(
    bands: &[std::ops::Range<usize>],
    w: usize,
    scratch: &mut [Vec<S>],
    out: &mut [O],
    job: impl Fn(std::ops::Range<usize>, &mut [S], &mut RgbViewMut<'_, O>) -> Result<(), IspError>
        + Sync,
) -> Result<(), IspError> {
    let mut chunks = Vec::with_capacity(bands.len());
    let mut rest = out;
    for band in bands {
        let (chunk, tail) = rest.split_at_mut(band.len() * 3 * w);
        chunks.push(chunk);
        rest = tail;
    }
    let run_band = |rows: &std::ops::Range<usize>, s: &mut Vec<S>, chunk: &mut [O]| {
        let mut view = RgbViewMut::new(chunk, w, rows.len(), 3 * w)?;
        job(rows.clone(), s, &mut view)
    };
    if let ([rows], [s], [chunk]) = (bands, &mut *scratch, chunks.as_mut_slice()) {
        return run_band(rows, s, chunk);
    }
    std::thread::scope(|scope| {
        let handles: Vec<_> = bands
            .iter()
            .zip(scratch.iter_mut())
            .zip(chunks)
            .map(|((rows, s), chunk)| scope.spawn(|| run_band(rows, s, chunk)))
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
            .collect::<Result<Vec<()>, IspError>>()
            .map(|_| ())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use raw_formats::dng::{Crop, Orientation};

    #[test]
    fn framed_size_is_the_size_frame_samples_gives() {
        let crops = [
            None,
            Some(Crop {
                left: 1,
                top: 2,
                width: 5,
                height: 3,
            }),
            Some(Crop {
                left: 0,
                top: 0,
                width: 8,
                height: 6,
            }),
        ];
        for tiff in 1..=8 {
            for default_crop in crops {
                for choice in [CropChoice::Default, CropChoice::Active] {
                    let framing = Framing {
                        default_crop,
                        orientation: Orientation::from_tiff(tiff).unwrap(),
                    };
                    let data = vec![0u8; 8 * 6 * 3];
                    let (framed, w, h, _) = frame_samples(data, 8, 6, 3, &framing, choice).unwrap();
                    assert_eq!(framed_size(8, 6, &framing, choice), (w, h));
                    assert_eq!(framed.len(), w * h * 3);
                }
            }
        }
    }
}
