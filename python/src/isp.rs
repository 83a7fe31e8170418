//! The ISP on arrays: options from keyword arguments (checked by the command line's parsers,
//! so they refuse what `camsim isp` refuses with the same words), `develop` on a read file or
//! an array, whole-frame demosaicing, the white-balance estimators and the colour-matrix fit.

use camsim::develop::{
    frame_samples, framed_size, stage_names, with_prepared, IspReport, RawInput, RunOptions, Runner,
};
use camsim::isp_options::{self as options, IspOptions, ShadingGrid, WhiteBalance};
use isp_core::dpc::Defect;
use isp_core::frame::RawFrame;
use isp_core::pipeline::Input;
use numpy::ndarray::Array3;
use numpy::{
    IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raw_formats::RawImage;

use crate::errors;
use crate::raw::{samples, RawFile};

/// The options `develop` takes, by their Python names (the command line's flags with `_` for
/// `-`), in the order the documentation lists them.
const KEYS: [&str; 31] = [
    "pattern",
    "bits",
    "black_level",
    "white_level",
    "gain",
    "wb",
    "awb",
    "ccm",
    "calibration",
    "tuning",
    "demosaic",
    "denoise",
    "denoise_search",
    "chroma_denoise",
    "noise_profile",
    "highlight_knee",
    "sharpen",
    "dpc_threshold",
    "defects",
    "lsc",
    "look",
    "path",
    "out_bits",
    "linear",
    "distortion",
    "camera_matrix",
    "crop",
    "baseline_exposure",
    "threads",
    "stage_times",
    "out",
];

/// What `develop`'s keyword arguments resolve to.
#[derive(Default)]
struct Settings {
    options: IspOptions,
    calibration: Option<isp_core::ccm::Calibration>,
    threads: usize,
    linear: bool,
    stage_times: bool,
}

fn refuse(e: options::OptionError) -> PyErr {
    errors::option(e.to_string())
}

/// `key` as `T`, or an error naming the key and what it should be.
fn value<'a, 'py, T: FromPyObject<'a, 'py>>(
    v: &'a Bound<'py, PyAny>,
    key: &str,
    what: &str,
) -> PyResult<T> {
    v.extract::<T>()
        .map_err(|_| errors::option(format!("{key} must be {what}")))
}

/// Numbers from a scalar or any nested sequence (a numpy array included), flattened.
fn numbers(v: &Bound<'_, PyAny>, key: &str) -> PyResult<Vec<f64>> {
    if let Ok(x) = v.extract::<f64>() {
        return Ok(vec![x]);
    }
    let np = v.py().import("numpy")?;
    let flat = np
        .call_method1("asarray", (v,))
        .and_then(|a| a.call_method1("astype", ("float64",)))
        .and_then(|a| a.call_method0("ravel"))
        .map_err(|_| errors::option(format!("{key} must be numbers")))?;
    value::<Vec<f64>>(&flat.call_method0("tolist")?, key, "numbers")
}

fn settings(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Settings> {
    let mut s = Settings {
        threads: RunOptions::default().threads,
        ..Settings::default()
    };
    let Some(kwargs) = kwargs else {
        return Ok(s);
    };
    let o = &mut s.options;
    let mut awb = None;
    for (k, v) in kwargs.iter() {
        let key: String = k.extract()?;
        if v.is_none() {
            continue;
        }
        let k = key.as_str();
        match k {
            "pattern" => {
                o.pattern = Some(
                    options::pattern(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?,
                )
            }
            "bits" => o.bits = Some(value(&v, k, "a whole number in 8..=16")?),
            "black_level" => {
                o.black_level = Some(options::black_levels(numbers(&v, k)?, k).map_err(refuse)?)
            }
            "white_level" => o.white_level = Some(value(&v, k, "a whole number in 0..=65535")?),
            "gain" => o.gain = Some(value(&v, k, "a number")?),
            "wb" => {
                let g = options::count_of(numbers(&v, k)?, k, &[3]).map_err(refuse)?;
                o.white_balance =
                    Some(WhiteBalance::Gains([g[0] as f32, g[1] as f32, g[2] as f32]));
            }
            "awb" => {
                awb = Some(options::awb(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?)
            }
            "ccm" => o.ccm = Some(options::matrix(numbers(&v, k)?, k).map_err(refuse)?),
            "calibration" => {
                let path: std::path::PathBuf = value(&v, k, "the path of a calibration file")?;
                let file = raw_formats::calibration::CalibrationFile::read(&path)
                    .map_err(errors::format)?;
                s.calibration = Some(file.to_isp().map_err(errors::format)?);
            }
            "tuning" => {
                o.tuning = Some(value(&v, k, "the path of a tuning file from camsim tune")?)
            }
            "demosaic" => {
                o.demosaic = Some(
                    options::demosaic(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?,
                )
            }
            "denoise" => o.denoise = Some(value(&v, k, "a number")?),
            "denoise_search" => {
                o.denoise_search = Some(
                    options::denoise_search(&value::<String>(&v, k, "a string")?, k)
                        .map_err(refuse)?,
                )
            }
            "chroma_denoise" => o.chroma_denoise = Some(value(&v, k, "a number")?),
            "noise_profile" => {
                o.noise_profile = Some(options::noise_profile(numbers(&v, k)?, k).map_err(refuse)?)
            }
            "highlight_knee" => o.highlight_knee = Some(value(&v, k, "a number")?),
            "sharpen" => o.sharpen = Some(value(&v, k, "a number")?),
            "dpc_threshold" => o.dpc_threshold = Some(value(&v, k, "a whole number in 0..=65535")?),
            "defects" => {
                let pairs: Vec<(u16, u16)> = value(
                    &v,
                    k,
                    "a list of (x, y) pairs of whole numbers in 0..=65535",
                )?;
                let mut list: Vec<Defect> =
                    pairs.into_iter().map(|(x, y)| Defect { x, y }).collect();
                list.sort();
                list.dedup();
                o.defects = Some(list);
            }
            "lsc" => o.lsc = Some(shading(&v)?),
            "look" => {
                o.look =
                    Some(options::look(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?)
            }
            "path" => {
                o.fixed =
                    Some(options::path(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?)
            }
            "out_bits" => {
                o.out_bits = Some(options::out_bits(value(&v, k, "8 or 16")?, k).map_err(refuse)?)
            }
            "linear" => s.linear = value(&v, k, "True or False")?,
            "distortion" => {
                o.distortion = Some(options::distortion(numbers(&v, k)?, k).map_err(refuse)?)
            }
            "camera_matrix" => {
                o.camera_matrix = Some(options::camera_matrix(numbers(&v, k)?, k).map_err(refuse)?)
            }
            "crop" => {
                o.crop =
                    Some(options::crop(&value::<String>(&v, k, "a string")?, k).map_err(refuse)?)
            }
            "baseline_exposure" => o.baseline_exposure = Some(value(&v, k, "True or False")?),
            "threads" => {
                let t: usize = value(&v, k, "a whole number >= 1")?;
                if t == 0 {
                    return Err(errors::option(
                        "threads must be a whole number >= 1 (got 0)",
                    ));
                }
                s.threads = t;
            }
            "stage_times" => s.stage_times = value(&v, k, "True or False")?,
            // The caller's array: `develop_input` takes it.
            "out" => {}
            other => {
                return Err(errors::option(format!(
                    "unknown option {other:?}; known options: {}",
                    KEYS.join(", ")
                )))
            }
        }
    }
    if let Some(method) = awb {
        if s.options.white_balance.is_some() {
            return Err(errors::option("give wb or awb, not both"));
        }
        s.options.white_balance = Some(WhiteBalance::Auto(method));
    }
    if s.linear && s.options.fixed == Some(true) {
        return Err(errors::option(
            "linear output comes from the float path: give path=\"float\" (or leave it out)",
        ));
    }
    Ok(s)
}

/// A lens-shading grid: an array of (grid height, grid width, 4) gains, one per 2x2 CFA
/// position, each in [0, 16) (stored in Q4.12 as the config file's `[lsc]` table is).
fn shading(v: &Bound<'_, PyAny>) -> PyResult<ShadingGrid> {
    let np = v.py().import("numpy")?;
    let what = "lsc must be a (grid height, grid width, 4) array of gains in [0, 16)";
    let array = np
        .call_method1("asarray", (v,))
        .and_then(|a| a.call_method1("astype", ("float64",)))
        .map_err(|_| errors::option(what))?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    let max = isp_core::lsc::MAX_GRID_SIDE;
    let (height, width) = match shape.as_slice() {
        [h, w, 4] if (2..=max).contains(h) && (2..=max).contains(w) => (*h, *w),
        _ => {
            return Err(errors::option(format!(
                "{what}, each side in 2..={max} (got shape {shape:?})"
            )))
        }
    };
    let gains: Vec<f64> = array
        .call_method0("ravel")?
        .call_method0("tolist")?
        .extract()?;
    if !gains.iter().all(|g| (0.0..16.0).contains(g)) {
        return Err(errors::option(what));
    }
    Ok(ShadingGrid {
        width,
        height,
        gains_q12: gains
            .iter()
            .map(|g| (g * 4096.0).round().min(65535.0) as u16)
            .collect(),
    })
}

/// A developed image: its samples at the depth asked for.
enum Developed {
    U8(Vec<u8>),
    U16(Vec<u16>),
    F32(Vec<f32>),
    /// Written into the caller's array.
    InPlace,
}

/// Where the developed samples go: new memory, or the caller's C-contiguous array.
enum Target<'a> {
    New,
    U8(&'a mut [u8]),
    U16(&'a mut [u16]),
    F32(&'a mut [f32]),
}

/// What [`develop_into`] ran: the new samples (`None` when written into the caller's array),
/// the run's time in milliseconds, and what framing did.
type Ran<O> = (Option<Vec<O>>, f64, Option<String>);

/// Runs `runner` into `target` (or new memory), `finish` applied to every sample, then frames
/// the image: the new samples (`None` when written into `target`), the time of the run in
/// milliseconds and what framing did.
#[allow(clippy::too_many_arguments)]
fn develop_into<O: isp_core::pipeline::OutputSample + Default + Send + Copy>(
    runner: &mut Runner<'_>,
    target: Option<&mut [O]>,
    (w, h): (usize, usize),
    framing: &raw_formats::dng::Framing,
    crop: options::CropChoice,
    finish: fn(&mut [O]),
    out_shape: &[usize],
) -> Result<Ran<O>, camsim::Error> {
    let (fw, fh) = framed_size(w, h, framing, crop);
    let unframed =
        (fw, fh) == (w, h) && framing.orientation == raw_formats::dng::Orientation::Normal;
    match target {
        Some(t) if t.len() != 3 * fw * fh || out_shape != [fh, fw, 3] => {
            Err(camsim::Error::Message(format!(
                "out must have shape ({fh}, {fw}, 3) for this frame and these options (got {out_shape:?})"
            )))
        }
        Some(t) if unframed => {
            let ms = runner.best_ms(t, 1)?;
            finish(t);
            Ok((None, ms, None))
        }
        target => {
            let mut v = vec![O::default(); 3 * w * h];
            let ms = runner.best_ms(&mut v, 1)?;
            finish(&mut v);
            let (v, _, _, framed) = frame_samples(v, w, h, 3, framing, crop)?;
            match target {
                Some(t) => {
                    t.copy_from_slice(&v);
                    Ok((None, ms, framed))
                }
                None => Ok((Some(v), ms, framed)),
            }
        }
    }
}

/// Intervals of [`decode_all`]'s table over `[0, 1]`.
const DECODE_STEPS: usize = 4096;

/// The float path's encoded output as linear light: `isp_core::srgb::decode` sampled at 4097
/// points and interpolated linearly, within 8e-8 of the exact curve (a power per sample,
/// 90 ns, made a 12 MP frame's linear output 40 times slower than its 8-bit output).
fn decode_all(v: &mut [f32]) {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..=DECODE_STEPS)
            .map(|i| isp_core::srgb::decode(i as f32 / DECODE_STEPS as f32))
            .collect()
    });
    for x in v {
        let at = x.clamp(0.0, 1.0) * DECODE_STEPS as f32;
        let i = (at as usize).min(DECODE_STEPS - 1);
        let (a, b) = (table[i], table[i + 1]);
        *x = a + (at - i as f32) * (b - a);
    }
}

/// Develops `input` as `camsim isp` does, into an output of the asked depth (no conversion
/// between depths), new or the caller's: the samples, width, height and the report as JSON.
fn run(
    input: &RawInput,
    s: &Settings,
    target: Target<'_>,
    out_shape: &[usize],
) -> Result<(Developed, usize, usize, String), camsim::Error> {
    with_prepared(input, &s.options, s.calibration, |p| {
        let (w, h) = (p.input.width(), p.input.height());
        let linear_input = matches!(p.input, Input::Linear(_));
        let mut runner = Runner::new(&p.input, &p.config, p.fixed, p.out_bits, s.threads)?;
        let framing = &input.framing;
        let size = (w, h);
        let wrong = |asked: &str| {
            camsim::Error::Message(format!(
                "out must be an array of the output's dtype, {asked} for these options"
            ))
        };
        // One arm per output type: the caller's array must be of that type.
        macro_rules! into {
            ($variant:ident, $ty:ty, $name:literal, $finish:expr) => {{
                let t = match target {
                    Target::$variant(t) => Some(t),
                    Target::New => None,
                    _ => return Err(wrong($name)),
                };
                let (v, ms, f) =
                    develop_into::<$ty>(&mut runner, t, size, framing, p.crop, $finish, out_shape)?;
                (v.map_or(Developed::InPlace, Developed::$variant), ms, f)
            }};
        }
        let (out, total_ms, framed) = if s.linear {
            into!(F32, f32, "float32", decode_all)
        } else if p.out_bits == 8 {
            into!(U8, u8, "uint8", |_| {})
        } else {
            into!(U16, u16, "uint16", |_| {})
        };
        let (w2, h2) = framed_size(w, h, framing, p.crop);
        let stage_ms = if s.stage_times {
            camsim::develop::stage_times(&p.input, &p.config, p.fixed, 8, s.threads, 3)?
        } else {
            Vec::new()
        };
        let report = IspReport {
            stages: stage_names(&p.config, linear_input),
            awb: p.awb,
            wb_gains: p.config.wb_gains,
            distortion: p
                .config
                .distortion
                .filter(|d| !d.is_identity())
                .map(|d| (d, d.window_rows(w, h))),
            fixed: p.fixed,
            stage_ms,
            total_ms,
            threads: runner.threads(),
            framing: framed,
            baseline_exposure: p.baseline_ev,
            noise: p.noise.clone(),
        };
        let json = serde_json::to_string(&report.to_json()).unwrap_or_default();
        Ok((out, w2, h2, json))
    })
}

fn to_numpy<'py>(
    py: Python<'py>,
    out: Developed,
    w: usize,
    h: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let shape = (h, w, 3);
    let bad = |e: numpy::ndarray::ShapeError| errors::option(format!("output shape: {e}"));
    Ok(match out {
        Developed::U8(v) => Array3::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any(),
        Developed::U16(v) => Array3::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any(),
        Developed::F32(v) => Array3::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any(),
        Developed::InPlace => py.None().into_bound(py),
    })
}

fn develop_input<'py>(
    py: Python<'py>,
    input: &RawInput,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, String)> {
    let s = settings(kwargs)?;
    let out = match kwargs {
        Some(k) => k.get_item("out")?.filter(|v| !v.is_none()),
        None => None,
    };
    let Some(out) = out else {
        let (image, w, h, report) = py
            .detach(|| run(input, &s, Target::New, &[]))
            .map_err(errors::camsim)?;
        return Ok((to_numpy(py, image, w, h)?, report));
    };
    // The caller's array, written in place: C-contiguous, writeable, of the output's dtype.
    let refuse_out = || {
        errors::option(
            "out must be a writeable C-contiguous numpy array of uint8, uint16 or float32",
        )
    };
    let shape: Vec<usize> = out.getattr("shape")?.extract()?;
    let report = if let Ok(mut a) = out.extract::<numpy::PyReadwriteArrayDyn<'py, u8>>() {
        let t = a.as_slice_mut().map_err(|_| refuse_out())?;
        py.detach(|| run(input, &s, Target::U8(t), &shape))
    } else if let Ok(mut a) = out.extract::<numpy::PyReadwriteArrayDyn<'py, u16>>() {
        let t = a.as_slice_mut().map_err(|_| refuse_out())?;
        py.detach(|| run(input, &s, Target::U16(t), &shape))
    } else if let Ok(mut a) = out.extract::<numpy::PyReadwriteArrayDyn<'py, f32>>() {
        let t = a.as_slice_mut().map_err(|_| refuse_out())?;
        py.detach(|| run(input, &s, Target::F32(t), &shape))
    } else {
        return Err(refuse_out());
    }
    .map_err(errors::camsim)?
    .3;
    Ok((out, report))
}

/// Develops a file read by `read_raw` (its tags are the defaults the keyword arguments
/// override): the image (height, width, 3) and the report as JSON.
#[pyfunction]
#[pyo3(signature = (raw, **kwargs))]
fn develop_file<'py>(
    py: Python<'py>,
    raw: &Bound<'py, RawFile>,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, String)> {
    develop_input(py, &raw.get().input, kwargs)
}

