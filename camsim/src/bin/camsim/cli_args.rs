//! Checked parsing of numeric command-line values, so a bad value gets one line that names the
//! argument and the allowed range instead of a parser's generic message.

use camsim::Error;

/// Parses a finite number that satisfies `valid`, described by `allowed`.
pub fn number(
    arg: &'static str,
    raw: &str,
    allowed: &str,
    valid: impl Fn(f64) -> bool,
) -> Result<f64, Error> {
    let error = || Error::Option {
        option: arg,
        value: format!("{raw:?}"),
        allowed: allowed.to_string(),
    };
    let x: f64 = raw.trim().parse().map_err(|_| error())?;
    if x.is_finite() && valid(x) {
        Ok(x)
    } else {
        Err(error())
    }
}

/// Like [`number`], but also accepts `inf` / `infinity` (any case), returned as `f64::INFINITY`.
pub fn number_or_infinity(
    arg: &'static str,
    raw: &str,
    allowed: &str,
    valid: impl Fn(f64) -> bool,
) -> Result<f64, Error> {
    match raw.trim().to_ascii_lowercase().as_str() {
        "inf" | "infinity" => Ok(f64::INFINITY),
        _ => number(arg, raw, allowed, valid),
    }
}
