//! DNG opcode lists (OpcodeList1/2/3, tags 51008/51009/51022): the processing steps a file
//! asks for, always big-endian whatever the file's byte order (DNG 1.4, chapter 7). Each list
//! is a count, then per opcode its id, the DNG version it was written for, its flags (bit 0:
//! optional; bit 1: may be skipped for previews), the size of its parameters, and those.
//!
//! Parsed here are the opcodes the pipeline has stages for: GainMap (lens shading),
//! FixBadPixelsConstant and FixBadPixelsList (defect correction) and WarpRectilinear (lens
//! distortion), and the two the reader applies to OpcodeList2's samples, MapTable and
//! MapPolynomial (Adobe's lossy DNGs map their 8-bit JPEG samples to linear with the latter).
//! Any other is kept as [`Opcode::Other`] with its id and flags, so the developer
//! can skip an optional one with a note and refuse one that is not optional, by name.

use crate::error::{FormatError, Result};

/// GainMap (opcode 9): gains over a grid, relative to the image area, for some planes of a
/// region of pixels, applied by multiplying.
#[derive(Debug, Clone, PartialEq)]
pub struct GainMap {
    /// The region `[top, left, bottom, right]` the map applies to.
    pub area: [u32; 4],
    /// First plane (colour) and the number of planes it applies to.
    pub plane: u32,
    /// Number of planes.
    pub planes: u32,
    /// Only every `row_pitch`-th row and `col_pitch`-th column of the area take gains (2 and 2
    /// with a phase from `area` selects one CFA colour).
    pub row_pitch: u32,
    /// Column pitch, as `row_pitch`.
    pub col_pitch: u32,
    /// Map points vertically and horizontally.
    pub points: [u32; 2],
    /// Spacing of map points, vertically and horizontally, as fractions of the image size.
    pub spacing: [f64; 2],
    /// Position of the first map point, vertically and horizontally, as fractions of the
    /// image size.
    pub origin: [f64; 2],
    /// Planes in the map (1: the same gains for every plane).
    pub map_planes: u32,
    /// Gains, `points[0] x points[1] x map_planes`, row by row, planes innermost.
    pub gains: Vec<f32>,
}

/// The samples an opcode applies to: a region, some planes, every `row_pitch`-th row and
/// `col_pitch`-th column of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// `[top, left, bottom, right]`.
    pub area: [u32; 4],
    /// First plane.
    pub plane: u32,
    /// Number of planes.
    pub planes: u32,
    /// Row pitch (at least 1).
    pub row_pitch: u32,
    /// Column pitch (at least 1).
    pub col_pitch: u32,
}

impl Region {
    /// The region's fields as an opcode's parameters write them (big-endian): area, plane,
    /// planes, row pitch, column pitch.
    fn encode(&self, out: &mut Vec<u8>) {
        let fields = [self.plane, self.planes, self.row_pitch, self.col_pitch];
        for v in self.area.iter().chain(&fields) {
            out.extend_from_slice(&v.to_be_bytes());
        }
    }

    /// Whether sample `plane` of pixel `(x, y)` is in the region.
    pub fn covers(&self, x: usize, y: usize, plane: usize) -> bool {
        let [top, left, bottom, right] = self.area.map(|v| v as usize);
        let first = self.plane as usize;
        (top..bottom).contains(&y)
            && (left..right).contains(&x)
            && (first..first.saturating_add(self.planes as usize)).contains(&plane)
            && (y - top).is_multiple_of(self.row_pitch.max(1) as usize)
            && (x - left).is_multiple_of(self.col_pitch.max(1) as usize)
    }
}

