//! `camsim demosaic`: one mosaic file through one of isp-core's demosaicing methods.

use std::path::PathBuf;

use camsim::demosaic::{demosaic_file, Demosaic};
use camsim::Error;
use clap::Args;
use isp_core::demosaic::{Border, Method};

use crate::args::{BorderArg, DemosaicArg, PatternArg};

#[derive(Args)]
pub struct DemosaicArgs {
    /// The method: bilinear-opencv is bit-exact to OpenCV's cvtColor, directional the
    /// high-quality method, directional-fixed the same in integer arithmetic.
    #[arg(long, value_enum, default_value_t = DemosaicArg::Mhc)]
    method: DemosaicArg,
    /// Border rule: reflect101 (mirror without repeating the edge; keeps CFA parity) or opencv
    /// (OpenCV's cvtColor rule; bilinear only, same as --method bilinear-opencv).
    #[arg(long, value_enum, default_value_t = BorderArg::Reflect101)]
    border: BorderArg,
    /// CFA pattern by the top-left 2x2 block.
    #[arg(long, value_enum, ignore_case = true, default_value_t = PatternArg::Rggb)]
    pattern: PatternArg,
    /// Input mosaic: .png or .pgm, single channel, 8 or 16 bit.
    #[arg(long)]
    input: PathBuf,
    /// Output RGB image: .png or .ppm.
    #[arg(long)]
    output: PathBuf,
}

/// Runs `camsim demosaic`.
pub fn run(args: &DemosaicArgs) -> Result<String, Error> {
    let method = Demosaic::from(args.method);
    let method = match (method, Border::from(args.border)) {
        (method, Border::Reflect101) => method,
        (m, Border::OpenCv) if m.method == Method::Bilinear => Demosaic {
            border: Border::OpenCv,
            ..m
        },
        (method, Border::OpenCv) => {
            return Err(Error::Message(format!(
                "--border opencv applies to bilinear only (got --method {})",
                method.name()
            )))
        }
    };
    demosaic_file(&args.input, &args.output, method, args.pattern.into())
}
