//! Rendering an image: tiles of 16 x 16 pixels shared among threads (rayon), each pixel with
//! its own random stream, so the result for a seed does not depend on the thread count; a
//! one-pixel box filter (each sample lands in its own pixel). Progress is reported through a
//! callback ([`render_with_progress`]); nothing here prints.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::color::{band_rgb_channel, Channels};
use super::integrator::{radiance, PathSettings};
use super::sampling::Rng;
use super::scene::{CameraRig, MaskTable, Scene, SceneDesc};
use crate::error::{Error, Result};
use crate::spectra::{bands_to_linear_srgb, xyz_weights, BANDS};

/// What to render and how.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed: the same seed gives the same image.
    pub seed: u64,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Path limits.
    pub path: PathSettings,
}

/// Largest width or height accepted.
pub const MAX_SIDE: u32 = 16384;
/// Largest samples per pixel accepted.
pub const MAX_SPP: u32 = 1 << 20;

impl RenderSettings {
    /// Defaults from the scene.
    pub fn for_scene(desc: &SceneDesc) -> Self {
        Self {
            width: desc.film.0,
            height: desc.film.1,
            spp: desc.spp,
            seed: 0,
            threads: 0,
            path: PathSettings {
                max_depth: desc.max_depth,
                ..PathSettings::default()
            },
        }
    }

    fn check(&self) -> Result<()> {
        if !(1..=MAX_SIDE).contains(&self.width) || !(1..=MAX_SIDE).contains(&self.height) {
            return Err(Error::out_of_range(
                "width and height",
                format!("{} x {}", self.width, self.height),
                format!("in 1..={MAX_SIDE}"),
            ));
        }
        if !(1..=MAX_SPP).contains(&self.spp) {
            return Err(Error::out_of_range(
                "spp",
                self.spp,
                format!("in 1..={MAX_SPP}"),
            ));
        }
        if !(1..=1024).contains(&self.path.max_depth) {
            return Err(Error::out_of_range(
                "max depth",
                self.path.max_depth,
                "in 1..=1024",
            ));
        }
        Ok(())
    }
}

/// A rendered image: linear RGB always, and the spectral bands when the scene was spectral.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Linear sRGB radiance (the mean of the samples), row-major, 3 per pixel.
    pub rgb: Vec<f32>,
    /// For spectral scenes, [`BANDS`] band radiances per pixel; empty for RGB scenes.
    pub bands: Vec<f32>,
    /// Wall-clock rendering time (after scene preparation).
    pub elapsed: Duration,
    /// Time spent building the BVH and tables.
    pub prepare: Duration,
    /// Camera samples traced (`width * height * spp`).
    pub samples: u64,
    /// Camera samples the lens stopped (a real lens's vignetting; a distorted raster's
    /// pixels without a source).
    pub lost_samples: u64,
}

impl Rendered {
    /// Camera samples per second.
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

const TILE: u32 = 16;

/// Renders `desc`. Spectral scenes are traced in [`BANDS`] bands, others in RGB.
pub fn render(desc: &SceneDesc, settings: &RenderSettings) -> Result<Rendered> {
    render_with_progress(desc, settings, &|_| {})
}

/// How far a render is: tiles finished out of all tiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderProgress {
    /// Tiles finished.
    pub done: usize,
    /// Tiles in all.
    pub total: usize,
}

/// [`render`], calling `progress` after each tile (from the worker threads, so it must be
/// cheap and `Sync`).
pub fn render_with_progress(
    desc: &SceneDesc,
    settings: &RenderSettings,
    progress: &(dyn Fn(RenderProgress) + Sync),
) -> Result<Rendered> {
    settings.check()?;
    if desc.is_spectral() {
        let mut out = render_channels::<BANDS>(desc, settings, progress)?;
        let weights = xyz_weights();
        let rgb = out
            .bands
            .chunks_exact(BANDS)
            .flat_map(|b| bands_to_linear_srgb(b, &weights))
            .collect();
        out.rgb = rgb;
        Ok(out)
    } else {
        render_channels::<3>(desc, settings, progress)
    }
}

fn camera_weight<const N: usize>(throughput: [f32; 3]) -> Channels<N> {
    if throughput == [1.0; 3] {
        return Channels::ONE;
    }
    if N == 3 {
        let mut c = Channels::ZERO;
        c.0.copy_from_slice(&throughput);
        c
    } else {
        Channels(std::array::from_fn(|b| throughput[band_rgb_channel(b)]))
    }
}