/// One opcode of a list.
#[derive(Debug, Clone, PartialEq)]
pub enum Opcode {
    /// MapTable (opcode 7): each sample of the region replaced by `table[sample]` (the last
    /// entry for samples past its end), on the 16-bit scale of the list's stage.
    MapTable {
        /// The samples it applies to.
        region: Region,
        /// 1..=65536 entries.
        table: Vec<u16>,
    },
    /// MapPolynomial (opcode 8): each sample of the region, as a fraction `x` of full scale,
    /// replaced by `sum c_i x^i`, clipped to `[0, 1]`.
    MapPolynomial {
        /// The samples it applies to.
        region: Region,
        /// `c_0..=c_degree`, degree at most 8.
        coefficients: Vec<f64>,
    },
    /// WarpRectilinear (opcode 1): radial and tangential distortion per plane, about an optical
    /// centre given as fractions of the image size.
    WarpRectilinear {
        /// Per plane: kr0, kr1, kr2, kr3 (radial), kt0, kt1 (tangential).
        planes: Vec<[f64; 6]>,
        /// Optical centre (x, y), normalised to the image size.
        centre: [f64; 2],
    },
    /// FixBadPixelsConstant (opcode 4): every pixel whose raw value is `constant` is defective.
    FixBadPixelsConstant {
        /// The marker value.
        constant: u32,
        /// The CFA phase of the image's top-left pixel (0 red, 1 green on a red row, ...).
        bayer_phase: u32,
    },
    /// FixBadPixelsList (opcode 5): listed defective pixels and rectangles.
    FixBadPixelsList {
        /// The CFA phase of the image's top-left pixel.
        bayer_phase: u32,
        /// Defective pixels as (row, column).
        points: Vec<[u32; 2]>,
        /// Defective rectangles as (top, left, bottom, right).
        rects: Vec<[u32; 4]>,
    },
    /// GainMap (opcode 9).
    GainMap(GainMap),
    /// Any other opcode, by id, with whether the file marks it optional.
    Other {
        /// The opcode id.
        id: u32,
        /// Flag bit 0: a reader may skip it.
        optional: bool,
    },
}

impl Opcode {
    /// The opcode's name in the DNG specification.
    pub fn name(&self) -> &'static str {
        match self {
            Opcode::WarpRectilinear { .. } => "WarpRectilinear",
            Opcode::FixBadPixelsConstant { .. } => "FixBadPixelsConstant",
            Opcode::FixBadPixelsList { .. } => "FixBadPixelsList",
            Opcode::GainMap(_) => "GainMap",
            Opcode::MapTable { .. } => "MapTable",
            Opcode::MapPolynomial { .. } => "MapPolynomial",
            Opcode::Other { id, .. } => match id {
                2 => "WarpFisheye",
                3 => "FixVignetteRadial",
                6 => "TrimBounds",
                7 => "MapTable",
                8 => "MapPolynomial",
                10 => "DeltaPerRow",
                11 => "DeltaPerColumn",
                12 => "ScalePerRow",
                13 => "ScalePerColumn",
                14 => "WarpRectilinear2",
                _ => "an unknown opcode",
            },
        }
    }
}

impl GainMap {
    /// The map's gain at a pixel `(x, y)` of a `width` x `height` image, bilinear between map
    /// points and held at the map's edges; `None` where the map does not apply (outside its
    /// area, or off its row and column pitch). Pixel centres sit at `(x + 0.5) / width` on
    /// the map's 0..1 scale, as the DNG SDK places them.
    pub fn gain_at(&self, x: usize, y: usize, width: usize, height: usize) -> Option<f32> {
        if !self.covers(x, y) {
            return None;
        }
        let u = (x as f64 + 0.5) / width.max(1) as f64;
        let v = (y as f64 + 0.5) / height.max(1) as f64;
        Some(self.gain_at_fraction(u, v))
    }

    /// Whether the map applies to pixel `(x, y)`: inside its area and on its pitch.
    pub fn covers(&self, x: usize, y: usize) -> bool {
        let [top, left, bottom, right] = self.area.map(|v| v as usize);
        (top..bottom).contains(&y)
            && (left..right).contains(&x)
            && (y - top).is_multiple_of(self.row_pitch as usize)
            && (x - left).is_multiple_of(self.col_pitch as usize)
    }

    /// The map's gain at `(u, v)` on its 0..1 scale of the image's width and height: bilinear
    /// between map points, held at the map's edges.
    pub fn gain_at_fraction(&self, u: f64, v: f64) -> f32 {
        let position = |p: f64, axis: usize| {
            let t = (p - self.origin[axis]) / self.spacing[axis].max(f64::MIN_POSITIVE);
            let last = (self.points[axis] - 1) as f64;
            let t = t.clamp(0.0, last);
            let i = (t.floor() as usize).min(self.points[axis].saturating_sub(2) as usize);
            (i, (t - i as f64) as f32)
        };
        let (row, fy) = position(v, 0);
        let (col, fx) = position(u, 1);
        let (rows, cols) = (self.points[0] as usize, self.points[1] as usize);
        let planes = self.map_planes as usize;
        let at =
            |r: usize, c: usize| self.gains[(r.min(rows - 1) * cols + c.min(cols - 1)) * planes];
        let top_gain = at(row, col) * (1.0 - fx) + at(row, col + 1) * fx;
        let bottom_gain = at(row + 1, col) * (1.0 - fx) + at(row + 1, col + 1) * fx;
        top_gain * (1.0 - fy) + bottom_gain * fy
    }
}

