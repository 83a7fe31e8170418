//! Thin-lens and pinhole camera rays, field of view, shutter time sampling and camera motion.
//!
//! Camera space is right-handed: `+x` right, `+y` up, looking down `-z`. The film is described by
//! its *virtual* image in front of the lens (upright, as the final raster shows it): the film point
//! `(x, y)` mm sees the scene through the lens centre along `(x, y, -s_i)`, where `s_i` is the
//! sensor-to-lens distance that focuses the focus distance. Lens lengths are millimetres; ray
//! origins are scaled to scene units by `world_units_per_mm`.
//!
//! A feature that is off costs nothing: aperture radius 0 takes the pinhole path (no lens
//! sample), a static camera no interpolation, chromatic strength 0 no channel choice.

use glam::{Quat, Vec2, Vec3};

use crate::aperture::{Aperture, Disk};
use crate::chromatic::ChromaticAberration;
use crate::lens::sensor_distance_for_focus;
use crate::real::{non_negative, positive, positive_or_infinite};
use crate::{math, OpticsError, Real, Result};

/// A ray in world space at a time within the shutter interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin (on the lens), in scene units.
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// Time in the shutter interval, in the shutter's units (seconds by convention).
    pub time: f32,
}

/// A camera ray with its per-channel (R, G, B) throughput weight from chromatic aberration;
/// `[1, 1, 1]` without it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSample {
    /// The ray.
    pub ray: Ray,
    /// Weight to multiply each colour channel's radiance by.
    pub throughput: [f32; 3],
}

/// Horizontal (or any) field of view, in radians, of a sensor dimension `sensor_mm` behind a
/// lens focused at infinity: `2 atan(d / 2f)`.
///
/// ```
/// use optics_core::camera::field_of_view;
/// // Full-frame width behind a 36/2 mm lens: 90 degrees.
/// let fov = field_of_view(36.0_f64, 18.0).unwrap();
/// assert!((fov.to_degrees() - 90.0).abs() < 1e-9);
/// ```
pub fn field_of_view<T: Real>(sensor_mm: T, focal_length_mm: T) -> Result<T> {
    let d = positive(sensor_mm, "sensor_mm")?;
    let f = positive(focal_length_mm, "focal_length_mm")?;
    Ok(T::lit(2.0) * (d / (T::lit(2.0) * f)).atan())
}

/// Camera-to-world placement: rotation then translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position of the lens centre, in scene units.
    pub translation: Vec3,
    /// Orientation (unit quaternion).
    pub rotation: Quat,
}

impl Default for Pose {
    fn default() -> Self {
        Self {
            translation: Vec3::ZERO,
            rotation: Quat::IDENTITY,
        }
    }
}

impl Pose {
    /// A camera at `eye` looking at `target` with `up` roughly up.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Result<Self> {
        let forward = target - eye;
        let bad = OpticsError::InvalidParameter {
            name: "eye/target/up",
            allowed: "finite, eye != target, up not parallel to the view direction",
        };
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(bad);
        }
        let f = forward.try_normalize().ok_or(bad)?;
        let right = f.cross(up).try_normalize().ok_or(bad)?;
        let true_up = right.cross(f);
        // Columns are the camera axes in world space: +x right, +y up, -z forward.
        let rotation = Quat::from_mat3(&glam::Mat3::from_cols(right, true_up, -f)).normalize();
        Ok(Self {
            translation: eye,
            rotation,
        })
    }
}

/// The open and close times of the shutter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shutter {
    open: f32,
    close: f32,
}

impl Default for Shutter {
    fn default() -> Self {
        Self {
            open: 0.0,
            close: 0.0,
        }
    }
}

impl Shutter {
    /// A shutter open over `[open, close]` (equal for an instant).
    pub fn new(open: f32, close: f32) -> Result<Self> {
        if !(open.is_finite() && close.is_finite() && open <= close) {
            return Err(OpticsError::InvalidParameter {
                name: "open/close",
                allowed: "finite with open <= close",
            });
        }
        Ok(Self { open, close })
    }

    /// Time for a uniform sample `u` in `[0, 1)`, uniform over the interval.
    pub fn sample_time(&self, u: f32) -> f32 {
        let u = if u.is_nan() { 0.0 } else { u.clamp(0.0, 1.0) };
        self.open + u * (self.close - self.open)
    }

    /// Open time.
    pub fn open(&self) -> f32 {
        self.open
    }

    /// Close time.
    pub fn close(&self) -> f32 {
        self.close
    }

    /// `close - open`.
    pub fn duration(&self) -> f32 {
        self.close - self.open
    }
}

