//! `camsim isp`: a raw mosaic file (DNG, or a PNG/PGM mosaic) through isp-core's pipeline to
//! an sRGB PNG, printing the stages run, the AWB estimate and the time each stage costs. A
//! DNG gives the pattern, levels, as-shot white balance and colour matrices; flags and the
//! config file override them.
//!
//! Stage times come from ablation: the pipeline is fused (every stage runs per row in one
//! pass), so each stage's cost is the time of a run with it minus the time of a run without it,
//! stages added in pipeline order, each run timed best of three.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use isp_core::colour::LINEAR_SRGB_TO_XYZ;
use isp_core::demosaic::Method;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::dpc::DpcConfig;
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::lsc::LensShading;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig, OutputSample};
use isp_core::tone::Look;
use isp_core::wb::{self, AwbEstimate};
use isp_core::CfaPattern;

use isp_core::ccm::Calibration;

use crate::calibrate::CalibrationFile;
use crate::dng::Dng;
use crate::imageio::{self, Image};
use crate::isp_options::{self as options, IspOptions, WhiteBalance};

/// The options of `camsim isp`. Every processing option can also come from `--config FILE`
/// (see [`crate::isp_options`]); a flag given here wins over the file.
#[derive(Args, Debug, Clone)]
pub struct IspArgs {
    /// Input: a DNG (uncompressed CFA), or a single-channel 8- or 16-bit PNG or PGM mosaic.
    #[arg(long)]
    pub input: PathBuf,
    /// Output sRGB image (.png or .ppm).
    #[arg(long)]
    pub output: PathBuf,
    /// TOML file of processing options, keyed by these flags' names (plus an `[lsc]` grid and
    /// a `defects` list); flags given on the command line win.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// CFA pattern by the top-left 2x2 block: RGGB, BGGR, GRBG or GBRG [default: RGGB].
    #[arg(long)]
    pub pattern: Option<String>,
    /// Bits of raw data in each sample, 8..=16 [default: the file's depth].
    #[arg(long)]
    pub bits: Option<u8>,
    /// Black level: one value, or four (one per 2x2 CFA position, row by row), comma-separated
    /// [default: 0].
    #[arg(long)]
    pub black_level: Option<String>,
    /// White level [default: 2^bits - 1].
    #[arg(long)]
    pub white_level: Option<u16>,
    /// ISO / digital gain, [0, 64) [default: 1].
    #[arg(long)]
    pub gain: Option<f32>,
    /// White-balance gains R,G,B, each in [0, 16) [default: 1,1,1].
    #[arg(long, conflicts_with = "awb")]
    pub wb: Option<String>,
    /// Automatic white balance: grey-world, white-patch, shades-of-grey or grey-edge.
    #[arg(long)]
    pub awb: Option<String>,
    /// Colour matrix, camera RGB to linear sRGB: nine numbers row by row [default: identity].
    #[arg(long, allow_hyphen_values = true)]
    pub ccm: Option<String>,
    /// Demosaicing: nearest, bilinear or mhc [default: bilinear].
    #[arg(long)]
    pub demosaic: Option<String>,
    /// Lens distortion to correct: k1,k2,p1,p2 or k1,k2,p1,p2,k3 (OpenCV's order) [default: off].
    #[arg(long, allow_hyphen_values = true)]
    pub distortion: Option<String>,
    /// Camera matrix of the distortion: fx,fy,cx,cy in pixels [default: fx = fy = the larger
    /// side, principal point at the centre].
    #[arg(long, allow_hyphen_values = true)]
    pub camera_matrix: Option<String>,
    /// Denoise strength in linear units, [0, 1]; 0 is off [default: 0].
    #[arg(long)]
    pub denoise: Option<f32>,
    /// Dynamic defective-pixel threshold in raw units [default: off].
    #[arg(long)]
    pub dpc_threshold: Option<u16>,
    /// Look: neutral, vivid, muted, mono or high-contrast [default: neutral].
    #[arg(long)]
    pub look: Option<String>,
    /// Colour calibration file from `camsim calibrate`: the colour matrix then follows the
    /// white balance's colour temperature [default: the DNG's ColorMatrix tags, if any].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// float (the reference) or fixed (the firmware path) [default: float].
    #[arg(long)]
    pub path: Option<String>,
    /// Output depth: 8 or 16 [default: 8].
    #[arg(long)]
    pub out_bits: Option<u8>,
}

