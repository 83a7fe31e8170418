//! Demosaicing over parity-split rows: the filters of bilinear and Malvar-He-Cutler written
//! out over named neighbours, run one loop per column parity, which the compiler vectorises.
//! The pipeline's planar schedule ([`crate::pipeline`]) and the whole-frame
//! [`demosaic`](super::demosaic) both run them; their output equals [`row`](super::row)'s bit
//! for bit (the same sums in the same order; tested).
//!
//! A prepared row is held as its even columns, then its odd columns, each with one sample
//! beyond either end ([`Halves`]). Within one half every sample has the same CFA position, so
//! a filter at every site of a half reads the same offsets: `x - 2`, `x`, `x + 2` of the
//! site's own half and `x - 1`, `x + 1` of the other half.

use super::{reflect, Method};
use crate::demosaic::directional::SourceRow;
use crate::frame::{MosaicView, RgbViewMut, Sample};
use crate::{CfaColour, CfaPattern};

/// A prepared row's layout: `[E(-1), E(0) .. E(even-1), E(even), O(-1), O(0) .. O(odd-1),
/// O(odd)]`, where `E(i)` is column `2i` and `O(i)` column `2i + 1`, and the outer samples
/// of each half are the columns reflect-101 gives there.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Halves {
    /// Columns in the even half (`E(0) ..`).
    pub(crate) even: usize,
    /// Columns in the odd half.
    pub(crate) odd: usize,
}

impl Halves {
    pub(crate) fn new(w: usize) -> Self {
        Self {
            even: w.div_ceil(2),
            odd: w / 2,
        }
    }

    pub(crate) fn len(self) -> usize {
        self.even + self.odd + 4
    }

    /// Index of `O(-1)`.
    pub(crate) fn odd_start(self) -> usize {
        self.even + 2
    }

    /// The row's own samples (without the padding) as the directional stream reads them.
    pub(crate) fn unpadded<T>(self, row: &[T]) -> SourceRow<'_, T> {
        let o = self.odd_start();
        SourceRow::Split {
            even: &row[1..1 + self.even],
            odd: &row[o + 1..o + 1 + self.odd],
        }
    }

    /// Writes the four reflected samples of a row whose halves are filled (width at least 4).
    pub(crate) fn pad<T: Copy>(self, row: &mut [T]) {
        let (ne, no, o) = (self.even, self.odd, self.odd_start());
        // E(i) is at 1 + i, O(i) at o + 1 + i. Column -2 is column 2, column -1 is column 1.
        row[0] = row[2];
        row[o] = row[o + 1];
        if ne == no {
            // Even width: column w is w - 2 (even), column w + 1 is w - 3 (odd).
            row[1 + ne] = row[ne];
            row[o + 1 + no] = row[o + no - 1];
        } else {
            // Odd width: column w is w - 2 (odd), column w + 1 is w - 3 (even).
            row[o + 1 + no] = row[o + no];
            row[1 + ne] = row[ne - 1];
        }
    }

    /// The sites of one column parity as `(same, other)`: `same[i + 1]` is site `i` (so
    /// `same[i]` and `same[i + 2]` are two columns left and right) and `other[i]` and
    /// `other[i + 1]` the columns left and right of it.
    pub(crate) fn sites<T>(self, row: &[T], parity: usize) -> (&[T], &[T]) {
        let o = self.odd_start();
        match parity {
            0 => (&row[..self.even + 2], &row[o..o + self.even + 1]),
            _ => (&row[o..o + self.odd + 2], &row[1..self.odd + 2]),
        }
    }
}

/// The `(same, other)` slices of one column parity in five rows, `rows[k]` being row
/// `y + k - 2` (see [`Halves::sites`]).
pub(crate) type SiteRows<'r, T> = [(&'r [T], &'r [T]); 5];

