//! Lens files: a prescription for optics-core's [`optics_core::prescription`], in TOML (the
//! format below) or pbrt's four-column `.dat`; and `camsim lens`'s report of a lens's paraxial
//! data and of rays traced through it.
//!
//! The TOML format, version 1 (lengths in millimetres, surfaces from the object side):
//!
//! ```toml
//! version = 1
//! name = "Biconvex singlet"
//! source = "where the prescription comes from (a patent, a book, a page)"
//! field_deg = 20.0         # optional: the design's half field of view (the curves' span)
//!
//! [[surface]]
//! radius = 50.0            # mm; 0 or "inf" (absent) is flat; or `curvature` (1/mm)
//! thickness = 5.0          # to the next vertex (after the last surface: to the image plane)
//! semi_diameter = 10.0     # clear aperture radius
//! glass = "N-BK7"          # a catalogue glass; or nd + vd (a model glass); or index (no
//!                          # dispersion); or sellmeier = { b = [..], c = [..] } (c in um^2);
//!                          # none: air
//! stop = true              # exactly one surface is the aperture stop
//!
//! [[surface]]
//! radius = -50.0
//! thickness = 47.0
//! semi_diameter = 10.0
//! conic = 0.0              # with `aspheric = [A4, A6, ..., A16]`: an even asphere
//! ```
//!
//! Unknown keys are refused, and every error names the surface (counted from 1) and the key.

use std::path::Path;

pub use host_tracer::lens_file::{LensFile, LENS_FILE_VERSION};
use optics_core::prescription::glass::LAMBDA_D_NM;
use optics_core::prescription::paraxial::Paraxial;
use optics_core::prescription::trace::{Loss, Ray, Traced};
use optics_core::prescription::Prescription;
use serde::{Deserialize, Serialize};

use crate::Error;

/// The paraxial data `camsim lens` prints, at one wavelength.
#[derive(Debug, Clone, Serialize)]
pub struct LensReport {
    /// The lens's name.
    pub name: String,
    /// Where its prescription comes from.
    pub source: String,
    /// Surfaces.
    pub surfaces: usize,
    /// The stop's surface, counted from 1.
    pub stop_surface: usize,
    /// Wavelength, nm.
    pub wavelength_nm: f64,
    /// Effective focal length, mm.
    pub efl_mm: f64,
    /// Back focal length (last vertex to rear focal point), mm.
    pub bfl_mm: f64,
    /// Front focal length (first vertex to front focal point), mm.
    pub ffl_mm: f64,
    /// First vertex to the front principal plane, mm.
    pub front_principal_mm: f64,
    /// Last vertex to the rear principal plane, mm.
    pub rear_principal_mm: f64,
    /// Entrance pupil position from the first vertex, mm.
    pub entrance_pupil_position_mm: f64,
    /// Entrance pupil diameter, mm.
    pub entrance_pupil_diameter_mm: f64,
    /// Exit pupil position from the last vertex, mm (`None`: at infinity).
    pub exit_pupil_position_mm: Option<f64>,
    /// Exit pupil diameter, mm.
    pub exit_pupil_diameter_mm: Option<f64>,
    /// f-number at infinite conjugate, EFL / EPD.
    pub f_number: f64,
    /// First vertex to the image plane the file gives, mm.
    pub total_length_mm: f64,
    /// Curves against the field, when the file gives its field.
    pub curves: Option<FieldCurves>,
    /// Chromatic focal shift against the d line, micrometres, at 400 to 700 nm by 20 nm.
    pub chromatic_focal_shift: Vec<(f64, f64)>,
}

/// Real-ray curves against the field angle (object at infinity), at the report's wavelength,
/// on its paraxial focal plane (optics-core's `prescription::analysis`).
#[derive(Debug, Clone, Serialize)]
pub struct FieldCurves {
    /// Field angles, degrees: 0 to the design's half field in ten steps.
    pub field_deg: Vec<f64>,
    /// Distortion against `efl tan(field)`, percent (`None`: the chief ray is lost).
    pub distortion_percent: Vec<Option<f64>>,
    /// Lateral colour, the chief ray at F (486.13 nm) less at C (656.27 nm), micrometres.
    pub lateral_colour_um: Vec<Option<f64>>,
    /// Relative illumination (vignetting times the cosine-fourth law in image space).
    pub relative_illumination: Vec<Option<f64>>,
    /// RMS spot radius, micrometres (a 33 x 33 pupil grid).
    pub rms_spot_um: Vec<Option<f64>>,
}

