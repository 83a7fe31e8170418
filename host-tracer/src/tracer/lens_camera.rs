//! A camera through a real lens: rays leave the film, pass optics-core's prescription turned
//! round ([`optics_core::prescription::Prescription::reversed_into`]) at the wavelength the
//! path carries, and enter the scene from the front element.
//!
//! How rays are aimed (after Kolb, Mitchell and Hanrahan 1995, as pbrt's `RealisticCamera`):
//! a ray from a film point is aimed at a point of the rear element's vertex plane, drawn
//! uniformly in a rectangle known to hold every point that lets a ray through (the exit
//! pupil's bounds as the film point sees it). The bounds depend on the film point's distance
//! from the axis only, so they are precomputed once, for [`PUPIL_BINS`] rings of film radius,
//! with the film point on the `+x` axis, and rotated to the film point's angle when used.
//!
//! The ring artefact and how it is avoided: pbrt-v3 traced its bounds from a few film radii
//! per ring, so at radii between them a passing ray could fall outside the rectangle and never
//! be drawn; the image then shows darker rings (a bias, not noise). Here each ring's rectangle
//! is traced from [`RADII_PER_BIN`] radii spanning the ring (both ends included) at the
//! shortest and longest wavelength rendered, grown by one cell of the tracing grid on every
//! side and united with its two neighbours' rectangles. The bounds are then conservative: a
//! sample outside the true pupil is simply lost (counted as vignetted), which costs time,
//! never brightness. `exit_pupil_bounds_hold_every_passing_ray` checks it densely.
//!
//! Weights: a sample carries `A cos^4(theta) / d^2` (the rectangle's area `A`, the angle
//! `theta` of the ray to the axis, the film-to-rear-vertex distance `d`: the solid angle the
//! area subtends, projected), divided by the same quantity's expectation at the film's centre.
//! The centre of the image therefore reads the scene's radiance as the thin lens does, and the
//! rest falls off by the lens's relative illumination (pupil clipping and the cosine terms).
//!
//! The lens is placed with its front principal plane at the camera's position (where a thin
//! lens of the same focal length would be) and focuses by moving as a unit
//! ([`optics_core::prescription::Prescription::focus_extension`]).

use glam::{Vec2, Vec3};
use optics_core::camera::{CameraMotion, CameraSample, Ray, Shutter};
use optics_core::prescription::glass::LAMBDA_D_NM;
use optics_core::prescription::trace::{Ray as LensRay, Traced};
use optics_core::prescription::{Prescription, Surface};

use crate::error::{Error, Result};
use crate::lens_file::LensFile;

/// Rings of film radius the exit pupil's bounds are kept for.
pub const PUPIL_BINS: usize = 64;
/// Film radii traced per ring when its bounds are made.
pub const RADII_PER_BIN: usize = 4;
/// Cells across the rear element's square when bounds are made.
pub const BOUNDS_GRID: usize = 32;

/// Everything the render needs of a lens, precomputed.
#[derive(Debug, Clone)]
pub struct LensRig {
    /// The prescription turned round (film side first), stop scaled to the f-number.
    reversed: Vec<Surface<f64>>,
    /// Film to the last vertex, mm (back focus plus the focusing move).
    film_distance: f64,
    /// First to last vertex, mm.
    length: f64,
    /// The lens-frame `z` placed at the camera's position (the front principal plane).
    origin_z: f64,
    /// Per ring of film radius: `[x0, x1, y0, y1]` on the rear vertex plane (film point on
    /// `+x`); `x1 < x0` when nothing passes.
    bins: Vec<[f64; 4]>,
    /// Film radius per ring, mm.
    bin_width: f64,
    /// One over the mean weight at the film's centre.
    centre_norm: f64,
    /// Sensor width and height, mm.
    sensor_mm: Vec2,
    width: u32,
    height: u32,
    units_per_mm: f32,
    motion: CameraMotion,
    shutter: Shutter,
    /// Paraxial data of the lens as used.
    pub efl_mm: f64,
    /// The f-number the stop was set to.
    pub f_number: f64,
}

/// The lens and how it is used, as a scene describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraLens {
    /// The prescription, from its file.
    pub file: LensFile,
    /// The f-number to stop down to (`None`: the design's, wide open).
    pub f_number: Option<f64>,
}