/// The camera pose at shutter open and at shutter close, interpolated in between (position
/// linearly, rotation by slerp).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CameraMotion {
    start: Pose,
    end: Pose,
    moving: bool,
}

impl CameraMotion {
    /// A camera that does not move.
    pub fn fixed(pose: Pose) -> Self {
        Self {
            start: pose,
            end: pose,
            moving: false,
        }
    }

    /// A camera moving from `start` (at shutter open) to `end` (at shutter close).
    pub fn linear(start: Pose, end: Pose) -> Result<Self> {
        for p in [start, end] {
            if !(p.translation.is_finite()
                && p.rotation.is_finite()
                && p.rotation.length_squared() > 0.0)
            {
                return Err(OpticsError::InvalidParameter {
                    name: "pose",
                    allowed: "finite translation and a non-zero finite rotation",
                });
            }
        }
        let (start, end) = (
            Pose {
                rotation: start.rotation.normalize(),
                ..start
            },
            Pose {
                rotation: end.rotation.normalize(),
                ..end
            },
        );
        Ok(Self {
            start,
            end,
            moving: start != end,
        })
    }

    /// Pose at fraction `s` of the shutter interval (0 = open, 1 = close).
    pub fn at(&self, s: f32) -> Pose {
        if !self.moving {
            return self.start;
        }
        let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
        Pose {
            translation: self.start.translation.lerp(self.end.translation, s),
            rotation: self.start.rotation.slerp(self.end.rotation, s),
        }
    }

    /// Whether the pose changes over the shutter interval.
    pub fn is_moving(&self) -> bool {
        self.moving
    }
}

/// A thin-lens camera (a pinhole camera when the aperture radius is 0).
///
/// ```
/// use optics_core::camera::ThinLensCamera;
/// use glam::Vec2;
/// // 50 mm lens, 36x24 mm sensor, 50/1.8 aperture, focused at 2 m.
/// let cam = ThinLensCamera::new(50.0, 36.0, 24.0)
///     .unwrap()
///     .with_aperture(50.0 / 1.8 / 2.0)
///     .unwrap()
///     .focused_at(2000.0)
///     .unwrap();
/// let film = cam.film_point(480.0, 320.0, 960, 640); // a pixel right of centre
/// let a = cam.generate_ray(film, Vec2::new(0.1, 0.2), 0.0).ray;
/// let b = cam.generate_ray(film, Vec2::new(0.9, 0.6), 0.0).ray;
/// // Both reach the same point on the plane of focus, z = -2000 mm.
/// let hit = |r: optics_core::camera::Ray| r.origin + r.direction * ((-2000.0 - r.origin.z) / r.direction.z);
/// assert!((hit(a) - hit(b)).length() < 1e-2);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct ThinLensCamera<'a> {
    focal_length_mm: f32,
    sensor_mm: Vec2,
    /// `2 / |sensor diagonal|`: film mm to the normalised radius chromatic aberration uses.
    film_to_normalised: f32,
    aperture_radius_mm: f32,
    focus_distance_mm: f32,
    image_distance_mm: f32,
    aperture: Aperture<'a>,
    chromatic: ChromaticAberration,
    shutter: Shutter,
    motion: CameraMotion,
    world_units_per_mm: f32,
}

impl<'a> ThinLensCamera<'a> {
    /// A pinhole camera (aperture radius 0) of focal length `f` focused at infinity, with a
    /// sensor of `width_mm` x `height_mm`.
    pub fn new(focal_length_mm: f32, width_mm: f32, height_mm: f32) -> Result<Self> {
        let f = positive(focal_length_mm, "focal_length_mm")?;
        let w = positive(width_mm, "sensor_width_mm")?;
        let h = positive(height_mm, "sensor_height_mm")?;
        Ok(Self {
            focal_length_mm: f,
            sensor_mm: Vec2::new(w, h),
            film_to_normalised: 2.0 / Vec2::new(w, h).length(),
            aperture_radius_mm: 0.0,
            focus_distance_mm: f32::INFINITY,
            image_distance_mm: f,
            aperture: Aperture::Disk(Disk),
            chromatic: ChromaticAberration::default(),
            shutter: Shutter::default(),
            motion: CameraMotion::default(),
            world_units_per_mm: 1.0,
        })
    }

    /// Sets the aperture (entrance pupil) radius in mm; 0 is a pinhole.
    pub fn with_aperture(mut self, radius_mm: f32) -> Result<Self> {
        self.aperture_radius_mm = non_negative(radius_mm, "aperture_radius_mm")?;
        Ok(self)
    }

