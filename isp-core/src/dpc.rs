//! Defective pixel correction on the raw mosaic, before black level subtraction.
//!
//! Two mechanisms, both replacing a pixel by the median of its same-colour neighbours:
//! - a **static map** of known bad pixels ([`DefectMap`], fixed capacity in a `heapless::Vec`,
//!   kept sorted by row then column so a row finds its defects by binary search);
//! - **dynamic detection**: a pixel more than `threshold` (raw units) above the second-largest,
//!   or below the second-smallest, of its usable same-colour neighbours (at least three) is
//!   replaced. Comparing with
//!   the second extreme rather than the extreme lets a pair of adjacent same-colour defects
//!   (a cluster) be found, while a one-pixel line, whose neighbours along the line share its
//!   value, is kept.
//!
//! The same-colour neighbours of a Bayer pixel are the eight at offsets `(±2, 0)`, `(0, ±2)`
//! and `(±2, ±2)`; an offset that leaves the frame is mirrored about the pixel (`-2` becomes
//! `+2`, same CFA colour), so a pixel next to the edge still sees both sides of a thin line.
//! Offsets outside the frame either way (frames under 3 wide or high), the pixel itself, and
//! pixels on the static map are
//! not usable: they are left out of detection and of the median; with none left a listed pixel
//! keeps its value. A static defect is replaced whatever its value; dynamic detection runs on
//! the other pixels. Detection reads only the
//! input, never corrected values, so the result does not depend on the order rows are processed
//! in (streaming is exact). The arithmetic is integer on raw samples, shared by the float and
//! fixed-point pipelines.
//!
//! ```
//! use isp_core::dpc::{correct_row, Defect, DefectMap, DpcConfig};
//! use isp_core::frame::RawFrame;
//! use isp_core::CfaPattern;
//! let mut data = [100u16; 36];
//! data[2 * 6 + 3] = 4000; // a hot pixel at (3, 2)
//! let raw = RawFrame::new(&data, 6, 6, 6, 12, CfaPattern::Rggb, [0; 4], 4095).unwrap();
//! let config = DpcConfig { static_defects: &[], dynamic_threshold: Some(200) };
//! let mut row = [0u16; 6];
//! correct_row(&raw, &config, 2, &mut row).unwrap();
//! assert_eq!(row, [100; 6]);
//! // Or list it as known:
//! let mut map: DefectMap<16> = DefectMap::new();
//! map.insert(Defect { x: 3, y: 2 }).unwrap();
//! let config = DpcConfig { static_defects: map.as_slice(), dynamic_threshold: None };
//! correct_row(&raw, &config, 2, &mut row).unwrap();
//! assert_eq!(row, [100; 6]);
//! ```

use crate::frame::RawFrame;
use crate::IspError;

/// A pixel position. Ordered by row, then column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
// C layout: the C API (isp-ffi) takes a caller's array of `{ uint16_t y, x; }` as is.
#[repr(C)]
pub struct Defect {
    /// Row (first, so the derived order is row-major).
    pub y: u16,
    /// Column.
    pub x: u16,
}

/// A static defect map of at most `N` pixels, sorted, without duplicates.
#[derive(Debug, Clone, Default)]
pub struct DefectMap<const N: usize> {
    list: heapless::Vec<Defect, N>,
}

impl<const N: usize> DefectMap<N> {
    /// An empty map.
    pub const fn new() -> Self {
        Self {
            list: heapless::Vec::new(),
        }
    }

    /// Adds a pixel (a duplicate is ignored); errors when the map is full.
    pub fn insert(&mut self, defect: Defect) -> Result<(), IspError> {
        match self.list.binary_search(&defect) {
            Ok(_) => Ok(()),
            Err(at) => self
                .list
                .insert(at, defect)
                .map_err(|_| IspError::InvalidParameter {
                    name: "defect map",
                    allowed: "at most its capacity N pixels",
                }),
        }
    }

    /// The pixels, sorted by row then column.
    pub fn as_slice(&self) -> &[Defect] {
        &self.list
    }
}

/// Defective pixel correction settings. The default corrects nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct DpcConfig<'a> {
    /// Known bad pixels, sorted by row then column without duplicates (as [`DefectMap`] keeps
    /// them); pixels outside the frame are ignored.
    pub static_defects: &'a [Defect],
    /// Dynamic detection threshold in raw units, or `None` for no detection.
    pub dynamic_threshold: Option<u16>,
}