impl IspArgs {
    /// The processing options given as flags.
    pub fn flag_options(&self) -> Result<IspOptions, String> {
        let list = |text: &Option<String>, what: &str, counts: &[usize]| {
            text.as_deref()
                .map(|t| options::numbers(t, what, counts))
                .transpose()
        };
        let white_balance = match (&self.wb, &self.awb) {
            (Some(_), _) => list(&self.wb, "--wb", &[3])?
                .map(|g| WhiteBalance::Gains([g[0] as f32, g[1] as f32, g[2] as f32])),
            (None, Some(name)) => Some(WhiteBalance::Auto(options::awb(name, "--awb")?)),
            (None, None) => None,
        };
        Ok(IspOptions {
            pattern: self
                .pattern
                .as_deref()
                .map(|t| options::pattern(t, "--pattern"))
                .transpose()?,
            bits: self.bits,
            black_level: list(&self.black_level, "--black-level", &[1, 4])?
                .map(|v| options::black_levels(v, "--black-level"))
                .transpose()?,
            white_level: self.white_level,
            gain: self.gain,
            white_balance,
            ccm: list(&self.ccm, "--ccm", &[9])?
                .map(|v| options::matrix(v, "--ccm"))
                .transpose()?,
            demosaic: self
                .demosaic
                .as_deref()
                .map(|t| options::demosaic(t, "--demosaic"))
                .transpose()?,
            denoise: self.denoise,
            dpc_threshold: self.dpc_threshold,
            defects: None,
            lsc: None,
            look: self
                .look
                .as_deref()
                .map(|t| options::look(t, "--look"))
                .transpose()?,
            fixed: self
                .path
                .as_deref()
                .map(|t| options::path(t, "--path"))
                .transpose()?,
            out_bits: self
                .out_bits
                .map(|b| options::out_bits(b, "--out-bits"))
                .transpose()?,
            distortion: list(&self.distortion, "--distortion", &[4, 5])?
                .map(|v| options::distortion(v, "--distortion"))
                .transpose()?,
            camera_matrix: list(&self.camera_matrix, "--camera-matrix", &[4])?
                .map(|v| options::camera_matrix(v, "--camera-matrix"))
                .transpose()?,
        })
    }

    /// The options to run with: flags, then the config file, each `None` left to its default.
    pub fn options(&self) -> Result<IspOptions, String> {
        let flags = self.flag_options()?;
        Ok(match &self.config {
            Some(file) => flags.or(options::from_file(file)?),
            None => flags,
        })
    }
}

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
    /// Milliseconds of the whole pipeline.
    pub total_ms: f64,
}

impl IspReport {
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
        out += "time per stage (ms, by ablation):\n";
        for (name, ms) in &self.stage_ms {
            out += &format!("  {name:<28} {ms:>9.2}\n");
        }
        out += &format!("  {:<28} {:>9.2}\n", "pipeline total", self.total_ms);
        out
    }
}

/// Where defaults come from beyond the flags and the config file: a DNG's tags.
#[derive(Debug, Clone, Default)]
pub struct RawSource {
    /// Options the file states (pattern, bits, levels, as-shot white balance).
    pub defaults: IspOptions,
    /// The file's colour calibration.
    pub calibration: Option<Calibration>,
}

