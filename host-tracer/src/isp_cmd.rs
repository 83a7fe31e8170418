//! `camsim isp`: a raw mosaic file through isp-core's pipeline to an sRGB PNG, printing the
//! stages run, the AWB estimate and the time each stage costs.
//!
//! Stage times come from ablation: the pipeline is fused (every stage runs per row in one
//! pass), so each stage's cost is the time of a run with it minus the time of a run without it,
//! stages added in pipeline order, each run timed best of three.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use isp_core::colour::LINEAR_SRGB_TO_XYZ;
use isp_core::demosaic::Method;
use isp_core::dpc::DpcConfig;
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::pipeline::{scratch_len, FixedPipeline, FloatPipeline, IspConfig, OutputSample};
use isp_core::tone::Look;
use isp_core::wb::{self, AwbEstimate, AwbMethod};
use isp_core::CfaPattern;

use crate::imageio::{self, Image};

/// The options of `camsim isp`.
#[derive(Args, Debug, Clone)]
pub struct IspArgs {
    /// Input mosaic: single-channel 8- or 16-bit PNG or PGM.
    #[arg(long)]
    pub input: PathBuf,
    /// Output sRGB image (.png or .ppm).
    #[arg(long)]
    pub output: PathBuf,
    /// CFA pattern by the top-left 2x2 block: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, default_value = "RGGB")]
    pub pattern: String,
    /// Bits of raw data in each sample, 8..=16 (default: the file's depth).
    #[arg(long)]
    pub bits: Option<u8>,
    /// Black level: one value, or four (one per 2x2 CFA position, row by row), comma-separated.
    #[arg(long, default_value = "0")]
    pub black_level: String,
    /// White level (default: 2^bits - 1).
    #[arg(long)]
    pub white_level: Option<u16>,
    /// ISO / digital gain, [0, 64).
    #[arg(long, default_value_t = 1.0)]
    pub gain: f32,
    /// White-balance gains R,G,B, each in [0, 16).
    #[arg(long, conflicts_with = "awb")]
    pub wb: Option<String>,
    /// Automatic white balance: grey-world, white-patch, shades-of-grey or grey-edge.
    #[arg(long)]
    pub awb: Option<String>,
    /// Colour matrix, camera RGB to linear sRGB: nine numbers row by row (default identity).
    #[arg(long, allow_hyphen_values = true)]
    pub ccm: Option<String>,
    /// Demosaicing: nearest, bilinear or mhc.
    #[arg(long, default_value = "bilinear")]
    pub demosaic: String,
    /// Denoise strength in linear units, [0, 1]; 0 is off.
    #[arg(long, default_value_t = 0.0)]
    pub denoise: f32,
    /// Dynamic defective-pixel threshold in raw units (default: off).
    #[arg(long)]
    pub dpc_threshold: Option<u16>,
    /// Look: neutral, vivid, muted, mono or high-contrast.
    #[arg(long, default_value = "neutral")]
    pub look: String,
    /// float (the reference) or fixed (the firmware path).
    #[arg(long, default_value = "float")]
    pub path: String,
    /// Output depth: 8 or 16.
    #[arg(long, default_value_t = 8)]
    pub out_bits: u8,
}

