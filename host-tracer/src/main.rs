//! `camsim`: the camera simulator's command line.

use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use host_tracer::dof::{compute, DofInput};

#[derive(Parser)]
#[command(
    name = "camsim",
    version,
    about = "Camera simulator and image signal processor"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Depth of field, hyperfocal distance, focus position and magnification of a thin lens.
    Dof(DofArgs),
}

#[derive(Args)]
struct DofArgs {
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

fn dof(args: &DofArgs) -> Result<String, String> {
    let input = DofInput::parse(
        &args.focal_length_mm,
        &args.f_number,
        &args.coc_mm,
        &args.focus_mm,
    )
    .map_err(|e| e.to_string())?;
    let report = compute(&input).map_err(|e| e.to_string())?;
    Ok(if args.json {
        report.to_json().to_string() + "\n"
    } else {
        report.to_table(&input)
    })
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Dof(args) => dof(args),
    };
    match result {
        Ok(out) => {
            print!("{out}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