/// The 5x5 neighbourhood of site `i` of a half, by name: the centre, left and right (`l`,
/// `r`, `ll`, `rr`), up and down (`u`, `d`, `uu`, `dd`) and the diagonals.
#[derive(Clone, Copy)]
pub(crate) struct Neighbours<T> {
    c: T,
    l: T,
    r: T,
    ll: T,
    rr: T,
    u: T,
    d: T,
    uu: T,
    dd: T,
    ul: T,
    ur: T,
    dl: T,
    dr: T,
}

/// The sum `0 + v1 * k1 + v2 * k2 + ...` in the accumulator, left to right: the order
/// `demosaic` forms its sums in, which the float path's rounding depends on.
macro_rules! weighted_sum {
    ($t:ty; $($v:expr => $k:expr),+ $(,)?) => {
        <$t as Sample>::Acc::default() $( + $v.weighted($k) )+
    };
}

/// One demosaic filter: a tap table of `demosaic` (or a sum of `bilinear_row`) written out
/// over [`Neighbours`], its terms in the table's order (the tests check the planar schedules
/// against the row functions bit for bit). Written out rather than looped over the table: LLVM works out the cost of unrolling a loop of at
/// most ten iterations, so a loop over an eleven-tap table stayed a loop with a branch per tap
/// and nothing was vectorised (5x slower).
#[derive(Clone, Copy)]
pub(crate) enum Filter {
    /// `demosaic::MHC_CHROMA_HORIZONTAL`.
    MhcHorizontal,
    /// `demosaic::MHC_CHROMA_VERTICAL`.
    MhcVertical,
    /// `demosaic::MHC_G_AT_CHROMA`.
    MhcGreen,
    /// `demosaic::MHC_OPPOSITE`.
    MhcOpposite,
    /// `bilinear_row`'s chroma at green from left and right.
    BilinearHorizontal,
    /// `bilinear_row`'s chroma at green from above and below.
    BilinearVertical,
    /// `bilinear_row`'s green at red or blue.
    BilinearGreen,
    /// `bilinear_row`'s other chroma at red or blue.
    BilinearOpposite,
}

impl Filter {
    #[inline(always)]
    fn apply<T: Sample>(self, n: Neighbours<T>) -> T {
        let Neighbours {
            c,
            l,
            r,
            ll,
            rr,
            u,
            d,
            uu,
            dd,
            ul,
            ur,
            dl,
            dr,
        } = n;
        let (sum, shift) = match self {
            Self::MhcHorizontal => (
                weighted_sum!(T; c => 10, l => 8, r => 8, ll => -2, rr => -2, ul => -2,
                    ur => -2, dl => -2, dr => -2, uu => 1, dd => 1),
                4,
            ),
            Self::MhcVertical => (
                weighted_sum!(T; c => 10, u => 8, d => 8, uu => -2, dd => -2, ul => -2,
                    ur => -2, dl => -2, dr => -2, ll => 1, rr => 1),
                4,
            ),
            Self::MhcGreen => (
                weighted_sum!(T; c => 8, u => 4, d => 4, l => 4, r => 4, uu => -2, dd => -2,
                    ll => -2, rr => -2),
                4,
            ),
            Self::MhcOpposite => (
                weighted_sum!(T; c => 12, ul => 4, ur => 4, dl => 4, dr => 4, uu => -3,
                    dd => -3, ll => -3, rr => -3),
                4,
            ),
            Self::BilinearHorizontal => (weighted_sum!(T; l => 1, r => 1), 1),
            Self::BilinearVertical => (weighted_sum!(T; u => 1, d => 1), 1),
            Self::BilinearGreen => (weighted_sum!(T; u => 1, d => 1, l => 1, r => 1), 2),
            Self::BilinearOpposite => (weighted_sum!(T; ul => 1, ur => 1, dl => 1, dr => 1), 2),
        };
        T::scaled_down(sum, shift)
    }
}

