//! `camsim dof`: depth of field, hyperfocal distance, focus position and magnification of a
//! thin lens.

use camsim::dof::{compute, DofInput, MIN_F_NUMBER};
use camsim::Error;
use clap::Args;

use crate::cli_args::{number, number_or_infinity};

#[derive(Args)]
pub struct DofArgs {
    /// Focal length in millimetres (> 0).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    focal_length_mm: String,
    /// f-number N = f / D (>= 0.5).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    f_number: String,
    /// Acceptable circle of confusion on the sensor, in millimetres (> 0; 0.03 for full frame).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    coc_mm: String,
    /// Focus (subject) distance in millimetres from the lens (> focal length), or `inf`.
    #[arg(long, value_name = "MM|inf", allow_hyphen_values = true)]
    focus_mm: String,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// Parses and checks the four values as given on the command line.
fn parse(focal_length: &str, f_number: &str, coc: &str, focus: &str) -> Result<DofInput, Error> {
    let focal_length_mm = number(
        "--focal-length-mm",
        focal_length,
        "a number > 0 (millimetres)",
        |x| x > 0.0,
    )?;
    let f_number = number("--f-number", f_number, "a number >= 0.5", |x| {
        x >= MIN_F_NUMBER
    })?;
    let coc_mm = number("--coc-mm", coc, "a number > 0 (millimetres)", |x| x > 0.0)?;
    let allowed = format!("a number > the focal length ({focal_length_mm} mm), or inf");
    let focus_mm = number_or_infinity("--focus-mm", focus, &allowed, |x| x > focal_length_mm)?;
    Ok(DofInput {
        focal_length_mm,
        f_number,
        coc_mm,
        focus_mm,
    })
}

/// Runs `camsim dof`.
pub fn run(args: &DofArgs) -> Result<String, Error> {
    let input = parse(
        &args.focal_length_mm,
        &args.f_number,
        &args.coc_mm,
        &args.focus_mm,
    )?;
    let report = compute(&input).map_err(|source| Error::Optics {
        option: "dof",
        source,
    })?;
    Ok(if args.json {
        serde_json::to_string(&report).map_err(|e| Error::Message(e.to_string()))? + "\n"
    } else {
        report.to_table(&input)
    })
}
