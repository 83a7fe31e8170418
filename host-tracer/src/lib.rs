//! host-tracer: the std side of camsim. It renders scenes through optics-core's cameras, will
//! simulate the sensor and run isp-core, and holds the `camsim` command line.
//!
//! Built so far: the `camsim dof` calculator ([`dof`]), image files ([`imageio`]), and
//! `camsim demosaic` / `camsim bench demosaic` ([`demosaic_cmd`]), and `camsim isp` ([`isp_cmd`]). The tracer, sensor, file formats and
//! benchmarks follow in their own issues; ARCHITECTURE.md has the plan.
#![warn(missing_docs)]

pub mod cli_args;
pub mod demosaic_cmd;
pub mod dof;
pub mod imageio;
pub mod isp_cmd;
pub mod isp_options;
pub mod spectra;
