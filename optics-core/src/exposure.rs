//! f-number, entrance pupil, stops and exposure ratios.

use crate::real::{checked, positive};
use crate::Real;
use crate::Result;

/// f-number `N = f / D` of a lens of focal length `f` with entrance pupil diameter `D` (mm).
pub fn f_number<T: Real>(focal_length: T, pupil_diameter: T) -> Result<T> {
    checked(positive(focal_length, "focal_length")? / positive(pupil_diameter, "pupil_diameter")?)
}

/// Entrance-pupil diameter `D = f / N` (mm).
///
/// ```
/// use optics_core::exposure::entrance_pupil_diameter;
/// assert_eq!(entrance_pupil_diameter(50.0_f64, 2.0).unwrap(), 25.0);
/// ```
pub fn entrance_pupil_diameter<T: Real>(focal_length: T, f_number: T) -> Result<T> {
    checked(positive(focal_length, "focal_length")? / positive(f_number, "f_number")?)
}

/// Stops from `n_from` to `n_to`: `2 log2(n_to / n_from)`, positive when stopping down
/// (f/2 -> f/4 is +2 stops).
pub fn stops_between<T: Real>(n_from: T, n_to: T) -> Result<T> {
    let r = positive(n_to, "n_to")? / positive(n_from, "n_from")?;
    checked(T::lit(2.0) * r.log2())
}

/// Exposure at `n_to` relative to `n_from` for the same scene and time: `(n_from / n_to)^2`
/// (image-plane irradiance goes as `1/N^2`).
pub fn exposure_ratio<T: Real>(n_from: T, n_to: T) -> Result<T> {
    let r = positive(n_from, "n_from")? / positive(n_to, "n_to")?;
    checked(r * r)
}
