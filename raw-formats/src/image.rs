//! Image files: PNG (8/16-bit grey or RGB, through the `png` crate) and binary PGM/PPM
//! (P5/P6, 8 or 16 bit). Samples are held as `u16` with the file's bit depth; errors name the
//! file and what was wrong with it. [`read_mosaic`] reads a single-channel file as a
//! [`RawImage`].

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

use isp_core::CfaPattern;

use crate::error::{FormatError, Result};
use crate::raw_image::RawImage;

/// An image in memory: `channels` samples per pixel (1 grey, 3 RGB), row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// 1 or 3.
    pub channels: usize,
    /// 8 or 16.
    pub bits: u8,
    /// `width * height * channels` samples.
    pub data: Vec<u16>,
}

const EXTENSIONS: &str = ".png, .pgm or .ppm";

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// Reads a PNG, PGM or PPM file, chosen by its extension.
pub fn read(path: &Path) -> Result<Image> {
    match extension(path).as_deref() {
        Some("png") => read_png(path),
        Some("pgm") | Some("ppm") => read_pnm(path),
        _ => Err(FormatError::UnknownExtension {
            expected: EXTENSIONS,
        }),
    }
    .map_err(|e| match e {
        e @ FormatError::Io { .. } => e,
        e => e.in_file(path),
    })
}

/// Reads a single-channel PNG, PGM or PPM as a raw mosaic: RGGB, `bits` the file's depth,
/// black 0, white the largest code; the caller sets what the file does not say.
pub fn read_mosaic(path: &Path) -> Result<RawImage> {
    let image = read(path)?;
    if image.channels != 1 {
        return Err(FormatError::Unsupported {
            field: "channel count",
            value: image.channels.to_string(),
            supported: "expected a single-channel mosaic",
        }
        .in_file(path));
    }
    let white = ((1u32 << image.bits) - 1) as u16;
    RawImage::new(
        image.width,
        image.height,
        CfaPattern::Rggb,
        image.bits,
        [0; 4],
        white,
        image.data,
    )
    .map_err(|e| e.in_file(path))
}

const WRITE_EXTENSIONS: &str = ".png, .pgm, .ppm, .tif, .tiff, .jpg or .jpeg";

/// How [`write_with`] encodes what the extension leaves open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteOptions {
    /// JPEG quality, 1..=100.
    pub jpeg_quality: u8,
}

impl Default for WriteOptions {
    /// JPEG quality 90.
    fn default() -> Self {
        Self { jpeg_quality: 90 }
    }
}

/// Writes a PNG, PGM (grey), PPM (RGB), TIFF or JPEG file, chosen by its extension, with
/// [`WriteOptions::default`].
pub fn write(path: &Path, image: &Image) -> Result<()> {
    write_with(path, image, &WriteOptions::default())
}

/// Writes an image file chosen by its extension: PNG, PGM/PPM and TIFF (uncompressed, one
/// strip) at the image's 8 or 16 bits, or JPEG (8 bits only) at `options.jpeg_quality`.
pub fn write_with(path: &Path, image: &Image, options: &WriteOptions) -> Result<()> {
    let expected = image
        .width
        .saturating_mul(image.height)
        .saturating_mul(image.channels);
    if !matches!(image.channels, 1 | 3)
        || !matches!(image.bits, 8 | 16)
        || image.data.len() != expected
    {
        return Err(FormatError::SizeMismatch {
            what: "image samples (1 or 3 channels of 8 or 16 bits)",
            found: image.data.len(),
            expected,
        }
        .in_file(path));
    }
    match extension(path).as_deref() {
        Some("png") => write_png(path, image),
        Some("pgm") | Some("ppm") => write_pnm(path, image),
        Some("tif") | Some("tiff") => write_tiff(path, image),
        Some("jpg") | Some("jpeg") => write_jpeg(path, image, options.jpeg_quality),
        _ => Err(FormatError::UnknownExtension {
            expected: WRITE_EXTENSIONS,
        }
        .in_file(path)),
    }
}