fn numbers(text: &str, what: &str, count: &[usize]) -> Result<Vec<f32>, String> {
    let values: Result<Vec<f32>, _> = text.split(',').map(|s| s.trim().parse::<f32>()).collect();
    match values {
        Ok(v) if count.contains(&v.len()) && v.iter().all(|x| x.is_finite()) => Ok(v),
        _ => Err(format!(
            "{what} must be {} comma-separated numbers (got {text:?})",
            count
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        )),
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
    /// Milliseconds per stage (ablation), in pipeline order.
    pub stage_ms: Vec<(&'static str, f64)>,
    /// Milliseconds of the whole pipeline.
    pub total_ms: f64,
}

impl IspReport {
    /// The readable report.
    pub fn to_text(&self, path: &str) -> String {
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
        out += "time per stage (ms, by ablation):\n";
        for (name, ms) in &self.stage_ms {
            out += &format!("  {name:<28} {ms:>9.2}\n");
        }
        out += &format!("  {:<28} {:>9.2}\n", "pipeline total", self.total_ms);
        out
    }
}

/// Runs `camsim isp`; returns the report text.
pub fn run(args: &IspArgs) -> Result<String, String> {
    let image = imageio::read(&args.input)?;
    if image.channels != 1 {
        return Err(format!(
            "{}: expected a single-channel mosaic, found {} channels",
            args.input.display(),
            image.channels
        ));
    }
    let (report, rgb) = process(&image, args)?;
    imageio::write(&args.output, &rgb)?;
    Ok(report.to_text(&args.path) + &format!("wrote {}\n", args.output.display()))
}

/// Processes a mosaic image with the options; returns the report and the RGB image.
pub fn process(image: &Image, args: &IspArgs) -> Result<(IspReport, Image), String> {
    let pattern: CfaPattern = args.pattern.parse().map_err(|_| {
        format!(
            "--pattern must be one of RGGB, BGGR, GRBG, GBRG (got {:?})",
            args.pattern
        )
    })?;
    let bits = args.bits.unwrap_or(image.bits);
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
    let black = numbers(&args.black_level, "--black-level", &[1, 4])?;
    let black: [u16; 4] =
        std::array::from_fn(|i| black[if black.len() == 1 { 0 } else { i }] as u16);
    let white = args.white_level.unwrap_or(max);
    let (w, h) = (image.width, image.height);
    let raw = RawFrame::new(&image.data, w, h, w, bits, pattern, black, white)
        .map_err(|e| format!("raw frame: {e} (check --bits, --black-level, --white-level)"))?;

    let mut awb = None;
    let wb_gains = match (&args.wb, &args.awb) {
        (Some(text), _) => {
            let g = numbers(text, "--wb", &[3])?;
            [g[0], g[1], g[2]]
        }
        (None, Some(name)) => {
            let method = AwbMethod::from_name(name).map_err(|e| format!("--awb: {e}"))?;
            let est = wb::estimate(&raw, method, &LINEAR_SRGB_TO_XYZ)
                .map_err(|e| format!("--awb: {e}"))?;
            awb = Some(est);
            est.gains
        }
        (None, None) => [1.0; 3],
    };
    let ccm = match &args.ccm {
        Some(text) => {
            let m = numbers(text, "--ccm", &[9])?;
            std::array::from_fn(|i| std::array::from_fn(|j| m[3 * i + j]))
        }
        None => isp_core::pipeline::IDENTITY,
    };
    let demosaic: Method = args.demosaic.parse().map_err(|_| {
        format!(
            "--demosaic must be one of nearest, bilinear, mhc (got {:?})",
            args.demosaic
        )
    })?;
    let look: Look = args.look.parse().map_err(|e| format!("--look: {e}"))?;
    let config = IspConfig {
        dpc: DpcConfig {
            static_defects: &[],
            dynamic_threshold: args.dpc_threshold,
        },
        lsc: None,
        gain: args.gain,
        wb_gains,
        demosaic,
        denoise: args.denoise,
        ccm,
        tone: look.tone(),
    };
    config.validate().map_err(|e| e.to_string())?;
    let fixed = match args.path.as_str() {
        "float" => false,
        "fixed" => true,
        other => return Err(format!("--path must be float or fixed (got {other:?})")),
    };
    let out_bits = match args.out_bits {
        b @ (8 | 16) => b,
        b => return Err(format!("--out-bits must be 8 or 16 (got {b})")),
    };

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

    // Cumulative configurations, one stage more each; the base is what always runs.
    let mut c = IspConfig {
        demosaic,
        ..IspConfig::default()
    };
    let mut steps = vec![("black level+demosaic+encode", true, c)];
    c.dpc.dynamic_threshold = config.dpc.dynamic_threshold;
    steps.push(("defective pixels", config.dpc.is_active(), c));
    c.gain = config.gain;
    steps.push(("gain", config.gain != 1.0, c));
    c.wb_gains = config.wb_gains;
    steps.push(("white balance", config.wb_gains != [1.0; 3], c));
    c.denoise = config.denoise;
    steps.push(("denoise", config.denoise > 0.0, c));
    c.ccm = config.ccm;
    steps.push((
        "colour matrix",
        config.ccm != isp_core::pipeline::IDENTITY,
        c,
    ));
    c.tone = config.tone;
    steps.push(("tone", config.tone != Look::Neutral.tone(), c));
    steps.retain(|s| s.1);
    // The report lists stages in pipeline order: demosaic before denoise, CCM and tone.
    let demosaic_at = steps
        .iter()
        .position(|s| ["denoise", "colour matrix", "tone"].contains(&s.0))
        .unwrap_or(steps.len());
    let mut stages = vec!["black level"];
    stages.extend(steps[1..demosaic_at].iter().map(|s| s.0));
    stages.push(demosaic.name());
    stages.extend(steps[demosaic_at..].iter().map(|s| s.0));
    stages.push("sRGB encode");
    let mut stage_ms = Vec::new();
    let mut previous = 0.0;
    let mut scratch_out = vec![0u8; w * h * 3];
    for (name, _, c) in &steps {
        let ms = time_run(&raw, c, fixed, &mut scratch_out)?;
        stage_ms.push((*name, (ms - previous).max(0.0)));
        previous = ms;
    }
    let report = IspReport {
        stages,
        awb,
        wb_gains,
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
    let len = scratch_len(w).ok_or("frame too wide")?;
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
