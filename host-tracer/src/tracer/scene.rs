//! What a scene is, independent of how it was written down ([`SceneDesc`]), and the form the
//! integrator traces ([`Scene`]): primitives in a BVH, per-material reflectance and per-emitter
//! radiance in `N` channels, and the light-selection table.

use glam::{Vec2, Vec3};
use optics_core::aperture::{Aperture, BitmapMask, Disk, Heart, RegularPolygon};
use optics_core::camera::{CameraMotion, CameraSample, Pose, Shutter, ThinLensCamera};
use optics_core::chromatic::ChromaticAberration;
use optics_core::distortion::BrownConrady;

use super::accel::{Accel, Primitive};
use super::color::{bands_from_rgb, Channels};
use super::geometry::Shape;
use super::lens_camera::{CameraLens, LensRig, LensSetup};
use super::sampling::Rng;
use crate::lens_file::LensFile;
use crate::spectra::BANDS;

/// A colour given in a scene: linear RGB, or a spectrum in [`BANDS`] bands.
#[derive(Debug, Clone, PartialEq)]
pub enum Colour {
    /// Linear RGB.
    Rgb([f32; 3]),
    /// Spectral bands (see [`super::color`]).
    Bands(Box<[f32; BANDS]>),
}

impl Colour {
    /// In `N` channels: RGB for `N = 3`, bands for `N = BANDS`. A spectrum asked for in RGB
    /// (never done by [`super::render`], which renders spectral scenes spectrally) gives its
    /// band averages over blue, green and red.
    pub fn channels<const N: usize>(&self) -> Channels<N> {
        let mut out = Channels::<N>::ZERO;
        match (self, N) {
            (Colour::Rgb(rgb), 3) => out.0.copy_from_slice(rgb),
            (Colour::Rgb(rgb), BANDS) => out.0.copy_from_slice(&bands_from_rgb(*rgb)),
            (Colour::Bands(b), BANDS) => out.0.copy_from_slice(&b[..]),
            (Colour::Bands(b), 3) => {
                let mean = |lo: usize, hi: usize| b[lo..hi].iter().sum::<f32>() / (hi - lo) as f32;
                out.0
                    .copy_from_slice(&[mean(19, 31), mean(9, 19), mean(0, 9)]);
            }
            _ => {}
        }
        out
    }

    /// Whether this needs the spectral path.
    pub fn is_spectral(&self) -> bool {
        matches!(self, Colour::Bands(_))
    }
}

/// A shape of a scene: its primitives, material and optional area-light emission.
#[derive(Debug, Clone)]
pub struct ShapeDesc {
    /// Name for messages.
    pub name: String,
    /// Triangles or a sphere, at shutter open.
    pub geometry: Vec<Shape>,
    /// Index into [`SceneDesc::materials`].
    pub material: usize,
    /// Radiance emitted from the front side (per unit projected area and solid angle).
    pub emission: Option<Colour>,
    /// Translation over the shutter interval.
    pub motion: Vec3,
}

/// The aperture's shape.
#[derive(Debug, Clone, PartialEq)]
pub enum ApertureDesc {
    /// Circle.
    Disk,
    /// n blades, rotated by `rotation` radians.
    Polygon {
        /// Blades, 3..=64.
        blades: u32,
        /// Rotation, radians.
        rotation: f32,
    },
    /// Heart.
    Heart,
    /// A transmission mask over the square `[-1, 1]^2` (row 0 at the top).
    Mask {
        /// Width in cells.
        width: usize,
        /// Height in cells.
        height: usize,
        /// Transmission 0..=255 per cell.
        cells: Vec<u8>,
    },
}

/// How the sensor's size is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SensorSize {
    /// Field of view (radians) across the image's smaller side, with the lens focused at
    /// infinity (Mitsuba's `fov` with `fov_axis = smaller`).
    Fov(f32),
    /// Sensor width in mm; the height follows the image's aspect ratio.
    WidthMm(f32),
}