impl LensReport {
    /// The report of `lens` at `wavelength_nm`.
    pub fn of(lens: &LensFile, wavelength_nm: f64) -> Result<Self, Error> {
        let p = lens.prescription()?;
        let optics = |source| Error::Optics {
            option: "lens",
            source,
        };
        let x: Paraxial<f64> = p.paraxial(wavelength_nm).map_err(optics)?;
        Ok(LensReport {
            name: lens.name.clone(),
            source: lens.source.clone(),
            surfaces: lens.surfaces.len(),
            stop_surface: p.stop_index() + 1,
            wavelength_nm,
            efl_mm: x.efl,
            bfl_mm: x.bfl,
            ffl_mm: x.ffl,
            front_principal_mm: x.front_principal,
            rear_principal_mm: x.rear_principal,
            entrance_pupil_position_mm: x.entrance_pupil.position,
            entrance_pupil_diameter_mm: 2.0 * x.entrance_pupil.semi_diameter,
            exit_pupil_position_mm: x.exit_pupil.map(|e| e.position),
            exit_pupil_diameter_mm: x.exit_pupil.map(|e| 2.0 * e.semi_diameter),
            f_number: x.f_number,
            total_length_mm: p.total_length(),
            curves: lens
                .field_deg
                .map(|max| field_curves(&p, max, wavelength_nm))
                .transpose()?,
            chromatic_focal_shift: (0..=15)
                .map(|k| {
                    let nm = 400.0 + 20.0 * k as f64;
                    p.chromatic_focal_shift(nm, LAMBDA_D_NM)
                        .map(|s| (nm, 1000.0 * s))
                        .map_err(optics)
                })
                .collect::<Result<_, _>>()?,
        })
    }

    /// The report as a table.
    pub fn to_table(&self) -> String {
        let opt = |v: Option<f64>| v.map_or("at infinity".to_string(), |v| format!("{v:.6}"));
        let mut s = format!("{}\n", self.name);
        if !self.source.is_empty() {
            s += &format!("source: {}\n", self.source);
        }
        s += &format!(
            "{} surfaces, stop at surface {}; paraxial at {} nm\n",
            self.surfaces, self.stop_surface, self.wavelength_nm
        );
        for (what, v) in [
            ("effective focal length", format!("{:.6} mm", self.efl_mm)),
            ("back focal length", format!("{:.6} mm", self.bfl_mm)),
            ("front focal length", format!("{:.6} mm", self.ffl_mm)),
            (
                "front principal plane",
                format!("{:.6} mm from the first vertex", self.front_principal_mm),
            ),
            (
                "rear principal plane",
                format!("{:.6} mm from the last vertex", self.rear_principal_mm),
            ),
            (
                "entrance pupil",
                format!(
                    "{:.6} mm from the first vertex, diameter {:.6} mm",
                    self.entrance_pupil_position_mm, self.entrance_pupil_diameter_mm
                ),
            ),
            (
                "exit pupil",
                format!(
                    "{} mm from the last vertex, diameter {} mm",
                    opt(self.exit_pupil_position_mm),
                    opt(self.exit_pupil_diameter_mm)
                ),
            ),
            (
                "f-number (infinite conjugate)",
                format!("{:.4}", self.f_number),
            ),
            (
                "first vertex to image plane",
                format!("{:.6} mm", self.total_length_mm),
            ),
        ] {
            s += &format!("  {what:<30} {v}\n");
        }
        if let Some(c) = &self.curves {
            let cell = |v: Option<f64>, digits: usize| {
                v.map_or("lost".to_string(), |v| format!("{v:.digits$}"))
            };
            s += "  field deg  distortion %  lateral colour um  rel. illumination  RMS spot um\n";
            for k in 0..c.field_deg.len() {
                s += &format!(
                    "  {:>9.2}  {:>12}  {:>17}  {:>17}  {:>11}\n",
                    c.field_deg[k],
                    cell(c.distortion_percent[k], 4),
                    cell(c.lateral_colour_um[k], 3),
                    cell(c.relative_illumination[k], 4),
                    cell(c.rms_spot_um[k], 2)
                );
            }
        }
        s
    }
}

