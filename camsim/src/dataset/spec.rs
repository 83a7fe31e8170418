//! The dataset spec: a TOML file of fixed values, choices and ranges, read into [`Spec`] and
//! checked whole before any sample renders (a typo found after an hour of rendering costs the
//! hour).

use std::path::{Path, PathBuf};

use host_tracer::random::Rng;
use toml::{Table, Value};

use crate::error::Error;

/// The scene generators a spec may name besides built-in scenes and scene files.
pub const GENERATORS: [&str; 5] = [
    "colorchecker",
    "slanted-edge",
    "checkerboard",
    "primitives",
    "textured-plane",
];

/// One parameter: a fixed value, a choice among values, or a range.
#[derive(Debug, Clone, PartialEq)]
pub enum Draw {
    /// Always this number.
    Number(f64),
    /// Always this text.
    Text(String),
    /// One of these, each as likely.
    Choice(Vec<Value>),
    /// Uniform in `[min, max]`, or log-uniform (`log = true`, `min > 0`).
    Range {
        /// Least value.
        min: f64,
        /// Largest value.
        max: f64,
        /// Uniform in the logarithm.
        log: bool,
    },
}

/// What a parameter's values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Number,
    Text,
}

impl Draw {
    fn parse(field: &str, value: &Value, kind: Kind) -> Result<Self, Error> {
        let bad = |why: &str| spec_error(field, why);
        let draw = match value {
            Value::Integer(i) => Draw::Number(*i as f64),
            Value::Float(f) => Draw::Number(*f),
            Value::String(s) => Draw::Text(s.clone()),
            Value::Array(items) => {
                if items.is_empty() {
                    return Err(bad("a choice needs at least one value"));
                }
                Draw::Choice(items.clone())
            }
            Value::Table(t) => {
                let number = |key: &str| {
                    match t.get(key) {
                    Some(Value::Integer(i)) => Ok(*i as f64),
                    Some(Value::Float(f)) => Ok(*f),
                    _ => Err(bad("a range is { min = a, max = b } (numbers), with log = true for a log-uniform one")),
                }
                };
                for key in t.keys() {
                    if !["min", "max", "log"].contains(&key.as_str()) {
                        return Err(bad(&format!(
                            "unknown key {key:?} in a range (min, max, log)"
                        )));
                    }
                }
                let (min, max) = (number("min")?, number("max")?);
                let log = match t.get("log") {
                    None => false,
                    Some(Value::Boolean(b)) => *b,
                    Some(_) => return Err(bad("log is true or false")),
                };
                if !(min.is_finite() && max.is_finite() && min <= max) {
                    return Err(bad("a range needs finite min <= max"));
                }
                if log && min <= 0.0 {
                    return Err(bad("a log-uniform range needs min > 0"));
                }
                Draw::Range { min, max, log }
            }
            _ => {
                return Err(bad(
                    "give a number, a text, a list to choose from, or { min, max }",
                ))
            }
        };
        // Every value the draw can give has the parameter's kind.
        let ok = match (&draw, kind) {
            (Draw::Number(v), Kind::Number) => v.is_finite(),
            (Draw::Range { .. }, Kind::Number) => true,
            (Draw::Text(_), Kind::Text) => true,
            (Draw::Choice(items), Kind::Number) => items.iter().all(|v| match v {
                Value::Integer(_) => true,
                Value::Float(f) => f.is_finite(),
                _ => false,
            }),
            (Draw::Choice(items), Kind::Text) => items.iter().all(Value::is_str),
            _ => false,
        };
        if !ok {
            return Err(bad(match kind {
                Kind::Number => "takes finite numbers: a number, a list of numbers or { min, max }",
                Kind::Text => "takes names: a name or a list of names",
            }));
        }
        Ok(draw)
    }

    /// The texts this draw can give (empty for a numeric draw).
    fn texts(&self) -> Vec<&str> {
        match self {
            Draw::Text(s) => vec![s.as_str()],
            Draw::Choice(items) => items.iter().filter_map(Value::as_str).collect(),
            _ => vec![],
        }
    }

    /// The numbers a choice or fixed draw can give, and a range's ends.
    fn numbers(&self) -> Vec<f64> {
        match self {
            Draw::Number(v) => vec![*v],
            Draw::Range { min, max, .. } => vec![*min, *max],
            Draw::Choice(items) => items.iter().filter_map(number_of).collect(),
            Draw::Text(_) => vec![],
        }
    }

