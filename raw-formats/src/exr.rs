//! A minimal OpenEXR writer: scanline image, no compression, 32-bit float channels. Enough for
//! linear radiance that any EXR reader (OpenEXR, Mitsuba's `Bitmap`, the `exr` crate) opens.
//!
//! Layout (OpenEXR file-layout document): magic and version, a header of attributes ended by a
//! null byte, a table of one offset per scanline, then each scanline as `y`, byte count, and
//! the channels' samples in alphabetical channel order.

use std::io::Write;
use std::path::Path;

use crate::error::{FormatError, Result};

fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    out.extend_from_slice(name.as_bytes());
    out.push(0);
    out.extend_from_slice(kind.as_bytes());
    out.push(0);
    out.extend_from_slice(&(value.len() as i32).to_le_bytes());
    out.extend_from_slice(value);
}

/// Encodes a `width` x `height` image whose named channels are given as planes of
/// `width * height` samples each, row-major from the top.
pub fn encode(width: usize, height: usize, channels: &[(&str, &[f32])]) -> Result<Vec<u8>> {
    if width == 0 || height == 0 || width > i32::MAX as usize || height > i32::MAX as usize {
        return Err(FormatError::OutOfRange {
            field: "EXR size",
            value: format!("{width} x {height}"),
            allowed: format!("1..={} on each side", i32::MAX),
        });
    }
    let mut sorted: Vec<&(&str, &[f32])> = channels.iter().collect();
    sorted.sort_by(|a, b| a.0.cmp(b.0));
    for (name, plane) in &sorted {
        if name.is_empty() || name.contains('\0') {
            return Err(FormatError::Unsupported {
                field: "EXR channel name",
                value: format!("{name:?}"),
                supported: "a non-empty name without NUL",
            });
        }
        if plane.len() != width * height {
            return Err(FormatError::SizeMismatch {
                what: "EXR channel samples",
                found: plane.len(),
                expected: width * height,
            });
        }
    }
    let mut out = Vec::with_capacity(width * height * 4 * sorted.len() + 1024);
    out.extend_from_slice(&20000630i32.to_le_bytes());
    out.extend_from_slice(&[2, 0, 0, 0]); // version 2, single-part scanline
    let mut chlist = Vec::new();
    for (name, _) in &sorted {
        chlist.extend_from_slice(name.as_bytes());
        chlist.push(0);
        chlist.extend_from_slice(&2i32.to_le_bytes()); // FLOAT
        chlist.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        chlist.extend_from_slice(&1i32.to_le_bytes()); // x sampling
        chlist.extend_from_slice(&1i32.to_le_bytes()); // y sampling
    }
    chlist.push(0);
    attribute(&mut out, "channels", "chlist", &chlist);
    attribute(&mut out, "compression", "compression", &[0]);
    let mut window = Vec::new();
    for v in [0, 0, width as i32 - 1, height as i32 - 1] {
        window.extend_from_slice(&v.to_le_bytes());
    }
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    attribute(&mut out, "pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    let mut centre = Vec::new();
    centre.extend_from_slice(&0.0f32.to_le_bytes());
    centre.extend_from_slice(&0.0f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &centre);
    attribute(
        &mut out,
        "screenWindowWidth",
        "float",
        &1.0f32.to_le_bytes(),
    );
    out.push(0);
    let line_bytes = width * 4 * sorted.len();
    let table_start = out.len();
    let first_line = table_start + 8 * height;
    for y in 0..height {
        let offset = (first_line + y * (8 + line_bytes)) as u64;
        out.extend_from_slice(&offset.to_le_bytes());
    }
    for y in 0..height {
        out.extend_from_slice(&(y as i32).to_le_bytes());
        out.extend_from_slice(&(line_bytes as i32).to_le_bytes());
        for (_, plane) in &sorted {
            for v in &plane[y * width..(y + 1) * width] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    Ok(out)
}

/// Writes interleaved linear RGB (`3 * width * height` values) as an EXR with channels R, G, B.
pub fn write_rgb(path: &Path, width: usize, height: usize, rgb: &[f32]) -> Result<()> {
    if rgb.len() != 3 * width * height {
        return Err(FormatError::SizeMismatch {
            what: "RGB values",
            found: rgb.len(),
            expected: 3 * width * height,
        }
        .in_file(path));
    }
    let plane = |c: usize| -> Vec<f32> { rgb.iter().skip(c).step_by(3).copied().collect() };
    let (r, g, b) = (plane(0), plane(1), plane(2));
    let bytes =
        encode(width, height, &[("R", &r), ("G", &g), ("B", &b)]).map_err(|e| e.in_file(path))?;
    std::fs::File::create(path)
        .and_then(|mut f| f.write_all(&bytes))
        .map_err(|e| FormatError::io(path, e))
}