/// Develops an array: a (height, width) uint16 CFA mosaic, or (height, width, 3) linear RGB;
/// `bits` (8..=16) is the depth of its samples (the default white level is 2^bits - 1).
#[pyfunction]
#[pyo3(signature = (mosaic, bits, **kwargs))]
fn develop_array<'py>(
    py: Python<'py>,
    mosaic: PyReadonlyArrayDyn<'py, u16>,
    bits: u8,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyAny>, String)> {
    let (data, w, h, spp) = samples(&mosaic, "mosaic", true)?;
    drop(mosaic);
    if !(8..=16).contains(&bits) {
        return Err(errors::option(format!(
            "bits must be in 8..=16 (got {bits})"
        )));
    }
    let white = ((1u32 << bits) - 1) as u16;
    let pattern = isp_core::CfaPattern::Rggb;
    let raw = if spp == 1 {
        RawImage::new(w, h, pattern, bits, [0; 4], white, data)
    } else {
        RawImage::linear_rgb(w, h, bits, [0; 3], white, data)
    }
    .map_err(errors::format)?;
    develop_input(py, &RawInput::plain(raw), kwargs)
}

/// Demosaics a (height, width) uint8 or uint16 mosaic with one of camsim's methods (the
/// whole-frame kernels `camsim demosaic` runs): a (height, width, 3) array of the same type.
#[pyfunction]
fn demosaic<'py>(
    py: Python<'py>,
    mosaic: &Bound<'py, PyAny>,
    pattern: &str,
    method: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let pattern = options::pattern(pattern, "pattern").map_err(refuse)?;
    let names: Vec<&str> = camsim::demosaic::Demosaic::ALL
        .iter()
        .map(|d| d.name())
        .collect();
    let Some(m) = camsim::demosaic::Demosaic::ALL
        .iter()
        .find(|d| d.name() == method)
        .copied()
    else {
        return Err(errors::option(format!(
            "method must be one of {} (got {method:?})",
            names.join(", ")
        )));
    };
    fn go<'py, T: isp_core::frame::IntSample + numpy::Element + Default + Send + Sync>(
        py: Python<'py>,
        a: PyReadonlyArray2<'py, T>,
        pattern: isp_core::CfaPattern,
        m: camsim::demosaic::Demosaic,
    ) -> PyResult<Bound<'py, PyAny>> {
        let shape = a.shape().to_vec();
        let data: Vec<T> = match a.as_slice() {
            Ok(s) => s.to_vec(),
            Err(_) => a.as_array().iter().copied().collect(),
        };
        let (h, w) = (shape[0], shape[1]);
        let mut out = vec![T::default(); 3 * w * h];
        py.detach(|| m.run(&data, w, h, pattern, &mut out))
            .map_err(errors::camsim)?;
        Ok(Array3::from_shape_vec((h, w, 3), out)
            .map_err(|e| errors::option(e.to_string()))?
            .into_pyarray(py)
            .into_any())
    }
    if let Ok(a) = mosaic.extract::<PyReadonlyArray2<'py, u16>>() {
        go(py, a, pattern, m)
    } else if let Ok(a) = mosaic.extract::<PyReadonlyArray2<'py, u8>>() {
        go(py, a, pattern, m)
    } else {
        Err(errors::option(
            "mosaic must be a 2-D numpy array of uint8 or uint16",
        ))
    }
}