/// A WarpRectilinear as OpenCV's distortion model, for a `width` x `height` image: the
/// coefficients `[k1, k2, p1, p2, k3]` and the camera matrix `[fx, fy, cx, cy]` in pixels (of
/// pixel indices, so pixel `i`'s centre is at `i`). The DNG warp maps an output pixel at offset
/// `d` from the optical centre, in units of the largest centre-to-corner distance `m`, to the
/// source offset `(kr0 + kr1 r^2 + kr2 r^4 + kr3 r^6) d` plus the tangential terms (DNG 1.4,
/// opcode 1): OpenCV's model with `f = m`, `k = kr1..kr3`, `p1 = kt0`, `p2 = kt1`, when
/// `kr0` is 1 (another `kr0` scales the image, which one camera matrix cannot) and every plane
/// has the same warp (different ones correct lateral chromatic aberration, which the pipeline's
/// one distortion stage does not). `None` otherwise, or for another opcode.
pub fn warp_as_opencv(op: &Opcode, width: usize, height: usize) -> Option<([f64; 5], [f64; 4])> {
    let Opcode::WarpRectilinear { planes, centre } = op else {
        return None;
    };
    let k = planes.first()?;
    if planes.iter().any(|p| p != k) || (k[0] - 1.0).abs() > 1e-9 {
        return None;
    }
    // The centre on the continuous image plane (pixel i spans [i, i + 1)).
    let (w, h) = (width as f64, height as f64);
    let (cx, cy) = (centre[0] * w, centre[1] * h);
    let m = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|(x, y)| (x - cx).hypot(y - cy))
        .fold(0.0, f64::max);
    if !(m.is_finite() && m > 0.0) {
        return None;
    }
    Some(([k[1], k[2], k[4], k[5], k[3]], [m, m, cx - 0.5, cy - 0.5]))
}

/// The GainMaps of `list` as a lens-shading grid for isp-core: `grid_w` x `grid_h` nodes over
/// a `width` x `height` CFA image, four gains per node (one per 2x2 CFA position, row by row:
/// the product of every map that applies to that position there, 1 where none does), or
/// `None` if the list has no GainMap. Maps for other planes than the first are left out (a
/// CFA image has one plane).
pub fn shading_grid(
    list: &[Opcode],
    width: usize,
    height: usize,
    grid_w: usize,
    grid_h: usize,
) -> Option<Vec<f32>> {
    let maps: Vec<&GainMap> = list
        .iter()
        .filter_map(|op| match op {
            Opcode::GainMap(g) if g.plane == 0 => Some(g),
            _ => None,
        })
        .collect();
    if maps.is_empty() || grid_w < 2 || grid_h < 2 || width < 2 || height < 2 {
        return None;
    }
    let mut grid = Vec::with_capacity(grid_w * grid_h * 4);
    for gy in 0..grid_h {
        // The node sits on pixel row gy (h - 1) / (grid_h - 1), fractional, as isp-core's grid
        // places it: the maps are evaluated exactly there.
        let py = (gy * (height - 1)) as f64 / (grid_h - 1) as f64;
        for gx in 0..grid_w {
            let px = (gx * (width - 1)) as f64 / (grid_w - 1) as f64;
            let (u, v) = ((px + 0.5) / width as f64, (py + 0.5) / height as f64);
            for p in 0..4 {
                // Whether a map applies to this CFA position is read at the pixel of that
                // position nearest the node.
                let near = |c: f64, phase: usize, n: usize| {
                    (((c / 2.0).round() as usize) * 2 + phase).min(n - 1 - (n - 1 + phase) % 2)
                };
                let (x, y) = (near(px, p % 2, width), near(py, p / 2, height));
                let gain: f32 = maps
                    .iter()
                    .filter(|m| m.covers(x, y))
                    .map(|m| m.gain_at_fraction(u, v))
                    .product();
                grid.push(gain);
            }
        }
    }
    Some(grid)
}

