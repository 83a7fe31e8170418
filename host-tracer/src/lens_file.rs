//! Lens files: a prescription for optics-core's [`optics_core::prescription`], in TOML (the
//! format below) or pbrt's four-column `.dat`. Read here, beside the scene files that name
//! them (`[camera] lens = "..."`); `camsim lens` reports on them.
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

use optics_core::prescription::glass::{catalogue_glass, Medium};
use optics_core::prescription::{Prescription, Shape, Surface, ASPHERE_TERMS};
use serde::Deserialize;

use crate::error::{Error, Result};

/// The lens file format's version.
pub const LENS_FILE_VERSION: u32 = 1;

/// The Abbe number a pbrt `.dat` file's single indices get when nobody says (a crown's).
pub const DEFAULT_PBRT_ABBE: f64 = 50.0;

/// A lens read from a file: its name, source and surfaces.
#[derive(Debug, Clone, PartialEq)]
pub struct LensFile {
    /// The lens's name.
    pub name: String,
    /// Where the prescription comes from.
    pub source: String,
    /// The surfaces, object side first.
    pub surfaces: Vec<Surface<f64>>,
    /// The design's half field of view, degrees (object at infinity), if the file gives it:
    /// the field the report's curves span.
    pub field_deg: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    version: u32,
    name: String,
    #[serde(default)]
    source: String,
    field_deg: Option<f64>,
    surface: Vec<SurfaceToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SellmeierToml {
    b: [f64; 3],
    c: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceToml {
    radius: Option<toml::Value>,
    curvature: Option<f64>,
    thickness: f64,
    semi_diameter: f64,
    glass: Option<String>,
    nd: Option<f64>,
    vd: Option<f64>,
    index: Option<f64>,
    sellmeier: Option<SellmeierToml>,
    #[serde(default)]
    stop: bool,
    conic: Option<f64>,
    aspheric: Option<Vec<f64>>,
}

fn surface_error(i: usize, key: &str, problem: impl std::fmt::Display) -> Error {
    Error::lens(format!("surface {}: {key}: {problem}", i + 1))
}

impl SurfaceToml {
    fn medium(&self, i: usize) -> Result<Medium<f64>> {
        let given = [
            self.glass.is_some(),
            self.nd.is_some() || self.vd.is_some(),
            self.index.is_some(),
            self.sellmeier.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() > 1 {
            return Err(surface_error(
                i,
                "glass",
                "give one of glass, nd + vd, index or sellmeier",
            ));
        }
        let medium = if let Some(name) = &self.glass {
            if name.eq_ignore_ascii_case("air") {
                Medium::Air
            } else {
                catalogue_glass(name)
                    .map_err(|_| {
                        surface_error(
                            i,
                            "glass",
                            format!(
                                "{name:?} is not in the catalogue ({})",
                                optics_core::prescription::catalogue::CATALOGUE
                                    .iter()
                                    .map(|g| g.name)
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        )
                    })?
                    .medium()
            }
        } else if self.nd.is_some() || self.vd.is_some() {
            match (self.nd, self.vd) {
                (Some(nd), Some(vd)) => Medium::Model { nd, vd },
                _ => return Err(surface_error(i, "nd", "a model glass needs both nd and vd")),
            }
        } else if let Some(n) = self.index {
            Medium::Constant { n }
        } else if let Some(s) = &self.sellmeier {
            Medium::Sellmeier { b: s.b, c_um2: s.c }
        } else {
            Medium::Air
        };
        medium
            .validate()
            .map_err(|e| surface_error(i, "glass", e))?;
        Ok(medium)
    }

    fn shape(&self, i: usize) -> Result<Shape<f64>> {
        let curvature = match (&self.radius, self.curvature) {
            (Some(_), Some(_)) => {
                return Err(surface_error(
                    i,
                    "radius",
                    "give radius or curvature, not both",
                ))
            }
            (None, Some(c)) => c,
            (None, None) => 0.0,
            (Some(toml::Value::String(s)), None) if s.eq_ignore_ascii_case("inf") => 0.0,
            (Some(v), None) => {
                let r = v
                    .as_float()
                    .or_else(|| v.as_integer().map(|n| n as f64))
                    .ok_or_else(|| {
                        surface_error(i, "radius", "a number of millimetres or \"inf\"")
                    })?;
                if r == 0.0 || r.is_infinite() {
                    0.0
                } else {
                    1.0 / r
                }
            }
        };
        if !curvature.is_finite() {
            return Err(surface_error(i, "radius", "finite"));
        }
        match (&self.aspheric, self.conic) {
            (None, None) if curvature == 0.0 => Ok(Shape::Flat),
            (None, None) => Ok(Shape::Sphere { curvature }),
            (terms, conic) => {
                let terms = terms.as_deref().unwrap_or(&[]);
                if terms.len() > ASPHERE_TERMS {
                    return Err(surface_error(
                        i,
                        "aspheric",
                        format!("at most {ASPHERE_TERMS} coefficients (A4 to A16)"),
                    ));
                }
                let mut coefficients = [0.0; ASPHERE_TERMS];
                coefficients[..terms.len()].copy_from_slice(terms);
                Ok(Shape::EvenAsphere {
                    curvature,
                    conic: conic.unwrap_or(0.0),
                    coefficients,
                })
            }
        }
    }
}

impl LensFile {
    /// Reads a lens file: `.dat` as pbrt's format (single indices as model glasses of Abbe
    /// number `pbrt_abbe`), anything else as the TOML format.
    pub fn read(path: &Path, pbrt_abbe: f64) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
            hint: None,
        })?;
        let lens = if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("dat"))
        {
            Self::from_pbrt(&text, pbrt_abbe)
        } else {
            Self::from_toml(&text)
        };
        lens.map_err(|e| e.in_lens_file(path))
    }

