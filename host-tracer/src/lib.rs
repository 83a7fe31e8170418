//! host-tracer: the std side of camsim. It renders scenes through optics-core's cameras
//! ([`tracer`], `camsim render` in [`render_cmd`], OpenEXR out through [`exr`]), runs isp-core
//! on raw mosaics (`camsim isp`, [`isp_cmd`]), and holds the `camsim` command line.
//!
//! Also: the `camsim dof` calculator ([`dof`]), image files ([`imageio`]), `camsim demosaic` /
//! `camsim bench demosaic` ([`demosaic_cmd`]) and spectral tables ([`spectra`]). The sensor
//! model, DNG and `camsim demo` follow in their own issue; ARCHITECTURE.md has the plan.
#![warn(missing_docs)]

pub mod cli_args;
pub mod demosaic_cmd;
pub mod dof;
pub mod exr;
pub mod imageio;
pub mod isp_cmd;
pub mod isp_options;
pub mod render_cmd;
pub mod spectra;
pub mod tracer;
