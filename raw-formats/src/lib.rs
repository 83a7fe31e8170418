//! raw-formats: camsim's files. Raw DNG (TIFF) read and write ([`dng`], with its lossless
//! JPEG codec in [`lossless_jpeg`] and the output framing in [`framing`]), PNG and binary
//! PGM/PPM images and mosaics at 8 or 16 bits, TIFF and JPEG out ([`image`]), an OpenEXR
//! writer for linear float images ([`exr`]), and camsim's colour calibration file
//! ([`calibration`]).
//!
//! It is a library of its own so that anything that reads or writes camera files (the `camsim`
//! command line, the tests, the fuzz targets, a user's tool) needs neither the path tracer nor
//! the command line: it depends on isp-core (for [`isp_core::CfaPattern`], the borrowed
//! [`isp_core::frame::RawFrame`] view and the colour calibration), the `png` and
//! `jpeg-encoder` crates, and serde and toml for the calibration file.
//!
//! Two types carry the data between layers:
//! - [`RawImage`]: the one owned raw frame (samples, size, pattern, black per 2x2 position,
//!   white, bit depth); the sensor model produces it, the DNG and mosaic readers return it, and
//!   [`RawImage::frame`] lends it to isp-core.
//! - [`dng::DngColour`]: a camera's colour metadata as a DNG states it, converted to and from
//!   isp-core's calibration in one place.
//!
//! Errors are [`FormatError`] values that hold the file, the field, the value and what is
//! allowed; nothing here prints.
#![warn(missing_docs)]

pub mod calibration;
pub mod dct_jpeg;
pub mod dng;
mod error;
pub mod exr;
pub mod framing;
pub mod fuzzing;
pub mod image;
pub mod lossless_jpeg;
mod raw_image;

pub use error::{FormatError, Result};
pub use image::Image;
pub use raw_image::RawImage;