    /// A number drawn with `rng` (a numeric draw: checked when the spec was read).
    pub fn number(&self, rng: &mut Rng) -> f64 {
        match self {
            Draw::Number(v) => *v,
            Draw::Range { min, max, log } => {
                let u = uniform(rng);
                if *log {
                    (min.ln() + u * (max.ln() - min.ln())).exp()
                } else {
                    min + u * (max - min)
                }
            }
            Draw::Choice(items) => number_of(&items[pick(rng, items.len())]).unwrap_or(0.0),
            Draw::Text(_) => 0.0,
        }
    }

    /// A text drawn with `rng` (a text draw: checked when the spec was read).
    pub fn text(&self, rng: &mut Rng) -> String {
        match self {
            Draw::Text(s) => s.clone(),
            Draw::Choice(items) => items[pick(rng, items.len())]
                .as_str()
                .unwrap_or_default()
                .to_owned(),
            _ => String::new(),
        }
    }
}

fn number_of(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

/// Uniform in `[0, 1)` with 53 bits.
pub(crate) fn uniform(rng: &mut Rng) -> f64 {
    let hi = u64::from(rng.next_u32()) << 21;
    let lo = u64::from(rng.next_u32() >> 11);
    (hi | lo) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// An index in `0..n` (`n >= 1`), without modulo bias worth the name (64 bits into `n`).
pub(crate) fn pick(rng: &mut Rng, n: usize) -> usize {
    ((uniform(rng) * n as f64) as usize).min(n - 1)
}

fn spec_error(field: &str, why: &str) -> Error {
    Error::Message(format!("dataset spec: {field}: {why}"))
}

/// The whole spec, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// The file's text as read (copied into the dataset's folder as `spec.toml`).
    pub text: String,
    /// The folder relative paths in it are relative to.
    pub dir: PathBuf,
    /// The dataset's seed.
    pub seed: u64,
    /// Samples in the dataset (indices `0..count`).
    pub count: u64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel of the render.
    pub spp: u32,
    /// Longest path; `None`: the scene's.
    pub max_depth: Option<u32>,
    /// Also develop each raw with the ISP into `srgb.png`.
    pub isp: bool,
    /// A tuning file from `camsim tune` (`dataset.tuning`, relative to the spec, or `camsim
    /// dataset --tuning`): every sample is calibrated, white-balanced and developed with it
    /// and its `raw.dng` carries it, as `camsim demo --tuning` does.
    pub tuning: Option<PathBuf>,
    /// Which scene each sample shows: generator names, built-in scene names, scene files.
    pub scene: Draw,
    /// Image folder of the textured-plane generator.
    pub images: Option<PathBuf>,
    /// The textured plane's cells across its longer side.
    pub texture_cells: u32,
    /// Objects in the primitives generator's scenes.
    pub objects: Draw,
    /// Distance from the camera to the generated scenes' subject, metres.
    pub subject_distance_m: Option<Draw>,
    /// Named draws of the `[camera]` and `[sensor]` tables (absent: the default each states).
    pub params: Vec<(&'static str, Draw)>,
}

/// The `[camera]` parameters: lens and motion (applied to built-in scenes only when given).
pub const CAMERA_KEYS: [(&str, &str); 7] = [
    ("focal_length_mm", "focal length, mm [generated scenes: 50]"),
    ("f_number", "f-number; 0 is a pinhole [generated scenes: 8]"),
    (
        "focus_ratio",
        "focus distance over the subject's distance [1]",
    ),
    ("motion_blur_px", "camera pan over the shutter, pixels [0]"),
    (
        "aperture",
        "disk, heart, triangle, square, pentagon, hexagon or octagon [disk]",
    ),
    ("chromatic_aberration", "three-aperture strength, 0 off [0]"),
    (
        "distortion_k1",
        "Brown-Conrady k1 (barrel < 0 < pincushion) [0]",
    ),
];

/// The `[sensor]` parameters.
pub const SENSOR_KEYS: [(&str, &str); 9] = [
    ("camera", "spectral response: nikon-5100, canon-eos-5d-mark-ii, sigma-sdmerill or cie1931 [nikon-5100]"),
    ("illuminant", "A, D50, D65, FL2, FL11 or LED-B3 [D65]"),
    ("iso", "ISO, 100 the base [100]"),
    ("exposure_s", "exposure time, s [metered]"),
    ("noise", "realistic or ideal [realistic]"),
    ("shading", "lens shading's strength, 1 the realistic sensor's, 0 off [1]"),
    ("defects_per_million", "defective pixels per million (hot:dead:stuck 10:5:2) [170]"),
    ("pattern", "CFA pattern: RGGB, BGGR, GRBG or GBRG [RGGB]"),
    ("bits", "ADC bits, 8..=16 [12]"),
];

const TEXT_KEYS: [&str; 6] = [
    "aperture",
    "camera",
    "illuminant",
    "noise",
    "pattern",
    "generators",
];

impl Spec {
    /// Reads and checks the spec file at `path`.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text =
            std::fs::read_to_string(path).map_err(|e| raw_formats::FormatError::io(path, e))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::parse(&text, &dir)
    }

    /// Checks the spec `text`, whose relative paths are relative to `dir`.
    pub fn parse(text: &str, dir: &Path) -> Result<Self, Error> {
        let root: Table = text
            .parse()
            .map_err(|e: toml::de::Error| spec_error("TOML", e.message().trim()))?;
        for key in root.keys() {
            if !["dataset", "scene", "camera", "sensor"].contains(&key.as_str()) {
                return Err(spec_error(
                    key,
                    "unknown table (dataset, scene, camera, sensor)",
                ));
            }
        }
        let section = |name: &str, keys: &[&str]| -> Result<Table, Error> {
            let table = match root.get(name) {
                None => Table::new(),
                Some(Value::Table(t)) => t.clone(),
                Some(_) => return Err(spec_error(name, "must be a table")),
            };
            for key in table.keys() {
                if !keys.contains(&key.as_str()) {
                    return Err(spec_error(
                        &format!("{name}.{key}"),
                        &format!("unknown key; {name} takes {}", keys.join(", ")),
                    ));
                }
            }
            Ok(table)
        };
        let dataset = section(
            "dataset",
            &[
                "seed",
                "count",
                "width",
                "height",
                "spp",
                "max_depth",
                "isp",
                "tuning",
            ],
        )?;
        let integer = |key: &str, lo: i64, hi: i64, default: Option<i64>| -> Result<i64, Error> {
            let field = format!("dataset.{key}");
            match (dataset.get(key), default) {
                (Some(Value::Integer(v)), _) if (lo..=hi).contains(v) => Ok(*v),
                (None, Some(d)) => Ok(d),
                (None, None) => Err(spec_error(&field, "is required")),
                _ => Err(spec_error(&field, &format!("an integer in {lo}..={hi}"))),
            }
        };
        let seed = integer("seed", 0, i64::MAX, None)? as u64;
        let count = integer("count", 1, 1 << 40, None)? as u64;
        let width = integer("width", 2, 16384, None)? as u32;
        let height = integer("height", 2, 16384, None)? as u32;
        let spp = integer("spp", 1, 1 << 20, None)? as u32;
        let max_depth = match dataset.get("max_depth") {
            None => None,
            Some(_) => Some(integer("max_depth", 1, 1024, None)? as u32),
        };
        let isp = match dataset.get("isp") {
            None => false,
            Some(Value::Boolean(b)) => *b,
            Some(_) => return Err(spec_error("dataset.isp", "true or false")),
        };

        let tuning = match dataset.get("tuning") {
            None => None,
            Some(Value::String(s)) => Some(dir.join(s)),
            Some(_) => {
                return Err(spec_error(
                    "dataset.tuning",
                    "a tuning file from camsim tune (relative to the spec)",
                ))
            }
        };

        let scene = section(
            "scene",
            &[
                "generators",
                "images",
                "texture_cells",
                "objects",
                "subject_distance_m",
            ],
        )?;
        let generators = match scene.get("generators") {
            Some(v) => Draw::parse("scene.generators", v, Kind::Text)?,
            None => Draw::Text("colorchecker".into()),
        };
        let images = match scene.get("images") {
            None => None,
            Some(Value::String(s)) => Some(dir.join(s)),
            Some(_) => return Err(spec_error("scene.images", "a folder of PNG images")),
        };
        for name in generators.texts() {
            let known = GENERATORS.contains(&name)
                || host_tracer::tracer::scene_file::BUILT_IN
                    .iter()
                    .any(|(n, _)| *n == name);
            if !known && !dir.join(name).is_file() {
                return Err(spec_error(
                    "scene.generators",
                    &format!(
                        "{name:?} is neither a generator ({}), a built-in scene ({}) nor a scene file",
                        GENERATORS.join(", "),
                        host_tracer::tracer::scene_file::BUILT_IN
                            .iter()
                            .map(|(n, _)| *n)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
            if name == "textured-plane" {
                let Some(folder) = &images else {
                    return Err(spec_error(
                        "scene.images",
                        "the textured-plane generator needs a folder of images",
                    ));
                };
                if super::scenes::image_files(folder)?.is_empty() {
                    return Err(spec_error(
                        "scene.images",
                        &format!("no .png in {}", folder.display()),
                    ));
                }
            }
        }
        let texture_cells = match scene.get("texture_cells") {
            None => 160,
            Some(Value::Integer(v)) if (8..=1024).contains(v) => *v as u32,
            Some(_) => return Err(spec_error("scene.texture_cells", "an integer in 8..=1024")),
        };
        let objects = match scene.get("objects") {
            None => Draw::Range {
                min: 4.0,
                max: 16.0,
                log: false,
            },
            Some(v) => Draw::parse("scene.objects", v, Kind::Number)?,
        };
        if objects
            .numbers()
            .iter()
            .any(|n| !(1.0..=1000.0).contains(n))
        {
            return Err(spec_error("scene.objects", "between 1 and 1000"));
        }
        let subject_distance_m = scene
            .get("subject_distance_m")
            .map(|v| Draw::parse("scene.subject_distance_m", v, Kind::Number))
            .transpose()?;
        if let Some(d) = &subject_distance_m {
            if d.numbers().iter().any(|n| !(0.05..=100.0).contains(n)) {
                return Err(spec_error("scene.subject_distance_m", "in [0.05, 100] m"));
            }
        }

        let mut params = Vec::new();
        for (table, keys) in [("camera", &CAMERA_KEYS[..]), ("sensor", &SENSOR_KEYS[..])] {
            let names: Vec<&str> = keys.iter().map(|(k, _)| *k).collect();
            let t = section(table, &names)?;
            for (key, _) in keys {
                let Some(v) = t.get(*key) else { continue };
                let field = format!("{table}.{key}");
                let kind = if TEXT_KEYS.contains(key) {
                    Kind::Text
                } else {
                    Kind::Number
                };
                let draw = Draw::parse(&field, v, kind)?;
                check_values(&field, key, &draw)?;
                params.push((*key, draw));
            }
        }
        let mut spec = Spec {
            text: text.to_owned(),
            dir: dir.to_path_buf(),
            seed,
            count,
            width,
            height,
            spp,
            max_depth,
            isp,
            tuning: None,
            scene: generators,
            images,
            texture_cells,
            objects,
            subject_distance_m,
            params,
        };
        if let Some(path) = tuning {
            spec.set_tuning(&path)?;
        }
        Ok(spec)
    }

    /// Develops every sample with the tuning file at `path`, after checking that it reads
    /// and that its camera mode (size, CFA pattern, bit depth) is the one every sample draws.
    pub fn set_tuning(&mut self, path: &Path) -> Result<(), Error> {
        let tuning = crate::tune::Tuning::read(path)?;
        let mode = |what: &str, spec: String| {
            Err(spec_error(
                "dataset.tuning",
                &format!(
                    "{} is a tuning of {}x{} {} {}-bit, but the spec's samples have {what} {spec}",
                    path.display(),
                    tuning.width,
                    tuning.height,
                    tuning.pattern,
                    tuning.bits
                ),
            ))
        };
        if (tuning.width, tuning.height) != (self.width as usize, self.height as usize) {
            return mode("size", format!("{}x{}", self.width, self.height));
        }
        let patterns = self.param("pattern").map_or(vec!["RGGB".to_owned()], |d| {
            d.texts().iter().map(|t| t.to_ascii_uppercase()).collect()
        });
        if patterns.iter().any(|p| *p != tuning.pattern) {
            return mode("CFA pattern", patterns.join(" or "));
        }
        let bits = self.param("bits").map_or(vec![12.0], |d| d.numbers());
        if bits.iter().any(|b| *b != f64::from(tuning.bits)) {
            return mode("bit depth", format!("{bits:?}"));
        }
        self.tuning = Some(path.to_path_buf());
        Ok(())
    }

    /// The draw for `key` of `[camera]` or `[sensor]`, if the spec gives it.
    pub fn param(&self, key: &str) -> Option<&Draw> {
        self.params.iter().find(|(k, _)| *k == key).map(|(_, d)| d)
    }
}

/// Checks every value a draw can give against what the parameter allows.
fn check_values(field: &str, key: &str, draw: &Draw) -> Result<(), Error> {
    let names_ok = |allowed: &[&str]| -> Result<(), Error> {
        for t in draw.texts() {
            if !allowed.iter().any(|a| a.eq_ignore_ascii_case(t)) {
                return Err(spec_error(
                    field,
                    &format!("{t:?} is not one of {}", allowed.join(", ")),
                ));
            }
        }
        Ok(())
    };
    let range_ok = |lo: f64, hi: f64, what: &str| -> Result<(), Error> {
        if draw.numbers().iter().any(|v| !(lo..=hi).contains(v)) {
            return Err(spec_error(field, what));
        }
        Ok(())
    };
    match key {
        "camera" => names_ok(&host_tracer::sensor::camera_names()),
        "illuminant" => {
            let table = host_tracer::spectra::Table::parse(host_tracer::spectra::ILLUMINANTS)
                .map_err(Error::Simulation)?;
            let names: Vec<&str> = table.names().iter().map(String::as_str).collect();
            names_ok(&names)
        }
        "noise" => names_ok(&["realistic", "ideal"]),
        "pattern" => names_ok(&["RGGB", "BGGR", "GRBG", "GBRG"]),
        "aperture" => names_ok(&super::scenes::APERTURES.map(|(n, _)| n)),
        "bits" => {
            range_ok(8.0, 16.0, "ADC bits in 8..=16")?;
            if draw.numbers().iter().any(|v| v.fract() != 0.0) || matches!(draw, Draw::Range { .. })
            {
                return Err(spec_error(field, "whole numbers: a number or a list"));
            }
            Ok(())
        }
        "iso" => range_ok(1.0, 1e6, "ISO in [1, 1e6]"),
        "exposure_s" => range_ok(1e-6, 3600.0, "exposure in [1e-6, 3600] s"),
        "focal_length_mm" => range_ok(1.0, 2000.0, "focal length in [1, 2000] mm"),
        "f_number" => {
            range_ok(0.0, 1000.0, "f-number in [0.5, 1000], or 0 for a pinhole")?;
            if draw.numbers().iter().any(|v| *v > 0.0 && *v < 0.5) {
                return Err(spec_error(
                    field,
                    "f-number in [0.5, 1000], or 0 for a pinhole",
                ));
            }
            Ok(())
        }
        "focus_ratio" => range_ok(0.05, 100.0, "a ratio in [0.05, 100]"),
        "motion_blur_px" => range_ok(0.0, 10000.0, "pixels in [0, 10000]"),
        "chromatic_aberration" => range_ok(0.0, 10.0, "strength in [0, 10]"),
        "distortion_k1" => range_ok(-1.0, 1.0, "k1 in [-1, 1]"),
        "shading" => range_ok(0.0, 4.0, "strength in [0, 4]"),
        "defects_per_million" => range_ok(0.0, 100000.0, "in [0, 100000] per million"),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn draw(text: &str, kind: Kind) -> Result<Draw, Error> {
        let value: Table = format!("v = {text}").parse().unwrap();
        Draw::parse("test.v", &value["v"], kind)
    }

    #[test]
    fn ranges_stay_inside_and_choices_are_equally_likely() {
        let mut rng = Rng::new(1, 2);
        let log = draw("{ min = 100, max = 6400, log = true }", Kind::Number).unwrap();
        let values: Vec<f64> = (0..4000).map(|_| log.number(&mut rng)).collect();
        assert!(values.iter().all(|v| (100.0..=6400.0).contains(v)));
        // Log-uniform: half the draws below the geometric mean, 800.
        let below = values.iter().filter(|v| **v < 800.0).count();
        assert!((1800..2200).contains(&below), "{below}");
        let choice = draw("[\"a\", \"b\", \"c\"]", Kind::Text).unwrap();
        let mut counts = [0; 3];
        for _ in 0..3000 {
            counts[(choice.text(&mut rng).as_bytes()[0] - b'a') as usize] += 1;
        }
        assert!(counts.iter().all(|c| (900..1100).contains(c)), "{counts:?}");
        assert_eq!(draw("12", Kind::Number).unwrap().number(&mut rng), 12.0);
    }

    #[test]
    fn draws_of_the_wrong_kind_or_shape_are_refused() {
        for (text, kind, message) in [
            ("\"D65\"", Kind::Number, "takes finite numbers"),
            ("[1, \"a\"]", Kind::Number, "takes finite numbers"),
            ("3", Kind::Text, "takes names"),
            ("[]", Kind::Text, "at least one value"),
            ("{ min = 2, max = 1 }", Kind::Number, "min <= max"),
            ("{ min = 0, max = 1, log = true }", Kind::Number, "min > 0"),
            (
                "{ min = 0, maximum = 1 }",
                Kind::Number,
                "unknown key \"maximum\"",
            ),
        ] {
            let e = draw(text, kind).unwrap_err().to_string();
            assert!(
                e.starts_with("dataset spec: test.v: ") && e.contains(message),
                "{text}: {e}"
            );
        }
    }
}