    /// Sets the aperture radius from an f-number: `r = f / (2N)`.
    pub fn with_f_number(self, f_number: f32) -> Result<Self> {
        let n = positive(f_number, "f_number")?;
        let r = self.focal_length_mm / (2.0 * n);
        self.with_aperture(r)
    }

    /// Sets the aperture's shape (default: a disk).
    pub fn with_shape(mut self, shape: Aperture<'a>) -> Self {
        self.aperture = shape;
        self
    }

    /// Focuses at `distance_mm` (`f32::INFINITY` allowed) by moving the sensor; the subject must
    /// be farther than the focal length.
    pub fn focused_at(mut self, distance_mm: f32) -> Result<Self> {
        let s = positive_or_infinite(distance_mm, "focus_distance_mm")?;
        self.image_distance_mm = sensor_distance_for_focus(self.focal_length_mm, s)?;
        self.focus_distance_mm = s;
        Ok(self)
    }

    /// Sets the chromatic-aberration model (strength 0 turns it off).
    pub fn with_chromatic_aberration(mut self, chromatic: ChromaticAberration) -> Self {
        self.chromatic = chromatic;
        self
    }

    /// Sets the shutter interval.
    pub fn with_shutter(mut self, shutter: Shutter) -> Self {
        self.shutter = shutter;
        self
    }

    /// Sets the camera's placement over the shutter interval.
    pub fn with_motion(mut self, motion: CameraMotion) -> Self {
        self.motion = motion;
        self
    }

    /// Sets how many scene units one millimetre is (e.g. 0.001 for a scene in metres).
    pub fn with_world_units_per_mm(mut self, scale: f32) -> Result<Self> {
        self.world_units_per_mm = positive(scale, "world_units_per_mm")?;
        Ok(self)
    }

    /// Sensor-to-lens distance (mm) for the current focus.
    pub fn image_distance_mm(&self) -> f32 {
        self.image_distance_mm
    }

    /// Focus distance (mm; may be infinite).
    pub fn focus_distance_mm(&self) -> f32 {
        self.focus_distance_mm
    }

    /// Aperture radius (mm).
    pub fn aperture_radius_mm(&self) -> f32 {
        self.aperture_radius_mm
    }

    /// Horizontal and vertical field of view (radians) at the current focus.
    pub fn field_of_view(&self) -> Vec2 {
        let half = self.sensor_mm / (2.0 * self.image_distance_mm);
        Vec2::new(2.0 * math::atan(half.x), 2.0 * math::atan(half.y))
    }

    /// Film point (mm from the sensor centre, `+y` up) of raster position `(px, py)` on a
    /// `width` x `height` image whose `(0, 0)` is the top-left corner.
    pub fn film_point(&self, px: f32, py: f32, width: u32, height: u32) -> Vec2 {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        Vec2::new(
            (px / w - 0.5) * self.sensor_mm.x,
            (0.5 - py / h) * self.sensor_mm.y,
        )
    }

    /// The ray for film point `film_mm`, lens sample `lens_u` and time sample `time_u` (both
    /// uniform in `[0, 1)`), in world space.
    pub fn generate_ray(&self, film_mm: Vec2, lens_u: Vec2, time_u: f32) -> CameraSample {
        // Chief ray through the lens centre, towards the virtual film point.
        let chief = Vec3::new(film_mm.x, film_mm.y, -self.image_distance_mm);
        let (origin, direction, throughput) = if self.aperture_radius_mm == 0.0 {
            (Vec3::ZERO, chief.normalize(), [1.0; 3])
        } else {
            let s =
                self.chromatic
                    .sample(&self.aperture, film_mm * self.film_to_normalised, lens_u);
            let lens = (s.lens_point * self.aperture_radius_mm).extend(0.0);
            let direction = if self.focus_distance_mm.is_infinite() {
                chief.normalize()
            } else {
                // Every ray from this film point passes through its conjugate on the plane of focus.
                let on_focus_plane = chief * (self.focus_distance_mm / self.image_distance_mm);
                (on_focus_plane - lens).normalize()
            };
            (lens * self.world_units_per_mm, direction, s.throughput)
        };
        let time = self.shutter.sample_time(time_u);
        let pose = if self.motion.is_moving() {
            let duration = self.shutter.duration();
            let s = if duration > 0.0 {
                (time - self.shutter.open()) / duration
            } else {
                0.0
            };
            self.motion.at(s)
        } else {
            self.motion.at(0.0)
        };
        let ray = Ray {
            origin: pose.translation + pose.rotation * origin,
            direction: pose.rotation * direction,
            time,
        };
        CameraSample { ray, throughput }
    }
}
