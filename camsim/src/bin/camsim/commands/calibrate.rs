//! `camsim calibrate`: fit a camera's colour matrix on a rendered ColorChecker and write the
//! calibration file.

use std::path::PathBuf;

use camsim::Error;
use clap::Args;
use host_tracer::calibrate;

/// Options of `camsim calibrate`.
#[derive(Args, Debug, Clone)]
pub struct CalibrateArgs {
    /// Camera: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931.
    #[arg(long, default_value = "nikon-5100")]
    pub camera: String,
    /// Illuminant(s), comma-separated, at most two (the DNG's ColorMatrix1/2): A, D50, D65, ...
    #[arg(long, default_value = "A,D65")]
    pub illuminant: String,
    /// Where to write the calibration (TOML) [default: CAMERA-calibration.toml].
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// Runs `camsim calibrate`; returns the report.
pub fn run(args: &CalibrateArgs) -> Result<String, Error> {
    let illuminants: Vec<&str> = args.illuminant.split(',').map(str::trim).collect();
    if illuminants.is_empty() || illuminants.len() > 2 {
        return Err(Error::Message(format!(
            "--illuminant: give one or two illuminants, comma-separated (got {:?})",
            args.illuminant
        )));
    }
    let mut results = Vec::new();
    let mut text = String::new();
    for name in &illuminants {
        let c = calibrate::calibrate(&args.camera, name)?;
        text += &calibrate::report_text(&args.camera, &c);
        results.push(c);
    }
    if results.len() == 2 && (results[0].cct_k - results[1].cct_k).abs() < 1.0 {
        return Err(Error::Message(
            "--illuminant: the two illuminants must differ in colour temperature".into(),
        ));
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}-calibration.toml", args.camera)));
    calibrate::to_file(&args.camera, &results).write(&out)?;
    text += &format!(
        "wrote {} (use it with camsim isp --calibration or camsim demo --calibration)\n",
        out.display()
    );
    Ok(text)
}