/// A baseline TIFF: grey or RGB, 8 or 16 bits, uncompressed, one little-endian strip.
fn write_tiff(path: &Path, image: &Image) -> Result<()> {
    use crate::dng::write::{layout, long, short};
    if image.width > u32::MAX as usize || image.height > u32::MAX as usize {
        return Err(FormatError::OutOfRange {
            field: "TIFF size",
            value: format!("{} x {}", image.width, image.height),
            allowed: "up to 2^32 - 1 on each side".into(),
        }
        .in_file(path));
    }
    let bits = u16::from(image.bits);
    let strip = if image.bits == 8 {
        image.data.iter().map(|v| *v as u8).collect::<Vec<u8>>()
    } else {
        image.data.iter().flat_map(|v| v.to_le_bytes()).collect()
    };
    let entries = vec![
        long(256, &[image.width as u32]),
        long(257, &[image.height as u32]),
        short(258, &vec![bits; image.channels]),
        short(259, &[1]),
        short(262, &[if image.channels == 3 { 2 } else { 1 }]),
        long(273, &[0]), // patched by the layout
        short(277, &[image.channels as u16]),
        long(278, &[image.height as u32]),
        long(279, &[strip.len() as u32]),
        short(284, &[1]),
    ];
    let bytes = layout(entries, &[strip], true);
    std::fs::write(path, bytes).map_err(|e| FormatError::io(path, e))
}

/// A baseline JPEG of an 8-bit image.
fn write_jpeg(path: &Path, image: &Image, quality: u8) -> Result<()> {
    if image.bits != 8 {
        return Err(FormatError::Unsupported {
            field: "bit depth for JPEG",
            value: image.bits.to_string(),
            supported: "8 (write 16-bit images as .png or .tif)",
        }
        .in_file(path));
    }
    if !(1..=100).contains(&quality) {
        return Err(FormatError::OutOfRange {
            field: "JPEG quality",
            value: quality.to_string(),
            allowed: "1..=100".into(),
        }
        .in_file(path));
    }
    let (Ok(width), Ok(height)) = (u16::try_from(image.width), u16::try_from(image.height)) else {
        return Err(FormatError::OutOfRange {
            field: "JPEG size",
            value: format!("{} x {}", image.width, image.height),
            allowed: "up to 65535 on each side".into(),
        }
        .in_file(path));
    };
    let colour = if image.channels == 3 {
        jpeg_encoder::ColorType::Rgb
    } else {
        jpeg_encoder::ColorType::Luma
    };
    let bytes: Vec<u8> = image.data.iter().map(|v| *v as u8).collect();
    let mut out = Vec::new();
    jpeg_encoder::Encoder::new(&mut out, quality)
        .encode(&bytes, width, height, colour)
        .map_err(|e| FormatError::JpegEncode(e.to_string()).in_file(path))?;
    std::fs::write(path, out).map_err(|e| FormatError::io(path, e))
}

fn read_png(path: &Path) -> Result<Image> {
    let file = File::open(path).map_err(|e| FormatError::io(path, e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(FormatError::PngDecode)?;
    let size = reader.output_buffer_size().ok_or(FormatError::OutOfRange {
        field: "PNG size",
        value: "too large".into(),
        allowed: "what fits in memory".into(),
    })?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(FormatError::PngDecode)?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::Rgb => 3,
        other => {
            return Err(FormatError::Unsupported {
                field: "PNG colour type",
                value: format!("{other:?}"),
                supported: "grey or RGB without alpha",
            })
        }
    };
    let (width, height) = (info.width as usize, info.height as usize);
    let bits = match info.bit_depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        other => {
            return Err(FormatError::Unsupported {
                field: "PNG bit depth",
                value: format!("{other:?}"),
                supported: "8 or 16 bits",
            })
        }
    };
    let row_bytes = width * channels * (bits as usize / 8);
    let mut data = Vec::with_capacity(width * height * channels);
    for row in buf.chunks(info.line_size).take(height) {
        let row = &row[..row_bytes];
        if bits == 8 {
            data.extend(row.iter().map(|b| *b as u16));
        } else {
            data.extend(
                row.chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]])),
            );
        }
    }
    Ok(Image {
        width,
        height,
        channels,
        bits,
        data,
    })
}

