//! Raw files: `read_raw` (a DNG, or a PNG/PGM mosaic) into a [`RawFile`] whose samples numpy
//! sees without a copy, and `write_dng`.

use std::path::PathBuf;

use camsim::develop::RawInput;
use numpy::ndarray::{ArrayViewD, IxDyn};
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use raw_formats::dng::{
    ColourCalibration, Crop, Dng, DngColour, Framing, Illuminant, Orientation, Processing,
};
use raw_formats::RawImage;

use crate::errors;

/// A raw frame read from a file: the frame and what the file says beyond its samples.
#[pyclass(frozen, module = "camsim._camsim")]
pub struct RawFile {
    /// The frame ready to develop (its samples are what `raw_image` shows).
    pub(crate) input: RawInput,
    /// The file, for messages.
    path: PathBuf,
    /// The DNG's tags beyond the frame, for `metadata` and for writing the frame again.
    dng: Option<DngRest>,
}

/// A DNG's tags beyond the frame.
struct DngRest {
    camera_model: String,
    colour: DngColour,
    processing: Processing,
}

fn matrix(m: &[[f64; 3]; 3]) -> Vec<Vec<f64>> {
    m.iter().map(|r| r.to_vec()).collect()
}

#[pymethods]
impl RawFile {
    /// The samples as a read-only numpy array, (height, width) for a mosaic, (height,
    /// width, 3) for a linear frame; a view of this object's memory, no copy.
    #[getter]
    fn raw_image<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArrayDyn<u16>>> {
        let raw = &slf.get().input.raw;
        let spp = usize::from(raw.samples_per_pixel);
        let shape: Vec<usize> = if spp == 1 {
            vec![raw.height, raw.width]
        } else {
            vec![raw.height, raw.width, spp]
        };
        let view = ArrayViewD::from_shape(IxDyn(&shape), &raw.samples)
            .map_err(|e| errors::option(format!("raw samples: {e}")))?;
        // SAFETY: the samples live as long as this object, which the array keeps alive as
        // its base, and are never written (the array is made read-only below).
        let array = unsafe { PyArrayDyn::borrow_from_array(&view, slf.clone().into_any()) };
        array.getattr("flags")?.setattr("writeable", false)?;
        Ok(array)
    }

    /// Everything the file states beyond the samples, as a dict of plain values (the Python
    /// `Raw` class turns it into attributes).
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let raw = &self.input.raw;
        let linear = raw.is_linear();
        d.set_item("path", self.path.to_string_lossy())?;
        d.set_item("width", raw.width)?;
        d.set_item("height", raw.height)?;
        d.set_item("samples_per_pixel", raw.samples_per_pixel)?;
        d.set_item("pattern", (!linear).then(|| raw.pattern.name()))?;
        d.set_item("bits", raw.bits)?;
        d.set_item("black_level", raw.black_level.to_vec())?;
        d.set_item("white_level", raw.white_level)?;
        d.set_item("baseline_exposure", self.input.baseline_exposure)?;
        d.set_item(
            "noise_profile",
            self.input.noise_profile.map(|p| {
                let (s, o) = (p.scale(), p.offset());
                (0..3)
                    .map(|c| vec![f64::from(s[c]), f64::from(o[c])])
                    .collect::<Vec<_>>()
            }),
        )?;
        d.set_item("orientation", self.input.framing.orientation.to_tiff())?;
        d.set_item(
            "default_crop",
            self.input
                .framing
                .default_crop
                .map(|c| (c.left, c.top, c.width, c.height)),
        )?;
        d.set_item(
            "defects",
            self.input
                .defaults
                .defects
                .as_ref()
                .map(|list| list.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>()),
        )?;
        let opcodes = PyList::empty(py);
        for (name, optional) in &self.input.opcodes_not_applied {
            opcodes.append((*name, *optional))?;
        }
        d.set_item("opcodes_not_applied", opcodes)?;
        if let Some(rest) = &self.dng {
            d.set_item("camera_model", &rest.camera_model)?;
            d.set_item(
                "as_shot_neutral",
                rest.colour.as_shot_neutral.map(|n| n.to_vec()),
            )?;
            d.set_item(
                "as_shot_white_xy",
                rest.colour.as_shot_white_xy.map(|n| n.to_vec()),
            )?;
            d.set_item(
                "analog_balance",
                rest.colour.analog_balance.map(|n| n.to_vec()),
            )?;
            let calibrations = PyList::empty(py);
            for c in &rest.colour.calibrations {
                let entry = PyDict::new(py);
                entry.set_item("illuminant", illuminant_name(c.illuminant))?;
                entry.set_item("illuminant_code", c.illuminant.code())?;
                entry.set_item("color_matrix", matrix(&c.color_matrix))?;
                entry.set_item("forward_matrix", c.forward_matrix.as_ref().map(matrix))?;
                entry.set_item(
                    "camera_calibration",
                    c.camera_calibration.as_ref().map(matrix),
                )?;
                calibrations.append(entry)?;
            }
            d.set_item("calibrations", calibrations)?;
        }
        Ok(d)
    }
}