/// The camera of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraDesc {
    /// Lens centre at shutter open.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Focal length, mm.
    pub focal_length_mm: f32,
    /// Sensor size.
    pub sensor: SensorSize,
    /// Aperture radius, mm; 0 is a pinhole.
    pub aperture_radius_mm: f32,
    /// Focus distance in scene units (`None`: the distance to `target`).
    pub focus_distance: Option<f32>,
    /// Scene units per mm (0.001 for a scene in metres).
    pub units_per_mm: f32,
    /// Aperture shape.
    pub aperture: ApertureDesc,
    /// Shutter open and close times.
    pub shutter: (f32, f32),
    /// Lens position and target at shutter close, when the camera moves.
    pub end: Option<(Vec3, Vec3)>,
    /// Chromatic-aberration strength (0: off).
    pub chromatic_aberration: f32,
    /// Brown-Conrady coefficients `[k1, k2, p1, p2, k3]` (OpenCV's order) the image is
    /// distorted by; `None`: no distortion.
    pub distortion: Option<[f64; 5]>,
    /// A real lens instead of the thin lens (then `focal_length_mm` is its focal length and
    /// `aperture_radius_mm` its entrance pupil's radius at the f-number used).
    pub lens: Option<CameraLens>,
}

impl CameraDesc {
    /// A pinhole at `position` looking at `target`, `fov_deg` across the smaller side.
    pub fn pinhole(position: Vec3, target: Vec3, fov_deg: f32) -> Self {
        Self {
            position,
            target,
            up: Vec3::Y,
            focal_length_mm: 50.0,
            sensor: SensorSize::Fov(fov_deg.to_radians()),
            aperture_radius_mm: 0.0,
            focus_distance: None,
            units_per_mm: 0.001,
            aperture: ApertureDesc::Disk,
            shutter: (0.0, 1.0),
            end: None,
            chromatic_aberration: 0.0,
            distortion: None,
            lens: None,
        }
    }

    /// Sensor width and height in mm for a `width` x `height` image.
    pub fn sensor_mm(&self, width: u32, height: u32) -> Vec2 {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        match self.sensor {
            SensorSize::Fov(fov) => {
                let smaller = 2.0 * self.focal_length_mm * (0.5 * fov).tan();
                Vec2::new(smaller * w / w.min(h), smaller * h / w.min(h))
            }
            SensorSize::WidthMm(mm) => Vec2::new(mm, mm * h / w),
        }
    }

    /// The thin lens in millimetres for a `width` x `height` image, as plain numbers for
    /// whatever models the optics beyond the tracer (the sensor's `LensGeometry::thin_lens`):
    /// focal length, aperture radius (0 for a pinhole) and sensor width and height.
    pub fn lens_mm(&self, width: u32, height: u32) -> (f64, f64, [f64; 2]) {
        let sensor = self.sensor_mm(width, height);
        (
            self.focal_length_mm as f64,
            self.aperture_radius_mm as f64,
            [sensor.x as f64, sensor.y as f64],
        )
    }

    /// Puts the real lens `file` on this camera in place of its thin lens: the focal length
    /// becomes the lens's, the f-number stays (opened no wider than the lens's widest; a
    /// pinhole gets the lens wide open), the sensor (a field of view stays a field of view), focus and shutter stay; the thin lens's
    /// shaped aperture, chromatic-aberration heuristic and distortion go (the lens makes its
    /// own). Returns the f-number used.
    pub fn use_lens(&mut self, file: LensFile) -> crate::Result<f64> {
        let mut lens = CameraLens {
            file,
            f_number: None,
        };
        let (efl, design_n) = lens.design()?;
        let asked = (self.aperture_radius_mm > 0.0)
            .then(|| f64::from(self.focal_length_mm) / (2.0 * f64::from(self.aperture_radius_mm)));
        let n = asked.map_or(design_n, |n| n.max(design_n));
        lens.f_number = Some(n);
        self.focal_length_mm = efl as f32;
        self.aperture_radius_mm = (efl / (2.0 * n)) as f32;
        self.aperture = ApertureDesc::Disk;
        self.chromatic_aberration = 0.0;
        self.distortion = None;
        self.lens = Some(lens);
        Ok(n)
    }

    /// [`Self::use_lens`] with the lens read from `path` (TOML, or pbrt's `.dat` with
    /// [`crate::lens_file::DEFAULT_PBRT_ABBE`]): what `--lens FILE` does.
    pub fn use_lens_file(&mut self, path: &std::path::Path) -> crate::Result<f64> {
        self.use_lens(LensFile::read(path, crate::lens_file::DEFAULT_PBRT_ABBE)?)
    }