impl DpcConfig<'_> {
    /// Whether the stage changes anything.
    pub fn is_active(&self) -> bool {
        !self.static_defects.is_empty() || self.dynamic_threshold.is_some()
    }

    /// Checks that the static list is sorted without duplicates.
    pub fn validate(&self) -> Result<(), IspError> {
        if self.static_defects.windows(2).any(|p| p[0] >= p[1]) {
            return Err(IspError::InvalidParameter {
                name: "static_defects",
                allowed: "sorted by (y, x) without duplicates",
            });
        }
        Ok(())
    }

    fn is_static(&self, x: usize, y: usize) -> bool {
        match (u16::try_from(x), u16::try_from(y)) {
            (Ok(x), Ok(y)) => self.static_defects.binary_search(&Defect { x, y }).is_ok(),
            _ => false,
        }
    }
}

/// Offsets of the eight same-colour neighbours.
const NEIGHBOURS: [(isize, isize); 8] = [
    (-2, -2),
    (0, -2),
    (2, -2),
    (-2, 0),
    (2, 0),
    (-2, 2),
    (0, 2),
    (2, 2),
];

/// Writes row `y` of `raw`, corrected, into `out` (`width` samples).
pub fn correct_row(
    raw: &RawFrame<'_>,
    config: &DpcConfig<'_>,
    y: usize,
    out: &mut [u16],
) -> Result<(), IspError> {
    config.validate()?;
    let mosaic = raw.mosaic();
    let (w, h) = (mosaic.width(), mosaic.height());
    if y >= h || out.len() != w {
        return Err(IspError::InvalidParameter {
            name: "row",
            allowed: "y < height and out of width samples",
        });
    }
    correct_span(raw, config, y, 0, out);
    Ok(())
}

/// Pixels `x0..x0 + out.len()` of row `y`, corrected, for a caller that has checked the
/// arguments (a sorted list, the span within the frame).
#[inline(always)]
pub(crate) fn correct_span(
    raw: &RawFrame<'_>,
    config: &DpcConfig<'_>,
    y: usize,
    x0: usize,
    out: &mut [u16],
) {
    let mosaic = raw.mosaic();
    let x1 = x0 + out.len();
    out.copy_from_slice(&mosaic.row(y)[x0..x1]);
    if let Some(threshold) = config.dynamic_threshold {
        // Interior pixels of rows with a same-colour row above and below have all eight
        // neighbours unmirrored: the vectorised detection below, then the exact rule for the
        // few it flags. Pixels within two columns of a static defect in rows y - 2 ..= y + 2
        // (whose median leaves it out) and everything else take the general rule directly.
        let (w, h) = (mosaic.width(), mosaic.height());
        let near = {
            let list = config.static_defects;
            let first = list.partition_point(|d| (d.y as usize) + 2 < y);
            let count = list[first..]
                .iter()
                .take_while(|d| (d.y as usize) <= y + 2)
                .count();
            &list[first..first + count]
        };
        // Rows with a same-colour row above and below (or its mirror about the pixel, by
        // the `mirror_about` that `neighbours` uses: row y + 2 stands for y - 2 in the top
        // two rows, y - 2 for y + 2 in the bottom two) give every pixel eight usable
        // neighbours (mirrored at the sides too) unless a static defect is among them: the
        // interior columns lo..hi take the vectorised detection below, the pixels it flags
        // and the two at each side `sorted8`. Everything else takes the general rule. (The
        // top and bottom rows had taken it, a sort per pixel: 2 % of the float directional
        // pipeline's time; so had every row near a static defect, which made a map of 200
        // defects on a 5 Mpix frame cost 70 ns per pixel.)
        let rows = match (mirror_about(y, -2, h), mirror_about(y, 2, h)) {
            (Some(above), Some(below)) if w >= 5 => {
                Some([mosaic.row(above), mosaic.row(y), mosaic.row(below)])
            }
            _ => None,
        };
        // The dynamic rule where all eight neighbours are usable.
        let fast_rule = |rows, x| match row_neighbours(rows, x) {
            Some((own, values)) => outlier_median(own, &sorted8(values), threshold),
            None => dynamic_replacement(raw, config, x, y, threshold),
        };
        let (lo, hi) = if rows.is_some() {
            let lo = x0.max(2).min(x1);
            (lo, x1.min(w - 2).max(lo))
        } else {
            (x1, x1)
        };
        if let (Some(rows), true) = (rows, lo < hi) {
            let mut flags = [0u8; DETECT_BLOCK];
            for start in (lo..hi).step_by(DETECT_BLOCK) {
                let n = DETECT_BLOCK.min(hi - start);
                if n < DETECT_BLOCK {
                    flags = [0; DETECT_BLOCK];
                }
                detect_interior(rows, start, threshold, &mut flags[..n]);
                // Columns a static defect may be a neighbour of: the general rule, flagged 2.
                for d in near {
                    let dx = d.x as usize;
                    for x in dx.saturating_sub(2).max(start)..(dx + 3).min(start + n) {
                        flags[x - start] = GENERAL;
                    }
                }
                // Eight flags at a time, visiting only the set ones: a loop testing each flag
                // took a tenth of the whole pipeline's time (a load, a compare and a branch
                // per pixel, for the few pixels flagged).
                // `n` is a whole number of eights but at the end, whose flags past `n` are
                // zero (cleared before detection): a fixed-size read per eight, where a
                // copy of `chunk.len()` bytes called `memcpy` (1 % of the directional
                // pipeline's time).
                let eights = n.div_ceil(8);
                for (k, eight) in flags.as_chunks::<8>().0[..eights].iter().enumerate() {
                    // Each flag is 0, 1 or GENERAL (2), so each set flag is one set bit.
                    let mut set = u64::from_le_bytes(*eight);
                    while set != 0 {
                        let byte = (set.trailing_zeros() / 8) as usize;
                        let x = start + 8 * k + byte;
                        set &= set - 1;
                        let v = if eight[byte] == GENERAL {
                            dynamic_replacement(raw, config, x, y, threshold)
                        } else {
                            fast_rule(rows, x)
                        };
                        if let Some(v) = v {
                            out[x - x0] = v;
                        }
                    }
                }
            }
        }
        // The sides after the interior, whose loads have brought their columns into cache.
        for x in (x0..lo).chain(hi..x1) {
            let v = match rows {
                Some(rows) if near.is_empty() => fast_rule(rows, x),
                _ => dynamic_replacement(raw, config, x, y, threshold),
            };
            if let Some(v) = v {
                out[x - x0] = v;
            }
        }
    }
    if !config.static_defects.is_empty() {
        let Ok(y16) = u16::try_from(y) else {
            return;
        };
        let start = config.static_defects.partition_point(|d| d.y < y16);
        for d in config.static_defects[start..]
            .iter()
            .take_while(|d| d.y == y16)
        {
            let x = d.x as usize;
            if (x0..x1).contains(&x) {
                if let Some(v) = replacement(raw, config, x, y) {
                    out[x - x0] = v;
                }
            }
        }
    }
}