fn write_png(path: &Path, image: &Image) -> Result<()> {
    let file = File::create(path).map_err(|e| FormatError::io(path, e))?;
    let mut encoder = png::Encoder::new(
        BufWriter::new(file),
        image.width as u32,
        image.height as u32,
    );
    encoder.set_color(if image.channels == 1 {
        png::ColorType::Grayscale
    } else {
        png::ColorType::Rgb
    });
    encoder.set_depth(if image.bits == 8 {
        png::BitDepth::Eight
    } else {
        png::BitDepth::Sixteen
    });
    // fdeflate's PNG-tuned encoder: on a 5 Mpix photo about 10x faster than the default
    // level for files about a tenth larger, so writing does not outlast developing.
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder
        .write_header()
        .map_err(|e| FormatError::PngEncode(e).in_file(path))?;
    writer
        .write_image_data(&to_bytes(image))
        .map_err(|e| FormatError::PngEncode(e).in_file(path))
}

fn to_bytes(image: &Image) -> Vec<u8> {
    if image.bits == 8 {
        image.data.iter().map(|v| *v as u8).collect()
    } else {
        image.data.iter().flat_map(|v| v.to_be_bytes()).collect()
    }
}

fn read_pnm(path: &Path) -> Result<Image> {
    let mut bytes = Vec::new();
    File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(|e| FormatError::io(path, e))?;
    // Header: magic, width, height, maxval, separated by whitespace (and # comments), then one
    // whitespace byte before the samples.
    let mut fields = Vec::new();
    let mut i = 0;
    while fields.len() < 4 {
        while i < bytes.len() && (bytes[i].is_ascii_whitespace() || bytes[i] == b'#') {
            if bytes[i] == b'#' {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            } else {
                i += 1;
            }
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if start == i {
            return Err(FormatError::NotFormat {
                format: "PGM/PPM",
                reason: "truncated header",
            });
        }
        fields.push(String::from_utf8_lossy(&bytes[start..i]).to_string());
    }
    let channels = match fields[0].as_str() {
        "P5" => 1,
        "P6" => 3,
        other => {
            return Err(FormatError::Unsupported {
                field: "PNM magic",
                value: format!("{other:?}"),
                supported: "only binary PGM (P5) and PPM (P6) are read",
            })
        }
    };
    let number = |s: &str, what: &'static str| {
        s.parse::<usize>().map_err(|_| FormatError::OutOfRange {
            field: what,
            value: format!("{s:?}"),
            allowed: "a whole number".into(),
        })
    };
    let (width, height, maxval) = (
        number(&fields[1], "width")?,
        number(&fields[2], "height")?,
        number(&fields[3], "maxval")?,
    );
    if width == 0 || height == 0 || maxval == 0 || maxval > 65535 {
        return Err(FormatError::OutOfRange {
            field: "PGM/PPM width, height, maxval",
            value: format!("{width}, {height}, {maxval}"),
            allowed: ">= 1, >= 1, 1..=65535".into(),
        });
    }
    let bits = if maxval < 256 { 8 } else { 16 };
    let start = (i + 1).min(bytes.len());
    let samples = &bytes[start..];
    let count = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or(FormatError::OutOfRange {
            field: "PGM/PPM size",
            value: format!("{width} x {height}"),
            allowed: "what fits in memory".into(),
        })?;
    let need = count * (bits as usize / 8);
    if samples.len() < need {
        return Err(FormatError::Truncated {
            offset: start,
            len: need,
        });
    }
    let data = if bits == 8 {
        samples[..count].iter().map(|b| *b as u16).collect()
    } else {
        samples[..need]
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect()
    };
    Ok(Image {
        width,
        height,
        channels,
        bits,
        data,
    })
}

fn write_pnm(path: &Path, image: &Image) -> Result<()> {
    let magic = if image.channels == 1 { "P5" } else { "P6" };
    let maxval = if image.bits == 8 { 255 } else { 65535 };
    let io = |e| FormatError::io(path, e);
    let mut w = BufWriter::new(File::create(path).map_err(io)?);
    write!(w, "{magic}\n{} {}\n{maxval}\n", image.width, image.height).map_err(io)?;
    w.write_all(&to_bytes(image)).map_err(io)?;
    w.flush().map_err(io)
}