/// Reads a DNG as a mosaic image and the defaults its tags give.
pub fn read_dng(path: &std::path::Path) -> Result<(Image, RawSource), String> {
    let dng = Dng::read(path)?;
    let bits = (16 - dng.white_level.leading_zeros()).clamp(8, 16) as u8;
    let image = Image {
        width: dng.width,
        height: dng.height,
        channels: 1,
        bits: 16,
        data: dng.raw.clone(),
    };
    let white_balance = dng
        .as_shot_neutral
        .map(|n| WhiteBalance::Gains([(n[1] / n[0]) as f32, 1.0, (n[1] / n[2]) as f32]));
    let mut entries = Vec::new();
    for (illuminant, xyz_to_camera) in &dng.calibrations {
        let cct = illuminant.cct_k().ok_or_else(|| {
            format!(
                "{}: calibration illuminant code {} has no known colour temperature (A, D50, D55, D65, D75 do)",
                path.display(),
                illuminant.code()
            )
        })?;
        let to_xyz = isp_core::colour::mat3_inverse(xyz_to_camera)
            .map_err(|e| format!("{}: ColorMatrix: {e}", path.display()))?;
        entries.push((cct, to_xyz));
    }
    let calibration = match entries.as_slice() {
        [] => None,
        [(t, m)] => Some(Calibration::single(*t, *m)),
        [(t1, m1), (t2, m2)] => Some(Calibration::new([*t1, *t2], [*m1, *m2])),
        _ => None,
    }
    .transpose()
    .map_err(|e| format!("{}: colour matrices: {e}", path.display()))?;
    let defaults = IspOptions {
        pattern: Some(dng.pattern),
        bits: Some(bits),
        black_level: Some(dng.black_level.to_vec()),
        white_level: Some(dng.white_level),
        white_balance,
        ..IspOptions::default()
    };
    Ok((
        image,
        RawSource {
            defaults,
            calibration,
        },
    ))
}

/// Runs `camsim isp`; returns the report text.
pub fn run(args: &IspArgs) -> Result<String, String> {
    let is_dng = args
        .input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("dng"));
    let (image, source) = if is_dng {
        read_dng(&args.input)?
    } else {
        (imageio::read(&args.input)?, RawSource::default())
    };
    if image.channels != 1 {
        return Err(format!(
            "{}: expected a single-channel mosaic, found {} channels",
            args.input.display(),
            image.channels
        ));
    }
    let (report, rgb) = process_raw(&image, args, source)?;
    imageio::write(&args.output, &rgb)?;
    Ok(report.to_text() + &format!("wrote {}\n", args.output.display()))
}

/// Processes a mosaic image with the options; returns the report and the RGB image.
pub fn process(image: &Image, args: &IspArgs) -> Result<(IspReport, Image), String> {
    process_raw(image, args, RawSource::default())
}

/// The colour temperature of a camera neutral under a calibration (two passes: the matrix
/// depends on the temperature).
pub fn neutral_cct(calibration: &Calibration, neutral: [f32; 3]) -> Result<f64, String> {
    let mut cct = 5000.0;
    for _ in 0..3 {
        let m = calibration.camera_to_xyz(cct).map_err(|e| e.to_string())?;
        cct = wb::cct_of_neutral(neutral, &m).map_err(|e| e.to_string())?;
    }
    Ok(cct)
}

