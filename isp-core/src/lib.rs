//! # isp-core
//!
//! The raw-to-sRGB pipeline a camera runs, for firmware: `#![no_std]`, no heap, no panics on any
//! input. Every size and parameter is checked and answered with an [`IspError`].
//!
//! The pipeline ([`pipeline`]) runs, in order: defective pixel correction ([`dpc`]), black
//! level and normalisation, lens shading ([`lsc`]), ISO gain, white balance ([`wb`], with
//! presets and automatic white balance), demosaicing ([`demosaic`]), lens distortion
//! correction ([`distortion`], OpenCV's `cv2.undistort` through optics-core's Brown-Conrady
//! model), denoise ([`denoise`], with the sensor's noise model in [`noise`]), colour
//! correction ([`ccm`], interpolated by colour temperature from a calibration), tone
//! ([`tone`]: saturation, contrast, curve, looks), sRGB encoding ([`srgb`]) and chroma noise
//! reduction ([`chroma`]). A float reference path and a fixed-point firmware path produce the same
//! output to 1 LSB, streaming a band of rows at a time through line buffers in caller memory.
//! [`colour`] holds the colorimetry the control code needs, [`frame`] the checked views over
//! caller memory.
//!
//! ```
//! use isp_core::{srgb, CfaPattern, CfaColour};
//! let rggb: CfaPattern = "RGGB".parse().unwrap();
//! assert_eq!(rggb.colour_at(1, 1), CfaColour::Blue);
//! assert_eq!((srgb::encode(0.5) * 255.0).round(), 188.0);
//! ```
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod ccm;
mod cfa;
pub mod chroma;
pub mod colour;
pub mod demosaic;
pub mod denoise;
pub mod distortion;
pub mod dpc;
pub mod frame;
pub mod highlights;
pub mod lateral_colour;
pub mod lens_correction;
pub mod lsc;
mod math;
pub mod metrics;
pub mod noise;
pub mod pipeline;
pub mod srgb;
pub mod tone;
pub mod wb;

pub use cfa::{CfaColour, CfaPattern};

use core::fmt;

/// Everything isp-core can refuse, each with what went wrong and what would be accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IspError {
    /// A parameter is outside its allowed range.
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The allowed range, in words.
        allowed: &'static str,
    },
    /// A caller-provided buffer is too small.
    BufferTooSmall {
        /// Elements needed.
        needed: usize,
        /// Elements provided.
        provided: usize,
    },
}

impl fmt::Display for IspError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidParameter { name, allowed } => {
                write!(f, "invalid {name}: must be {allowed}")
            }
            Self::BufferTooSmall { needed, provided } => {
                write!(
                    f,
                    "buffer too small: {needed} elements needed, {provided} provided"
                )
            }
        }
    }
}

impl core::error::Error for IspError {}
