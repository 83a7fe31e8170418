//! [`FormatError`]: everything this crate can refuse, as data (the field, the value found, what
//! is allowed); the one-line message a user reads is its `Display`.

use std::fmt;
use std::path::PathBuf;

/// A file that could not be read, decoded, encoded or written.
#[derive(Debug)]
#[non_exhaustive]
pub enum FormatError {
    /// The operating system refused to open, read or write `path`.
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The contents of `path` were refused; `error` says why.
    InFile {
        /// The file.
        path: PathBuf,
        /// Why.
        error: Box<FormatError>,
    },
    /// The bytes end before `len` bytes at `offset` that the file points to.
    Truncated {
        /// Where the missing bytes start.
        offset: usize,
        /// How many bytes were needed there.
        len: usize,
    },
    /// The bytes are not a file of this format.
    NotFormat {
        /// The format expected, e.g. `TIFF/DNG`.
        format: &'static str,
        /// What gave it away, e.g. `bad header`.
        reason: &'static str,
    },
    /// A required field (a TIFF tag, a header entry) is absent or holds no value.
    Missing {
        /// The field's name, e.g. `ImageWidth`.
        field: &'static str,
        /// Its TIFF tag number, where it has one.
        tag: Option<u16>,
    },
    /// A DNG has no CFA image (PhotometricInterpretation 32803, NewSubfileType 0) in IFD 0 or
    /// its SubIFDs.
    NoCfaImage,
    /// A TIFF field's type is unknown, or not a number where one is needed.
    FieldType {
        /// The TIFF field type code.
        field_type: u16,
    },
    /// A TIFF field claims more values than any real file holds.
    FieldTooLong {
        /// The count it claims.
        count: u32,
    },
    /// The samples' bit depth is not one this reader handles.
    SampleBits {
        /// BitsPerSample as the file states it.
        bits: u32,
    },
    /// The samples are compressed in a way this reader does not decode.
    Compression {
        /// The TIFF Compression value.
        value: u32,
    },
    /// A lossless JPEG stream is damaged or uses what this decoder does not support.
    LosslessJpeg {
        /// Byte offset in the stream where it went wrong.
        offset: usize,
        /// What was wrong.
        problem: &'static str,
    },
    /// A DCT JPEG stream (Compression 7's lossy form) is damaged or uses what this decoder
    /// does not support.
    DctJpeg {
        /// Byte offset in the stream where it went wrong.
        offset: usize,
        /// What was wrong.
        problem: &'static str,
    },
    /// A lossy (baseline) JPEG stream is damaged or not what a DNG holds.
    LossyJpeg {
        /// What was wrong, as the decoder (`jpeg-decoder`) says.
        problem: String,
    },
    /// A field holds a value this reader does not support.
    Unsupported {
        /// The field.
        field: &'static str,
        /// The value found, as the file has it.
        value: String,
        /// What is supported.
        supported: &'static str,
    },
    /// A value is outside its allowed range.
    OutOfRange {
        /// The field or parameter.
        field: &'static str,
        /// The value found.
        value: String,
        /// The allowed range.
        allowed: String,
    },
    /// Two sizes that must agree do not.
    SizeMismatch {
        /// What is counted, e.g. `strip bytes`.
        what: &'static str,
        /// How many there are.
        found: usize,
        /// How many are needed.
        expected: usize,
    },
    /// A black level is not below the white level.
    BlackNotBelowWhite {
        /// Black level per 2x2 CFA position.
        black: [u16; 4],
        /// White level.
        white: u16,
    },
    /// A colour matrix cannot be inverted or used as a calibration.
    Colour {
        /// Which matrix or tag.
        field: &'static str,
        /// isp-core's reason.
        source: isp_core::IspError,
    },
    /// A file name's extension names no format this crate writes or reads.
    UnknownExtension {
        /// The extensions accepted.
        expected: &'static str,
    },
    /// A TOML file does not parse, or holds a key or value its format does not have.
    Toml {
        /// The `toml` crate's message.
        message: String,
    },
    /// The `png` crate could not decode the file.
    PngDecode(png::DecodingError),
    /// The `png` crate could not encode the image.
    PngEncode(png::EncodingError),
    /// The `jpeg-encoder` crate could not encode the image.
    JpegEncode(String),
}

impl FormatError {
    /// This error, as found in `path`.
    pub fn in_file(self, path: impl Into<PathBuf>) -> Self {
        FormatError::InFile {
            path: path.into(),
            error: Box::new(self),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        FormatError::Io {
            path: path.into(),
            source,
        }
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Self::InFile { path, error } => write!(f, "{}: {error}", path.display()),
            Self::Truncated { offset, len } => write!(
                f,
                "truncated file: {len} bytes at offset {offset} are past its end"
            ),
            Self::NotFormat { format, reason } => write!(f, "not a {format} file ({reason})"),
            Self::Missing { field, tag: Some(tag) } => write!(f, "missing {field} tag ({tag})"),
            Self::Missing { field, tag: None } => write!(f, "missing {field}"),
            Self::NoCfaImage => f.write_str(
                "no raw image (PhotometricInterpretation 32803, CFA, or 34892, LinearRaw, with NewSubfileType 0) in IFD 0 or its SubIFDs",
            ),
            Self::FieldType { field_type } => {
                write!(f, "TIFF field type {field_type} is unknown or not a number")
            }
            Self::FieldTooLong { count } => {
                write!(f, "TIFF field with {count} values is too long")
            }
            Self::SampleBits { bits } => {
                write!(f, "{bits}-bit samples are not supported (8 to 16 are)")
            }
            Self::Compression { value } => {
                let name = match value {
                    8 | 32946 => " (deflate)",
                    52546 => " (JPEG XL)",
                    _ => "",
                };
                write!(
                    f,
                    "Compression {value}{name} is not supported (1, uncompressed, 7, lossless or DCT JPEG, and 34892, lossy JPEG, are)"
                )
            }
            Self::LossyJpeg { problem } => write!(f, "lossy JPEG: {problem}"),
            Self::DctJpeg { offset, problem } => {
                write!(f, "DCT JPEG: {problem} (at byte {offset} of the stream)")
            }
            Self::LosslessJpeg { offset, problem } => {
                write!(f, "lossless JPEG: {problem} (at byte {offset} of the stream)")
            }
            Self::Unsupported {
                field,
                value,
                supported,
            } => write!(f, "{field} {value} is not supported ({supported})"),
            Self::OutOfRange {
                field,
                value,
                allowed,
            } => write!(f, "{field} {value} is outside {allowed}"),
            Self::SizeMismatch {
                what,
                found,
                expected,
            } => write!(f, "{what}: {found} found, {expected} needed"),
            Self::BlackNotBelowWhite { black, white } => {
                write!(f, "black level {black:?} is not below the white level {white}")
            }
            Self::Colour { field, source } => write!(f, "{field}: {source}"),
            Self::UnknownExtension { expected } => {
                write!(f, "unknown image type: expected {expected}")
            }
            Self::Toml { message } => f.write_str(message),
            Self::PngDecode(e) => write!(f, "not a readable PNG: {e}"),
            Self::PngEncode(e) => write!(f, "{e}"),
            Self::JpegEncode(e) => write!(f, "JPEG encoding failed: {e}"),
        }
    }
}

impl std::error::Error for FormatError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            Self::InFile { error, .. } => Some(error.as_ref()),
            Self::Colour { source, .. } => Some(source),
            Self::PngDecode(e) => Some(e),
            Self::PngEncode(e) => Some(e),
            _ => None,
        }
    }
}

/// The result type of this crate.
pub type Result<T> = std::result::Result<T, FormatError>;