impl CameraLens {
    /// The surfaces as the camera uses them: the stop's clear semi-diameter narrowed to the
    /// f-number asked for (the design's when none is), and that f-number. An f-number wider
    /// than the design's is refused.
    pub fn stopped_surfaces(&self) -> Result<(Vec<Surface<f64>>, f64)> {
        let file = &self.file;
        let lens = file.prescription()?;
        let (_, design_n) = self.design()?;
        let f_number = self.f_number.unwrap_or(design_n);
        if !(f_number.is_finite() && f_number >= design_n * (1.0 - 1e-9)) {
            return Err(Error::out_of_range(
                "camera: f_number",
                f_number,
                format!("at least the lens's widest, f/{design_n:.3}"),
            ));
        }
        let mut surfaces = file.surfaces.clone();
        surfaces[lens.stop_index()].semi_diameter *= design_n / f_number;
        Ok((surfaces, f_number))
    }

    /// The film's distance behind the last vertex, mm, for `surfaces` (as
    /// [`CameraLens::stopped_surfaces`] gives them) focused at `focus_mm` from the camera's
    /// position (the front principal plane; infinite: at infinity): the d line's back focus
    /// plus the focusing move (the whole lens moved away from the film).
    pub fn film_distance_mm(&self, surfaces: &[Surface<f64>], focus_mm: f64) -> Result<f64> {
        let lens = Prescription::new(surfaces).map_err(optics("lens"))?;
        let p = lens.paraxial(LAMBDA_D_NM).map_err(optics("lens"))?;
        let extension = if focus_mm.is_infinite() {
            0.0
        } else {
            let object = focus_mm - p.front_principal;
            lens.focus_extension(object, LAMBDA_D_NM, p.efl)
                .map_err(optics("focus distance"))?
        };
        let film_distance = p.bfl + extension;
        if film_distance.is_nan() || film_distance <= 0.0 {
            return Err(Error::lens(format!(
                "{}: its focal plane lies inside the lens (back focus {:.3} mm)",
                self.file.name, p.bfl
            )));
        }
        Ok(film_distance)
    }

    /// The lens's paraxial focal length and design f-number at the d line.
    pub fn design(&self) -> Result<(f64, f64)> {
        let p = self
            .file
            .prescription()?
            .paraxial(LAMBDA_D_NM)
            .map_err(optics("lens"))?;
        Ok((p.efl, p.f_number))
    }
}

fn optics(part: &'static str) -> impl Fn(optics_core::OpticsError) -> Error {
    move |source| Error::Optics { part, source }
}

/// Everything [`LensRig::new`] takes.
pub struct LensSetup<'a> {
    /// The lens.
    pub lens: &'a CameraLens,
    /// Sensor width and height, mm.
    pub sensor_mm: Vec2,
    /// Image width and height, pixels.
    pub size: (u32, u32),
    /// Focus distance from the camera's position, mm (infinite: focused at infinity).
    pub focus_mm: f64,
    /// Scene units per mm.
    pub units_per_mm: f32,
    /// Shortest and longest wavelength the render traces, nm.
    pub wavelengths_nm: [f64; 2],
    /// The camera's motion over the shutter.
    pub motion: CameraMotion,
    /// The shutter.
    pub shutter: Shutter,
}

impl LensRig {
    /// Stops the lens down, focuses it and precomputes the exit pupil's bounds.
    pub fn new(setup: LensSetup<'_>) -> Result<Self> {
        let file = &setup.lens.file;
        let (efl, _) = setup.lens.design()?;
        if efl <= 0.0 {
            return Err(Error::lens(format!(
                "{}: a camera lens must converge (its focal length is {efl:.3} mm)",
                file.name
            )));
        }
        let (surfaces, f_number) = setup.lens.stopped_surfaces()?;
        let lens = Prescription::new(&surfaces).map_err(optics("lens"))?;
        let p = lens.paraxial(LAMBDA_D_NM).map_err(optics("lens"))?;
        let origin_z = p.front_principal;
        let film_distance = setup.lens.film_distance_mm(&surfaces, setup.focus_mm)?;
        let k = surfaces.len();
        let mut reversed = surfaces.clone();
        lens.reversed_into(&mut reversed).map_err(optics("lens"))?;
        let length = lens.vertex_z(k - 1);
        let mut rig = LensRig {
            reversed,
            film_distance,
            length,
            origin_z,
            bins: Vec::new(),
            bin_width: 0.0,
            centre_norm: 0.0,
            sensor_mm: setup.sensor_mm,
            width: setup.size.0.max(1),
            height: setup.size.1.max(1),
            units_per_mm: setup.units_per_mm,
            motion: setup.motion,
            shutter: setup.shutter,
            efl_mm: efl,
            f_number,
        };
        rig.bin_width = f64::from(setup.sensor_mm.length()) / 2.0 / PUPIL_BINS as f64;
        rig.bins = rig.pupil_bounds(setup.wavelengths_nm)?;
        rig.centre_norm = rig.centre_normalisation()?;
        Ok(rig)
    }