/// Pixels the vectorised detection handles at a time.
const DETECT_BLOCK: usize = 128;

/// The detection's flag for a pixel that takes the general rule (a static defect may be
/// among its neighbours).
const GENERAL: u8 = 2;

/// Flags (1, else 0) the pixels `x0..x0 + flags.len()` (all at least two from the sides)
/// that dynamic detection would replace: above the second-largest of the eight same-colour
/// neighbours by more than `threshold`, or below the second-smallest by more. `rows` are rows
/// `y - 2`, `y` and `y + 2` (or their mirrors at the top and bottom). Branch-free over
/// contiguous slices so it vectorises; saturating `u16` sums give the comparisons of the
/// `u32` ones in [`dynamic_replacement`].
#[inline(always)]
fn detect_interior(rows: [&[u16]; 3], x0: usize, threshold: u16, flags: &mut [u8]) {
    let n = flags.len();
    let tap = |r: usize, dx: usize| &rows[r][x0 + dx - 2..x0 + dx - 2 + n];
    let (nw, no, ne) = (tap(0, 0), tap(0, 2), tap(0, 4));
    let (we, own, ea) = (tap(1, 0), tap(1, 2), tap(1, 4));
    let (sw, so, se) = (tap(2, 0), tap(2, 2), tap(2, 4));
    for i in 0..n {
        let values = [nw[i], no[i], ne[i], we[i], ea[i], sw[i], so[i], se[i]];
        // The two largest and two smallest, kept as running pairs.
        let (mut max1, mut max2, mut min1, mut min2) = (0u16, 0u16, u16::MAX, u16::MAX);
        for v in values {
            max2 = max2.max(max1.min(v));
            max1 = max1.max(v);
            min2 = min2.min(min1.max(v));
            min1 = min1.min(v);
        }
        let v = own[i];
        flags[i] =
            u8::from((v > max2.saturating_add(threshold)) | (v.saturating_add(threshold) < min2));
    }
}

/// Column `x` of `rows` (rows `y - 2`, `y` and `y + 2` or their mirrors, at least 5 wide)
/// and its eight same-colour neighbours, the columns past a side mirrored about `x` as
/// [`neighbours`] mirrors them; `None` where `x` is outside.
#[inline]
fn row_neighbours(rows: [&[u16]; 3], x: usize) -> Option<(u16, [u16; 8])> {
    let w = rows[1].len();
    let left = if x >= 2 { x - 2 } else { x + 2 };
    let right = if x + 2 < w { x + 2 } else { x.checked_sub(2)? };
    let at = |r: usize, c: usize| rows[r].get(c).copied();
    let values = [
        at(0, left)?,
        at(0, x)?,
        at(0, right)?,
        at(1, left)?,
        at(1, right)?,
        at(2, left)?,
        at(2, x)?,
        at(2, right)?,
    ];
    Some((at(1, x)?, values))
}

