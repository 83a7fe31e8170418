//! `camsim demo`: the whole camera on a built-in scene (see `camsim::demo`), with progress
//! on stderr.

use std::path::PathBuf;

use camsim::demo::{self, DemoProgress, DemoSettings, SensorPreset};
use camsim::Error;
use clap::{Args, ValueEnum};

use crate::args::{AwbArg, PatternArg, PipelineDemosaicArg, RenderFlags};
use crate::progress::RenderBar;

/// A sensor preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SensorArg {
    /// Noise, shading, defects and an optical low-pass filter on at typical values.
    Realistic,
    /// Everything off.
    Ideal,
}

/// Options of `camsim demo`.
#[derive(Args, Debug, Clone)]
// The demo's seed has always been 1 (the README's figures are for it).
#[command(mut_arg("seed", |a| a.default_value("1")))]
pub struct DemoArgs {
    /// Scene: a built-in name (demo, cornell-box) or a TOML file.
    #[arg(long, default_value = "demo")]
    pub scene: String,
    /// Output folder (created if missing).
    #[arg(long, default_value = "camsim-demo")]
    pub output: PathBuf,
    /// Camera response: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    #[arg(long, default_value = "nikon-5100")]
    pub camera: String,
    /// Sensor preset: realistic (noise, shading, defects, optical low-pass filter on) or ideal (all off).
    #[arg(long, value_enum, default_value_t = SensorArg::Realistic)]
    pub sensor: SensorArg,
    /// Light the scene with this illuminant: A, D50, D65, FL2, FL11 or LED-B3 (the lights of
    /// the scene illuminant change spectrum, at the same luminance) [default: the scene's own;
    /// D65 for an RGB scene].
    #[arg(long)]
    pub illuminant: Option<String>,
    /// Calibration file from `camsim calibrate` [default: calibrate under A and D65 now].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Tuning file from `camsim tune` (a tuning of this camera mode: size, pattern, bits):
    /// calibrate, white-balance through its locus and develop with it, and write it into
    /// raw.dng (colour matrices, AsShotNeutral, black level, NoiseProfile, the defect map as
    /// FixBadPixelsList, the shading as GainMaps) [default: the sensor's factory calibration].
    #[arg(long, conflicts_with = "calibration")]
    pub tuning: Option<PathBuf>,
    /// Size, samples, seed and threads of the render (and the seed of the sensor's noise).
    #[command(flatten)]
    pub render: RenderFlags,
    /// ISO (analog gain; 100 is the base).
    #[arg(long, default_value_t = 100.0)]
    pub iso: f64,
    /// Exposure time in seconds [default: automatic].
    #[arg(long)]
    pub exposure: Option<f64>,
    /// ADC bits, 8..=16.
    #[arg(long, default_value_t = 12)]
    pub bits: u8,
    /// CFA pattern by the top-left 2x2 block.
    #[arg(long, value_enum, ignore_case = true, default_value_t = PatternArg::Rggb)]
    pub pattern: PatternArg,
    /// AWB method.
    #[arg(long, value_enum, default_value_t = AwbArg::WhitePatch)]
    pub awb: AwbArg,
    /// Demosaicing (the methods the pipeline runs).
    #[arg(long, value_enum, default_value_t = PipelineDemosaicArg::Directional)]
    pub demosaic: PipelineDemosaicArg,
    /// Noise reduction's strength, a multiplier on the default the sensor's noise profile
    /// sets: [0, 4], 0 off [default: 1 with the realistic sensor, 0 with the ideal one].
    #[arg(long)]
    pub denoise: Option<f32>,
    /// Chroma noise reduction's strength, [0, 4], 0 off [default: 1 where noise reduction is
    /// on, else 0].
    #[arg(long)]
    pub chroma_denoise: Option<f32>,
    /// Render through this lens file (TOML or pbrt .dat, see `camsim lens`) instead of the
    /// scene's thin lens: its focal length, the scene's f-number (no wider than the lens's),
    /// sensor and focus; each sample is traced at one wavelength, so the lens's dispersion
    /// shows.
    #[arg(long, value_name = "FILE")]
    pub lens: Option<PathBuf>,
    /// Print the JSON report instead of the readable one.
    #[arg(long)]
    pub json: bool,
}

impl DemoArgs {
    /// The settings these flags give.
    fn settings(&self) -> DemoSettings {
        let sensor = match self.sensor {
            SensorArg::Realistic => SensorPreset::Realistic,
            SensorArg::Ideal => SensorPreset::Ideal,
        };
        DemoSettings {
            scene: self.scene.clone(),
            output: self.output.clone(),
            camera: self.camera.clone(),
            sensor,
            illuminant: self.illuminant.clone(),
            calibration: self.calibration.clone(),
            tuning: self.tuning.clone(),
            width: self.render.width,
            height: self.render.height,
            spp: self.render.spp,
            threads: self.render.threads,
            seed: self.render.seed,
            iso: self.iso,
            exposure: self.exposure,
            bits: self.bits,
            pattern: self.pattern.into(),
            awb: self.awb.into(),
            demosaic: self.demosaic.into(),
            denoise: self.denoise,
            chroma_denoise: self.chroma_denoise,
            lens: self.lens.clone(),
        }
    }
}

/// Runs `camsim demo`: steps on stderr (the render with a bar on a terminal), the report
/// (readable or JSON) returned for stdout.
pub fn run(args: &DemoArgs) -> Result<String, Error> {
    let settings = args.settings();
    let bar = RenderBar::new();
    let outcome = bar.during(|bar| {
        demo::run(&settings, &|p| match p {
            DemoProgress::Step { n, what } => {
                bar.finish_line();
                eprintln!("[{n}/{}] {what}", DemoProgress::STEPS);
            }
            DemoProgress::Render(r) => bar.update(r),
        })
    })?;
    Ok(if args.json {
        outcome.json
    } else {
        outcome.text
    })
}
