//! Argument types shared by the commands: the render flags defined once and flattened into each
//! command that renders, and value enums for every enumerated flag (each converts into the
//! library's type). A value outside an enum gets one line listing the choices (see
//! [`invalid_value_message`]).

use camsim::isp_options::CropChoice;
use clap::{Args, ValueEnum};
use isp_core::demosaic::{Border, Method};
use isp_core::tone::Look;
use isp_core::wb::AwbMethod;
use isp_core::CfaPattern;

/// Image size, sampling, seed and threads of a render. The seed defaults to 0; a command with
/// another default sets it with `#[command(mut_arg("seed", ...))]` (a const generic would not
/// do: clap keeps a default's text in a static shared by every instantiation).
#[derive(Args, Debug, Clone)]
pub struct RenderFlags {
    /// Image width in pixels [default: the scene's].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels [default: the scene's].
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel [default: the scene's].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed; the same seed gives the same image at any thread count.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// A CFA pattern by the top-left 2x2 block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PatternArg {
    /// R G / G B.
    #[value(name = "RGGB")]
    Rggb,
    /// B G / G R.
    #[value(name = "BGGR")]
    Bggr,
    /// G R / B G.
    #[value(name = "GRBG")]
    Grbg,
    /// G B / R G.
    #[value(name = "GBRG")]
    Gbrg,
}

impl From<PatternArg> for CfaPattern {
    fn from(p: PatternArg) -> Self {
        match p {
            PatternArg::Rggb => CfaPattern::Rggb,
            PatternArg::Bggr => CfaPattern::Bggr,
            PatternArg::Grbg => CfaPattern::Grbg,
            PatternArg::Gbrg => CfaPattern::Gbrg,
        }
    }
}

/// An automatic white-balance method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AwbArg {
    /// Grey world.
    #[value(alias = "gray-world")]
    GreyWorld,
    /// The 99th percentile of each channel is white.
    WhitePatch,
    /// Minkowski p-mean, p = 6.
    #[value(alias = "shades-of-gray")]
    ShadesOfGrey,
    /// First-order grey edge, p = 6.
    #[value(alias = "gray-edge")]
    GreyEdge,
}

impl From<AwbArg> for AwbMethod {
    fn from(a: AwbArg) -> Self {
        match a {
            AwbArg::GreyWorld => AwbMethod::GreyWorld,
            AwbArg::WhitePatch => AwbMethod::WhitePatch { percentile: 99.0 },
            AwbArg::ShadesOfGrey => AwbMethod::ShadesOfGrey { p: 6.0 },
            AwbArg::GreyEdge => AwbMethod::GreyEdge { p: 6.0 },
        }
    }
}

/// A demosaicing method of the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PipelineDemosaicArg {
    /// 2x2 superpixel.
    Nearest,
    /// Bilinear.
    Bilinear,
    /// Malvar-He-Cutler.
    Mhc,
    /// The high-quality directional method (the fixed path runs its integer version).
    Directional,
}

impl From<PipelineDemosaicArg> for Method {
    fn from(m: PipelineDemosaicArg) -> Self {
        match m {
            PipelineDemosaicArg::Nearest => Method::Nearest,
            PipelineDemosaicArg::Bilinear => Method::Bilinear,
            PipelineDemosaicArg::Mhc => Method::Mhc,
            PipelineDemosaicArg::Directional => Method::Directional,
        }
    }
}

/// A look (saturation, contrast, curve).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LookArg {
    /// The identity.
    Neutral,
    /// More saturation and contrast.
    Vivid,
    /// Less saturation, softer contrast.
    Muted,
    /// Greyscale.
    Mono,
    /// A strong S-curve.
    HighContrast,
}

impl From<LookArg> for Look {
    fn from(l: LookArg) -> Self {
        match l {
            LookArg::Neutral => Look::Neutral,
            LookArg::Vivid => Look::Vivid,
            LookArg::Muted => Look::Muted,
            LookArg::Mono => Look::Mono,
            LookArg::HighContrast => Look::HighContrast,
        }
    }
}

/// Noise reduction's search window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DenoiseSearchArg {
    /// 5x5 packed pixels (12 offsets by symmetry): the default.
    Wide,
    /// 3x3 packed pixels (4 offsets): the fast setting, for video and firmware.
    Fast,
}

impl From<DenoiseSearchArg> for isp_core::denoise::Search {
    fn from(s: DenoiseSearchArg) -> Self {
        match s {
            DenoiseSearchArg::Wide => isp_core::denoise::Search::Wide,
            DenoiseSearchArg::Fast => isp_core::denoise::Search::Fast,
        }
    }
}

