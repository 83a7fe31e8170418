//! optics-core's thin-lens equations over arrays: the Python side broadcasts the arguments
//! and flattens them; each element goes through the scalar `f64` function, an infinite
//! distance comes back as `inf`, and a refused element raises with its index and reason.

use numpy::{PyArray1, PyReadonlyArray1};
use optics_core::lens::ImageDistance;
use optics_core::{dof, exposure, lens, Distance, OpticsError};
use pyo3::prelude::*;

use crate::errors;

fn distance(d: Distance<f64>) -> f64 {
    d.finite().unwrap_or(f64::INFINITY)
}

/// The functions by name: how many arguments, how many results, and the scalar function.
type Scalar = fn(&[f64]) -> Result<Vec<f64>, OpticsError>;

fn function(name: &str) -> Option<(usize, Scalar)> {
    Some(match name {
        "f_number" => (2, |a| Ok(vec![exposure::f_number(a[0], a[1])?])),
        "entrance_pupil_diameter" => (2, |a| {
            Ok(vec![exposure::entrance_pupil_diameter(a[0], a[1])?])
        }),
        "stops_between" => (2, |a| Ok(vec![exposure::stops_between(a[0], a[1])?])),
        "exposure_ratio" => (2, |a| Ok(vec![exposure::exposure_ratio(a[0], a[1])?])),
        "hyperfocal_distance" => (3, |a| {
            Ok(vec![distance(dof::hyperfocal_distance(a[0], a[1], a[2])?)])
        }),
        "depth_of_field" => (4, |a| {
            let d = dof::depth_of_field(a[0], a[1], a[2], a[3])?;
            Ok(vec![d.near, distance(d.far), distance(d.total)])
        }),
        "circle_of_confusion" => (4, |a| {
            Ok(vec![dof::circle_of_confusion(a[0], a[1], a[2], a[3])?])
        }),
        "image_distance" => (2, |a| {
            Ok(vec![match lens::image_distance(a[0], a[1])? {
                ImageDistance::Real(z) => z,
                ImageDistance::Virtual(z) => -z,
                ImageDistance::Infinite => f64::INFINITY,
            }])
        }),
        "lateral_magnification" => (2, |a| Ok(vec![lens::lateral_magnification(a[0], a[1])?])),
        "sensor_distance_for_focus" => (2, |a| {
            Ok(vec![lens::sensor_distance_for_focus(a[0], a[1])?])
        }),
        "power_dioptres" => (1, |a| Ok(vec![lens::power_dioptres(a[0])?])),
        "lensmaker_focal_length" => (3, |a| {
            Ok(vec![lens::lensmaker_focal_length(a[0], a[1], a[2])?])
        }),
        _ => return None,
    })
}

/// Applies optics function `name` element by element to equal-length `f64` arrays: one
/// array per result.
#[pyfunction]
fn optics_apply<'py>(
    py: Python<'py>,
    name: &str,
    args: Vec<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Vec<Bound<'py, PyArray1<f64>>>> {
    let Some((arity, f)) = function(name) else {
        return Err(errors::option(format!("no optics function {name:?}")));
    };
    if args.len() != arity {
        return Err(errors::option(format!(
            "{name} takes {arity} arguments (got {})",
            args.len()
        )));
    }
    let columns: Vec<Vec<f64>> = args.iter().map(|a| a.as_array().to_vec()).collect();
    let n = columns.first().map_or(0, Vec::len);
    if columns.iter().any(|c| c.len() != n) {
        return Err(errors::option(format!(
            "{name}: arguments of different lengths"
        )));
    }
    let results = py.detach(|| {
        let mut out: Vec<Vec<f64>> = Vec::new();
        let mut element = vec![0.0; arity];
        for i in 0..n {
            for (e, c) in element.iter_mut().zip(&columns) {
                *e = c[i];
            }
            let values = f(&element).map_err(|e| (i, e))?;
            if out.is_empty() {
                out = vec![Vec::with_capacity(n); values.len()];
            }
            for (o, v) in out.iter_mut().zip(values) {
                o.push(v);
            }
        }
        Ok(out)
    });
    let results = results.map_err(|(i, e): (usize, OpticsError)| {
        crate::errors::ProcessingError::new_err(format!("{name}, element {i}: {e}"))
    })?;
    Ok(results
        .into_iter()
        .map(|v| PyArray1::from_vec(py, v))
        .collect())
}

/// A lens file's report (`camsim lens --json`) at `wavelength_nm`, as JSON text.
#[pyfunction]
fn lens_report(path: std::path::PathBuf, wavelength_nm: f64, pbrt_abbe: f64) -> PyResult<String> {
    let lens = camsim::lens::LensFile::read(&path, pbrt_abbe).map_err(errors::lens_file)?;
    let report = camsim::lens::LensReport::of(&lens, wavelength_nm)
        .map_err(|e| errors::camsim(e.in_file(&path)))?;
    serde_json::to_string(&report).map_err(|e| errors::option(e.to_string()))
}

/// Rays (JSON text, as `camsim lens --trace` reads them) through a lens file to its paraxial
/// image plane at `wavelength_nm`: the outcomes as JSON text.
#[pyfunction]
fn lens_trace(
    path: std::path::PathBuf,
    rays_json: &str,
    wavelength_nm: f64,
    pbrt_abbe: f64,
) -> PyResult<String> {
    let lens = camsim::lens::LensFile::read(&path, pbrt_abbe).map_err(errors::lens_file)?;
    let rays: Vec<camsim::lens::RayInput> =
        serde_json::from_str(rays_json).map_err(|e| errors::option(format!("rays: {e}")))?;
    let out = camsim::lens::trace_rays(&lens, &rays, wavelength_nm).map_err(errors::camsim)?;
    serde_json::to_string(&out).map_err(|e| errors::option(e.to_string()))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(optics_apply, m)?)?;
    m.add_function(wrap_pyfunction!(lens_report, m)?)?;
    m.add_function(wrap_pyfunction!(lens_trace, m)?)?;
    Ok(())
}