/// Writes `report`'s curves as `dir/lens.svg` (the folder made if missing), in the bench's
/// chart style, `caption` under it; returns the file written.
pub fn plot(report: &LensReport, dir: &Path, caption: &str) -> Result<std::path::PathBuf, Error> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::Format(raw_formats::FormatError::io(dir, e)))?;
    let path = dir.join("lens.svg");
    crate::suite::charts::lens_curves(report, caption, &path)?;
    Ok(path)
}

/// The curves of `p` over 0 to `max_deg` at `wavelength_nm`.
fn field_curves(
    p: &Prescription<'_, f64>,
    max_deg: f64,
    wavelength_nm: f64,
) -> Result<FieldCurves, Error> {
    use optics_core::prescription::glass::{LAMBDA_C_NM, LAMBDA_F_NM};
    let optics = |source| Error::Optics {
        option: "lens curves",
        source,
    };
    let field_deg: Vec<f64> = (0..=10).map(|k| max_deg * k as f64 / 10.0).collect();
    let mut c = FieldCurves {
        field_deg: field_deg.clone(),
        distortion_percent: Vec::new(),
        lateral_colour_um: Vec::new(),
        relative_illumination: Vec::new(),
        rms_spot_um: Vec::new(),
    };
    for &deg in &field_deg {
        let rad = deg.to_radians();
        c.distortion_percent.push(if deg == 0.0 {
            Some(0.0)
        } else {
            p.distortion_percent(rad, wavelength_nm).map_err(optics)?
        });
        c.lateral_colour_um.push(
            p.lateral_colour(rad, LAMBDA_F_NM, LAMBDA_C_NM, wavelength_nm)
                .map_err(optics)?
                .map(|v| 1000.0 * v),
        );
        c.relative_illumination.push(
            p.relative_illumination(rad, wavelength_nm, 33)
                .map_err(optics)?,
        );
        c.rms_spot_um.push(
            p.rms_spot(rad, wavelength_nm, 33)
                .map_err(optics)?
                .map(|v| 1000.0 * v),
        );
    }
    Ok(c)
}

/// A ray of a `--trace` file.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RayInput {
    /// Start point in the first vertex's frame, mm (`z` along the axis, towards the image).
    pub origin: [f64; 3],
    /// Direction (any length but zero).
    pub direction: [f64; 3],
    /// Wavelength in air, nm (default the d line, 587.56 nm).
    #[serde(default = "d_line")]
    pub wavelength_nm: f64,
}

fn d_line() -> f64 {
    LAMBDA_D_NM
}

/// Where a ray ended.
#[derive(Debug, Clone, Serialize)]
pub struct RayOutcome {
    /// The wavelength, nm.
    pub wavelength_nm: f64,
    /// Where it meets the paraxial image plane (the rear focal plane at the report's
    /// wavelength), mm in the first vertex's frame; `None` when lost.
    pub image: Option<[f64; 3]>,
    /// Its unit direction there.
    pub direction: Option<[f64; 3]>,
    /// The surface (counted from 1; surfaces + 1 is the image plane) that lost it.
    pub lost_at_surface: Option<usize>,
    /// Why it was lost: `missed`, `vignetted`, `total internal reflection`, `no intersection`.
    pub lost_because: Option<&'static str>,
}

