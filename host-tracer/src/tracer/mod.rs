//! The ray tracer: scenes ([`scene`], read from TOML by [`scene_file`]), shapes and their BVH
//! ([`geometry`], [`accel`]), a diffuse path tracer with next-event estimation and MIS
//! ([`integrator`]) and the tiled, multi-threaded, seed-deterministic renderer ([`render`]).
//! Cameras come from optics-core (thin lens or pinhole, shaped apertures, shutter and motion,
//! chromatic aberration; Brown-Conrady distortion is applied to the raster) or are a real lens's
//! prescription traced at each path's wavelength ([`lens_camera`]).
//!
//! Colour is three linear RGB channels unless the scene has spectral data, in which case it is
//! [`crate::spectra::BANDS`] bands of 10 nm ([`color`]): a scene pays only for what it uses.
//!
//! ```
//! use host_tracer::tracer::{render::{render, RenderSettings}, scene_file};
//! let scene = scene_file::load("cornell-box").unwrap();
//! let mut settings = RenderSettings::for_scene(&scene);
//! (settings.width, settings.height, settings.spp) = (16, 16, 4);
//! let image = render(&scene, &settings).unwrap();
//! assert_eq!(image.rgb.len(), 16 * 16 * 3);
//! assert!(image.rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
//! ```

pub mod accel;
pub mod color;
pub mod geometry;
pub mod integrator;
pub mod lens_camera;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod scene_file;