/// The name the command line uses for an illuminant, or its EXIF code as text.
fn illuminant_name(i: Illuminant) -> String {
    match i {
        Illuminant::A => "A".into(),
        Illuminant::D50 => "D50".into(),
        Illuminant::D55 => "D55".into(),
        Illuminant::D65 => "D65".into(),
        Illuminant::D75 => "D75".into(),
        Illuminant::Other(code) => format!("EXIF {code}"),
    }
}

/// Reads a DNG, or a single-channel 8- or 16-bit PNG/PGM mosaic, with the GIL released.
#[pyfunction]
fn read_raw(py: Python<'_>, path: PathBuf) -> PyResult<RawFile> {
    let is_dng = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("dng"));
    py.detach(|| {
        if !is_dng {
            let input = RawInput::read(&path).map_err(errors::format)?;
            return Ok(RawFile {
                input,
                path,
                dng: None,
            });
        }
        let dng = Dng::read(&path).map_err(errors::format)?;
        let rest = DngRest {
            camera_model: dng.camera_model.clone(),
            colour: dng.colour.clone(),
            processing: dng.processing.clone(),
        };
        let input = RawInput::from_dng(dng, &path).map_err(errors::format)?;
        Ok(RawFile {
            input,
            path,
            dng: Some(rest),
        })
    })
}

/// The samples of an array as a row-major `Vec<u16>` with its width and height: a (height,
/// width) mosaic, or (height, width, 3) linear RGB when `linear_ok`.
pub(crate) fn samples(
    array: &PyReadonlyArrayDyn<'_, u16>,
    what: &str,
    linear_ok: bool,
) -> PyResult<(Vec<u16>, usize, usize, u8)> {
    let shape = array.shape().to_vec();
    let spp = match shape.as_slice() {
        [_, _] => 1,
        [_, _, 3] if linear_ok => 3,
        _ => {
            return Err(errors::option(format!(
                "{what} must be a (height, width) uint16 mosaic{} (got shape {shape:?})",
                if linear_ok {
                    " or (height, width, 3) linear RGB"
                } else {
                    ""
                }
            )))
        }
    };
    let data = match array.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => array.as_array().iter().copied().collect(),
    };
    Ok((data, shape[1], shape[0], spp))
}

/// A 3x3 matrix from nested lists.
fn mat3(rows: Vec<Vec<f64>>, what: &str) -> PyResult<[[f64; 3]; 3]> {
    if rows.len() != 3
        || rows
            .iter()
            .any(|r| r.len() != 3 || r.iter().any(|v| !v.is_finite()))
    {
        return Err(errors::option(format!(
            "{what} must be a 3x3 matrix of finite numbers"
        )));
    }
    Ok(std::array::from_fn(|i| std::array::from_fn(|j| rows[i][j])))
}

/// One calibration as `write_dng` takes it: (illuminant name or EXIF code, ColorMatrix,
/// ForwardMatrix or None, CameraCalibration or None), matrices as nested lists.
type CalibrationArgs = (
    String,
    Vec<Vec<f64>>,
    Option<Vec<Vec<f64>>>,
    Option<Vec<Vec<f64>>>,
);

/// Writes a DNG as `camsim demo` does: the frame, its levels and pattern, and the colour,
/// framing and noise tags given. `calibrations` is a list of (illuminant name or EXIF code,
/// ColorMatrix, ForwardMatrix or None, CameraCalibration or None).
#[pyfunction]
#[pyo3(signature = (path, samples, pattern, bits, black_level, white_level, camera_model,
    as_shot_neutral, calibrations, analog_balance, noise_profile, baseline_exposure,
    orientation, default_crop, source = None))]
