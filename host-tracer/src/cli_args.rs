//! Checked parsing of numeric command-line values, so a bad value gets one line that names the
//! argument and the allowed range instead of a parser's generic message.

use std::fmt;

/// A rejected command-line value.
#[derive(Debug, Clone, PartialEq)]
pub struct ArgError {
    /// The argument, e.g. `--f-number`.
    pub arg: &'static str,
    /// What is allowed, e.g. `a number >= 0.5`.
    pub allowed: String,
    /// What was given.
    pub got: String,
}

impl fmt::Display for ArgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} must be {} (got {:?})",
            self.arg, self.allowed, self.got
        )
    }
}

impl std::error::Error for ArgError {}

/// Parses a finite number that satisfies `valid`, described by `allowed`.
pub fn number(
    arg: &'static str,
    raw: &str,
    allowed: &str,
    valid: impl Fn(f64) -> bool,
) -> Result<f64, ArgError> {
    let error = || ArgError {
        arg,
        allowed: allowed.to_string(),
        got: raw.to_string(),
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
) -> Result<f64, ArgError> {
    match raw.trim().to_ascii_lowercase().as_str() {
        "inf" | "infinity" => Ok(f64::INFINITY),
        _ => number(arg, raw, allowed, valid),
    }
}
