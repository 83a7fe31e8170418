//! # optics-core
//!
//! The camera math of the thin-lens model, for lens-control firmware and for renderers.
//!
//! `#![no_std]`, no heap, no panics on any input: every size and parameter is checked and a
//! value that cannot be honoured is answered with an [`OpticsError`]. Lengths are millimetres
//! unless a type says otherwise; distances that may be infinite are either a [`Distance`]
//! (finite or infinite) or a vergence in dioptres (1/m, where infinity is simply 0).
//!
//! | module | what |
//! |---|---|
//! | [`refraction`] | Snell's law (angles and vectors), paraxial refraction, the single-surface equation and its error against the exact ray |
//! | [`lens`] | lensmaker (thin and thick), Gaussian lens formula, power, magnification, focusing by moving the sensor |
//! | [`exposure`] | f-number, entrance pupil, stops and exposure ratios |
//! | [`dof`] | circle of confusion, hyperfocal distance, near/far limits, the 2u²Nc/f² approximation |
//! | [`aperture`] | aperture shapes for bokeh: disk, n-blade polygon, heart, bitmap mask; uniform sampling |
//! | [`camera`] | thin-lens and pinhole camera rays, field of view, shutter time sampling, camera motion |
//! | [`chromatic`] | the three-aperture chromatic aberration model with balance-heuristic weights |
//! | [`distortion`] | Brown-Conrady radial/tangential distortion as OpenCV defines it, forward and inverse |
//! | [`fixed_point`] | focusing and depth of field in fixed point (vergence form) for firmware |
//! | [`prescription`] | real lenses: surfaces (flat, spherical, even asphere), glasses (model, Sellmeier, a catalogue), paraxial data, real rays with dispersion, vignetting and total internal reflection |
//!
//! Scalar equations are generic over [`Real`] (`f32` and `f64`); geometry that a renderer uses per
//! sample ([`aperture`], [`camera`], [`chromatic`]) is `f32` with `glam` vectors, the tracer's types.
//!
//! ```
//! use optics_core::lens::{image_distance, ImageDistance};
//! // A 50 mm lens focused on a subject 2 m away puts the sensor 51.28 mm behind the lens.
//! let ImageDistance::Real(s_i) = image_distance(50.0_f64, 2000.0).unwrap() else { panic!() };
//! assert!((s_i - 51.282_051_282).abs() < 1e-6);
//! ```
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod aperture;
pub mod camera;
pub mod chromatic;
pub mod distortion;
pub mod dof;
mod error;
pub mod exposure;
pub mod fixed_point;
pub mod lens;
pub mod math;
pub mod prescription;
mod real;
pub mod refraction;

pub use error::{OpticsError, Result};
/// The vector library of the geometry API, re-exported so callers use the same version.
pub use glam;
pub use real::{Distance, Real};
