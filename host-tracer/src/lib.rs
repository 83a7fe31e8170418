//! host-tracer: the std side of camsim. It renders scenes through optics-core's cameras
//! ([`tracer`], `camsim render` in [`render_cmd`], OpenEXR out through [`exr`]), runs isp-core
//! on raw mosaics (`camsim isp`, [`isp_cmd`]), and holds the `camsim` command line.
//!
//! Also: the `camsim dof` calculator ([`dof`]), image files ([`imageio`]), `camsim demosaic` /
//! `camsim bench demosaic` ([`demosaic_cmd`]) and spectral tables ([`spectra`]). The camera
//! side: the sensor model ([`sensor`]), raw DNG files ([`dng`]), colour calibration on a
//! rendered ColorChecker ([`calibrate`]) and `camsim demo` / `camsim calibrate`
//! ([`demo_cmd`]), which run scene -> raw -> ISP -> sRGB with the ground truth beside it.
#![warn(missing_docs)]

pub mod calibrate;
pub mod cli_args;
pub mod demo_cmd;
pub mod demosaic_cmd;
pub mod dng;
pub mod dof;
pub mod exr;
pub mod imageio;
pub mod isp_cmd;
pub mod isp_options;
pub mod render_bench;
pub mod render_cmd;
pub mod sensor;
pub mod spectra;
pub mod tracer;
