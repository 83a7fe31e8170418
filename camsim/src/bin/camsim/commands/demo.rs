//! `camsim demo`: the whole camera on a built-in scene (see `camsim::demo`), with progress
//! on stderr.

use std::path::PathBuf;

use camsim::demo::{self, DemoProgress, DemoSettings, SensorPreset};
use camsim::isp_options;
use camsim::Error;
use clap::Args;

use crate::progress::RenderBar;

/// Options of `camsim demo`.
#[derive(Args, Debug, Clone)]
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
    /// Sensor preset: realistic (noise, shading, defects on) or ideal (all off).
    #[arg(long, default_value = "realistic")]
    pub sensor: String,
    /// The scene's illuminant (for the truth's scale and the AWB error): A, D50, D65, FL2, ...
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Calibration file from `camsim calibrate` [default: calibrate under A and D65 now].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Image width [default: the scene's].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height [default: the scene's].
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel [default: the scene's].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render threads; 0 uses every core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Seed of the render and the sensor's noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// ISO (analog gain; 100 is the base).
    #[arg(long, default_value_t = 100.0)]
    pub iso: f64,
    /// Exposure time in seconds [default: automatic].
    #[arg(long)]
    pub exposure: Option<f64>,
    /// ADC bits, 8..=16.
    #[arg(long, default_value_t = 12)]
    pub bits: u8,
    /// CFA pattern: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, default_value = "RGGB")]
    pub pattern: String,
    /// AWB method: grey-world, white-patch, shades-of-grey or grey-edge.
    #[arg(long, default_value = "white-patch")]
    pub awb: String,
    /// Demosaicing: nearest, bilinear or mhc (the methods the pipeline runs).
    #[arg(long, default_value = "mhc")]
    pub demosaic: String,
    /// Print the JSON report instead of the readable one.
    #[arg(long)]
    pub json: bool,
}

impl DemoArgs {
    /// The settings these flags give.
    fn settings(&self) -> Result<DemoSettings, Error> {
        let sensor = match self.sensor.as_str() {
            "realistic" => SensorPreset::Realistic,
            "ideal" => SensorPreset::Ideal,
            other => {
                return Err(Error::Message(format!(
                    "--sensor: unknown preset {other:?}; expected realistic or ideal"
                )))
            }
        };
        Ok(DemoSettings {
            scene: self.scene.clone(),
            output: self.output.clone(),
            camera: self.camera.clone(),
            sensor,
            illuminant: self.illuminant.clone(),
            calibration: self.calibration.clone(),
            width: self.width,
            height: self.height,
            spp: self.spp,
            threads: self.threads,
            seed: self.seed,
            iso: self.iso,
            exposure: self.exposure,
            bits: self.bits,
            pattern: isp_options::pattern(&self.pattern, "--pattern")?,
            awb: isp_options::awb(&self.awb, "--awb")?,
            demosaic: isp_options::demosaic(&self.demosaic, "--demosaic")?,
        })
    }
}

/// Runs `camsim demo`: steps on stderr (the render with a bar on a terminal), the report
/// (readable or JSON) returned for stdout.
pub fn run(args: &DemoArgs) -> Result<String, Error> {
    let settings = args.settings()?;
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