    /// The real lens as a `width` x `height` render uses it, for deriving the ISP's
    /// corrections (isp-core's `lens_correction`): its surfaces stopped down as rendered, the
    /// pixel pitch (mm) and the film's distance behind the last vertex (mm, focused where
    /// the camera is). `None` for a thin lens.
    pub fn lens_as_rendered(
        &self,
        width: u32,
        height: u32,
    ) -> crate::Result<Option<LensAsRendered>> {
        let Some(lens) = &self.lens else {
            return Ok(None);
        };
        let (surfaces, f_number) = lens.stopped_surfaces()?;
        let film_mm = lens.film_distance_mm(
            &surfaces,
            f64::from(self.focus_distance() / self.units_per_mm),
        )?;
        let pitch_mm = f64::from(self.sensor_mm(width, height).x) / f64::from(width.max(1));
        Ok(Some(LensAsRendered {
            name: lens.file.name.clone(),
            surfaces,
            f_number,
            pitch_mm,
            film_mm,
        }))
    }

    /// Focus distance in scene units.
    pub fn focus_distance(&self) -> f32 {
        self.focus_distance
            .unwrap_or_else(|| (self.target - self.position).length())
    }
}

/// A whole scene as described.
#[derive(Debug, Clone)]
pub struct SceneDesc {
    /// Name for messages and reports.
    pub name: String,
    /// Materials by name: diffuse reflectance.
    pub materials: Vec<(String, Colour)>,
    /// Shapes.
    pub shapes: Vec<ShapeDesc>,
    /// Constant environment radiance seen by rays that leave the scene.
    pub environment: Option<Colour>,
    /// Camera.
    pub camera: CameraDesc,
    /// Default image width and height.
    pub film: (u32, u32),
    /// Default samples per pixel.
    pub spp: u32,
    /// Default longest path, in segments (1: emitters seen directly only).
    pub max_depth: u32,
    /// The scene illuminant: the named illuminant of the environment, else of the first light
    /// that names one (`None` when no light is a named illuminant). [`SceneDesc::relight`]
    /// replaces it.
    pub illuminant: Option<String>,
}

impl SceneDesc {
    /// Lights the scene with the named illuminant `to` instead of its scene illuminant: every
    /// emitter (and the environment) whose spectrum is the scene illuminant's gets `to`'s
    /// spectrum at the same luminance; lights of other spectra (the demo's bokeh lamps) and
    /// every reflectance stay as they are. Returns how many lights changed (none when `to` is
    /// already the scene illuminant).
    ///
    /// An error when the scene has no scene illuminant (RGB lights only) or `to` is not one of
    /// [`crate::spectra::ILLUMINANTS`].
    pub fn relight(&mut self, to: &str) -> crate::Result<usize> {
        use crate::spectra::{illuminant_bands, xyz_weights};
        let Some(from) = self.illuminant.clone() else {
            return Err(crate::Error::out_of_range(
                format!("scene {}", self.name),
                "no light is a named illuminant",
                "a spectral scene with a light given by illuminant = \"...\"",
            ));
        };
        let target = illuminant_bands(to)?;
        if from == to {
            return Ok(0);
        }
        let source = illuminant_bands(&from)?;
        let weights = xyz_weights();
        let luminance =
            |b: &[f32; BANDS]| -> f32 { b.iter().zip(&weights).map(|(v, w)| v * w[1]).sum() };
        let (source_y, target_y) = (luminance(&source), luminance(&target));
        let peak = source.iter().fold(0.0f32, |m, v| m.max(v / source_y));
        let mut relit = 0;
        let lights = self
            .shapes
            .iter_mut()
            .filter_map(|s| s.emission.as_mut())
            .chain(self.environment.as_mut());
        for light in lights {
            let Colour::Bands(bands) = light else {
                continue;
            };
            let y = luminance(bands);
            // The same spectrum up to scale: equal once both are normalised to unit luminance.
            let same = y > 0.0
                && bands
                    .iter()
                    .zip(&source)
                    .all(|(v, s)| (v / y - s / source_y).abs() <= 1e-4 * peak);
            if same {
                **bands = target.map(|v| v * y / target_y);
                relit += 1;
            }
        }
        self.illuminant = Some(to.to_owned());
        Ok(relit)
    }

