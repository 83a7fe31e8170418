//! [`Error`]: everything host-tracer can refuse, as data (the file and line, the field, the
//! value, what is allowed); the one-line message is its `Display`.

use std::fmt;
use std::path::PathBuf;

/// An error of the tracer, the sensor model, the spectral tables or calibration.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// An entry of a scene file is wrong.
    Scene {
        /// The file (or `<built-in NAME>`).
        file: String,
        /// The line of the entry, where known.
        line: Option<usize>,
        /// The entry, e.g. `camera: f_number` or `shape[0] (sphere): radius`; empty for a
        /// syntax error.
        field: String,
        /// What is wrong with it and what is allowed.
        problem: String,
    },
    /// A file could not be read.
    Io {
        /// The file as named.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
        /// What the name may also be, e.g. the built-in scenes.
        hint: Option<String>,
    },
    /// A setting is outside its allowed range.
    OutOfRange {
        /// The setting, e.g. `spp` or `sensor adc_bits`.
        field: String,
        /// The value given.
        value: String,
        /// The allowed range.
        allowed: String,
    },
    /// A name (camera, illuminant, spectral column) is not one of the known ones.
    Unknown {
        /// What kind of name, e.g. `camera`.
        kind: &'static str,
        /// The name given.
        name: String,
        /// The names known.
        known: Vec<String>,
    },
    /// A built-in spectral table does not parse.
    Table {
        /// The line (1-based), where known.
        line: Option<usize>,
        /// What is wrong.
        problem: String,
    },
    /// optics-core refused a camera parameter.
    Optics {
        /// The camera part, e.g. `aperture` or `focus distance`.
        part: &'static str,
        /// optics-core's reason.
        source: optics_core::OpticsError,
    },
    /// isp-core refused (the calibration fit, colour conversions).
    Isp {
        /// The step, e.g. `3x3 fit`.
        step: &'static str,
        /// isp-core's reason.
        source: isp_core::IspError,
    },
    /// A file format error (aperture masks, the sensor's raw frame).
    Format(raw_formats::FormatError),
    /// A sensor setting is outside its range.
    SensorSetting {
        /// The [`crate::sensor::SensorConfig`] field, e.g. `adc_bits`.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// The frame gives the sensor nothing to work with (e.g. black for automatic exposure).
    Sensor {
        /// What is wrong and what to do.
        problem: &'static str,
    },
    /// The render's worker threads could not start.
    Threads(String),
    /// A lens file is wrong.
    Lens {
        /// The file, when read from one.
        file: Option<PathBuf>,
        /// What is wrong (the surface and key, where it is one).
        problem: String,
    },
}

impl Error {
    /// A value outside its range.
    pub fn out_of_range(
        field: impl Into<String>,
        value: impl fmt::Display,
        allowed: impl Into<String>,
    ) -> Self {
        Error::OutOfRange {
            field: field.into(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }

    /// A problem of a lens file.
    pub fn lens(problem: impl Into<String>) -> Self {
        Error::Lens {
            file: None,
            problem: problem.into(),
        }
    }

    /// This error, said of the lens file `path` (a lens problem gets the file's name; others
    /// are returned as they are).
    pub fn in_lens_file(self, path: &std::path::Path) -> Self {
        match self {
            Error::Lens { problem, .. } => Error::Lens {
                file: Some(path.to_owned()),
                problem,
            },
            Error::Optics { source, .. } => Error::Lens {
                file: Some(path.to_owned()),
                problem: source.to_string(),
            },
            other => other,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Scene {
                file,
                line,
                field,
                problem,
            } => {
                write!(f, "{file}")?;
                if let Some(line) = line {
                    write!(f, ":{line}")?;
                }
                if field.is_empty() {
                    write!(f, ": {problem}")
                } else {
                    write!(f, ": {field}: {problem}")
                }
            }
            Self::Io { path, source, hint } => {
                write!(f, "{}: {source}", path.display())?;
                match hint {
                    Some(hint) => write!(f, " ({hint})"),
                    None => Ok(()),
                }
            }
            Self::OutOfRange {
                field,
                value,
                allowed,
            } => write!(f, "{field} must be {allowed} (got {value})"),
            Self::Unknown { kind, name, known } => {
                write!(f, "unknown {kind} {name:?}; known: {}", known.join(", "))
            }
            Self::Table {
                line: Some(line),
                problem,
            } => write!(f, "spectral table, line {line}: {problem}"),
            Self::Table {
                line: None,
                problem,
            } => write!(f, "spectral table: {problem}"),
            Self::Optics { part, source } => write!(f, "camera: {part}: {source}"),
            Self::Isp { step, source } => write!(f, "{step}: {source}"),
            Self::Format(e) => e.fmt(f),
            Self::SensorSetting {
                field,
                value,
                allowed,
            } => write!(f, "sensor {field}: expected {allowed}, got {value}"),
            Self::Sensor { problem } => write!(f, "sensor: {problem}"),
            Self::Threads(e) => write!(f, "cannot start render threads: {e}"),
            Self::Lens {
                file: Some(file),
                problem,
            } => write!(f, "{}: {problem}", file.display()),
            Self::Lens {
                file: None,
                problem,
            } => write!(f, "{problem}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            Self::Optics { source, .. } => Some(source),
            Self::Isp { source, .. } => Some(source),
            Self::Format(e) => Some(e),
            _ => None,
        }
    }
}

impl From<raw_formats::FormatError> for Error {
    fn from(e: raw_formats::FormatError) -> Self {
        Error::Format(e)
    }
}

/// The result type of host-tracer.
pub type Result<T> = std::result::Result<T, Error>;
