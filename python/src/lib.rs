//! `camsim._camsim`, the compiled half of the Python package `camsim` (python/camsim/): the
//! DNG reader and writer, the ISP, the renderer and sensor model and the lens equations on
//! numpy arrays, and the dataset generator's calls. The Python half wraps these functions in the API users see (`imread`,
//! `Raw`, `develop`, ...) and documents it; this module converts, checks and releases the
//! GIL around every pixel loop.
//!
//! Errors are raised as the classes in `errors.rs`, with the command line's one-line messages.

mod dataset;
mod errors;
mod isp;
mod optics;
mod raw;
mod sim;

use pyo3::prelude::*;

#[pymodule]
fn _camsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    raw::register(m)?;
    isp::register(m)?;
    sim::register(m)?;
    optics::register(m)?;
    dataset::register(m)?;
    Ok(())
}