    /// The colour of an RGB scene's light, linear RGB: the emitters' radiance weighted by
    /// their area, else the environment's; `None` when a light is spectral or there is none
    /// (a scene lit by several colours gets their area-weighted mix, what a grey-world
    /// white balance would see of the lights themselves).
    pub fn light_rgb(&self) -> Option<[f32; 3]> {
        let mut sum = [0.0f64; 3];
        for shape in &self.shapes {
            match &shape.emission {
                None => {}
                Some(Colour::Rgb(rgb)) => {
                    let area: f64 = shape.geometry.iter().map(|g| f64::from(g.area())).sum();
                    for (s, v) in sum.iter_mut().zip(rgb) {
                        *s += area * f64::from(*v);
                    }
                }
                Some(Colour::Bands(_)) => return None,
            }
        }
        if sum == [0.0; 3] {
            match &self.environment {
                Some(Colour::Rgb(rgb)) => sum = rgb.map(f64::from),
                _ => return None,
            }
        }
        let light = sum.map(|v| v as f32);
        light
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
            .then_some(light)
    }

    /// Whether any colour is spectral, so the scene renders in bands.
    pub fn is_spectral(&self) -> bool {
        self.materials.iter().any(|(_, c)| c.is_spectral())
            || self
                .shapes
                .iter()
                .any(|s| s.emission.as_ref().is_some_and(Colour::is_spectral))
            || self.environment.as_ref().is_some_and(Colour::is_spectral)
    }

    /// Whether anything moves over the shutter interval.
    pub fn has_motion(&self) -> bool {
        self.camera.end.is_some() || self.shapes.iter().any(|s| s.motion != Vec3::ZERO)
    }
}

/// The camera as used for one image, with what it needs sampled.
pub struct CameraRig<'a> {
    camera: ThinLensCamera<'a>,
    width: u32,
    height: u32,
    /// Draw a lens sample (aperture > 0).
    pub needs_lens: bool,
    /// Draw a time sample (something moves and the shutter is open for a while).
    pub needs_time: bool,
    shutter: (f32, f32),
    distortion: Option<(BrownConrady<f64>, f32)>,
    /// The real lens, when the camera has one: [`CameraRig::sample`] is then not used, the
    /// renderer draws a wavelength per sample and asks the lens.
    pub lens: Option<LensRig>,
}

/// A real lens as a render uses it ([`CameraDesc::lens_as_rendered`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LensAsRendered {
    /// The lens file's name.
    pub name: String,
    /// The surfaces, the stop narrowed to the f-number rendered at.
    pub surfaces: Vec<optics_core::prescription::Surface<f64>>,
    /// That f-number.
    pub f_number: f64,
    /// Pixel pitch, mm.
    pub pitch_mm: f64,
    /// The film's distance behind the last vertex, mm.
    pub film_mm: f64,
}

/// Storage a bitmap aperture's sampling table lives in while a camera uses it.
#[derive(Default)]
pub struct MaskTable(Vec<u32>);

