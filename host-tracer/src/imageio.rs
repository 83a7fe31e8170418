//! Image files: PNG (8/16-bit grey or RGB, through the `png` crate) and binary PGM/PPM
//! (P5/P6, 8 or 16 bit). Samples are held as `u16` with the file's bit depth; errors name the
//! file and what was wrong with it.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

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

fn err(path: &Path, what: impl std::fmt::Display) -> String {
    format!("{}: {what}", path.display())
}

/// Reads a PNG, PGM or PPM file, chosen by its extension.
pub fn read(path: &Path) -> Result<Image, String> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("png") => read_png(path),
        Some("pgm") | Some("ppm") => read_pnm(path),
        _ => Err(err(path, "unknown image type: expected .png, .pgm or .ppm")),
    }
}

/// Writes a PNG, PGM (grey) or PPM (RGB) file, chosen by its extension.
pub fn write(path: &Path, image: &Image) -> Result<(), String> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("png") => write_png(path, image),
        Some("pgm") | Some("ppm") => write_pnm(path, image),
        _ => Err(err(path, "unknown image type: expected .png, .pgm or .ppm")),
    }
}

fn read_png(path: &Path) -> Result<Image, String> {
    let file = File::open(path).map_err(|e| err(path, e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| err(path, format!("not a readable PNG: {e}")))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| err(path, "PNG too large"))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| err(path, format!("corrupt PNG: {e}")))?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::Rgb => 3,
        other => {
            return Err(err(
                path,
                format!("{other:?} PNG: expected grey or RGB without alpha"),
            ))
        }
    };
    let (width, height) = (info.width as usize, info.height as usize);
    let bits = match info.bit_depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        other => {
            return Err(err(
                path,
                format!("{other:?}-bit PNG: expected 8 or 16 bits"),
            ))
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

fn write_png(path: &Path, image: &Image) -> Result<(), String> {
    let file = File::create(path).map_err(|e| err(path, e))?;
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
    let mut writer = encoder.write_header().map_err(|e| err(path, e))?;
    writer
        .write_image_data(&to_bytes(image))
        .map_err(|e| err(path, e))
}

fn to_bytes(image: &Image) -> Vec<u8> {
    if image.bits == 8 {
        image.data.iter().map(|v| *v as u8).collect()
    } else {
        image.data.iter().flat_map(|v| v.to_be_bytes()).collect()
    }
}

fn read_pnm(path: &Path) -> Result<Image, String> {
    let mut bytes = Vec::new();
    File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(|e| err(path, e))?;
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
            return Err(err(path, "truncated PGM/PPM header"));
        }
        fields.push(String::from_utf8_lossy(&bytes[start..i]).to_string());
    }
    let channels = match fields[0].as_str() {
        "P5" => 1,
        "P6" => 3,
        other => {
            return Err(err(
                path,
                format!("{other:?}: only binary PGM (P5) and PPM (P6) are read"),
            ))
        }
    };
    let number = |s: &str, what: &str| {
        s.parse::<usize>()
            .map_err(|_| err(path, format!("bad {what} {s:?} in header")))
    };
    let (width, height, maxval) = (
        number(&fields[1], "width")?,
        number(&fields[2], "height")?,
        number(&fields[3], "maxval")?,
    );
    if width == 0 || height == 0 || maxval == 0 || maxval > 65535 {
        return Err(err(
            path,
            "width and height must be >= 1 and maxval 1..=65535",
        ));
    }
    let bits = if maxval < 256 { 8 } else { 16 };
    let samples = &bytes[(i + 1).min(bytes.len())..];
    let count = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or_else(|| err(path, "image too large"))?;
    let need = count * (bits as usize / 8);
    if samples.len() < need {
        return Err(err(
            path,
            format!(
                "truncated: {need} bytes of samples expected, {} present",
                samples.len()
            ),
        ));
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

fn write_pnm(path: &Path, image: &Image) -> Result<(), String> {
    let magic = if image.channels == 1 { "P5" } else { "P6" };
    let maxval = if image.bits == 8 { 255 } else { 65535 };
    let mut w = BufWriter::new(File::create(path).map_err(|e| err(path, e))?);
    write!(w, "{magic}\n{} {}\n{maxval}\n", image.width, image.height).map_err(|e| err(path, e))?;
    w.write_all(&to_bytes(image)).map_err(|e| err(path, e))?;
    w.flush().map_err(|e| err(path, e))
}