/// Estimates the white balance of a (height, width) uint16 mosaic: (gains R, G, B with green
/// 1, the illuminant's colour in camera RGB, its correlated colour temperature in kelvin).
#[pyfunction]
#[pyo3(signature = (mosaic, pattern, method, bits, black_level, white_level))]
fn estimate_white_balance(
    py: Python<'_>,
    mosaic: PyReadonlyArrayDyn<'_, u16>,
    pattern: &str,
    method: &str,
    bits: u8,
    black_level: Vec<f64>,
    white_level: u16,
) -> PyResult<([f32; 3], [f32; 3], f64)> {
    let (data, w, h, _) = samples(&mosaic, "mosaic", false)?;
    let pattern = options::pattern(pattern, "pattern").map_err(refuse)?;
    let method = options::awb(method, "method").map_err(refuse)?;
    let black = options::black_levels(black_level, "black_level").map_err(refuse)?;
    if black.len() == 3 {
        return Err(errors::option(
            "black_level must be one value or four (per 2x2 CFA position)",
        ));
    }
    let black: [u16; 4] = std::array::from_fn(|i| black[i.min(black.len() - 1)]);
    py.detach(|| {
        let frame = RawFrame::new(&data, w, h, w, bits, pattern, black, white_level)
            .map_err(errors::isp)?;
        let e = isp_core::wb::estimate(&frame, method, &isp_core::colour::LINEAR_SRGB_TO_XYZ)
            .map_err(errors::isp)?;
        Ok((e.gains, e.neutral, e.cct_k))
    })
}

