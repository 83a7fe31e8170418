//! Focusing and depth of field in fixed point, for lens-control firmware without an FPU.
//!
//! Distances that may be infinite are carried as **vergence** in dioptres (1/m), where infinity
//! is exactly 0. Formats (the `fixed` crate's types):
//!
//! | alias | type | meaning | range | step |
//! |---|---|---|---|---|
//! | [`Mm`] | unsigned Q32.32 (`U32F32`) | lengths in mm: focal length, CoC, sensor distance, hyperfocal | [0, 4.29e9) mm | 2.3e-10 mm |
//! | [`FNumber`] | unsigned Q32.32 (`U32F32`) | f-number | [0, 4.29e9) | 2.3e-10 |
//! | [`Dioptres`] | unsigned Q16.48 (`U16F48`) | vergence 1/distance, in 1/m | [0, 65536) D (distances down to 0.016 mm) | 3.6e-15 D |
//!
//! Intermediates are unsigned Q64.64 (`U64F64`, 128-bit), so the only rounding that matters is the
//! final conversion to the output format. Every function checks its inputs and reports a result
//! out of range as an error; nothing wraps.
//!
//! **Error bound** (property test `fixed_point_matches_float` in `optics-core/tests`): over
//! f = 1..800 mm, N = 0.95..32, c = 0.001..0.1 mm and subject distances from 2f to infinity,
//! against the same equations in `f64` on the same (quantised) inputs,
//! sensor distance, hyperfocal distance and circle of confusion are within `1e-9` relative
//! (plus one output step), and near/far vergences within `1e-12` D absolute.
//!
//! ```
//! use optics_core::fixed_point::{depth_of_field, distance, vergence, Dioptres, FNumber, Mm};
//! use optics_core::Distance;
//! let f = Mm::from_num(50);
//! let v = vergence(Distance::Finite(Mm::from_num(3000))).unwrap(); // 1/3 D
//! let dof = depth_of_field(f, FNumber::from_num(2.8), Mm::from_num(0.03), v).unwrap();
//! let Distance::Finite(near) = distance(dof.near).unwrap() else { panic!() };
//! assert!((near.to_num::<f64>() - 2729.456_292).abs() < 1e-5);
//! ```

use fixed::types::{U16F48, U32F32, U64F64};

use crate::{Distance, OpticsError, Result};

/// Length in millimetres, unsigned Q32.32.
pub type Mm = U32F32;
/// f-number, unsigned Q32.32.
pub type FNumber = U32F32;
/// Vergence in dioptres (1/m), unsigned Q16.48; 0 is infinity.
pub type Dioptres = U16F48;

type Wide = U64F64;

const MM_PER_M: Wide = Wide::const_from_int(1000);

fn wide_mm(x: Mm) -> Wide {
    Wide::from_num(x)
}

fn wide_d(x: Dioptres) -> Wide {
    Wide::from_num(x)
}

fn to_mm(x: Wide) -> Result<Mm> {
    x.checked_to_num::<Mm>().ok_or(OpticsError::Overflow)
}

fn to_dioptres(x: Wide) -> Result<Dioptres> {
    x.checked_to_num::<Dioptres>().ok_or(OpticsError::Overflow)
}

fn nonzero(x: Mm, name: &'static str) -> Result<Wide> {
    if x == Mm::ZERO {
        Err(OpticsError::InvalidParameter {
            name,
            allowed: "> 0",
        })
    } else {
        Ok(wide_mm(x))
    }
}

fn mul(a: Wide, b: Wide) -> Result<Wide> {
    a.checked_mul(b).ok_or(OpticsError::Overflow)
}

fn div(a: Wide, b: Wide) -> Result<Wide> {
    a.checked_div(b).ok_or(OpticsError::Overflow)
}

/// Vergence (dioptres) of a distance in mm: `1000 / d`, 0 for infinity.
pub fn vergence(distance: Distance<Mm>) -> Result<Dioptres> {
    match distance {
        Distance::Infinite => Ok(Dioptres::ZERO),
        Distance::Finite(d) => to_dioptres(div(MM_PER_M, nonzero(d, "distance")?)?),
    }
}

/// Distance in mm of a vergence: `1000 / v`, infinite for 0.
pub fn distance(v: Dioptres) -> Result<Distance<Mm>> {
    if v == Dioptres::ZERO {
        return Ok(Distance::Infinite);
    }
    Ok(Distance::Finite(to_mm(div(MM_PER_M, wide_d(v))?)?))
}