/// [`process`] with a raw file's defaults and calibration under the flags and config file.
pub fn process_raw(
    image: &Image,
    args: &IspArgs,
    source: RawSource,
) -> Result<(IspReport, Image), String> {
    let options = args.options()?.or(source.defaults);
    let calibration = match &args.calibration {
        Some(path) => Some(CalibrationFile::read(path)?.to_isp()?),
        None => source.calibration,
    };
    let pattern = options.pattern.unwrap_or(CfaPattern::Rggb);
    let bits = options.bits.unwrap_or(image.bits);
    if !(8..=16).contains(&bits) || bits > image.bits {
        return Err(format!(
            "--bits must be 8..=16 and at most the file's depth {} (got {bits})",
            image.bits
        ));
    }
    let max = ((1u32 << bits) - 1) as u16;
    if let Some(v) = image.data.iter().find(|v| **v > max) {
        return Err(format!(
            "{}: sample {v} exceeds {bits}-bit range (pass the right --bits)",
            args.input.display()
        ));
    }
    let black = options.black_level.clone().unwrap_or(vec![0]);
    let black: [u16; 4] = std::array::from_fn(|i| black[if black.len() == 1 { 0 } else { i }]);
    let white = options.white_level.unwrap_or(max);
    let (w, h) = (image.width, image.height);
    let raw = RawFrame::new(&image.data, w, h, w, bits, pattern, black, white)
        .map_err(|e| format!("raw frame: {e} (check --bits, --black-level, --white-level)"))?;

    let mut awb = None;
    let wb_gains = match options.white_balance {
        Some(WhiteBalance::Gains(g)) => g,
        Some(WhiteBalance::Auto(method)) => {
            let to_xyz = match &calibration {
                Some(c) => c.camera_to_xyz(6504.0).map_err(|e| e.to_string())?,
                None => LINEAR_SRGB_TO_XYZ,
            };
            let mut est = wb::estimate(&raw, method, &to_xyz).map_err(|e| format!("--awb: {e}"))?;
            if let Some(c) = &calibration {
                est.cct_k = neutral_cct(c, est.neutral)?;
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
            let neutral = wb_gains.map(|g| 1.0 / g);
            let cct = neutral_cct(c, neutral)?;
            c.ccm(cct, wb_gains)
                .map_err(|e| format!("colour matrix from the calibration: {e}"))?
        }
        (None, None) => isp_core::pipeline::IDENTITY,
    };
    let demosaic = options.demosaic.unwrap_or(Method::Bilinear);
    let defects = options.defects.clone().unwrap_or_default();
    let lsc = options
        .lsc
        .as_ref()
        .map(|g| LensShading::new(g.width, g.height, &g.gains_q12))
        .transpose()
        .map_err(|e| format!("lsc: {e}"))?;
    let distortion = match options.distortion {
        Some(d) => {
            let [fx, fy, cx, cy] = options.camera_matrix.unwrap_or_else(|| {
                let f = w.max(h) as f64;
                [f, f, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0]
            });
            let model = BrownConrady::from_opencv(d).map_err(|e| format!("--distortion: {e}"))?;
            Some(
                LensDistortion::new(fx, fy, cx, cy, model)
                    .map_err(|e| format!("--camera-matrix: {e}"))?,
            )
        }
        None if options.camera_matrix.is_some() => {
            return Err("--camera-matrix needs --distortion (the coefficients to correct)".into())
        }
        None => None,
    };
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &defects,
            dynamic_threshold: options.dpc_threshold,
        },
        lsc,
        gain: options.gain.unwrap_or(1.0),
        wb_gains,
        demosaic,
        distortion,
        denoise: options.denoise.unwrap_or(0.0),
        ccm,
        tone: options.look.unwrap_or(Look::Neutral).tone(),
    };
    config.validate().map_err(|e| e.to_string())?;
    let fixed = options.fixed.unwrap_or(false);
    let out_bits = options.out_bits.unwrap_or(8);
    let (mut report, rgb) = execute(&raw, &config, fixed, out_bits)?;
    report.awb = awb;
    Ok((report, rgb))
}

