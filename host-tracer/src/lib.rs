//! host-tracer: the camera before the ISP, on the host. It renders scenes through
//! optics-core's cameras ([`tracer`]) onto a simulated sensor ([`sensor`]) to produce the raw
//! Bayer frames isp-core consumes, with the ground truth beside them, and fits a camera's
//! colour matrix on a rendered ColorChecker ([`calibrate`]).
//!
//! Layers, each depending only on those before it:
//! - [`spectra`] (the spectral tables and the renderer's band grid) and [`random`] (the PCG32
//!   generator): shared by all that follows.
//! - [`lens_file`]: lens prescriptions read from files, for cameras that name one.
//! - [`tracer`]: scenes, BVH, path tracing; [`render_bench`] measures what its features cost.
//! - [`sensor`]: radiance to a raw frame ([`raw_formats::RawImage`]); it knows nothing of the
//!   tracer, only camera RGB radiance and a [`sensor::LensGeometry`].
//! - [`calibrate`]: renders the chart through the tracer's public API, captures it through the
//!   sensor, fits the matrix.
//!
//! Nothing here parses command lines or prints: progress comes back through callbacks
//! ([`tracer::render::render_with_progress`]), and the `camsim` crate is the command line.
#![warn(missing_docs)]

pub mod calibrate;
mod error;
pub mod lens_file;
pub mod random;
pub mod render_bench;
pub mod sensor;
pub mod spectra;
pub mod tracer;

pub use error::{Error, Result};
