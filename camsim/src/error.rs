//! [`Error`]: what the host workflows (developing a raw, demosaicing files, the demo) can
//! refuse, as data; `camsim` prints its `Display` as one line.

use std::fmt;
use std::path::PathBuf;

use isp_core::IspError;
use optics_core::OpticsError;
use raw_formats::FormatError;

/// An error of the host workflows.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read, decoded or written.
    Format(FormatError),
    /// isp-core refused a parameter or buffer.
    Isp(IspError),
    /// isp-core refused what a stage or option was given.
    InStage {
        /// The stage or option, e.g. `--awb`.
        stage: &'static str,
        /// isp-core's reason.
        source: IspError,
    },
    /// optics-core refused what an option was given.
    Optics {
        /// The option, e.g. `--distortion`.
        option: &'static str,
        /// optics-core's reason.
        source: OpticsError,
    },
    /// An option's value is outside what it allows.
    Option {
        /// The option, e.g. `--bits`.
        option: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// An option that only makes sense with another was given alone.
    Needs {
        /// The option given.
        option: &'static str,
        /// What it needs.
        needs: &'static str,
    },
    /// A raw sample exceeds the bit depth the frame is said to have.
    SampleRange {
        /// The sample.
        sample: u16,
        /// The bit depth.
        bits: u8,
    },
    /// An error about the input file `path`.
    InFile {
        /// The file.
        path: PathBuf,
        /// The error.
        error: Box<Error>,
    },
    /// The tracer, the sensor model, the spectral tables or calibration refused.
    Simulation(host_tracer::Error),
    /// A processing option (flag or config file) was refused.
    Options(crate::isp_options::OptionError),
    /// A command-level refusal in words (a combination of flags that does not go together).
    Message(String),
    /// The frame's noise profile could not be estimated from it.
    NoiseEstimate {
        /// Why, in words.
        reason: &'static str,
    },
}

impl Error {
    /// isp-core's `source`, refused for `stage`.
    pub fn in_stage(stage: &'static str, source: IspError) -> Self {
        Error::InStage { stage, source }
    }

    /// This error, about the file `path`.
    pub fn in_file(self, path: impl Into<PathBuf>) -> Self {
        Error::InFile {
            path: path.into(),
            error: Box::new(self),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Format(e) => e.fmt(f),
            Self::Isp(e) => e.fmt(f),
            Self::InStage { stage, source } => write!(f, "{stage}: {source}"),
            Self::Optics { option, source } => write!(f, "{option}: {source}"),
            Self::Option {
                option,
                value,
                allowed,
            } => write!(f, "{option} must be {allowed} (got {value})"),
            Self::Needs { option, needs } => write!(f, "{option} needs {needs}"),
            Self::SampleRange { sample, bits } => write!(
                f,
                "sample {sample} exceeds {bits}-bit range (pass the right --bits)"
            ),
            Self::InFile { path, error } => write!(f, "{}: {error}", path.display()),
            Self::Simulation(e) => e.fmt(f),
            Self::Options(e) => e.fmt(f),
            Self::Message(message) => f.write_str(message),
            Self::NoiseEstimate { reason } => {
                write!(f, "the noise profile could not be estimated: {reason}")
            }
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Format(e) => Some(e),
            Self::Isp(e) | Self::InStage { source: e, .. } => Some(e),
            Self::Optics { source, .. } => Some(source),
            Self::InFile { error, .. } => Some(error.as_ref()),
            Self::Simulation(e) => Some(e),
            Self::Options(e) => Some(e),
            _ => None,
        }
    }
}

impl From<FormatError> for Error {
    fn from(e: FormatError) -> Self {
        Error::Format(e)
    }
}

impl From<IspError> for Error {
    fn from(e: IspError) -> Self {
        Error::Isp(e)
    }
}

impl From<host_tracer::Error> for Error {
    fn from(e: host_tracer::Error) -> Self {
        Error::Simulation(e)
    }
}

impl From<crate::isp_options::OptionError> for Error {
    fn from(e: crate::isp_options::OptionError) -> Self {
        Error::Options(e)
    }
}
