//! `camsim demosaic`: one mosaic file through one of isp-core's demosaicing methods.

use std::path::PathBuf;

use camsim::demosaic::{demosaic_file, Demosaic};
use camsim::{isp_options, Error};
use clap::Args;
use isp_core::demosaic::{Border, Method};

#[derive(Args)]
pub struct DemosaicArgs {
    /// nearest, bilinear, bilinear-opencv (bit-exact to OpenCV's cvtColor), mhc, directional
    /// (the high-quality method) or directional-fixed (the same in integer arithmetic).
    #[arg(long, default_value = "mhc")]
    method: String,
    /// Border rule: reflect101 (mirror without repeating the edge; keeps CFA parity) or opencv
    /// (OpenCV's cvtColor rule; bilinear only, same as --method bilinear-opencv).
    #[arg(long, default_value = "reflect101")]
    border: String,
    /// CFA pattern by the top-left 2x2 block: RGGB, BGGR, GRBG or GBRG.
    #[arg(long, default_value = "RGGB")]
    pattern: String,
    /// Input mosaic: .png or .pgm, single channel, 8 or 16 bit.
    #[arg(long)]
    input: PathBuf,
    /// Output RGB image: .png or .ppm.
    #[arg(long)]
    output: PathBuf,
}

/// Runs `camsim demosaic`.
pub fn run(args: &DemosaicArgs) -> Result<String, Error> {
    let method = Demosaic::parse(&args.method)?;
    let method = match (method, args.border.as_str()) {
        (method, "reflect101") => method,
        (m, "opencv") if m.method == Method::Bilinear => Demosaic {
            border: Border::OpenCv,
            ..m
        },
        (method, "opencv") => {
            return Err(Error::Message(format!(
                "--border opencv applies to bilinear only (got --method {})",
                method.name()
            )))
        }
        (_, other) => {
            return Err(Error::Option {
                option: "--border",
                value: format!("{other:?}"),
                allowed: "reflect101 or opencv".into(),
            })
        }
    };
    let pattern = isp_options::pattern(&args.pattern, "--pattern")?;
    demosaic_file(&args.input, &args.output, method, pattern)
}