#[allow(clippy::too_many_arguments)]
fn write_dng(
    py: Python<'_>,
    path: PathBuf,
    samples: PyReadonlyArrayDyn<'_, u16>,
    pattern: &str,
    bits: u8,
    black_level: Vec<u16>,
    white_level: u16,
    camera_model: String,
    as_shot_neutral: Option<[f64; 3]>,
    calibrations: Vec<CalibrationArgs>,
    analog_balance: Option<[f64; 3]>,
    noise_profile: Option<Vec<f64>>,
    baseline_exposure: Option<f64>,
    orientation: u32,
    default_crop: Option<(usize, usize, usize, usize)>,
    source: Option<Bound<'_, RawFile>>,
) -> PyResult<()> {
    let (data, width, height, spp) = self::samples(&samples, "samples", true)?;
    let pattern = camsim::isp_options::pattern(pattern, "pattern")
        .map_err(|e| errors::option(e.to_string()))?;
    let black: [u16; 4] = match (black_level.as_slice(), spp) {
        ([b], _) => [*b; 4],
        ([r, g, b], 3) => [*r, *g, *b, *g],
        ([a, b, c, d], 1) => [*a, *b, *c, *d],
        _ => {
            return Err(errors::option(format!(
                "black_level must be one value, or four (per 2x2 CFA position) for a mosaic, three (R, G, B) for linear RGB (got {black_level:?})"
            )))
        }
    };
    let image = if spp == 1 {
        RawImage::new(width, height, pattern, bits, black, white_level, data)
    } else {
        RawImage::linear_rgb(
            width,
            height,
            bits,
            [black[0], black[1], black[2]],
            white_level,
            data,
        )
    }
    .map_err(errors::format)?;
    let mut colour = DngColour {
        as_shot_neutral,
        analog_balance,
        ..DngColour::default()
    };
    for (name, cm, fm, cc) in calibrations {
        let illuminant = match Illuminant::from_name(&name) {
            Some(i) => i,
            None => match name.strip_prefix("EXIF ").unwrap_or(&name).parse::<u16>() {
                Ok(code) => Illuminant::from_code(code),
                Err(_) => {
                    return Err(errors::option(format!(
                        "illuminant must be A, D50, D55, D65, D75 or an EXIF LightSource code (got {name:?})"
                    )))
                }
            },
        };
        colour.calibrations.push(ColourCalibration {
            illuminant,
            color_matrix: mat3(cm, "color_matrix")?,
            forward_matrix: fm.map(|m| mat3(m, "forward_matrix")).transpose()?,
            camera_calibration: cc.map(|m| mat3(m, "camera_calibration")).transpose()?,
        });
    }
    if colour.calibrations.len() > 2 {
        return Err(errors::option("a DNG holds at most two calibrations"));
    }
    let noise_profile = noise_profile
        .map(|v| {
            camsim::isp_options::noise_profile(v, "noise_profile")
                .map_err(|e| errors::option(e.to_string()))
        })
        .transpose()?;
    let orientation = Orientation::from_tiff(orientation).map_err(errors::format)?;
    let default_crop = default_crop.map(|(left, top, width, height)| Crop {
        left,
        top,
        width,
        height,
    });
    if let Some(c) = default_crop {
        c.check(width, height).map_err(errors::format)?;
    }
    // A frame read from a DNG keeps the file's opcodes and defect lists.
    let processing = match &source {
        Some(s) => s.get().dng.as_ref().map(|d| d.processing.clone()),
        None => None,
    }
    .unwrap_or_default();
    let dng = Dng {
        image,
        camera_model,
        colour,
        framing: Framing {
            default_crop,
            orientation,
        },
        processing: Processing {
            noise_profile,
            baseline_exposure,
            ..processing
        },
    };
    py.detach(|| dng.write(&path)).map_err(errors::format)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<RawFile>()?;
    m.add_function(wrap_pyfunction!(read_raw, m)?)?;
    m.add_function(wrap_pyfunction!(write_dng, m)?)?;
    Ok(())
}