/// Runs the pipeline on `raw` with `config` (float or fixed path, 8- or 16-bit output) and
/// times each stage by ablation; returns the report (with no AWB estimate) and the image.
pub fn execute(
    raw: &RawFrame<'_>,
    config: &IspConfig<'_>,
    fixed: bool,
    out_bits: u8,
) -> Result<(IspReport, Image), String> {
    let raw = *raw;
    let config = *config;
    let (demosaic, distortion, wb_gains) = (config.demosaic, config.distortion, config.wb_gains);
    let (w, h) = (raw.mosaic().width(), raw.mosaic().height());
    let mut out = vec![0u16; w * h * 3];
    let total_ms = if out_bits == 8 {
        let mut out8 = vec![0u8; w * h * 3];
        let ms = time_run(&raw, &config, fixed, &mut out8)?;
        for (o, v) in out.iter_mut().zip(&out8) {
            *o = *v as u16;
        }
        ms
    } else {
        time_run(&raw, &config, fixed, &mut out)?
    };

    // Cumulative configurations, one stage more each, in pipeline order; the base is what
    // always runs. `true` marks the stages after demosaicing.
    let mut c = IspConfig {
        demosaic,
        ..IspConfig::default()
    };
    let mut steps = vec![("black level+demosaic+encode", true, false, c)];
    c.dpc = config.dpc;
    steps.push(("defective pixels", config.dpc.is_active(), false, c));
    c.lsc = config.lsc;
    steps.push(("lens shading", config.lsc.is_some(), false, c));
    c.gain = config.gain;
    steps.push(("gain", config.gain != 1.0, false, c));
    c.wb_gains = config.wb_gains;
    steps.push(("white balance", config.wb_gains != [1.0; 3], false, c));
    c.distortion = config.distortion;
    let lens_on = config.distortion.is_some_and(|d| !d.is_identity());
    steps.push(("distortion correction", lens_on, true, c));
    c.denoise = config.denoise;
    steps.push(("denoise", config.denoise > 0.0, true, c));
    c.ccm = config.ccm;
    steps.push((
        "colour matrix",
        config.ccm != isp_core::pipeline::IDENTITY,
        true,
        c,
    ));
    c.tone = config.tone;
    steps.push(("tone", config.tone != Look::Neutral.tone(), true, c));
    steps.retain(|s| s.1);
    let mut stages = vec!["black level"];
    stages.extend(steps[1..].iter().filter(|s| !s.2).map(|s| s.0));
    stages.push(demosaic.name());
    stages.extend(steps[1..].iter().filter(|s| s.2).map(|s| s.0));
    stages.push("sRGB encode");
    let mut stage_ms = Vec::new();
    let mut previous = 0.0;
    let mut scratch_out = vec![0u8; w * h * 3];
    for (name, _, _, c) in &steps {
        let ms = time_run(&raw, c, fixed, &mut scratch_out)?;
        stage_ms.push((*name, (ms - previous).max(0.0)));
        previous = ms;
    }
    let report = IspReport {
        stages,
        awb: None,
        wb_gains,
        distortion: distortion
            .filter(|_| lens_on)
            .map(|d| (d, d.window_rows(w, h))),
        fixed,
        stage_ms,
        total_ms,
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

/// Runs the whole frame, best of three, in milliseconds.
fn time_run<O: OutputSample + Default>(
    raw: &RawFrame<'_>,
    config: &IspConfig<'_>,
    fixed: bool,
    out: &mut [O],
) -> Result<f64, String> {
    // One short-lived value on the stack: the variants' sizes do not matter.
    #[allow(clippy::large_enum_variant)]
    enum Runner<'a> {
        Float(FloatPipeline<'a>, Vec<f32>),
        // Boxed: the fixed pipeline carries 32 KiB of tables.
        Fixed(Box<FixedPipeline<'a>>, Vec<u16>),
    }
    let (w, h) = (raw.mosaic().width(), raw.mosaic().height());
    let len = config.scratch_len(w, h).ok_or("frame too large")?;
    let bits = if O::BITS == 16 { 16 } else { 8 };
    let mut runner = if fixed {
        let p = FixedPipeline::new(config, bits).map_err(|e| e.to_string())?;
        Runner::Fixed(Box::new(p), vec![0; len])
    } else {
        let p = FloatPipeline::new(config).map_err(|e| e.to_string())?;
        Runner::Float(p, vec![0.0; len])
    };
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let mut view = RgbViewMut::new(out, w, h, 3 * w).map_err(|e| e.to_string())?;
        let start = Instant::now();
        match &mut runner {
            Runner::Float(p, scratch) => p.run(raw, 0..h, scratch, &mut view),
            Runner::Fixed(p, scratch) => p.run(raw, 0..h, scratch, &mut view),
        }
        .map_err(|e| e.to_string())?;
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
    }
    Ok(best)
}
