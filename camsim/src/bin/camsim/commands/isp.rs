//! `camsim isp`: a raw mosaic file (DNG, or a PNG/PGM mosaic) through isp-core's pipeline to
//! an sRGB image, printing the stages run, the AWB estimate and the time each stage costs. A
//! DNG gives the pattern, levels, as-shot white balance and colour matrices; flags and the
//! config file override them.

use std::path::PathBuf;

use camsim::develop::{develop, RawInput, RunOptions};
use camsim::isp_options::{self as options, IspOptions, WhiteBalance};
use camsim::Error;
use clap::Args;
use raw_formats::calibration::CalibrationFile;

use crate::args::{
    AwbArg, CropArg, DenoiseSearchArg, LookArg, PathArg, PatternArg, PipelineDemosaicArg,
};

/// The options of `camsim isp`. Every processing option can also come from `--config FILE`
/// (see [`crate::isp_options`]); a flag given here wins over the file.
#[derive(Args, Debug, Clone)]
pub struct IspArgs {
    /// Input: a CFA DNG (uncompressed or lossless JPEG), or a single-channel 8- or 16-bit PNG
    /// or PGM mosaic.
    #[arg(long)]
    pub input: PathBuf,
    /// Output sRGB image, by extension: .png (8 or 16 bits), .tif/.tiff (8 or 16 bits,
    /// uncompressed), .jpg/.jpeg (8 bits) or .ppm.
    #[arg(long)]
    pub output: PathBuf,
    /// JPEG quality, 1..=100, for a .jpg output [default: 90].
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=100))]
    pub jpeg_quality: Option<u8>,
    /// Also time each stage, by ablation: the pipeline runs once more per stage that is on,
    /// each best of three (the pipeline is fused, so a stage's time is a run with it minus
    /// a run without it).
    #[arg(long)]
    pub stage_times: bool,
    /// Print the report as JSON (stages, white balance, the noise profile and its source,
    /// times) instead of text.
    #[arg(long)]
    pub json: bool,
    /// How to process.
    #[command(flatten)]
    pub processing: ProcessingArgs,
}

/// The processing options of `camsim isp` (and `camsim bench isp`).
#[derive(Args, Debug, Clone)]
pub struct ProcessingArgs {
    /// TOML file of processing options, keyed by these flags' names (plus an `[lsc]` grid and
    /// a `defects` list); flags given on the command line win.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// CFA pattern by the top-left 2x2 block [default: the file's, else RGGB].
    #[arg(long, value_enum, ignore_case = true)]
    pub pattern: Option<PatternArg>,
    /// Bits of raw data in each sample, 8..=16 [default: the file's depth].
    #[arg(long)]
    pub bits: Option<u8>,
    /// Black level: one value, or four (one per 2x2 CFA position, row by row), or for a linear
    /// DNG three (R, G, B), comma-separated [default: 0].
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
    /// Automatic white balance.
    #[arg(long, value_enum)]
    pub awb: Option<AwbArg>,
    /// Colour matrix, camera RGB to linear sRGB: nine numbers row by row [default: identity].
    #[arg(long, allow_hyphen_values = true)]
    pub ccm: Option<String>,
    /// Demosaicing [default: directional, the best; mhc and bilinear are faster].
    #[arg(long, value_enum)]
    pub demosaic: Option<PipelineDemosaicArg>,
    /// Lens distortion to correct: k1,k2,p1,p2 or k1,k2,p1,p2,k3 (OpenCV's order) [default: off].
    #[arg(long, allow_hyphen_values = true)]
    pub distortion: Option<String>,
    /// Camera matrix of the distortion: fx,fy,cx,cy in pixels [default: fx = fy = the larger
    /// side, principal point at the centre].
    #[arg(long, allow_hyphen_values = true)]
    pub camera_matrix: Option<String>,
    /// Noise reduction's strength, a multiplier on the default the noise profile sets: [0, 4],
    /// 0 off [default: 1 for a mosaic with a noise profile (given, the file's, or estimated;
    /// 0.5 for an estimate the report calls low confidence: texture above noise), else 0].
    /// Raw-domain non-local means, distances in units of the profile's variance.
    #[arg(long)]
    pub denoise: Option<f32>,
    /// Noise reduction's search window: wide (5x5 packed pixels, 12 offsets by symmetry) or
    /// fast (3x3, 4 offsets: about a third of the cost, for video and firmware) [default: wide].
    #[arg(long, value_enum)]
    pub denoise_search: Option<DenoiseSearchArg>,
    /// Chroma noise reduction's strength, [0, 4], 0 off: an edge-aware mean of each pixel's
    /// chroma over its neighbours after sRGB encoding, which keeps luma and takes out the
    /// colour mottling noise leaves after demosaicing [default: 1 where noise reduction is
    /// on, else 0].
    #[arg(long)]
    pub chroma_denoise: Option<f32>,
    /// The raw's noise profile: S,O for every colour, or S,O per colour R, G, B (six values),
    /// the variance of a sample at signal x (a fraction of white above black) being S x + O,
    /// as the DNG NoiseProfile tag states it [default: the file's NoiseProfile, else estimated
    /// from the frame].
    #[arg(long, allow_hyphen_values = true)]
    pub noise_profile: Option<String>,
    /// Highlight knee, [0, 1]: a white-balanced pixel whose largest channel passes it fades to
    /// neutral, fully at the clip, so clipped highlights come out white rather than magenta or
    /// speckled; 1 is off [default: 0.9].
    #[arg(long)]
    pub highlight_knee: Option<f32>,
    /// Sharpening, [0, 4]: the amount of an unsharp mask on luma after sRGB encoding (the same
    /// luma detail added to each channel); 0 is off [default: 0].
    #[arg(long)]
    pub sharpen: Option<f32>,
    /// Dynamic defective-pixel threshold in raw units [default: off].
    #[arg(long)]
    pub dpc_threshold: Option<u16>,
    /// Look [default: neutral].
    #[arg(long, value_enum)]
    pub look: Option<LookArg>,
    /// Colour calibration file from `camsim calibrate`: the colour matrix then follows the
    /// white balance's colour temperature [default: the DNG's ColorMatrix tags, if any].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Tuning file from `camsim tune`: its black level, defect map and noise profile, the
    /// white balance (--awb's estimate, grey world by default) moved into its locus's band, and
    /// its lens shading and colour matrix at the locus's colour temperature; flags and --config
    /// override any of them.
    #[arg(long, conflicts_with = "calibration")]
    pub tuning: Option<PathBuf>,
    /// float (the reference) or fixed (the firmware path) [default: float].
    #[arg(long, value_enum)]
    pub path: Option<PathArg>,
    /// Output depth: 8 or 16 [default: 8].
    #[arg(long)]
    pub out_bits: Option<u8>,
    /// Framing of a DNG's output: `default` crops to the file's DefaultCrop, as Adobe's raw
    /// converters do; `active` keeps the whole active area, as LibRaw does [default: default].
    #[arg(long, value_enum)]
    pub crop: Option<CropArg>,
    /// Leave a DNG's BaselineExposure unapplied (it is applied as gain by default, as Adobe's
    /// converters do; LibRaw leaves it out).
    #[arg(long)]
    pub no_baseline_exposure: bool,
    /// Threads: the frame runs as that many bands in parallel (the output is the same for
    /// any count) [default: every core].
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub threads: Option<u16>,
}

