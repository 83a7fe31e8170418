//! `camsim tune`: a camera's tuning from its captures; `camsim tune-captures`: a capture set
//! shot with a simulated camera, to try it on (and the closed loop's other half).

use std::fmt::Write as _;
use std::path::PathBuf;

use camsim::tune::{self, simulate, TuneSettings};
use camsim::Error;
use clap::Args;
use host_tracer::sensor::SensorConfig;

use crate::progress::Progress;

/// Options of `camsim tune`.
#[derive(Args, Debug, Clone)]
pub struct TuneArgs {
    /// The capture folder: <name>_<CCT>k_<lux>l.dng charts, alsc_<CCT>k_<n>.dng flat fields,
    /// dark_<n>.dng, ptc_<ISO>_<level>_<a|b>.dng photon-transfer pairs.
    #[arg(long)]
    pub captures: PathBuf,
    /// Where to write the tuning file (TOML; written whole or not at all).
    #[arg(long, default_value = "tuning.toml")]
    pub out: PathBuf,
    /// Also write report.md (tables per chart, locus, noise, shading) into this folder.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print the tuning and the per-chart results as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// The chart's corners in pixels in every chart shot, instead of finding it:
    /// x0,y0,x1,y1,x2,y2,x3,y3 (dark skin's, bluish green's, black's and white's outer corners).
    #[arg(long)]
    pub chart: Option<String>,
    /// Lens-shading grid nodes, WxH.
    #[arg(long, default_value = "17x13")]
    pub grid: String,
}

fn parse_chart(text: &str) -> Result<tune::chart::Corners, Error> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| Error::Option {
            option: "--chart",
            value: text.into(),
            allowed: "eight numbers x0,y0,x1,y1,x2,y2,x3,y3".into(),
        })?;
    if values.len() != 8 || values.iter().any(|v| !v.is_finite()) {
        return Err(Error::Option {
            option: "--chart",
            value: text.into(),
            allowed: "eight finite numbers x0,y0,x1,y1,x2,y2,x3,y3".into(),
        });
    }
    Ok(std::array::from_fn(|k| [values[2 * k], values[2 * k + 1]]))
}

fn parse_grid(text: &str) -> Result<(usize, usize), Error> {
    let bad = || Error::Option {
        option: "--grid",
        value: text.into(),
        allowed: "WxH, 3..=64 nodes each way".into(),
    };
    let (w, h) = text.split_once('x').ok_or_else(bad)?;
    Ok((w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?))
}

/// Runs `camsim tune`; returns what it prints.
pub fn run(args: &TuneArgs) -> Result<String, Error> {
    let mut settings = TuneSettings::new(&args.captures);
    settings.grid = parse_grid(&args.grid)?;
    if let Some(c) = &args.chart {
        settings.chart = Some(parse_chart(c)?);
    }
    let mut progress = Progress::new("tune");
    let tuned = tune::tune(&settings, &mut |s| progress.step(s))?;
    progress.finish();
    let text = tuned.tuning.to_toml()?;
    tune::write_atomically(&args.out, &text)?;
    let markdown = tune::report::markdown(&tuned);
    if let Some(dir) = &args.report {
        std::fs::create_dir_all(dir).map_err(|e| raw_formats::FormatError::io(dir, e))?;
        tune::report::write(&tuned, dir)?;
    }
    for w in &tuned.warnings {
        eprintln!("warning: {w}");
    }
    if args.json {
        return Ok(tune::report::json(&tuned).to_string() + "\n");
    }
    let mut out = markdown;
    let _ = writeln!(out, "\nwrote {}", args.out.display());
    if let Some(dir) = &args.report {
        let _ = writeln!(out, "wrote {}", dir.join("report.md").display());
    }
    Ok(out)
}

/// Options of `camsim tune-captures`.
#[derive(Args, Debug, Clone)]
pub struct TuneCapturesArgs {
    /// The folder to shoot into.
    #[arg(long)]
    pub out: PathBuf,
    /// Camera response: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    #[arg(long, default_value = "nikon-5100")]
    pub camera: String,
    /// ADC bits.
    #[arg(long, default_value_t = 12)]
    pub bits: u8,
    /// Black level, DN [default: 2^(bits - 4)].
    #[arg(long)]
    pub black: Option<u16>,
    /// Seed of the sensor's fixed patterns (defects, PRNU, DSNU).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The chart's rotation, degrees.
    #[arg(long, default_value_t = 4.0)]
    pub rotation: f64,
    /// The chart's width as a fraction of the frame's.
    #[arg(long, default_value_t = 0.6)]
    pub chart_width: f64,
    /// Shoot the chart without its black frame.
    #[arg(long)]
    pub no_border: bool,
    /// Write this BlackLevel tag instead of the true black (metadata that is off).
    #[arg(long)]
    pub dng_black: Option<u16>,
}

/// Runs `camsim tune-captures`.
pub fn run_captures(args: &TuneCapturesArgs) -> Result<String, Error> {
    let sensor = SensorConfig {
        camera: args.camera.clone(),
        adc_bits: args.bits,
        black_level: args.black,
        seed: args.seed,
        ..SensorConfig::realistic()
    };
    let mut spec = simulate::CaptureSetSpec::standard(sensor);
    spec.chart.rotation_deg = args.rotation;
    spec.chart.width_fraction = args.chart_width;
    spec.chart.border = !args.no_border;
    spec.dng_black_level = args.dng_black;
    let mut progress = Progress::new("tune-captures");
    let truth = simulate::write_capture_set(&spec, &args.out, &mut |s| progress.step(s))?;
    progress.finish();
    Ok(format!(
        "wrote {} captures to {} (black {}, {} planted defects); tune them with camsim tune --captures {}\n",
        truth.files.len(),
        args.out.display(),
        truth.black,
        truth.defects.len(),
        args.out.display()
    ))
}
