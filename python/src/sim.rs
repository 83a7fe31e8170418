//! The simulator: a scene rendered to linear radiance ([`Rendering`]) and captured through the
//! sensor model into a raw mosaic, as `camsim render` and `camsim demo` do.

use camsim::demo::expose;
use host_tracer::sensor::{camera_names, Response, SensorConfig};
use host_tracer::tracer::render::{render_with_progress, RenderSettings, Rendered};
use host_tracer::tracer::scene::SceneDesc;
use host_tracer::tracer::scene_file;
use numpy::ndarray::{Array2, ArrayView3};
use numpy::{IntoPyArray, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors;

/// A rendered scene: its linear radiance and, for a spectral scene, its band radiances, with
/// the scene's camera (whose lens the sensor's vignetting follows).
#[pyclass(frozen, module = "camsim._camsim")]
pub struct Rendering {
    scene: SceneDesc,
    image: Rendered,
    spp: u32,
}

fn view<'py>(
    owner: &Bound<'py, Rendering>,
    data: &[f32],
    channels: usize,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let r = owner.get();
    let (w, h) = (r.image.width as usize, r.image.height as usize);
    let view = ArrayView3::from_shape((h, w, channels), data)
        .map_err(|e| errors::option(format!("radiance: {e}")))?;
    // SAFETY: the samples live as long as the rendering, which the array keeps alive as its
    // base, and are never written (the array is read-only).
    let array = unsafe { PyArray3::borrow_from_array(&view, owner.clone().into_any()) };
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array)
}

#[pymethods]
impl Rendering {
    /// Linear sRGB radiance, float32 (height, width, 3): a read-only view.
    #[getter]
    fn rgb<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        view(slf, &slf.get().image.rgb, 3)
    }

    /// Band radiances of a spectral scene, float32 (height, width, bands), or None.
    #[getter]
    fn bands<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyArray3<f32>>>> {
        let r = slf.get();
        if r.image.bands.is_empty() {
            return Ok(None);
        }
        let n = r.image.bands.len() / (r.image.width as usize * r.image.height as usize).max(1);
        view(slf, &r.image.bands, n).map(Some)
    }

    /// The scene's name.
    #[getter]
    fn scene(&self) -> String {
        self.scene.name.clone()
    }

    /// Samples per pixel.
    #[getter]
    fn spp(&self) -> u32 {
        self.spp
    }

    /// Seconds spent rendering (scene preparation included).
    #[getter]
    fn seconds(&self) -> f64 {
        (self.image.elapsed + self.image.prepare).as_secs_f64()
    }
}

/// Renders a scene (a built-in name, a TOML file, or TOML text when `text` is given, named
/// `scene` in messages) with the GIL released; `progress(done, total)` is called as tiles
/// finish. Width, height and spp default to the scene's.
#[pyfunction]
#[pyo3(signature = (scene, text=None, width=None, height=None, spp=None, seed=1, threads=0, max_depth=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn render_scene(
    py: Python<'_>,
    scene: &str,
    text: Option<&str>,
    width: Option<u32>,
    height: Option<u32>,
    spp: Option<u32>,
    seed: u64,
    threads: usize,
    max_depth: Option<u32>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Rendering> {
    let sim = |e: host_tracer::Error| errors::camsim(camsim::Error::Simulation(e));
    let desc = match text {
        Some(t) => scene_file::parse(t, scene, std::path::Path::new(".")),
        None => scene_file::load(scene),
    }
    .map_err(sim)?;
    let mut s = RenderSettings::for_scene(&desc);
    s.width = width.unwrap_or(s.width);
    s.height = height.unwrap_or(s.height);
    s.spp = spp.unwrap_or(s.spp);
    s.seed = seed;
    s.threads = threads;
    s.path.max_depth = max_depth.unwrap_or(s.path.max_depth);
    let mut table = host_tracer::tracer::scene::MaskTable::default();
    desc.camera
        .rig(s.width, s.height, false, &mut table)
        .map_err(sim)?;
    let reported = std::sync::atomic::AtomicUsize::new(0);
    let image = py
        .detach(|| {
            render_with_progress(&desc, &s, &|p| {
                if let Some(callback) = &progress {
                    // Workers finish tiles in any order and reach the interpreter in any
                    // order; under the GIL, only a count above the last one reported is
                    // passed on, so the calls rise and the last is (total, total).
                    Python::attach(|py| {
                        if p.done > reported.load(std::sync::atomic::Ordering::Relaxed) {
                            reported.store(p.done, std::sync::atomic::Ordering::Relaxed);
                            if let Err(e) = callback.call1(py, (p.done, p.total)) {
                                e.print(py);
                            }
                        }
                    });
                }
            })
        })
        .map_err(sim)?;
    Ok(Rendering {
        scene: desc,
        image,
        spp: s.spp,
    })
}