/// Two filters at every site of a half, into `first` and `second`.
#[inline(always)]
fn filter_pair<T: Sample>(
    rows: SiteRows<'_, T>,
    filters: [Filter; 2],
    first: &mut [T],
    second: &mut [T],
) {
    let n = first.len();
    let second = &mut second[..n];
    // Written out, not `array::map`, which camsim's build left as a call.
    let [r0, r1, r2, r3, r4] = rows;
    let s = [
        &r0.0[..n + 2],
        &r1.0[..n + 2],
        &r2.0[..n + 2],
        &r3.0[..n + 2],
        &r4.0[..n + 2],
    ];
    let t = [
        &r0.1[..n + 1],
        &r1.1[..n + 1],
        &r2.1[..n + 1],
        &r3.1[..n + 1],
        &r4.1[..n + 1],
    ];
    for (i, (a, b)) in first.iter_mut().zip(second.iter_mut()).enumerate() {
        let around = Neighbours {
            c: s[2][i + 1],
            l: t[2][i],
            r: t[2][i + 1],
            ll: s[2][i],
            rr: s[2][i + 2],
            u: s[1][i + 1],
            d: s[3][i + 1],
            uu: s[0][i + 1],
            dd: s[4][i + 1],
            ul: t[1][i],
            ur: t[1][i + 1],
            dl: t[3][i],
            dr: t[3][i + 1],
        };
        *a = filters[0].apply(around);
        *b = filters[1].apply(around);
    }
}

/// Demosaics row `y` from its five prepared rows into `planes` (R, G, B, each `w` long: even
/// half, then odd half).
#[inline(always)]
pub(crate) fn demosaic_row<T: Sample>(
    method: Method,
    source: [&[T]; 5],
    halves: Halves,
    pattern: CfaPattern,
    y: usize,
    planes: &mut [T],
) {
    let w = halves.even + halves.odd;
    for parity in 0..2 {
        let [s0, s1, s2, s3, s4] = source;
        let rows: SiteRows<'_, T> = [
            halves.sites(s0, parity),
            halves.sites(s1, parity),
            halves.sites(s2, parity),
            halves.sites(s3, parity),
            halves.sites(s4, parity),
        ];
        let own = pattern.colour_at(parity, y);
        let half = |c: CfaColour| match parity {
            0 => c.index() * w..c.index() * w + halves.even,
            _ => c.index() * w + halves.even..(c.index() + 1) * w,
        };
        planes[half(own)].copy_from_slice(&rows[2].0[1..rows[2].0.len() - 1]);
        // The two colours the site lacks, and the filters that give them.
        let (first, second) = match own {
            CfaColour::Green => (
                pattern.colour_at(parity + 1, y),
                pattern.colour_at(parity, y + 1),
            ),
            _ => (CfaColour::Green, pattern.colour_at(parity + 1, y + 1)),
        };
        let (lo, hi) = (half(first), half(second));
        // Split the planes so both outputs are borrowed at once; `first` and `second` differ.
        let (a, b) = if lo.start < hi.start {
            let (head, tail) = planes.split_at_mut(hi.start);
            (&mut head[lo], &mut tail[..hi.len()])
        } else {
            let (head, tail) = planes.split_at_mut(lo.start);
            (&mut tail[..lo.len()], &mut head[hi])
        };
        // Each arm names its filters, so that once inlined the loop holds only their sums.
        match (method, own) {
            (Method::Mhc, CfaColour::Green) => {
                filter_pair(rows, [Filter::MhcHorizontal, Filter::MhcVertical], a, b)
            }
            (Method::Mhc, _) => filter_pair(rows, [Filter::MhcGreen, Filter::MhcOpposite], a, b),
            (_, CfaColour::Green) => filter_pair(
                rows,
                [Filter::BilinearHorizontal, Filter::BilinearVertical],
                a,
                b,
            ),
            (_, _) => filter_pair(
                rows,
                [Filter::BilinearGreen, Filter::BilinearOpposite],
                a,
                b,
            ),
        }
    }
}

