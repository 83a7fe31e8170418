//! camsim: the workflows the `camsim` command runs, as a library the tests and other tools can
//! call; the command line itself (argument types, terminal output, progress bars) is the
//! binary in `src/bin/camsim/`, and nothing in this library prints.
//!
//! - [`develop`]: a raw frame ([`raw_formats::RawImage`]) through isp-core's pipeline to sRGB,
//!   with options from flags, a config file ([`isp_options`]) and a DNG's tags, and stage times
//!   by ablation (`camsim isp`, and the ISP step of `camsim demo`).
//! - [`demo`]: the whole camera: render (host-tracer), sensor, DNG (raw-formats), ISP, truth,
//!   measurements (`camsim demo`).
//! - [`dataset`]: synthetic raw datasets, each sample a pure function of (spec, seed, index),
//!   written atomically, gathered into a checked manifest (`camsim dataset`).
//! - [`demosaic`]: isp-core's demosaicing methods on files and their accuracy against speed
//!   (`camsim demosaic`, `camsim bench demosaic`).
//! - [`dof`]: the depth-of-field calculator (`camsim dof`).
//! - [`lens`]: lens files (TOML, pbrt's `.dat`) and the paraxial and traced report of a real
//!   lens (`camsim lens`).
//! - [`noise_estimate`]: a raw frame's noise profile estimated from the frame (Foi et al.
//!   2008), for raws whose file states none.
//! - [`suite`]: the benchmark suites, charted (`camsim bench` without a subcommand).
//! - [`tune`]: a camera's tuning from its captures (black level, noise profile, defects, lens
//!   shading, white-balance locus, colour matrices), and capture sets shot with a simulated
//!   camera to check it against (`camsim tune`, `camsim tune-captures`).
//!
//! Errors are [`Error`] values; quality figures come from [`isp_core::metrics`].
#![warn(missing_docs)]

pub mod dataset;
pub mod demo;
pub mod demosaic;
pub mod develop;
pub mod dof;
mod error;
pub mod isp_options;
pub mod lens;
pub mod noise_estimate;
pub mod suite;
pub mod tune;

pub use error::Error;