    fn rear_radius(&self) -> f64 {
        self.reversed[0].semi_diameter
    }

    /// Traces from film point `(fx, fy)` towards rear-plane point `(px, py)`: the ray in the
    /// turned lens's frame as it leaves the front element, or `None` when the lens stops it.
    fn trace(&self, film: [f64; 2], rear: [f64; 2], nm: f64) -> Option<([f64; 3], [f64; 3])> {
        let ray = LensRay {
            origin: [film[0], film[1], -self.film_distance],
            direction: [rear[0] - film[0], rear[1] - film[1], self.film_distance],
            wavelength_nm: nm,
        };
        // Checked when the rig was made, so this cannot fail (if it did, the ray would be lost).
        let lens = Prescription::new(&self.reversed).ok()?;
        match lens.trace(&ray) {
            Ok(Traced::Image { point, direction }) => Some((point, direction)),
            _ => None,
        }
    }

    fn pupil_bounds(&self, nm: [f64; 2]) -> Result<Vec<[f64; 4]>> {
        let r = self.rear_radius();
        let cell = 2.0 * r / BOUNDS_GRID as f64;
        let empty = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut raw = vec![empty; PUPIL_BINS];
        for (i, b) in raw.iter_mut().enumerate() {
            for j in 0..RADII_PER_BIN {
                let t = j as f64 / (RADII_PER_BIN - 1) as f64;
                let film = [(i as f64 + t) * self.bin_width, 0.0];
                for gy in 0..BOUNDS_GRID {
                    for gx in 0..BOUNDS_GRID {
                        let p = [-r + (gx as f64 + 0.5) * cell, -r + (gy as f64 + 0.5) * cell];
                        if p[0] * p[0] + p[1] * p[1] > (r + cell) * (r + cell) {
                            continue;
                        }
                        if nm.iter().any(|&w| self.trace(film, p, w).is_some()) {
                            b[0] = b[0].min(p[0]);
                            b[1] = b[1].max(p[0]);
                            b[2] = b[2].min(p[1]);
                            b[3] = b[3].max(p[1]);
                        }
                    }
                }
            }
        }
        let grown: Vec<[f64; 4]> = raw
            .iter()
            .map(|b| [b[0] - cell, b[1] + cell, b[2] - cell, b[3] + cell])
            .collect();
        let bins = (0..PUPIL_BINS)
            .map(|i| {
                let lo = i.saturating_sub(1);
                let hi = (i + 1).min(PUPIL_BINS - 1);
                grown[lo..=hi].iter().fold(empty, |a, b| {
                    if b[1] < b[0] {
                        a
                    } else {
                        [
                            a[0].min(b[0]),
                            a[1].max(b[1]),
                            a[2].min(b[2]),
                            a[3].max(b[3]),
                        ]
                    }
                })
            })
            .collect::<Vec<_>>();
        if bins[0][1] < bins[0][0] {
            return Err(Error::lens(
                "no ray from the film's centre passes the lens (a stop too small, or clear \
                 apertures that do not overlap)",
            ));
        }
        Ok(bins)
    }

    /// The unnormalised weight `A cos^4 / d^2` of a ray from `film` towards `rear`.
    fn raw_weight(&self, bin: &[f64; 4], film: [f64; 2], rear: [f64; 2]) -> f64 {
        let area = (bin[1] - bin[0]) * (bin[3] - bin[2]);
        let (dx, dy, d) = (rear[0] - film[0], rear[1] - film[1], self.film_distance);
        let cos2 = d * d / (dx * dx + dy * dy + d * d);
        area * cos2 * cos2 / (d * d)
    }