/// `values` sorted by a branch-free network (Batcher's odd-even merge sort of eight, 19
/// exchanges), for pixels with eight usable neighbours: in place of the general rule's mirror
/// tests, static-map searches and insertion sort, it took the fixed MHC pipeline from 17.5 to
/// 10.3 ns per pixel with threshold 4 on `camsim bench isp`'s noisy synthetic frame, where
/// many pixels are flagged (the four side pixels of each row had taken about 2 % of the
/// directional pipeline's time at threshold 64).
#[inline]
fn sorted8(mut values: [u16; 8]) -> [u16; 8] {
    // Written out, not a loop over a table of pairs: LLVM kept that loop (19 iterations,
    // past its unrolling limit), with a bounds check per exchange and the values in memory.
    macro_rules! exchanges {
        ($(($a:literal, $b:literal)),*) => {$(
            let (lo, hi) = (values[$a].min(values[$b]), values[$a].max(values[$b]));
            (values[$a], values[$b]) = (lo, hi);
        )*};
    }
    exchanges!(
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (1, 2),
        (5, 6),
        (0, 4),
        (3, 7),
        (1, 5),
        (2, 6),
        (1, 4),
        (3, 6),
        (2, 4),
        (3, 5),
        (3, 4)
    );
    values
}

/// The dynamic rule's decision for a pixel `own` among its usable neighbours, `sorted` (at
/// least three): their median if `own` is above the second largest or below the second
/// smallest by more than `threshold`.
#[inline]
fn outlier_median(own: u16, sorted: &[u16], threshold: u16) -> Option<u16> {
    let n = sorted.len();
    let (second_least, second_largest) = (*sorted.get(1)?, *sorted.get(n.checked_sub(2)?)?);
    let (own, threshold) = (u32::from(own), u32::from(threshold));
    let hot = own > u32::from(second_largest) + threshold;
    let cold = own + threshold < u32::from(second_least);
    (hot || cold).then(|| median(sorted))
}

/// The dynamic rule at `(x, y)`: the median of the usable neighbours if the pixel is an
/// outlier among at least three of them.
fn dynamic_replacement(
    raw: &RawFrame<'_>,
    config: &DpcConfig<'_>,
    x: usize,
    y: usize,
    threshold: u16,
) -> Option<u16> {
    let v = raw.mosaic().row(y)[x];
    let (mut values, n) = neighbours(raw, config, x, y);
    if n < 3 {
        return None; // too few neighbours to call the pixel an outlier
    }
    let values = &mut values[..n];
    values.sort_unstable();
    outlier_median(v, values, threshold)
}

/// The usable same-colour neighbours of `(x, y)`: mirrored at the edges, leaving out the pixel
/// itself and pixels on the static map.
fn neighbours(raw: &RawFrame<'_>, config: &DpcConfig<'_>, x: usize, y: usize) -> ([u16; 8], usize) {
    let mosaic = raw.mosaic();
    let (w, h) = (mosaic.width(), mosaic.height());
    let mut values = [0u16; 8];
    let mut n = 0;
    for (dx, dy) in NEIGHBOURS {
        let (Some(nx), Some(ny)) = (mirror_about(x, dx, w), mirror_about(y, dy, h)) else {
            continue;
        };
        if (nx, ny) == (x, y) || config.is_static(nx, ny) {
            continue;
        }
        values[n] = mosaic.row(ny)[nx];
        n += 1;
    }
    (values, n)
}

/// `i + d`, or `i - d` (the mirror about the pixel, same CFA colour) when that is outside
/// `0..n`; `None` when both are.
#[inline]
fn mirror_about(i: usize, d: isize, n: usize) -> Option<usize> {
    let inside = |v: isize| (v >= 0 && (v as usize) < n).then_some(v as usize);
    inside(i as isize + d).or_else(|| inside(i as isize - d))
}

/// The median of sorted `values` (the rounded-up mean of the middle two for an even count).
fn median(values: &[u16]) -> u16 {
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        ((values[n / 2 - 1] as u32 + values[n / 2] as u32).div_ceil(2)) as u16
    }
}

/// The median of the usable same-colour neighbours of `(x, y)`, or `None` if there are none.
fn replacement(raw: &RawFrame<'_>, config: &DpcConfig<'_>, x: usize, y: usize) -> Option<u16> {
    let (mut values, n) = neighbours(raw, config, x, y);
    let values = &mut values[..n];
    values.sort_unstable();
    (n > 0).then(|| median(values))
}
