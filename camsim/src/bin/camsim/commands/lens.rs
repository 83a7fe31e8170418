//! `camsim lens`: a real lens's paraxial data, and rays traced through it.

use std::path::PathBuf;

use camsim::lens::{trace_rays, LensFile, LensReport, RayInput};
use camsim::Error;
use clap::Args;

use crate::cli_args::number;

#[derive(Args)]
pub struct LensArgs {
    /// The lens file: TOML (camsim's format, see the README) or pbrt's `.dat`.
    file: PathBuf,
    /// Wavelength of the paraxial data and of the image plane rays are traced to, nm
    /// (300-2500; default the d line, 587.5618).
    #[arg(long, value_name = "NM", allow_hyphen_values = true)]
    wavelength: Option<String>,
    /// Abbe number given to a pbrt file's single indices (its model glasses).
    #[arg(
        long,
        value_name = "VD",
        default_value = "50",
        allow_hyphen_values = true
    )]
    pbrt_abbe: String,
    /// Trace the rays a JSON file lists (`[{"origin": [x, y, z], "direction": [dx, dy, dz],
    /// "wavelength_nm": 550}]`, mm, the first vertex's frame) to the paraxial image plane.
    #[arg(long, value_name = "RAYS.json")]
    trace: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Write the curves (distortion, lateral colour, relative illumination, RMS spot against
    /// the field, chromatic focal shift) as DIR/lens.svg.
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
}

/// Runs `camsim lens`.
pub fn run(args: &LensArgs) -> Result<String, Error> {
    let wavelength = match &args.wavelength {
        Some(w) => number("--wavelength", w, "a wavelength of 300 to 2500 nm", |x| {
            (300.0..=2500.0).contains(&x)
        })?,
        None => optics_core::prescription::glass::LAMBDA_D_NM,
    };
    let abbe = number(
        "--pbrt-abbe",
        &args.pbrt_abbe,
        "an Abbe number of 10 to 120",
        |x| (10.0..=120.0).contains(&x),
    )?;
    let lens = LensFile::read(&args.file, abbe)?;
    let report = LensReport::of(&lens, wavelength).map_err(|e| e.in_file(&args.file))?;
    if let Some(dir) = &args.plot {
        let caption = format!(
            "camsim lens {} --wavelength {wavelength}; {}",
            args.file.display(),
            report.source
        );
        let path = camsim::lens::plot(&report, dir, &caption)?;
        eprintln!("lens: wrote {}", path.display());
    }
    if let Some(path) = &args.trace {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::Format(raw_formats::FormatError::io(path, e)))?;
        let rays: Vec<RayInput> = serde_json::from_str(&text)
            .map_err(|e| Error::Message(format!("{}: {e}", path.display())).in_file(path))?;
        let out = trace_rays(&lens, &rays, wavelength).map_err(|e| e.in_file(path))?;
        if args.json {
            return json_line(&serde_json::json!({ "lens": report, "rays": out }));
        }
        let mut s = report.to_table();
        s += &format!(
            "rays to the paraxial image plane ({:.6} mm after the last vertex):\n",
            report.bfl_mm
        );
        for (k, r) in out.iter().enumerate() {
            s += &match (r.image, r.lost_at_surface, r.lost_because) {
                (Some(p), _, _) => format!(
                    "  ray {:>3} ({} nm): x {:+.6} y {:+.6} mm\n",
                    k + 1,
                    r.wavelength_nm,
                    p[0],
                    p[1]
                ),
                (None, Some(surface), Some(why)) => format!(
                    "  ray {:>3} ({} nm): lost at surface {surface}: {why}\n",
                    k + 1,
                    r.wavelength_nm
                ),
                _ => String::new(),
            };
        }
        return Ok(s);
    }
    if args.json {
        json_line(&report)
    } else {
        Ok(report.to_table())
    }
}

/// `value` as one line of JSON.
fn json_line(value: &impl serde::Serialize) -> Result<String, Error> {
    Ok(serde_json::to_string(value).map_err(|e| Error::Message(e.to_string()))? + "\n")
}