/// Columns of one strip of the whole-frame kernel: its rows and planes live on the stack
/// (five padded rows and three planes, 1.3 K samples), so [`demosaic`](super::demosaic)
/// needs no scratch. Even, so every strip starts at an even column and keeps the CFA parity.
const STRIP: usize = 1024;

/// Bilinear or MHC over the whole frame, in vertical strips of [`STRIP`] columns: each
/// strip's rows are split by parity once (the samples beyond the strip's ends taken from the
/// neighbouring columns, reflect-101 at the frame's edges), [`demosaic_row`] fills planes,
/// and one pass interleaves them into the output. The caller has checked the sizes (equal,
/// at least 1 x 3).
#[inline(always)]
pub(crate) fn whole_frame<T: Sample>(
    method: Method,
    input: &MosaicView<'_, T>,
    output: &mut RgbViewMut<'_, T>,
) {
    let (w, h, pattern) = (input.width(), input.height(), input.pattern());
    let mut rows = [[T::default(); STRIP + 4]; 5];
    let mut planes = [T::default(); 3 * STRIP];
    for x0 in (0..w).step_by(STRIP) {
        let halves = Halves::new(STRIP.min(w - x0));
        let mut tags = [usize::MAX; 5];
        for y in 0..h {
            for dy in -2..=2isize {
                let my = reflect(y as isize + dy, h);
                if tags[my % 5] != my {
                    split_row(input.row(my), x0, halves, &mut rows[my % 5]);
                    tags[my % 5] = my;
                }
            }
            let row = |dy: isize| &rows[reflect(y as isize + dy, h) % 5][..halves.len()];
            let source = [row(-2), row(-1), row(0), row(1), row(2)];
            let n = halves.even + halves.odd;
            let planes = &mut planes[..3 * n];
            demosaic_row(method, source, halves, pattern, y, planes);
            interleave(planes, halves, &mut output.row_mut(y)[3 * x0..3 * (x0 + n)]);
        }
    }
}

/// Columns `x0 ..` (as many as `halves` holds) of `src` into `dst` split by parity, with the
/// column before and after each half (reflect-101 at the row's ends).
#[inline(always)]
fn split_row<T: Sample>(src: &[T], x0: usize, halves: Halves, dst: &mut [T]) {
    let w = src.len();
    let n = halves.even + halves.odd;
    let o = halves.odd_start();
    let at = |x: isize| src[reflect(x0 as isize + x, w)];
    dst[0] = at(-2);
    dst[o] = at(-1);
    let pairs = src[x0..x0 + n].chunks_exact(2);
    if let [last] = pairs.remainder() {
        dst[halves.even] = *last;
    }
    let (even, odd) = dst.split_at_mut(o);
    for ((e, d), pair) in even[1..].iter_mut().zip(&mut odd[1..]).zip(pairs) {
        *e = pair[0];
        *d = pair[1];
    }
    dst[1 + halves.even] = at(2 * halves.even as isize);
    dst[o + 1 + halves.odd] = at(2 * halves.odd as isize + 1);
}

/// Planes R, G, B (each even half, then odd half) into interleaved RGB.
#[inline(always)]
fn interleave<T: Sample>(planes: &[T], halves: Halves, out: &mut [T]) {
    let n = halves.even + halves.odd;
    let (r, rest) = planes.split_at(n);
    let (g, b) = rest.split_at(n);
    let (even, odd) = (halves.even, halves.odd);
    for (i, px) in out[..6 * odd].chunks_exact_mut(6).enumerate() {
        px[0] = r[i];
        px[1] = g[i];
        px[2] = b[i];
        px[3] = r[even + i];
        px[4] = g[even + i];
        px[5] = b[even + i];
    }
    if even > odd {
        let i = even - 1;
        out[3 * (n - 1)..3 * n].copy_from_slice(&[r[i], g[i], b[i]]);
    }
}