/// Captures a rendering through the sensor model: the raw mosaic (uint16, height x width)
/// and a dict of what the sensor knows (levels, pattern, exposure, noise profile, defects,
/// the camera-RGB truth), as `camsim demo` captures its scene.
#[pyfunction]
#[pyo3(signature = (rendering, camera="nikon-5100", preset="realistic", iso=100.0, exposure=None, bits=12, pattern="RGGB", seed=1, fixed_seed=None))]
#[allow(clippy::too_many_arguments)]
fn capture<'py>(
    py: Python<'py>,
    rendering: &Bound<'py, Rendering>,
    camera: &str,
    preset: &str,
    iso: f64,
    exposure: Option<f64>,
    bits: u8,
    pattern: &str,
    seed: u64,
    fixed_seed: Option<u64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let mut config = match preset {
        "realistic" => SensorConfig::realistic(),
        "ideal" => SensorConfig::ideal(),
        other => {
            return Err(errors::option(format!(
                "preset must be realistic or ideal (got {other:?})"
            )))
        }
    };
    config.camera = camera.to_owned();
    config.pattern = camsim::isp_options::pattern(pattern, "pattern")
        .map_err(|e| errors::option(e.to_string()))?;
    config.adc_bits = bits;
    config.iso = iso;
    config.exposure_s = exposure;
    config.frame_seed = seed;
    if let Some(s) = fixed_seed {
        config.seed = s;
    }
    let sim = |e: host_tracer::Error| errors::camsim(camsim::Error::Simulation(e));
    config.validate().map_err(sim)?;
    let r = rendering.get();
    let c = py
        .detach(|| {
            let response = Response::named(camera)?;
            expose(&r.scene, &r.image, &response, &config)
        })
        .map_err(errors::camsim)?;
    let (w, h) = (c.raw.width, c.raw.height);
    let d = PyDict::new(py);
    d.set_item("pattern", c.raw.pattern.name())?;
    d.set_item("bits", c.raw.bits)?;
    d.set_item("black_level", c.raw.black_level.to_vec())?;
    d.set_item("white_level", c.raw.white_level)?;
    d.set_item("exposure_s", c.exposure_s)?;
    d.set_item("units_per_radiance", c.units_per_radiance)?;
    let (s, o) = (c.noise_profile.scale(), c.noise_profile.offset());
    d.set_item(
        "noise_profile",
        (0..3)
            .map(|i| vec![f64::from(s[i]), f64::from(o[i])])
            .collect::<Vec<_>>(),
    )?;
    d.set_item(
        "defects",
        c.defects
            .iter()
            .map(|(x, y, _)| (*x, *y))
            .collect::<Vec<_>>(),
    )?;
    d.set_item(
        "truth_camera",
        numpy::ndarray::Array3::from_shape_vec((h, w, 3), c.truth_camera)
            .map_err(|e| errors::option(e.to_string()))?
            .into_pyarray(py),
    )?;
    let mosaic = Array2::from_shape_vec((h, w), c.raw.samples)
        .map_err(|e| errors::option(e.to_string()))?
        .into_pyarray(py)
        .into_any();
    Ok((mosaic, d))
}

/// The built-in scenes' names.
#[pyfunction]
fn scene_names() -> Vec<&'static str> {
    scene_file::BUILT_IN.iter().map(|(n, _)| *n).collect()
}

/// The cameras whose spectral responses the sensor model has.
#[pyfunction]
fn cameras() -> Vec<&'static str> {
    camera_names()
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Rendering>()?;
    m.add_function(wrap_pyfunction!(render_scene, m)?)?;
    m.add_function(wrap_pyfunction!(capture, m)?)?;
    m.add_function(wrap_pyfunction!(scene_names, m)?)?;
    m.add_function(wrap_pyfunction!(cameras, m)?)?;
    Ok(())
}