/// Big-endian reads over one opcode's parameters, every read checked.
struct Reader<'a> {
    data: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let bytes = self
            .at
            .checked_add(N)
            .and_then(|end| self.data.get(self.at..end))
            .ok_or(FormatError::Truncated {
                offset: self.at,
                len: N,
            })?;
        self.at += N;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32> {
        self.take().map(u32::from_be_bytes)
    }

    fn f64(&mut self) -> Result<f64> {
        let v = f64::from_be_bytes(self.take()?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(FormatError::OutOfRange {
                field: "opcode parameter",
                value: v.to_string(),
                allowed: "a finite number".into(),
            })
        }
    }

    fn f32(&mut self) -> Result<f32> {
        let v = f32::from_be_bytes(self.take()?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(FormatError::OutOfRange {
                field: "GainMap gain",
                value: v.to_string(),
                allowed: "a finite number".into(),
            })
        }
    }

    /// `count` items of `size` bytes must fit in what is left: checked before allocating.
    fn room_for(&self, count: u64, size: u64, what: &'static str) -> Result<usize> {
        let left = (self.data.len() - self.at.min(self.data.len())) as u64;
        if count.saturating_mul(size) > left {
            return Err(FormatError::SizeMismatch {
                what,
                found: left as usize,
                expected: count.saturating_mul(size).min(usize::MAX as u64) as usize,
            });
        }
        Ok(count as usize)
    }
}

fn parse_one(id: u32, optional: bool, params: &[u8]) -> Result<Opcode> {
    let mut r = Reader {
        data: params,
        at: 0,
    };
    Ok(match id {
        1 => {
            let n = r.u32()?;
            if !(1..=4).contains(&n) {
                return Err(FormatError::OutOfRange {
                    field: "WarpRectilinear planes",
                    value: n.to_string(),
                    allowed: "1..=4".into(),
                });
            }
            let mut planes = Vec::with_capacity(n as usize);
            for _ in 0..n {
                let mut k = [0.0; 6];
                for v in k.iter_mut() {
                    *v = r.f64()?;
                }
                planes.push(k);
            }
            let centre = [r.f64()?, r.f64()?];
            Opcode::WarpRectilinear { planes, centre }
        }
        4 => Opcode::FixBadPixelsConstant {
            constant: r.u32()?,
            bayer_phase: r.u32()?,
        },
        5 => {
            let bayer_phase = r.u32()?;
            let (n_points, n_rects) = (r.u32()?, r.u32()?);
            let n_points = r.room_for(u64::from(n_points), 8, "FixBadPixelsList points")?;
            let mut points = Vec::with_capacity(n_points);
            for _ in 0..n_points {
                points.push([r.u32()?, r.u32()?]);
            }
            let n_rects = r.room_for(u64::from(n_rects), 16, "FixBadPixelsList rectangles")?;
            let mut rects = Vec::with_capacity(n_rects);
            for _ in 0..n_rects {
                rects.push([r.u32()?, r.u32()?, r.u32()?, r.u32()?]);
            }
            Opcode::FixBadPixelsList {
                bayer_phase,
                points,
                rects,
            }
        }
        9 => {
            let area = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
            let (plane, planes, row_pitch, col_pitch) = (r.u32()?, r.u32()?, r.u32()?, r.u32()?);
            let points = [r.u32()?, r.u32()?];
            let spacing = [r.f64()?, r.f64()?];
            let origin = [r.f64()?, r.f64()?];
            let map_planes = r.u32()?;
            if points[0] == 0
                || points[1] == 0
                || map_planes == 0
                || row_pitch == 0
                || col_pitch == 0
            {
                return Err(FormatError::OutOfRange {
                    field: "GainMap points, planes or pitch",
                    value: format!("{points:?}, {map_planes}, {row_pitch}x{col_pitch}"),
                    allowed: "at least 1 each".into(),
                });
            }
            let count = u64::from(points[0])
                .saturating_mul(u64::from(points[1]))
                .saturating_mul(u64::from(map_planes));
            let count = r.room_for(count, 4, "GainMap gains")?;
            let mut gains = Vec::with_capacity(count);
            for _ in 0..count {
                gains.push(r.f32()?);
            }
            Opcode::GainMap(GainMap {
                area,
                plane,
                planes,
                row_pitch,
                col_pitch,
                points,
                spacing,
                origin,
                map_planes,
                gains,
            })
        }
        7 | 8 => {
            let area = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
            let region = Region {
                area,
                plane: r.u32()?,
                planes: r.u32()?,
                row_pitch: r.u32()?,
                col_pitch: r.u32()?,
            };
            if region.row_pitch == 0 || region.col_pitch == 0 {
                return Err(FormatError::OutOfRange {
                    field: "MapTable/MapPolynomial pitch",
                    value: format!("{}x{}", region.row_pitch, region.col_pitch),
                    allowed: "at least 1 each".into(),
                });
            }
            let n = r.u32()?;
            if id == 7 {
                if !(1..=65536).contains(&n) {
                    return Err(FormatError::OutOfRange {
                        field: "MapTable size",
                        value: n.to_string(),
                        allowed: "1..=65536".into(),
                    });
                }
                let n = r.room_for(u64::from(n), 2, "MapTable entries")?;
                let mut table = Vec::with_capacity(n);
                for _ in 0..n {
                    let [a, b] = r.take()?;
                    table.push(u16::from_be_bytes([a, b]));
                }
                Opcode::MapTable { region, table }
            } else {
                if n > 8 {
                    return Err(FormatError::OutOfRange {
                        field: "MapPolynomial degree",
                        value: n.to_string(),
                        allowed: "0..=8".into(),
                    });
                }
                let mut coefficients = Vec::with_capacity(n as usize + 1);
                for _ in 0..=n {
                    coefficients.push(r.f64()?);
                }
                Opcode::MapPolynomial {
                    region,
                    coefficients,
                }
            }
        }
        _ => Opcode::Other { id, optional },
    })
}

