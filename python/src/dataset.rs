//! `camsim dataset`'s library calls for `camsim.dataset` (python/camsim/dataset.py), which
//! runs them as Ray tasks: prepare a dataset's folder, generate one sample, gather the
//! manifest; and `imwrite` for the batch development's images. Results cross as JSON text.

use std::path::Path;

use camsim::dataset::{self, Outcome, Spec};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use raw_formats::Image;

use crate::errors;

fn spec(text: &str, dir: &str) -> PyResult<Spec> {
    Spec::parse(text, Path::new(dir)).map_err(errors::camsim)
}

/// Checks the spec (TOML `text`, relative paths from `dir`) and makes `out` its dataset's
/// folder; returns the spec's sample count.
#[pyfunction]
fn dataset_prepare(text: &str, dir: &str, out: &str) -> PyResult<u64> {
    let spec = spec(text, dir)?;
    dataset::prepare_out(&spec, Path::new(out)).map_err(errors::camsim)?;
    Ok(spec.count)
}

/// Generates sample `index` into `out` with the GIL released: JSON of
/// `{"index", "status": "written" | "present", and seconds by step when written}`.
#[pyfunction]
#[pyo3(signature = (text, dir, out, index, threads=1))]
fn dataset_sample(
    py: Python<'_>,
    text: &str,
    dir: &str,
    out: &str,
    index: u64,
    threads: usize,
) -> PyResult<String> {
    let spec = spec(text, dir)?;
    let outcome = py
        .detach(|| dataset::generate(&spec, Path::new(out), index, threads))
        .map_err(errors::camsim)?;
    let value = match outcome {
        Outcome::Written(t) => {
            let mut v = serde_json::to_value(t).unwrap_or_default();
            v["status"] = "written".into();
            v
        }
        Outcome::Present => serde_json::json!({ "status": "present" }),
    };
    let mut value = value;
    value["index"] = index.into();
    Ok(value.to_string())
}

/// Gathers `out`'s records into `out/manifest.jsonl` and checks every sample: JSON of the
/// report (count, complete, missing, corrupt, partial).
#[pyfunction]
fn dataset_manifest(py: Python<'_>, out: &str) -> PyResult<String> {
    let report = py
        .detach(|| dataset::index_manifest(Path::new(out)))
        .map_err(errors::camsim)?;
    serde_json::to_string(&report).map_err(|e| errors::option(e.to_string()))
}

/// Writes an 8- or 16-bit image (height x width, or height x width x 3) as PNG, PGM or PPM
/// by the path's extension.
#[pyfunction]
fn imwrite(
    py: Python<'_>,
    path: &str,
    image: PyReadonlyArrayDyn<'_, u16>,
    bits: u8,
) -> PyResult<()> {
    let shape = image.shape().to_vec();
    let (height, width, channels) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, 3] => (h, w, 3),
        _ => {
            return Err(errors::option(format!(
                "image: shape {shape:?}; give (height, width) or (height, width, 3)"
            )))
        }
    };
    if bits != 8 && bits != 16 {
        return Err(errors::option(format!("bits {bits}: 8 or 16")));
    }
    let data: Vec<u16> = image.as_array().iter().copied().collect();
    let img = Image {
        width,
        height,
        channels,
        bits,
        data,
    };
    py.detach(|| raw_formats::image::write(Path::new(path), &img))
        .map_err(errors::format)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dataset_prepare, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_sample, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_manifest, m)?)?;
    m.add_function(wrap_pyfunction!(imwrite, m)?)?;
    Ok(())
}