/// The framing of a developed DNG.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CropArg {
    /// The file's DefaultCrop (Adobe's framing).
    Default,
    /// The whole active area (LibRaw's framing).
    Active,
}

impl From<CropArg> for CropChoice {
    fn from(c: CropArg) -> Self {
        match c {
            CropArg::Default => CropChoice::Default,
            CropArg::Active => CropChoice::Active,
        }
    }
}

/// The ISP's arithmetic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PathArg {
    /// The float reference path.
    Float,
    /// The fixed-point firmware path.
    Fixed,
}

/// A demosaicing border rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BorderArg {
    /// Mirror without repeating the edge (keeps CFA parity).
    Reflect101,
    /// OpenCV's cvtColor rule (bilinear only).
    Opencv,
}

impl From<BorderArg> for Border {
    fn from(b: BorderArg) -> Self {
        match b {
            BorderArg::Reflect101 => Border::Reflect101,
            BorderArg::Opencv => Border::OpenCv,
        }
    }
}

/// A whole-frame demosaic as `camsim demosaic` and `camsim bench demosaic` name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DemosaicArg {
    /// 2x2 superpixel.
    Nearest,
    /// Bilinear, reflect-101 borders.
    Bilinear,
    /// Bilinear with OpenCV's border rule (bit-exact to cvtColor).
    BilinearOpencv,
    /// Malvar-He-Cutler.
    Mhc,
    /// The high-quality directional method.
    Directional,
    /// The same in integer arithmetic.
    DirectionalFixed,
}

impl From<DemosaicArg> for camsim::demosaic::Demosaic {
    fn from(m: DemosaicArg) -> Self {
        use camsim::demosaic::Demosaic;
        match m {
            DemosaicArg::Nearest => Demosaic::NEAREST,
            DemosaicArg::Bilinear => Demosaic::BILINEAR,
            DemosaicArg::BilinearOpencv => Demosaic::BILINEAR_OPENCV,
            DemosaicArg::Mhc => Demosaic::MHC,
            DemosaicArg::Directional => Demosaic::DIRECTIONAL,
            DemosaicArg::DirectionalFixed => Demosaic::DIRECTIONAL_FIXED,
        }
    }
}

/// The one-line message for a value outside an enumerated flag's choices, in the form every
/// other refused value takes (`--pattern must be one of RGGB, BGGR, GRBG, GBRG (got "RGBG")`);
/// `None` for other clap errors, which print as clap formats them.
pub fn invalid_value_message(error: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if error.kind() != ErrorKind::InvalidValue {
        return None;
    }
    let text = |kind| match error.get(kind) {
        Some(ContextValue::String(s)) => Some(s.clone()),
        _ => None,
    };
    let flag = text(ContextKind::InvalidArg)?;
    let flag = flag.split(' ').next().unwrap_or(&flag).to_owned();
    let got = text(ContextKind::InvalidValue)?;
    let Some(ContextValue::Strings(valid)) = error.get(ContextKind::ValidValue) else {
        return None;
    };
    let allowed = match valid.as_slice() {
        [a, b] => format!("{a} or {b}"),
        many => format!("one of {}", many.join(", ")),
    };
    Some(format!("{flag} must be {allowed} (got {got:?})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name<T: ValueEnum>(v: &T) -> String {
        v.to_possible_value().unwrap().get_name().to_owned()
    }

    /// The flags' names are the libraries' names, so messages, reports and config files agree.
    #[test]
    fn enum_flags_name_what_the_libraries_name() {
        for v in DemosaicArg::value_variants() {
            assert_eq!(name(v), camsim::demosaic::Demosaic::from(*v).name());
        }
        for v in PipelineDemosaicArg::value_variants() {
            assert_eq!(name(v), Method::from(*v).name());
        }
        assert_eq!(
            PipelineDemosaicArg::value_variants().len(),
            Method::ALL.len()
        );
        for v in CropArg::value_variants() {
            assert_eq!(name(v), CropChoice::from(*v).name());
        }
        for v in LookArg::value_variants() {
            assert_eq!(name(v), Look::from(*v).name());
        }
        for v in PatternArg::value_variants() {
            assert_eq!(name(v), CfaPattern::from(*v).name());
        }
        for v in AwbArg::value_variants() {
            assert_eq!(AwbMethod::from_name(&name(v)).unwrap(), AwbMethod::from(*v));
        }
        assert_eq!(
            DemosaicArg::value_variants().len(),
            camsim::demosaic::Demosaic::ALL.len()
        );
    }
}