/// Traces `rays` through `lens` to its paraxial image plane at `wavelength_nm` (the rear
/// focal plane: the last thickness replaced by the back focal length).
pub fn trace_rays(
    lens: &LensFile,
    rays: &[RayInput],
    wavelength_nm: f64,
) -> Result<Vec<RayOutcome>, Error> {
    let optics = |source| Error::Optics {
        option: "--trace",
        source,
    };
    let p = lens.prescription()?;
    let bfl = p.paraxial(wavelength_nm).map_err(optics)?.bfl;
    rays.iter()
        .enumerate()
        .map(|(k, r)| {
            let ray = Ray {
                origin: r.origin,
                direction: r.direction,
                wavelength_nm: r.wavelength_nm,
            };
            let traced = p
                .trace_to_plane(&ray, bfl)
                .map_err(|source| Error::Message(format!("ray {}: {source}", k + 1)))?;
            Ok(match traced {
                Traced::Image { point, direction } => RayOutcome {
                    wavelength_nm: r.wavelength_nm,
                    image: Some(point),
                    direction: Some(direction),
                    lost_at_surface: None,
                    lost_because: None,
                },
                Traced::Lost { surface, loss } => RayOutcome {
                    wavelength_nm: r.wavelength_nm,
                    image: None,
                    direction: None,
                    lost_at_surface: Some(surface + 1),
                    lost_because: Some(match loss {
                        Loss::Missed => "missed",
                        Loss::Vignetted => "vignetted",
                        Loss::TotalInternalReflection => "total internal reflection",
                        Loss::NoIntersection => "no intersection",
                    }),
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use optics_core::prescription::glass::Medium;

    const SINGLET: &str = r#"
version = 1
name = "Biconvex singlet"
source = "a test"

[[surface]]
radius = 50.0
thickness = 5.0
semi_diameter = 10.0
glass = "N-BK7"
stop = true

[[surface]]
radius = -50.0
thickness = 47.0
semi_diameter = 10.0
"#;

    #[test]
    fn a_lens_file_reads_and_reports() {
        let lens = LensFile::from_toml(SINGLET).unwrap();
        assert_eq!(lens.surfaces.len(), 2);
        let r = LensReport::of(&lens, LAMBDA_D_NM).unwrap();
        assert!(r.efl_mm > 48.0 && r.efl_mm < 50.0);
        assert_eq!(r.stop_surface, 1);
        assert!(r.to_table().contains("effective focal length"));
    }

    #[test]
    fn bad_lens_files_name_the_surface_and_key() {
        let bad = SINGLET.replace("glass = \"N-BK7\"", "glass = \"N-BK8\"");
        let e = LensFile::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("surface 1: glass") && e.contains("N-BK7"), "{e}");
        let bad = SINGLET.replace("stop = true", "");
        let e = LensFile::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("no aperture stop"), "{e}");
        let bad = SINGLET.replace("thickness = 5.0", "thickness = -5.0");
        let e = LensFile::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("surface 0") || e.contains("thickness"), "{e}");
        let bad = SINGLET.replace("radius = -50.0", "radius = -50.0\nwobble = 1");
        assert!(LensFile::from_toml(&bad).is_err());
        let bad = SINGLET.replace("glass = \"N-BK7\"", "nd = 1.5");
        let e = LensFile::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("nd and vd"), "{e}");
        let bad = SINGLET.replace("version = 1", "version = 9");
        assert!(LensFile::from_toml(&bad).is_err());
    }

    #[test]
    fn pbrt_files_read_with_a_stated_abbe_number() {
        let dat = "# radius thickness index aperture\n50 5 1.5168 20\n-50 2 1 20\n0 45 0 16\n";
        let lens = LensFile::from_pbrt(dat, 64.17).unwrap();
        assert_eq!(lens.surfaces.len(), 3);
        assert!(lens.surfaces[2].is_stop);
        assert_eq!(
            lens.surfaces[0].medium,
            Medium::Model {
                nd: 1.5168,
                vd: 64.17
            }
        );
        assert!(LensFile::from_pbrt("50 5 1.5\n", 50.0).is_err());
    }

    #[test]
    fn traced_rays_say_where_they_land_or_why_not() {
        let lens = LensFile::from_toml(SINGLET).unwrap();
        let rays = [
            RayInput {
                origin: [0.001, 0.0, -1.0],
                direction: [0.0, 0.0, 1.0],
                wavelength_nm: LAMBDA_D_NM,
            },
            RayInput {
                origin: [11.0, 0.0, -1.0],
                direction: [0.0, 0.0, 1.0],
                wavelength_nm: LAMBDA_D_NM,
            },
        ];
        let out = trace_rays(&lens, &rays, LAMBDA_D_NM).unwrap();
        assert!(out[0].image.unwrap()[0].abs() < 1e-6);
        assert_eq!(out[1].lost_at_surface, Some(1));
        assert_eq!(out[1].lost_because, Some("vignetted"));
    }
}