impl CameraDesc {
    /// The optics-core camera for a `width` x `height` image; `any_motion` says whether the
    /// scene moves (so time samples are needed). `table` holds a mask aperture's sampling table.
    pub fn rig<'a>(
        &'a self,
        width: u32,
        height: u32,
        any_motion: bool,
        table: &'a mut MaskTable,
    ) -> crate::error::Result<CameraRig<'a>> {
        fn e(part: &'static str) -> impl Fn(optics_core::OpticsError) -> crate::error::Error {
            move |source| crate::error::Error::Optics { part, source }
        }
        let sensor = self.sensor_mm(width, height);
        let focus_mm = if self.aperture_radius_mm > 0.0 {
            self.focus_distance() / self.units_per_mm
        } else {
            f32::INFINITY
        };
        let aperture = match &self.aperture {
            ApertureDesc::Disk => Aperture::Disk(Disk),
            ApertureDesc::Polygon { blades, rotation } => {
                Aperture::Polygon(RegularPolygon::new(*blades, *rotation).map_err(e("aperture"))?)
            }
            ApertureDesc::Heart => Aperture::Heart(Heart::new()),
            ApertureDesc::Mask {
                width,
                height,
                cells,
            } => {
                table.0 = vec![0; BitmapMask::cdf_len(*width, *height).map_err(e("mask"))?];
                Aperture::Bitmap(
                    BitmapMask::new(cells, *width, *height, &mut table.0).map_err(e("mask"))?,
                )
            }
        };
        let start = Pose::look_at(self.position, self.target, self.up).map_err(e("pose"))?;
        let motion = match self.end {
            Some((p, t)) => {
                CameraMotion::linear(start, Pose::look_at(p, t, self.up).map_err(e("end pose"))?)
                    .map_err(e("motion"))?
            }
            None => CameraMotion::fixed(start),
        };
        let shutter = Shutter::new(self.shutter.0, self.shutter.1).map_err(e("shutter"))?;
        let camera = ThinLensCamera::new(self.focal_length_mm, sensor.x, sensor.y)
            .map_err(e("lens"))?
            .with_aperture(self.aperture_radius_mm)
            .map_err(e("aperture radius"))?
            .focused_at(focus_mm)
            .map_err(e("focus distance"))?
            .with_shape(aperture)
            .with_chromatic_aberration(
                ChromaticAberration::new(self.chromatic_aberration)
                    .map_err(e("chromatic aberration"))?,
            )
            .with_shutter(shutter)
            .with_motion(motion)
            .with_world_units_per_mm(self.units_per_mm)
            .map_err(e("units per mm"))?;
        let lens = match &self.lens {
            Some(lens) => Some(LensRig::new(LensSetup {
                lens,
                sensor_mm: sensor,
                size: (width, height),
                focus_mm: f64::from(self.focus_distance() / self.units_per_mm),
                units_per_mm: self.units_per_mm,
                wavelengths_nm: [
                    crate::spectra::band_centre_nm(0),
                    crate::spectra::band_centre_nm(BANDS - 1),
                ],
                motion,
                shutter,
            })?),
            None => None,
        };
        let distortion = match self.distortion {
            Some(d) => {
                let model = BrownConrady::from_opencv(d).map_err(e("distortion"))?;
                (!model.is_identity()).then_some((model, camera.image_distance_mm()))
            }
            None => None,
        };
        Ok(CameraRig {
            needs_lens: self.aperture_radius_mm > 0.0,
            needs_time: any_motion && self.shutter.1 > self.shutter.0,
            camera,
            width,
            height,
            shutter: self.shutter,
            distortion,
            lens,
        })
    }
}