impl ProcessingArgs {
    /// The processing options given as flags.
    pub fn flag_options(&self) -> Result<IspOptions, Error> {
        let list = |text: &Option<String>, what: &str, counts: &[usize]| {
            text.as_deref()
                .map(|t| options::numbers(t, what, counts))
                .transpose()
        };
        let white_balance = match (&self.wb, &self.awb) {
            (Some(_), _) => list(&self.wb, "--wb", &[3])?
                .map(|g| WhiteBalance::Gains([g[0] as f32, g[1] as f32, g[2] as f32])),
            (None, Some(method)) => Some(WhiteBalance::Auto((*method).into())),
            (None, None) => None,
        };
        Ok(IspOptions {
            pattern: self.pattern.map(Into::into),
            bits: self.bits,
            black_level: list(&self.black_level, "--black-level", &[1, 3, 4])?
                .map(|v| options::black_levels(v, "--black-level"))
                .transpose()?,
            white_level: self.white_level,
            gain: self.gain,
            white_balance,
            ccm: list(&self.ccm, "--ccm", &[9])?
                .map(|v| options::matrix(v, "--ccm"))
                .transpose()?,
            demosaic: self.demosaic.map(Into::into),
            denoise: self.denoise,
            denoise_search: self.denoise_search.map(Into::into),
            noise_profile: list(&self.noise_profile, "--noise-profile", &[2, 6])?
                .map(|v| options::noise_profile(v, "--noise-profile"))
                .transpose()?,
            dpc_threshold: self.dpc_threshold,
            defects: None,
            lsc: None,
            look: self.look.map(Into::into),
            fixed: self.path.map(|p| p == PathArg::Fixed),
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
            crop: self.crop.map(Into::into),
            baseline_exposure: self.no_baseline_exposure.then_some(false),
            highlight_knee: self.highlight_knee,
            sharpen: self.sharpen,
            chroma_denoise: self.chroma_denoise,
            tuning: self.tuning.clone(),
        })
    }

    /// Threads given, else every core.
    pub fn threads(&self) -> usize {
        self.threads
            .map_or(RunOptions::default().threads, usize::from)
    }

    /// The calibration file's, if given.
    pub fn calibration(&self) -> Result<Option<isp_core::ccm::Calibration>, Error> {
        match &self.calibration {
            Some(path) => Ok(Some(CalibrationFile::read(path)?.to_isp()?)),
            None => Ok(None),
        }
    }

    /// The options to run with: flags, then the config file, each `None` left to its default.
    pub fn options(&self) -> Result<IspOptions, Error> {
        let flags = self.flag_options()?;
        Ok(match &self.config {
            Some(file) => flags.or(options::from_file(file)?),
            None => flags,
        })
    }
}

/// Runs `camsim isp`; returns the report text.
pub fn run(args: &IspArgs) -> Result<String, Error> {
    let input = RawInput::read(&args.input)?;
    let processing = &args.processing;
    let options = processing.options()?;
    let calibration = processing.calibration()?;
    for (name, optional) in &input.opcodes_not_applied {
        let kind = if *optional {
            "optional"
        } else {
            "not marked optional"
        };
        eprintln!("note: the file's {name} opcode ({kind}) is not applied yet");
    }
    let run = RunOptions {
        threads: processing.threads(),
        stage_times: args.stage_times,
    };
    let (report, rgb) = develop(&input, &options, calibration, run).map_err(|e| match e {
        e @ Error::SampleRange { .. } => e.in_file(&args.input),
        e => e,
    })?;
    let write_options = raw_formats::image::WriteOptions {
        jpeg_quality: args.jpeg_quality.unwrap_or(90),
    };
    raw_formats::image::write_with(&args.output, &rgb, &write_options)?;
    if args.json {
        let mut json = report.to_json();
        json["output"] = args.output.display().to_string().into();
        return Ok(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n");
    }
    Ok(report.to_text() + &format!("wrote {}\n", args.output.display()))
}