    fn centre_normalisation(&self) -> Result<f64> {
        let b = self.bins[0];
        let n = 64;
        let mut sum = 0.0;
        for gy in 0..n {
            for gx in 0..n {
                let p = [
                    b[0] + (gx as f64 + 0.5) / n as f64 * (b[1] - b[0]),
                    b[2] + (gy as f64 + 0.5) / n as f64 * (b[3] - b[2]),
                ];
                if self.trace([0.0, 0.0], p, LAMBDA_D_NM).is_some() {
                    sum += self.raw_weight(&b, [0.0, 0.0], p);
                }
            }
        }
        let mean = sum / (n * n) as f64;
        if mean > 0.0 && mean.is_finite() {
            Ok(1.0 / mean)
        } else {
            Err(Error::lens("no ray from the film's centre passes the lens"))
        }
    }

    /// The exit pupil's bounds for film radius `r` mm, as `[x0, x1, y0, y1]` with the film
    /// point on `+x`.
    pub fn bounds_at(&self, r: f64) -> [f64; 4] {
        self.bins[((r / self.bin_width) as usize).min(PUPIL_BINS - 1)]
    }

    /// Film point (mm, `+y` up, as seen looking through the lens at the scene: the image the
    /// lens forms is this turned by half a turn) of raster position `(px, py)`.
    pub fn film_point(&self, px: f32, py: f32) -> Vec2 {
        let (w, h) = (self.width as f32, self.height as f32);
        Vec2::new(
            (px / w - 0.5) * self.sensor_mm.x,
            (0.5 - py / h) * self.sensor_mm.y,
        )
    }

    /// A camera ray through raster position `(px, py)` at `wavelength_nm`, with pupil sample
    /// `pupil_u` and time sample `time_u` (uniform in `[0, 1)`): the ray and its weight, or
    /// `None` when the lens stops it (vignetting).
    pub fn sample(
        &self,
        px: f32,
        py: f32,
        wavelength_nm: f64,
        pupil_u: Vec2,
        time_u: f32,
    ) -> Option<CameraSample> {
        let f = self.film_point(px, py);
        // The real film point is opposite: the lens turns the image round.
        let film = [-f64::from(f.x), -f64::from(f.y)];
        let r = film[0].hypot(film[1]);
        let b = self.bounds_at(r);
        if b[1] < b[0] {
            return None;
        }
        let (c, s) = if r > 0.0 {
            (film[0] / r, film[1] / r)
        } else {
            (1.0, 0.0)
        };
        let bx = b[0] + f64::from(pupil_u.x) * (b[1] - b[0]);
        let by = b[2] + f64::from(pupil_u.y) * (b[3] - b[2]);
        let rear = [c * bx - s * by, s * bx + c * by];
        let (point, dir) = self.trace(film, rear, wavelength_nm)?;
        let weight = self.raw_weight(&b, film, rear) * self.centre_norm;
        // Back to the lens's own frame (z towards the image), then to the camera's (the lens
        // frame shifted so the front principal plane is at the origin; -z looks at the scene).
        let z = self.length - point[2];
        let k = self.units_per_mm;
        let origin = Vec3::new(point[0] as f32, point[1] as f32, (z - self.origin_z) as f32) * k;
        let direction = Vec3::new(dir[0] as f32, dir[1] as f32, -dir[2] as f32).normalize();
        let time = self.shutter.sample_time(time_u);
        let duration = self.shutter.duration();
        let sf = if duration > 0.0 {
            (time - self.shutter.open()) / duration
        } else {
            0.0
        };
        let pose = self.motion.at(sf);
        let ray = Ray {
            origin: pose.translation + pose.rotation * origin,
            direction: pose.rotation * direction,
            time,
        };
        let w = weight as f32;
        w.is_finite().then_some(CameraSample {
            ray,
            throughput: [w; 3],
        })
    }

