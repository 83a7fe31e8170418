//! Scene files in TOML, read with serde; every error names the file, the line and the field.
//! `scenes/README.md` (and the built-in scenes in `host-tracer/scenes/`) show the format.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde::Deserialize;
use toml::Spanned;

use super::geometry::{cube, quad, Shape, Sphere, Triangle};
use super::lens_camera::CameraLens;
use super::scene::{ApertureDesc, CameraDesc, Colour, SceneDesc, SensorSize, ShapeDesc};
use crate::error::{Error, Result};
use crate::lens_file::{LensFile, DEFAULT_PBRT_ABBE};
use crate::spectra::{bands_from_grid, bands_from_samples, xyz_weights};
use crate::spectra::{Table, COLORCHECKER, ILLUMINANTS};

/// The built-in scenes, by name: the Cornell box of Mitsuba 3 and the demo scene.
pub const BUILT_IN: [(&str, &str); 2] = [
    ("cornell-box", include_str!("../../scenes/cornell-box.toml")),
    ("demo", include_str!("../../scenes/demo.toml")),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    film: Option<Spanned<FilmSpec>>,
    camera: Spanned<CameraSpec>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialSpec>>,
    #[serde(default)]
    shape: Vec<Spanned<ShapeSpec>>,
    #[serde(default)]
    environment: Option<Spanned<EmissionSpec>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilmSpec {
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    max_depth: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSpec {
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov_deg: Option<f32>,
    focal_length_mm: Option<f32>,
    sensor_width_mm: Option<f32>,
    f_number: Option<f32>,
    aperture_radius_mm: Option<f32>,
    focus_distance: Option<f32>,
    units_per_mm: Option<f32>,
    aperture: Option<ApertureSpec>,
    shutter: Option<[f32; 2]>,
    end_position: Option<[f32; 3]>,
    end_target: Option<[f32; 3]>,
    chromatic_aberration: Option<f32>,
    distortion: Option<Vec<f64>>,
    lens: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ApertureSpec {
    shape: String,
    blades: Option<u32>,
    rotation_deg: Option<f32>,
    png: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpectrumSpec {
    wavelengths_nm: Vec<f64>,
    values: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSpec {
    rgb: Option<[f32; 3]>,
    colorchecker: Option<String>,
    spectrum: Option<SpectrumSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EmissionSpec {
    rgb: Option<[f32; 3]>,
    illuminant: Option<String>,
    luminance: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeSpec {
    #[serde(rename = "type")]
    kind: String,
    name: Option<String>,
    material: Option<String>,
    emission: Option<EmissionSpec>,
    motion: Option<[f32; 3]>,
    // sphere
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    // quad
    corners: Option<[[f32; 3]; 4]>,
    // box
    min: Option<[f32; 3]>,
    max: Option<[f32; 3]>,
    to_world: Option<[[f32; 4]; 4]>,
    // mesh
    obj: Option<PathBuf>,
    scale: Option<f32>,
    translate: Option<[f32; 3]>,
    rotate_y_deg: Option<f32>,
}

/// Where errors point: the file's name and text.
struct Source<'a> {
    name: &'a str,
    text: &'a str,
}

impl Source<'_> {
    fn line(&self, offset: usize) -> usize {
        1 + self.text[..offset.min(self.text.len())]
            .matches('\n')
            .count()
    }

    fn error(
        &self,
        span: std::ops::Range<usize>,
        field: &str,
        what: impl std::fmt::Display,
    ) -> Error {
        Error::Scene {
            file: self.name.to_owned(),
            line: Some(self.line(span.start)),
            field: field.to_owned(),
            problem: what.to_string(),
        }
    }
}

/// Reads a scene: a built-in name ([`BUILT_IN`]) or a TOML file.
pub fn load(name_or_path: &str) -> Result<SceneDesc> {
    if let Some((name, text)) = BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
        return parse(text, &format!("<built-in {name}>"), Path::new("."));
    }
    let path = Path::new(name_or_path);
    let text = std::fs::read_to_string(path).map_err(|source| {
        let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
        Error::Io {
            path: path.to_owned(),
            source,
            hint: Some(format!(
                "a scene is a TOML file or one of the built-in scenes: {}",
                names.join(", ")
            )),
        }
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse(&text, name_or_path, dir)
}

fn finite3(v: [f32; 3]) -> Option<Vec3> {
    let v = Vec3::from(v);
    v.is_finite().then_some(v)
}

/// Parses scene TOML `text` named `name` (for messages); relative paths resolve against `dir`.
pub fn parse(text: &str, name: &str, dir: &Path) -> Result<SceneDesc> {
    let src = Source { name, text };
    let file: SceneFile = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| src.line(s.start));
        let message = e.message().trim().to_string();
        let problem = match line {
            Some(l) => {
                let shown = text.lines().nth(l - 1).unwrap_or("").trim();
                format!("{message} (at `{shown}`)")
            }
            None => message,
        };
        Error::Scene {
            file: name.to_owned(),
            line,
            field: String::new(),
            problem,
        }
    })?;
    let weights = xyz_weights();
    let scene_name = match name
        .strip_prefix("<built-in ")
        .and_then(|n| n.strip_suffix('>'))
    {
        Some(built_in) => built_in,
        None => {
            let stem = name.rsplit(['/', '\\']).next().unwrap_or(name);
            stem.strip_suffix(".toml").unwrap_or(stem)
        }
    };

    // Materials.
    let patches = Table::parse(COLORCHECKER)?;
    let mut materials = Vec::new();
    for (key, spec) in &file.materials {
        let field = format!("materials.{key}");
        let err = |what: String| src.error(spec.span(), &field, what);
        let m = spec.get_ref();
        let given = [
            m.rgb.is_some(),
            m.colorchecker.is_some(),
            m.spectrum.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(err(
                "give exactly one of rgb, colorchecker or spectrum".into()
            ));
        }
        let colour = if let Some(rgb) = m.rgb {
            if !rgb.iter().all(|v| (0.0..=1.0).contains(v)) {
                return Err(err(format!(
                    "rgb reflectance must be in [0, 1] (got {rgb:?})"
                )));
            }
            Colour::Rgb(rgb)
        } else if let Some(patch) = &m.colorchecker {
            let column = patches
                .names()
                .iter()
                .position(|n| n.eq_ignore_ascii_case(patch))
                .and_then(|i| patches.column_at(i))
                .ok_or_else(|| {
                    err(format!(
                        "unknown ColorChecker patch {patch:?}; patches: {}",
                        patches.names().join(", ")
                    ))
                })?;
            Colour::Bands(Box::new(bands_from_grid(column)))
        } else {
            let s = m.spectrum.as_ref().expect("one of the three is given");
            let ok = s.wavelengths_nm.len() == s.values.len()
                && !s.values.is_empty()
                && s.wavelengths_nm.windows(2).all(|w| w[0] < w[1])
                && s.wavelengths_nm.iter().all(|w| w.is_finite())
                && s.values.iter().all(|v| (0.0..=1.0).contains(v));
            if !ok {
                return Err(err(
                    "spectrum: wavelengths_nm must increase, with one value in [0, 1] for each"
                        .into(),
                ));
            }
            Colour::Bands(Box::new(bands_from_samples(&s.wavelengths_nm, &s.values)))
        };
        materials.push((key.clone(), colour));
    }

    let emission =
        |spec: &EmissionSpec, span: std::ops::Range<usize>, field: &str| -> Result<Colour> {
            let err = |what: String| src.error(span.clone(), field, what);
            match (spec.rgb, &spec.illuminant) {
                (Some(rgb), None) => {
                    if spec.luminance.is_some() {
                        return Err(err(
                            "luminance goes with illuminant; rgb is the radiance itself".into(),
                        ));
                    }
                    if !rgb.iter().all(|v| v.is_finite() && *v >= 0.0) {
                        return Err(err(format!(
                            "rgb radiance must be finite and >= 0 (got {rgb:?})"
                        )));
                    }
                    Ok(Colour::Rgb(rgb))
                }
                (None, Some(name)) => {
                    let table = Table::parse(ILLUMINANTS)?;
                    let column = table.column(name).ok_or_else(|| {
                        err(format!(
                            "unknown illuminant {name:?}; illuminants: {}",
                            table.names().join(", ")
                        ))
                    })?;
                    let luminance = spec.luminance.unwrap_or(1.0);
                    if !(luminance.is_finite() && luminance >= 0.0) {
                        return Err(err(format!(
                            "luminance must be finite and >= 0 (got {luminance})"
                        )));
                    }
                    let bands = bands_from_grid(column);
                    let y: f32 = bands.iter().zip(&weights).map(|(v, w)| v * w[1]).sum();
                    let k = if y > 0.0 { luminance / y } else { 0.0 };
                    Ok(Colour::Bands(Box::new(bands.map(|v| v * k))))
                }
                _ => Err(err(
                    "give either rgb or illuminant (with an optional luminance)".into(),
                )),
            }
        };

    let environment = match &file.environment {
        Some(e) => Some(emission(e.get_ref(), e.span(), "environment")?),
        None => None,
    };

    // Shapes.
    let mut shapes = Vec::new();
    for (i, spanned) in file.shape.iter().enumerate() {
        let s = spanned.get_ref();
        let label = format!("shape[{i}] ({})", s.name.as_deref().unwrap_or(&s.kind));
        let err = |field: &str, what: String| {
            src.error(spanned.span(), &format!("{label}: {field}"), what)
        };
        let unused = |allowed: &[&str]| -> Result<()> {
            let present = [
                ("center", s.center.is_some()),
                ("radius", s.radius.is_some()),
                ("corners", s.corners.is_some()),
                ("min", s.min.is_some()),
                ("max", s.max.is_some()),
                ("to_world", s.to_world.is_some()),
                ("obj", s.obj.is_some()),
                ("scale", s.scale.is_some()),
                ("translate", s.translate.is_some()),
                ("rotate_y_deg", s.rotate_y_deg.is_some()),
            ];
            match present.iter().find(|(k, p)| *p && !allowed.contains(k)) {
                Some((k, _)) => Err(err(
                    k,
                    format!(
                        "not a field of a {}; its fields: {}",
                        s.kind,
                        allowed.join(", ")
                    ),
                )),
                None => Ok(()),
            }
        };
        let geometry: Vec<Shape> = match s.kind.as_str() {
            "sphere" => {
                unused(&["center", "radius"])?;
                let centre = s
                    .center
                    .and_then(finite3)
                    .ok_or_else(|| err("center", "expected [x, y, z]".into()))?;
                let radius = s
                    .radius
                    .filter(|r| r.is_finite() && *r > 0.0)
                    .ok_or_else(|| err("radius", "expected a number > 0".into()))?;
                vec![Shape::Sphere(Sphere { centre, radius })]
            }
            "quad" => {
                unused(&["corners"])?;
                let c = s.corners.ok_or_else(|| {
                    err(
                        "corners",
                        "expected four [x, y, z] corners in order around the quad".into(),
                    )
                })?;
                let corners = c.map(Vec3::from);
                if !corners.iter().all(|c| c.is_finite()) {
                    return Err(err("corners", "must be finite".into()));
                }
                let shapes = quad(corners);
                if shapes.is_empty() {
                    return Err(err("corners", "the quad is degenerate (zero area)".into()));
                }
                shapes
            }
            "box" => {
                unused(&["min", "max", "to_world"])?;
                let m = match (s.min, s.max, s.to_world) {
                    (Some(lo), Some(hi), None) => {
                        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
                        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
                            return Err(err(
                                "min/max",
                                "min must be below max on every axis".into(),
                            ));
                        }
                        Mat4::from_translation((lo + hi) / 2.0) * Mat4::from_scale((hi - lo) / 2.0)
                    }
                    (None, None, Some(rows)) => {
                        let m = Mat4::from_cols_array_2d(&rows).transpose();
                        if !m.is_finite() || m.determinant() <= 0.0 || m.row(3) != glam::Vec4::W {
                            return Err(err("to_world", "expected a finite affine 4x4 matrix (rows) with a positive determinant".into()));
                        }
                        m
                    }
                    _ => {
                        return Err(err(
                            "min/max/to_world",
                            "give min and max, or to_world".into(),
                        ))
                    }
                };
                cube(&m)
            }
            "mesh" => {
                unused(&["obj", "scale", "translate", "rotate_y_deg"])?;
                let obj = s
                    .obj
                    .as_ref()
                    .ok_or_else(|| err("obj", "expected the path of an OBJ file".into()))?;
                let scale = s.scale.unwrap_or(1.0);
                let translate = Vec3::from(s.translate.unwrap_or([0.0; 3]));
                let angle = s.rotate_y_deg.unwrap_or(0.0).to_radians();
                if !(scale.is_finite() && scale > 0.0 && translate.is_finite() && angle.is_finite())
                {
                    return Err(err(
                        "scale/translate/rotate_y_deg",
                        "scale must be > 0; all finite".into(),
                    ));
                }
                let m = Mat4::from_translation(translate)
                    * Mat4::from_rotation_y(angle)
                    * Mat4::from_scale(Vec3::splat(scale));
                load_obj(&dir.join(obj), &m, |what| err("obj", what))?
            }
            other => {
                return Err(err(
                    "type",
                    format!("unknown shape type {other:?}; types: sphere, quad, box, mesh"),
                ));
            }
        };
        let material = match &s.material {
            Some(m) => materials.iter().position(|(n, _)| n == m).ok_or_else(|| {
                let names: Vec<&str> = materials.iter().map(|(n, _)| n.as_str()).collect();
                err(
                    "material",
                    format!("unknown material {m:?}; materials: {}", names.join(", ")),
                )
            })?,
            None if s.emission.is_some() => {
                // A light with no material of its own reflects nothing.
                if let Some(k) = materials.iter().position(|(n, _)| n == "<black>") {
                    k
                } else {
                    materials.push(("<black>".into(), Colour::Rgb([0.0; 3])));
                    materials.len() - 1
                }
            }
            None => {
                return Err(err(
                    "material",
                    "missing (only emitters may leave it out)".into(),
                ))
            }
        };
        let emission = match &s.emission {
            Some(e) => Some(emission(e, spanned.span(), &format!("{label}: emission"))?),
            None => None,
        };
        let motion = match s.motion {
            Some(m) => {
                finite3(m).ok_or_else(|| err("motion", "expected a finite [dx, dy, dz]".into()))?
            }
            None => Vec3::ZERO,
        };
        shapes.push(ShapeDesc {
            name: s.name.clone().unwrap_or_else(|| format!("{}-{i}", s.kind)),
            geometry,
            material,
            emission,
            motion,
        });
    }

    let camera = camera(&file.camera, &src, dir)?;
    let film = file.film.as_ref();
    let f = film.map(|f| f.get_ref());
    let film_err = |what: String| src.error(film.map_or(0..0, |f| f.span()), "film", what);
    let width = f.and_then(|f| f.width).unwrap_or(256);
    let height = f.and_then(|f| f.height).unwrap_or(256);
    let spp = f.and_then(|f| f.spp).unwrap_or(64);
    let max_depth = f.and_then(|f| f.max_depth).unwrap_or(8);
    if !(1..=super::render::MAX_SIDE).contains(&width)
        || !(1..=super::render::MAX_SIDE).contains(&height)
    {
        return Err(film_err(format!(
            "width and height must be in 1..={}",
            super::render::MAX_SIDE
        )));
    }
    if !(1..=super::render::MAX_SPP).contains(&spp) || !(1..=1024).contains(&max_depth) {
        return Err(film_err(format!(
            "spp must be in 1..={} and max_depth in 1..=1024",
            super::render::MAX_SPP
        )));
    }
    // The scene illuminant: the environment's named illuminant, else the first light's.
    let illuminant = file
        .environment
        .as_ref()
        .and_then(|e| e.get_ref().illuminant.clone())
        .or_else(|| {
            file.shape
                .iter()
                .find_map(|s| s.get_ref().emission.as_ref()?.illuminant.clone())
        });
    let desc = SceneDesc {
        name: scene_name.to_string(),
        materials,
        shapes,
        environment,
        camera,
        film: (width, height),
        spp,
        max_depth,
        illuminant,
    };
    // The camera must build (focus beyond the focal length, valid aperture and so on).
    let mut table = super::scene::MaskTable::default();
    desc.camera
        .rig(width, height, false, &mut table)
        .map_err(|e| match e {
            Error::Optics { part, source } => {
                src.error(file.camera.span(), "camera", format!("{part}: {source}"))
            }
            e => e,
        })?;
    Ok(desc)
}

fn camera(spanned: &Spanned<CameraSpec>, src: &Source<'_>, dir: &Path) -> Result<CameraDesc> {
    let c = spanned.get_ref();
    let err =
        |field: &str, what: String| src.error(spanned.span(), &format!("camera: {field}"), what);
    let point = |v: [f32; 3], field: &str| {
        finite3(v).ok_or_else(|| err(field, "expected a finite [x, y, z]".into()))
    };
    let positive = |v: Option<f32>, field: &str| -> Result<Option<f32>> {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => {
                Err(err(field, format!("must be > 0 (got {x})")))
            }
            v => Ok(v),
        }
    };
    let lens = match &c.lens {
        None => None,
        Some(path) => {
            let refuse = |field: &str| {
                Err(err(
                    field,
                    "a camera with a lens file takes its focal length, distortion and colour \
                     from the lens: give f_number, not this"
                        .into(),
                ))
            };
            if c.focal_length_mm.is_some() {
                return refuse("focal_length_mm");
            }
            if c.aperture_radius_mm.is_some() {
                return refuse("aperture_radius_mm");
            }
            if c.distortion.is_some() {
                return refuse("distortion");
            }
            if c.chromatic_aberration.is_some_and(|v| v != 0.0) {
                return refuse("chromatic_aberration");
            }
            if c.aperture.as_ref().is_some_and(|a| a.shape != "disk") {
                return refuse("aperture");
            }
            let file = LensFile::read(&dir.join(path), DEFAULT_PBRT_ABBE)
                .map_err(|e| err("lens", e.to_string()))?;
            let lens = CameraLens {
                file,
                f_number: positive(c.f_number, "f_number")?.map(f64::from),
            };
            let (efl, design_n) = lens.design().map_err(|e| err("lens", e.to_string()))?;
            Some((lens, efl, design_n))
        }
    };
    let focal_length_mm = match &lens {
        Some((_, efl, _)) => *efl as f32,
        None => positive(c.focal_length_mm, "focal_length_mm")?.unwrap_or(50.0),
    };
    let sensor = match (c.fov_deg, positive(c.sensor_width_mm, "sensor_width_mm")?) {
        (Some(fov), None) if fov > 0.0 && fov < 180.0 => SensorSize::Fov(fov.to_radians()),
        (Some(fov), None) => {
            return Err(err("fov_deg", format!("must be in (0, 180) (got {fov})")))
        }
        (None, w) => SensorSize::WidthMm(w.unwrap_or(36.0)),
        (Some(_), Some(_)) => {
            return Err(err(
                "fov_deg",
                "give fov_deg or sensor_width_mm, not both".into(),
            ))
        }
    };
    let aperture_radius_mm = match (positive(c.f_number, "f_number")?, c.aperture_radius_mm) {
        (n, _) if lens.is_some() => {
            let design_n = lens.as_ref().map_or(1.0, |l| l.2) as f32;
            focal_length_mm / (2.0 * n.unwrap_or(design_n))
        }
        (Some(n), None) => focal_length_mm / (2.0 * n),
        (None, Some(r)) if r.is_finite() && r >= 0.0 => r,
        (None, Some(r)) => {
            return Err(err("aperture_radius_mm", format!("must be >= 0 (got {r})")))
        }
        (None, None) => 0.0,
        (Some(_), Some(_)) => {
            return Err(err(
                "f_number",
                "give f_number or aperture_radius_mm, not both".into(),
            ))
        }
    };
    let aperture = match &c.aperture {
        None => ApertureDesc::Disk,
        Some(a) => match a.shape.as_str() {
            "disk" => ApertureDesc::Disk,
            "heart" => ApertureDesc::Heart,
            "polygon" => ApertureDesc::Polygon {
                blades: a.blades.filter(|b| (3..=64).contains(b)).ok_or_else(|| {
                    err(
                        "aperture.blades",
                        "expected a whole number in 3..=64".into(),
                    )
                })?,
                rotation: a.rotation_deg.unwrap_or(0.0).to_radians(),
            },
            "mask" => {
                let png = a.png.as_ref().ok_or_else(|| {
                    err(
                        "aperture.png",
                        "a mask aperture needs png = \"file.png\"".into(),
                    )
                })?;
                let image = raw_formats::image::read(&dir.join(png))
                    .map_err(|e| err("aperture.png", e.to_string()))?;
                let shift = image.bits.saturating_sub(8);
                let cells = image
                    .data
                    .chunks_exact(image.channels)
                    .map(|p| (p[0] >> shift) as u8)
                    .collect();
                ApertureDesc::Mask {
                    width: image.width,
                    height: image.height,
                    cells,
                }
            }
            other => {
                return Err(err(
                    "aperture.shape",
                    format!("unknown shape {other:?}; shapes: disk, polygon, heart, mask"),
                ))
            }
        },
    };
    let shutter = c.shutter.unwrap_or([0.0, 1.0]);
    if !(shutter[0].is_finite() && shutter[1].is_finite() && shutter[0] <= shutter[1]) {
        return Err(err(
            "shutter",
            format!("expected [open, close] with open <= close (got {shutter:?})"),
        ));
    }
    let position = point(c.position, "position")?;
    let end = match (c.end_position, c.end_target) {
        (None, None) => None,
        (p, t) => Some((
            point(p.unwrap_or(c.position), "end_position")?,
            point(t.unwrap_or(c.target), "end_target")?,
        )),
    };
    let distortion = match &c.distortion {
        None => None,
        Some(d) if (d.len() == 4 || d.len() == 5) && d.iter().all(|v| v.is_finite()) => {
            Some([d[0], d[1], d[2], d[3], d.get(4).copied().unwrap_or(0.0)])
        }
        Some(_) => {
            return Err(err(
                "distortion",
                "expected [k1, k2, p1, p2] or [k1, k2, p1, p2, k3], finite".into(),
            ))
        }
    };
    let chromatic_aberration = c.chromatic_aberration.unwrap_or(0.0);
    if !chromatic_aberration.is_finite() {
        return Err(err("chromatic_aberration", "must be finite".into()));
    }
    Ok(CameraDesc {
        position,
        target: point(c.target, "target")?,
        up: point(c.up.unwrap_or([0.0, 1.0, 0.0]), "up")?,
        focal_length_mm,
        sensor,
        aperture_radius_mm,
        focus_distance: positive(c.focus_distance, "focus_distance")?,
        units_per_mm: positive(c.units_per_mm, "units_per_mm")?.unwrap_or(0.001),
        aperture,
        shutter: (shutter[0], shutter[1]),
        end,
        chromatic_aberration,
        distortion,
        lens: lens.map(|l| l.0),
    })
}

/// The triangles of an OBJ file; `fail` turns a problem into the scene file's error.
fn load_obj(path: &Path, to_world: &Mat4, fail: impl Fn(String) -> Error) -> Result<Vec<Shape>> {
    let (models, _) = tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS)
        .map_err(|e| fail(format!("{}: {e}", path.display())))?;
    let mut out = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let vertex = |i: u32| -> Option<Vec3> {
            let k = 3 * i as usize;
            m.positions
                .get(k..k + 3)
                .map(|p| to_world.transform_point3(Vec3::new(p[0], p[1], p[2])))
        };
        for tri in m.indices.chunks_exact(3) {
            match (vertex(tri[0]), vertex(tri[1]), vertex(tri[2])) {
                (Some(a), Some(b), Some(c)) => {
                    out.extend(Triangle::new(a, b, c).map(Shape::Triangle))
                }
                _ => {
                    return Err(fail(format!(
                        "{}: a face refers to a vertex that is not there",
                        path.display()
                    )))
                }
            }
        }
    }
    if out.is_empty() {
        return Err(fail(format!("{}: no triangles", path.display())));
    }
    Ok(out)
}