    /// Parses the TOML format.
    pub fn from_toml(text: &str) -> Result<Self> {
        let file: FileToml =
            toml::from_str(text).map_err(|e| Error::lens(format!("lens file: {e}")))?;
        if file.version != LENS_FILE_VERSION {
            return Err(Error::lens(format!(
                "lens file version {} (this camsim reads version {LENS_FILE_VERSION})",
                file.version
            )));
        }
        let surfaces = file
            .surface
            .iter()
            .enumerate()
            .map(|(i, s)| {
                Ok(Surface {
                    shape: s.shape(i)?,
                    semi_diameter: s.semi_diameter,
                    thickness: s.thickness,
                    medium: s.medium(i)?,
                    is_stop: s.stop,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        if let Some(f) = file.field_deg {
            if !(f > 0.0 && f < 85.0) {
                return Err(Error::lens(format!(
                    "field_deg: the half field of view must be above 0 and below 85 degrees (got {f})"
                )));
            }
        }
        let lens = LensFile {
            name: file.name,
            source: file.source,
            surfaces,
            field_deg: file.field_deg,
        };
        lens.prescription()?;
        Ok(lens)
    }

    /// Parses pbrt's lens format: one surface per line, `radius thickness index aperture`
    /// (mm; radius 0 is the stop, aperture a diameter; index 0 or 1 is air), `#` comments.
    /// pbrt has one index per element: each becomes a model glass of Abbe number `abbe`.
    pub fn from_pbrt(text: &str, abbe: f64) -> Result<Self> {
        let mut surfaces = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|t| t.parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| Error::lens(format!("line {}: four numbers expected", n + 1)))?;
            let [radius, thickness, index, aperture] = v[..] else {
                return Err(Error::lens(format!(
                    "line {}: four numbers expected (radius thickness index aperture), got {}",
                    n + 1,
                    v.len()
                )));
            };
            let stop = radius == 0.0;
            let medium = if index == 0.0 || index == 1.0 {
                Medium::Air
            } else {
                Medium::Model {
                    nd: index,
                    vd: abbe,
                }
            };
            surfaces.push(Surface {
                shape: Shape::sphere_radius(radius),
                semi_diameter: aperture / 2.0,
                thickness,
                medium,
                is_stop: stop,
            });
        }
        let lens = LensFile {
            name: "pbrt lens".into(),
            source: format!(
                "pbrt lens file; single indices as model glasses of Abbe number {abbe}"
            ),
            surfaces,
            field_deg: None,
        };
        lens.prescription()?;
        Ok(lens)
    }

    /// The checked prescription.
    pub fn prescription(&self) -> Result<Prescription<'_, f64>> {
        Prescription::new(&self.surfaces).map_err(|source| Error::lens(source.to_string()))
    }
}