fn render_tile<const N: usize>(
    scene: &Scene<N>,
    rig: &CameraRig<'_>,
    settings: &RenderSettings,
    x0: u32,
    y0: u32,
) -> (Vec<Channels<N>>, u64) {
    let (w, h) = (settings.width, settings.height);
    let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
    let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
    let inv_spp = 1.0 / settings.spp as f32;
    let mut lost = 0u64;
    // With a lens, each channel's samples are averaged over their own count when every
    // channel gets one (spp >= N), so a pixel's channels do not flicker with the share each
    // got; below that, each sample stands for all N channels' share of the pixel.
    let per_channel = rig.lens.is_some() && settings.spp as usize >= N;
    let lens_scale = if per_channel { 1.0 } else { N as f32 };
    for y in y0..y1 {
        for x in x0..x1 {
            let mut rng = Rng::new(settings.seed, y as u64 * w as u64 + x as u64);
            let mut sum = Channels::<N>::ZERO;
            // With a real lens each sample carries one channel's wavelength; the channels
            // take turns from a random start, so every pixel sees each equally often.
            let first_channel = if rig.lens.is_some() {
                (rng.next_f32() * N as f32) as usize % N
            } else {
                0
            };
            for k in 0..settings.spp {
                let jitter = rng.next_2d();
                let (px, py) = (x as f32 + jitter.x, y as f32 + jitter.y);
                let sample = match &rig.lens {
                    Some(lens) => {
                        let c = (first_channel + k as usize) % N;
                        let pupil = rng.next_2d();
                        let time = if rig.needs_time { rng.next_f32() } else { 0.0 };
                        lens.sample(px, py, channel_wavelength_nm::<N>(c), pupil, time)
                            .map(|cs| {
                                let mut w = Channels::ZERO;
                                w.0[c] = cs.throughput[0] * lens_scale;
                                (cs, w)
                            })
                    }
                    None => rig
                        .sample(px, py, &mut rng)
                        .map(|cs| (cs, camera_weight(cs.throughput))),
                };
                let Some((cs, weight)) = sample else {
                    lost += 1;
                    continue;
                };
                let s = rig.shutter_fraction(cs.ray.time);
                let l = radiance(
                    scene,
                    &settings.path,
                    cs.ray.origin,
                    cs.ray.direction,
                    s,
                    weight,
                    &mut rng,
                );
                // A NaN or infinity from a degenerate sample must not poison the pixel.
                if l.0.iter().all(|v| v.is_finite()) {
                    sum += l;
                }
            }
            if per_channel {
                let spp = settings.spp as usize;
                for (c, v) in sum.0.iter_mut().enumerate() {
                    // Samples channel c got: those k with (first + k) % N == c.
                    let count = (spp + N - 1 - (c + N - first_channel) % N) / N;
                    *v /= count.max(1) as f32;
                }
                out.push(sum);
            } else {
                out.push(sum * inv_spp);
            }
        }
    }
    (out, lost)
}

/// The wavelength a sample of channel `c` of `N` is traced through a real lens at: the band's
/// centre for spectral renders; for RGB, the middle of the spectrum each channel stands for
/// (the split of [`super::color::bands_from_rgb`]: blue below 490 nm, green to 590 nm, red
/// above, over the 395..705 nm the bands cover).
pub fn channel_wavelength_nm<const N: usize>(c: usize) -> f64 {
    if N == 3 {
        [647.5, 540.0, 442.5][c.min(2)]
    } else {
        crate::spectra::band_centre_nm(c)
    }
}

fn render_channels<const N: usize>(
    desc: &SceneDesc,
    settings: &RenderSettings,
    progress: &(dyn Fn(RenderProgress) + Sync),
) -> Result<Rendered> {
    let start = Instant::now();
    let mut table = MaskTable::default();
    let rig = desc.camera.rig(
        settings.width,
        settings.height,
        desc.has_motion(),
        &mut table,
    )?;
    let scene = Scene::<N>::new(desc);
    let prepare = start.elapsed();
    let (w, h) = (settings.width, settings.height);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::Threads(e.to_string()))?;
    let done = AtomicUsize::new(0);
    let total = tiles.len();
    let begin = Instant::now();
    let results: Vec<(Vec<Channels<N>>, u64)> = pool.install(|| {
        tiles
            .par_iter()
            .map(|&(x0, y0)| {
                let tile = render_tile(&scene, &rig, settings, x0, y0);
                let done = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(RenderProgress { done, total });
                tile
            })
            .collect()
    });
    let elapsed = begin.elapsed();
    let mut data = vec![0.0f32; (w * h) as usize * N];
    let lost_samples = results.iter().map(|r| r.1).sum();
    for (&(x0, y0), (tile, _)) in tiles.iter().zip(&results) {
        let tw = (x0 + TILE).min(w) - x0;
        for (k, c) in tile.iter().enumerate() {
            let (x, y) = (x0 + k as u32 % tw, y0 + k as u32 / tw);
            let i = (y * w + x) as usize * N;
            data[i..i + N].copy_from_slice(&c.0);
        }
    }
    let samples = w as u64 * h as u64 * settings.spp as u64;
    let (rgb, bands) = if N == 3 {
        (data, Vec::new())
    } else {
        (Vec::new(), data)
    };
    Ok(Rendered {
        width: w,
        height: h,
        rgb,
        bands,
        elapsed,
        prepare,
        samples,
        lost_samples,
    })
}