impl Opcode {
    /// For MapTable and MapPolynomial, the mapped value of a sample `v` of plane `plane` at
    /// pixel `(x, y)` on the 0..=65535 scale; `None` for other opcodes or samples outside
    /// the region.
    pub fn map_sample(&self, x: usize, y: usize, plane: usize, v: u16) -> Option<u16> {
        match self {
            Opcode::MapTable { region, table } if region.covers(x, y, plane) => {
                table.get(usize::from(v)).or(table.last()).copied()
            }
            Opcode::MapPolynomial {
                region,
                coefficients,
            } if region.covers(x, y, plane) => {
                let t = f64::from(v) / 65535.0;
                // Horner's rule from the highest coefficient.
                let y = coefficients.iter().rev().fold(0.0, |acc, c| acc * t + c);
                let y = if y.is_finite() {
                    y.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                Some((y * 65535.0).round() as u16)
            }
            _ => None,
        }
    }
}

/// Parses an opcode list's bytes.
pub fn parse(data: &[u8]) -> Result<Vec<Opcode>> {
    let mut r = Reader { data, at: 0 };
    let count = r.u32()?;
    // Each opcode has a 16-byte header at least.
    let count = r.room_for(u64::from(count), 16, "opcodes")?;
    let mut list = Vec::with_capacity(count);
    for _ in 0..count {
        let id = r.u32()?;
        let _version: [u8; 4] = r.take()?;
        let flags = r.u32()?;
        let size = r.u32()?;
        let size = r.room_for(u64::from(size), 1, "opcode parameters")?;
        let params = &data[r.at..r.at + size];
        r.at += size;
        let optional = flags & 1 != 0;
        list.push(parse_one(id, optional, params)?);
    }
    Ok(list)
}

/// An opcode list's bytes (big-endian), for the writer and the tests.
pub fn encode(list: &[Opcode]) -> Vec<u8> {
    let mut out = (list.len() as u32).to_be_bytes().to_vec();
    for op in list {
        let mut p = Vec::new();
        let u = |p: &mut Vec<u8>, v: u32| p.extend_from_slice(&v.to_be_bytes());
        let d = |p: &mut Vec<u8>, v: f64| p.extend_from_slice(&v.to_be_bytes());
        let (id, optional) = match op {
            Opcode::WarpRectilinear { planes, centre } => {
                u(&mut p, planes.len() as u32);
                for k in planes {
                    k.iter().for_each(|v| d(&mut p, *v));
                }
                centre.iter().for_each(|v| d(&mut p, *v));
                (1, false)
            }
            Opcode::FixBadPixelsConstant {
                constant,
                bayer_phase,
            } => {
                u(&mut p, *constant);
                u(&mut p, *bayer_phase);
                (4, false)
            }
            Opcode::FixBadPixelsList {
                bayer_phase,
                points,
                rects,
            } => {
                u(&mut p, *bayer_phase);
                u(&mut p, points.len() as u32);
                u(&mut p, rects.len() as u32);
                points.iter().flatten().for_each(|v| u(&mut p, *v));
                rects.iter().flatten().for_each(|v| u(&mut p, *v));
                (5, false)
            }
            Opcode::GainMap(g) => {
                g.area.iter().for_each(|v| u(&mut p, *v));
                for v in [g.plane, g.planes, g.row_pitch, g.col_pitch] {
                    u(&mut p, v);
                }
                g.points.iter().for_each(|v| u(&mut p, *v));
                g.spacing
                    .iter()
                    .chain(&g.origin)
                    .for_each(|v| d(&mut p, *v));
                u(&mut p, g.map_planes);
                g.gains
                    .iter()
                    .for_each(|v| p.extend_from_slice(&v.to_be_bytes()));
                (9, false)
            }
            Opcode::MapTable { region, table } => {
                region.encode(&mut p);
                u(&mut p, table.len() as u32);
                table
                    .iter()
                    .for_each(|v| p.extend_from_slice(&v.to_be_bytes()));
                (7, false)
            }
            Opcode::MapPolynomial {
                region,
                coefficients,
            } => {
                region.encode(&mut p);
                u(&mut p, coefficients.len().saturating_sub(1) as u32);
                coefficients.iter().for_each(|v| d(&mut p, *v));
                (8, false)
            }
            Opcode::Other { id, optional } => (*id, *optional),
        };
        out.extend_from_slice(&id.to_be_bytes());
        out.extend_from_slice(&[1, 3, 0, 0]);
        out.extend_from_slice(&u32::from(optional).to_be_bytes());
        out.extend_from_slice(&(p.len() as u32).to_be_bytes());
        out.extend_from_slice(&p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_kind() -> Vec<Opcode> {
        vec![
            Opcode::GainMap(GainMap {
                area: [0, 1, 100, 200],
                plane: 0,
                planes: 1,
                row_pitch: 2,
                col_pitch: 2,
                points: [3, 4],
                spacing: [0.5, 1.0 / 3.0],
                origin: [0.0, 0.0],
                map_planes: 1,
                gains: (0..12).map(|i| 1.0 + i as f32 / 10.0).collect(),
            }),
            Opcode::FixBadPixelsConstant {
                constant: 0,
                bayer_phase: 1,
            },
            Opcode::FixBadPixelsList {
                bayer_phase: 0,
                points: vec![[5, 7], [9, 11]],
                rects: vec![[1, 2, 3, 4]],
            },
            Opcode::WarpRectilinear {
                planes: vec![[1.0, -0.02, 0.001, 0.0, 0.0001, -0.0002]],
                centre: [0.5, 0.5],
            },
            Opcode::MapTable {
                region: Region {
                    area: [0, 0, 10, 12],
                    plane: 0,
                    planes: 3,
                    row_pitch: 1,
                    col_pitch: 1,
                },
                table: vec![0, 100, 400, 900],
            },
            Opcode::MapPolynomial {
                region: Region {
                    area: [2, 2, 8, 8],
                    plane: 1,
                    planes: 1,
                    row_pitch: 1,
                    col_pitch: 2,
                },
                coefficients: vec![0.0, 0.5, 0.5],
            },
            Opcode::Other {
                id: 10,
                optional: true,
            },
        ]
    }

    #[test]
    fn maps_apply_inside_their_region() {
        let list = every_kind();
        let table = &list[4];
        assert_eq!(table.map_sample(3, 3, 2, 2), Some(400));
        assert_eq!(table.map_sample(3, 3, 2, 60000), Some(900));
        assert_eq!(table.map_sample(12, 3, 0, 2), None);
        let poly = &list[5];
        // 0.5 x + 0.5 x^2 at x = 1/2 is 3/8.
        assert_eq!(poly.map_sample(2, 2, 1, 32768), Some(24576));
        assert_eq!(
            poly.map_sample(3, 2, 1, 32768),
            None,
            "off the column pitch"
        );
        assert_eq!(poly.map_sample(2, 2, 0, 32768), None, "another plane");
        assert_eq!(list[0].map_sample(2, 2, 0, 5), None);
    }

    #[test]
    fn every_kind_round_trips_and_is_named() {
        let list = every_kind();
        assert_eq!(parse(&encode(&list)).unwrap(), list);
        let names: Vec<&str> = list.iter().map(Opcode::name).collect();
        assert_eq!(
            names,
            [
                "GainMap",
                "FixBadPixelsConstant",
                "FixBadPixelsList",
                "WarpRectilinear",
                "MapTable",
                "MapPolynomial",
                "DeltaPerRow"
            ]
        );
    }

    /// The OpenCV form of a WarpRectilinear maps every pixel where the DNG formula does.
    #[test]
    fn warp_rectilinear_maps_onto_opencvs_model() {
        let k = [1.0, -0.08, 0.02, -0.004, 0.003, -0.002];
        let centre = [0.52, 0.47];
        let op = Opcode::WarpRectilinear {
            planes: vec![k; 3],
            centre,
        };
        let (w, h) = (120usize, 80usize);
        let ([k1, k2, p1, p2, k3], [f, _, cx, cy]) = warp_as_opencv(&op, w, h).unwrap();
        // The DNG formula, on the continuous plane.
        let (ccx, ccy) = (centre[0] * w as f64, centre[1] * h as f64);
        let m = [
            (0.0, 0.0),
            (w as f64, 0.0),
            (0.0, h as f64),
            (w as f64, h as f64),
        ]
        .iter()
        .map(|(x, y)| (x - ccx).hypot(y - ccy))
        .fold(0.0, f64::max);
        for (x, y) in [(0usize, 0usize), (119, 79), (60, 40), (3, 70), (100, 5)] {
            let (dx, dy) = ((x as f64 + 0.5 - ccx) / m, (y as f64 + 0.5 - ccy) / m);
            let r2 = dx * dx + dy * dy;
            let radial = k[0] + k[1] * r2 + k[2] * r2 * r2 + k[3] * r2 * r2 * r2;
            let sx = ccx + m * (radial * dx + k[4] * 2.0 * dx * dy + k[5] * (r2 + 2.0 * dx * dx));
            let sy = ccy + m * (radial * dy + k[5] * 2.0 * dx * dy + k[4] * (r2 + 2.0 * dy * dy));
            // OpenCV's model on pixel indices.
            let (ox, oy) = ((x as f64 - cx) / f, (y as f64 - cy) / f);
            let q2 = ox * ox + oy * oy;
            let g = 1.0 + k1 * q2 + k2 * q2 * q2 + k3 * q2 * q2 * q2;
            let xd = ox * g + 2.0 * p1 * ox * oy + p2 * (q2 + 2.0 * ox * ox);
            let yd = oy * g + p1 * (q2 + 2.0 * oy * oy) + 2.0 * p2 * ox * oy;
            let (tx, ty) = (f * xd + cx + 0.5, f * yd + cy + 0.5);
            assert!(
                (tx - sx).abs() < 1e-9 && (ty - sy).abs() < 1e-9,
                "({x}, {y})"
            );
        }
        // A scale (kr0 != 1) or per-plane warps do not map.
        let scaled = Opcode::WarpRectilinear {
            planes: vec![[1.01, 0.0, 0.0, 0.0, 0.0, 0.0]],
            centre,
        };
        assert!(warp_as_opencv(&scaled, w, h).is_none());
        let lateral = Opcode::WarpRectilinear {
            planes: vec![k, [1.0, -0.07, 0.02, -0.004, 0.003, -0.002]],
            centre,
        };
        assert!(warp_as_opencv(&lateral, w, h).is_none());
    }

    #[test]
    fn truncated_and_oversized_lists_are_errors_not_allocations() {
        let bytes = encode(&every_kind());
        for n in 0..bytes.len() {
            assert!(parse(&bytes[..n]).is_err(), "{n}");
        }
        // A count of four billion opcodes in eight bytes.
        assert!(parse(&[0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0]).is_err());
        // A GainMap claiming 2^32 x 2^32 points.
        let mut gain_map = encode(&every_kind()[..1]);
        let points_at = 4 + 16 + 4 * 8;
        gain_map[points_at..points_at + 8].fill(0xff);
        assert!(parse(&gain_map).is_err());
    }
}