impl CameraRig<'_> {
    /// The underlying optics-core camera.
    pub fn camera(&self) -> &ThinLensCamera<'_> {
        &self.camera
    }

    /// Fraction of the shutter interval (0 open, 1 close) at `time`.
    #[inline]
    pub fn shutter_fraction(&self, time: f32) -> f32 {
        let duration = self.shutter.1 - self.shutter.0;
        if duration > 0.0 {
            ((time - self.shutter.0) / duration).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// A camera ray through raster position `(px, py)` (top-left origin), drawing lens and time
    /// samples from `rng` only when the camera needs them. `None` where a distorted pixel has
    /// no undistorted source.
    #[inline]
    pub fn sample(&self, px: f32, py: f32, rng: &mut Rng) -> Option<CameraSample> {
        let mut film = self.camera.film_point(px, py, self.width, self.height);
        if let Some((model, image_distance)) = &self.distortion {
            // The raster is the distorted image: find where the undistorted ray points.
            let d = *image_distance as f64;
            let [x, y] = model
                .undistort([film.x as f64 / d, -film.y as f64 / d])
                .ok()?;
            film = Vec2::new((x * d) as f32, (-y * d) as f32);
        }
        let lens = if self.needs_lens {
            rng.next_2d()
        } else {
            Vec2::ZERO
        };
        let time = if self.needs_time { rng.next_f32() } else { 0.0 };
        Some(self.camera.generate_ray(film, lens, time))
    }
}

/// Light selection: emitting primitives chosen in proportion to their power.
struct Lights {
    /// Primitive index of each light.
    primitives: Vec<u32>,
    /// Cumulative selection probability.
    cdf: Vec<f32>,
    /// Per primitive: probability of choosing it divided by its area (0 for non-emitters).
    area_pdf: Vec<f32>,
}

/// A scene ready to trace in `N` channels.
pub struct Scene<const N: usize> {
    /// Primitives and their BVH.
    pub accel: Accel,
    /// Reflectance per material.
    pub albedo: Vec<Channels<N>>,
    /// Radiance per emission index.
    pub emission: Vec<Channels<N>>,
    /// Environment radiance.
    pub environment: Channels<N>,
    lights: Lights,
    /// Scale of the scene (bounding-box diagonal): sets the ray offset.
    pub epsilon: f32,
}

/// A light sample seen from a point.
pub struct LightSample<const N: usize> {
    /// Unit direction to the light point.
    pub direction: Vec3,
    /// Distance to it.
    pub distance: f32,
    /// Radiance arriving.
    pub radiance: Channels<N>,
    /// Density over solid angle.
    pub pdf: f32,
}

impl<const N: usize> Scene<N> {
    /// Converts a description (validated when it was made) into `N` channels.
    pub fn new(desc: &SceneDesc) -> Self {
        let albedo = desc.materials.iter().map(|(_, c)| c.channels()).collect();
        let mut emission = Vec::new();
        let mut primitives = Vec::new();
        for shape in &desc.shapes {
            let emission_index = match &shape.emission {
                Some(c) => {
                    emission.push(c.channels::<N>());
                    (emission.len() - 1) as u32
                }
                None => Primitive::NO_EMISSION,
            };
            for g in &shape.geometry {
                primitives.push(Primitive {
                    shape: *g,
                    motion: shape.motion,
                    material: shape.material as u32,
                    emission: emission_index,
                });
            }
        }
        let (lo, hi) = primitives.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p: &Primitive| {
                let (a, b) = p.shape.bounds();
                (lo.min(a), hi.max(b))
            },
        );
        let extent = if lo.x.is_finite() {
            (hi - lo).length()
        } else {
            1.0
        };
        let accel = Accel::new(primitives);
        let lights = Self::lights(&accel.primitives, &emission);
        Self {
            accel,
            albedo,
            emission,
            environment: desc
                .environment
                .as_ref()
                .map_or(Channels::ZERO, Colour::channels),
            lights,
            epsilon: 1e-4 * extent.max(1e-3),
        }
    }

    fn lights(primitives: &[Primitive], emission: &[Channels<N>]) -> Lights {
        let mut lights = Lights {
            primitives: Vec::new(),
            cdf: Vec::new(),
            area_pdf: vec![0.0; primitives.len()],
        };
        let mut total = 0.0f64;
        let mut power = Vec::new();
        for (i, p) in primitives.iter().enumerate() {
            if p.emission == Primitive::NO_EMISSION {
                continue;
            }
            let w = (p.shape.area() * emission[p.emission as usize].mean()) as f64;
            if w > 0.0 && w.is_finite() {
                lights.primitives.push(i as u32);
                power.push(w);
                total += w;
            }
        }
        let mut running = 0.0f64;
        for (k, w) in power.iter().enumerate() {
            running += w;
            lights.cdf.push((running / total) as f32);
            let i = lights.primitives[k] as usize;
            lights.area_pdf[i] = (w / total) as f32 / primitives[i].shape.area();
        }
        if let Some(last) = lights.cdf.last_mut() {
            *last = 1.0;
        }
        lights
    }

    /// Whether the scene has area lights to sample.
    pub fn has_lights(&self) -> bool {
        !self.lights.primitives.is_empty()
    }

    /// Density (over area) with which [`Scene::sample_light`] picks a point on primitive `i`.
    #[inline]
    pub fn light_area_pdf(&self, i: u32) -> f32 {
        self.lights.area_pdf[i as usize]
    }

    /// Samples a point on a light as seen from `p` at shutter fraction `s`. `None` when the
    /// point faces away (lights emit from their front side only).
    pub fn sample_light(&self, p: Vec3, s: f32, rng: &mut Rng) -> Option<LightSample<N>> {
        let u = rng.next_f32();
        let k = self
            .lights
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.lights.primitives.len().checked_sub(1)?);
        let index = self.lights.primitives[k];
        let prim = &self.accel.primitives[index as usize];
        let (point, normal) = prim.shape.sample(rng.next_2d());
        let to = point + prim.motion * s - p;
        let distance2 = to.length_squared();
        let distance = distance2.sqrt();
        let direction = to * (1.0 / distance);
        let cos_light = -direction.dot(normal);
        if cos_light <= 0.0 || !distance.is_finite() || distance == 0.0 {
            return None;
        }
        Some(LightSample {
            direction,
            distance,
            radiance: self.emission[prim.emission as usize],
            pdf: self.lights.area_pdf[index as usize] * distance2 / cos_light,
        })
    }
}