    /// Film to last vertex, mm.
    pub fn film_distance_mm(&self) -> f64 {
        self.film_distance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use optics_core::camera::Pose;

    fn tessar() -> CameraLens {
        let text = include_str!("../../../camsim/lenses/tessar-f4.5.toml");
        CameraLens {
            file: LensFile::from_toml(text).unwrap(),
            f_number: None,
        }
    }

    fn rig(lens: &CameraLens, focus_mm: f64) -> LensRig {
        LensRig::new(LensSetup {
            lens,
            sensor_mm: Vec2::new(36.0, 24.0),
            size: (360, 240),
            focus_mm,
            units_per_mm: 0.001,
            wavelengths_nm: [400.0, 700.0],
            motion: CameraMotion::fixed(Pose::default()),
            shutter: Shutter::default(),
        })
        .unwrap()
    }

    #[test]
    fn exit_pupil_bounds_hold_every_passing_ray() {
        let lens = tessar();
        let rig = rig(&lens, f64::INFINITY);
        let r = rig.rear_radius();
        let n = 96;
        let max = f64::from(rig.sensor_mm.length()) / 2.0;
        let mut passed = 0;
        for k in 0..23 {
            // Radii between the ones the bounds were traced from.
            let fr = max * (k as f64 + 0.37) / 23.0;
            let b = rig.bounds_at(fr);
            for gy in 0..n {
                for gx in 0..n {
                    let p = [
                        -r + (gx as f64 + 0.5) * 2.0 * r / n as f64,
                        -r + (gy as f64 + 0.5) * 2.0 * r / n as f64,
                    ];
                    for nm in [400.0, 550.0, 700.0] {
                        if rig.trace([fr, 0.0], p, nm).is_some() {
                            passed += 1;
                            assert!(
                                p[0] >= b[0] && p[0] <= b[1] && p[1] >= b[2] && p[1] <= b[3],
                                "film radius {fr}: {p:?} passes outside {b:?}"
                            );
                        }
                    }
                }
            }
        }
        assert!(passed > 1000, "{passed}");
    }

    #[test]
    fn the_centre_reads_one_and_the_corner_less() {
        let lens = tessar();
        let rig = rig(&lens, f64::INFINITY);
        let mean = |px: f32, py: f32| {
            let (mut sum, n) = (0.0f64, 128);
            for j in 0..n {
                for i in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    if let Some(s) = rig.sample(px, py, LAMBDA_D_NM, u, 0.0) {
                        sum += f64::from(s.throughput[0]);
                    }
                }
            }
            sum / (n * n) as f64
        };
        let centre = mean(180.0, 120.0);
        assert!((centre - 1.0).abs() < 0.01, "{centre}");
        // Off the axis the lens's relative illumination: near optics-core's estimate from the
        // prescription (an approximation: entrance-pupil grid, cos^4 of the chief ray).
        let p = lens.file.prescription().unwrap();
        for (px, py) in [(2.0f32, 2.0f32), (90.0, 60.0), (0.0, 120.0)] {
            let r = f64::from(rig.film_point(px, py).length());
            let ri = p
                .relative_illumination((r / rig.efl_mm).atan(), LAMBDA_D_NM, 64)
                .unwrap()
                .unwrap();
            let got = mean(px, py);
            assert!(
                got < 0.99 && (got - ri).abs() < 0.03,
                "{r} mm: {got} against {ri}"
            );
        }
    }

    #[test]
    fn chief_rays_point_where_the_thin_lens_points() {
        // Far from the axis of a lens with little distortion, the ray from a film point
        // through the pupil's middle leaves within a few tenths of a degree of the thin
        // lens's direction for a focal length of the lens's EFL.
        let lens = tessar();
        let rig = rig(&lens, f64::INFINITY);
        let (px, py) = (300.0f32, 60.0f32);
        let f = rig.film_point(px, py);
        let thin = Vec3::new(f.x, f.y, -(rig.efl_mm as f32)).normalize();
        let mut mean = Vec3::ZERO;
        for j in 0..16 {
            for i in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                if let Some(s) = rig.sample(px, py, LAMBDA_D_NM, u, 0.0) {
                    mean += s.ray.direction;
                }
            }
        }
        let angle = mean.normalize().angle_between(thin).to_degrees();
        assert!(angle < 0.5, "{angle} degrees");
    }

    #[test]
    fn focusing_and_stopping_down_are_checked() {
        let lens = tessar();
        let near = rig(&lens, 1000.0);
        let far = rig(&lens, f64::INFINITY);
        assert!(near.film_distance_mm() > far.film_distance_mm());
        let wide = CameraLens {
            f_number: Some(1.0),
            ..lens.clone()
        };
        let setup = |l| LensSetup {
            lens: l,
            sensor_mm: Vec2::new(36.0, 24.0),
            size: (36, 24),
            focus_mm: f64::INFINITY,
            units_per_mm: 0.001,
            wavelengths_nm: [400.0, 700.0],
            motion: CameraMotion::fixed(Pose::default()),
            shutter: Shutter::default(),
        };
        assert!(LensRig::new(setup(&wide)).is_err());
        let too_near = LensSetup {
            focus_mm: 10.0,
            ..setup(&lens)
        };
        assert!(LensRig::new(too_near).is_err());
    }
}