/// The least-squares 3x3 colour matrix taking `camera` (N, 3) to `reference` (N, 3), N >= 3,
/// as `camsim calibrate` fits it: `reference ~= camera @ M.T`.
#[pyfunction]
fn fit_ccm<'py>(
    py: Python<'py>,
    camera: PyReadonlyArray2<'py, f64>,
    reference: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows = |a: &PyReadonlyArray2<'py, f64>, what: &str| -> PyResult<Vec<[f64; 3]>> {
        let v = a.as_array();
        if v.ncols() != 3 {
            return Err(errors::option(format!("{what} must be an (N, 3) array")));
        }
        Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
    };
    let (c, r) = (rows(&camera, "camera")?, rows(&reference, "reference")?);
    let m = isp_core::ccm::fit(&c, &r).map_err(errors::isp)?;
    let flat: Vec<f64> = m.iter().flatten().copied().collect();
    numpy::PyArray1::from_vec(py, flat).reshape([3, 3])
}

/// The names of the options `develop` takes.
#[pyfunction]
fn develop_options() -> Vec<&'static str> {
    KEYS.to_vec()
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(develop_file, m)?)?;
    m.add_function(wrap_pyfunction!(develop_array, m)?)?;
    m.add_function(wrap_pyfunction!(demosaic, m)?)?;
    m.add_function(wrap_pyfunction!(estimate_white_balance, m)?)?;
    m.add_function(wrap_pyfunction!(fit_ccm, m)?)?;
    m.add_function(wrap_pyfunction!(develop_options, m)?)?;
    Ok(())
}