/// `1 - f V / 1000`: the subject's vergence relative to the lens power; must be > 0.
fn focus_margin(f: Wide, subject: Dioptres) -> Result<Wide> {
    let fv = div(mul(f, wide_d(subject))?, MM_PER_M)?;
    match fv.cmp(&Wide::ONE) {
        core::cmp::Ordering::Less => Ok(Wide::ONE - fv),
        core::cmp::Ordering::Equal => Err(OpticsError::SubjectAtFocalLength),
        core::cmp::Ordering::Greater => Err(OpticsError::SubjectInsideFocalLength),
    }
}

/// Sensor-to-lens distance (mm) that focuses a subject of vergence `subject`:
/// `s_i = f / (1 - f V / 1000)`.
pub fn sensor_distance(f: Mm, subject: Dioptres) -> Result<Mm> {
    let f = nonzero(f, "focal_length")?;
    to_mm(div(f, focus_margin(f, subject)?)?)
}

/// `f^2 / (N c)` in mm (`H - f`), or `None` for `c = 0`.
fn hyperfocal_minus_f(f: Wide, n: FNumber, c: Mm) -> Result<Option<Wide>> {
    let n = nonzero(n, "f_number")?;
    if c == Mm::ZERO {
        return Ok(None);
    }
    Ok(Some(div(mul(f, f)?, mul(n, wide_mm(c))?)?))
}

/// Hyperfocal distance `H = f^2/(N c) + f` (mm); infinite when `c = 0`.
pub fn hyperfocal(f: Mm, n: FNumber, c: Mm) -> Result<Distance<Mm>> {
    let f = nonzero(f, "focal_length")?;
    hyperfocal_from(f, hyperfocal_minus_f(f, n, c)?)
}

/// `H = g + f` from `g = f^2/(N c)` (`None`: infinite).
fn hyperfocal_from(f: Wide, g: Option<Wide>) -> Result<Distance<Mm>> {
    match g {
        None => Ok(Distance::Infinite),
        Some(g) => Ok(Distance::Finite(to_mm(
            g.checked_add(f).ok_or(OpticsError::Overflow)?,
        )?)),
    }
}

/// Depth-of-field limits as vergences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedDepthOfField {
    /// Vergence of the near limit.
    pub near: Dioptres,
    /// Vergence of the far limit: 0 when the far limit is at infinity.
    pub far: Dioptres,
    /// Hyperfocal distance.
    pub hyperfocal: Distance<Mm>,
}

/// Near and far limits when focused at vergence `focus`:
/// `1/near = V + (1 - f V)/(H - f)` and `1/far = V - (1 - f V)/(H - f)` (0 when that is <= 0,
/// i.e. focused at or beyond the hyperfocal distance).
pub fn depth_of_field(f: Mm, n: FNumber, c: Mm, focus: Dioptres) -> Result<FixedDepthOfField> {
    let f = nonzero(f, "focal_length")?;
    let g = hyperfocal_minus_f(f, n, c)?;
    let hyperfocal = hyperfocal_from(f, g)?;
    let margin = focus_margin(f, focus)?;
    let v = wide_d(focus);
    let Some(g) = g else {
        return Ok(FixedDepthOfField {
            near: focus,
            far: focus,
            hyperfocal,
        });
    };
    // (1 - f V) / (H - f), in dioptres.
    let spread = div(mul(margin, MM_PER_M)?, g)?;
    let near = to_dioptres(v.checked_add(spread).ok_or(OpticsError::Overflow)?)?;
    let far = to_dioptres(v.saturating_sub(spread))?;
    Ok(FixedDepthOfField {
        near,
        far,
        hyperfocal,
    })
}

/// Blur-circle diameter (mm) of a point at vergence `point` when focused at vergence `focus`:
/// `c = (f^2 / N) |V_s - V_d| / 1000 / (1 - f V_s / 1000)`.
pub fn circle_of_confusion(f: Mm, n: FNumber, focus: Dioptres, point: Dioptres) -> Result<Mm> {
    let f = nonzero(f, "focal_length")?;
    let n = nonzero(n, "f_number")?;
    let margin = focus_margin(f, focus)?;
    let (vs, vd) = (wide_d(focus), wide_d(point));
    let dv = if vs > vd { vs - vd } else { vd - vs };
    let numerator = mul(div(mul(f, f)?, n)?, dv)?;
    to_mm(div(div(numerator, MM_PER_M)?, margin)?)
}
