//! Noise reduction driven by the sensor's noise profile: non-local means on the raw mosaic,
//! packed into its four CFA planes, with patch distances measured in a variance-stabilised
//! domain, scheduled offset by offset.
//!
//! The stage runs on the mosaic right after black-level subtraction (so the raw's
//! [`NoiseProfile`], which is stated there, applies as it is), before shading, gains and
//! demosaicing (which would correlate the noise and spread it across colours). Each 2x2 CFA
//! block is one *packed pixel* with four channels, one per CFA position; a packed pixel and
//! its neighbours at offsets `o` within the search window ([`Search`]) are compared through
//! the 3x3 packed patches around them, all four channels together, so one weight moves all
//! colours of a block together (no chroma noise from planes filtered apart).
//!
//! # Float semantics
//!
//! With `x_k(q)` channel `k` of packed pixel `q` (a fraction of white above black, clamped to
//! `[0, 1]`), extended beyond the frame by reflect-101 in packed coordinates, and `S_k`, `O_k`
//! the profile's scale and offset for the colour at CFA position `k`:
//!
//! ```text
//! var_k(x) = max(S_k x + O_k, Q)                 Q = (16 / 65535)^2, a floor
//! v_k(x)   = integral from 0 to x of dt / sqrt(var_k(t))     (the variance-stabilising transform)
//! D(p, q)  = sum over d in the 3x3 offsets, over k, of (v_k(x_k(q + d)) - v_k(x_k(p + d)))^2
//! u        = max(0, 1 - max(D - 72, 0) / (8 * 72 * h^2)),   h = h1 * strength
//! w(p, q)  = u^8                                 (about exp(-max(D - 72, 0) / (72 h^2)))
//! out_k(p) = sum over o in the window of w(p, p + o) x_k(p + o) / sum over o of w(p, p + o)
//! ```
//!
//! `v_k` makes the noise's standard deviation 1 at every level (Foi's generalised Anscombe
//! transform, with the variance floor), so for pure noise each of the 36 terms of `D` has
//! expectation 2 and `D` is about 72: the weight falls from 1 once two patches differ by more
//! than noise, and the centre (`o = 0`, `D = 0`) has weight 1. `h1` is 0.8 with the wide
//! window and 1.0 with the fast one, whose fewer candidates take a higher `h`. The polynomial `u^8` stands in
//! for the exponential of the classic method (Buades, Coll and Morel 2005) and is cheap in
//! integers. Only the distances are stabilised: the output is a convex combination of the
//! input samples themselves, so flat areas keep their level and there is no inverse transform
//! to bias the dark.
//!
//! In closed form `v_k(x) = x / sqrt(Q)` up to the knee `t = (Q - O) / S` where the floor
//! stops binding (0 when `O >= Q`), and `t / sqrt(Q) + 2 (x - t) / (sqrt(S x + O) + sqrt(S t +
//! O))` beyond it; the float path evaluates that in `f32`, its square root by Newton's method
//! from the bit pattern (within 4e-7 relative), so the loop vectorises and every target
//! computes the same bits.
//!
//! # The schedule: offset by offset, each distance row once, half the offsets
//!
//! `D(p, q) = D(q, p)`: the distance is symmetric, and so is the weight. The filter loops over
//! the offsets outside the pixels (Darbon et al., ISBI 2008; Froment, IPOL 2014): for each
//! offset `o` of the half window ([`Search::half_window`], `dy > 0`, or `dy = 0` and `dx > 0`:
//! 12 of the 24 for the 5x5 window), one row of per-pixel terms `E_o(r, c) = sum_k (v_k(r +
//! dy, c + dx) - v_k(r, c))^2` is computed once per packed row and kept in a ring of three, so
//! `D` is the 3x3 box sum of `E_o`: three rows added, then three columns. The weight at anchor
//! `p` serves both `p` (candidate `p + o`) and `p + o` (candidate `p`, offset `-o`), so the
//! other half of the window costs nothing but the accumulation. Anchors run over the packed
//! rows in order, one row of the frame above it and `R` packed pixels beyond either side (the
//! window's radius, whose `p + o` lands in the frame), and a packed row is finished once the
//! anchor row on it is: every offset's contribution to it has then been added, in the same
//! order whatever row a band starts at, so any band split gives the whole frame's output. Per
//! offset and packed pixel the work is constant, whatever the patch size: the four
//! channels' terms, two 3-term sums, a weight and two weighted accumulations.
//!
//! # Fixed-point path
//!
//! Samples are `u16` (65535 = 1.0). `v_k` is read from a table per colour of 1217 knots, one
//! every 16 input codes below 4096 (where the transform bends most) and every 64 above, each
//! `round(256 v)` (1/256 of the noise's deviation, below 2^21), interpolated linearly between
//! the knots around `x` with a rounded shift; the knots come from the float path's `v_k`. A term is `(min(|a - b|, 80 * 256)^2 + 128) >> 8`,
//! in 1/256 of a variance (80 deviations: a term that large already zeroes any weight at any
//! strength, so the clamp changes no weight and keeps `D` below 2^26), `D` a `u32`. The weight is Q15 arithmetic:
//! `u = 32768 - min((min(excess, cap) c) >> 16, 32768)` with `excess = D - 72 * 256` (at
//! least 0), `c = round(2^23 / (8 * 72 * h^2))` and `cap` where the drop saturates, three
//! squarings each rounded (`(u u + 2^14) >> 15`): Q15, 32768 is 1. The weighted sums are
//! `u64` (a 32 x 32 -> 64-bit product each, one instruction on a Cortex-M4), the weights' sum
//! a `u32`, and the output `(num + den / 2) / den`.
//! Within 0.1 dB of the float path on `camsim bench denoise`.
//!
//! Quality, speed and what bounds them: `camsim bench denoise` and `docs/performance.md`.

use crate::demosaic::reflect;
use crate::math;
use crate::noise::NoiseProfile;
use crate::{CfaPattern, IspError};

/// Largest strength (a multiplier on the profile-driven default, 1).
pub const MAX_STRENGTH: f32 = 4.0;
/// Radius of the patches compared (packed pixels).
pub const PATCH_RADIUS: usize = 1;
/// `h` at strength 1 with the wide and the fast window (each tuned on `camsim bench denoise`:
/// the fast window's fewer candidates take a higher `h`).
const H_AT_STRENGTH_1: [f32; 2] = [0.8, 1.0];
/// Terms of a patch distance: 3x3 packed pixels of four channels.
const TERMS: f32 = 36.0;
/// The variance floor: a standard deviation of 16 codes of 16 bits (one of 12 bits), far below
/// any visible noise.
const VAR_FLOOR: f32 = 256.0 / (65535.0 * 65535.0);
/// Largest search radius (the default window's).
const MAX_RADIUS: usize = 2;
/// Most offsets in a half window.
const MAX_HALF: usize = ((2 * MAX_RADIUS + 1) * (2 * MAX_RADIUS + 1) - 1) / 2;
/// Rows of samples the stream holds: the patch rows of the anchor row, of the row being
/// opened below it and of their partners `R` rows further down.
const fn held_rows(radius: usize) -> usize {
    radius + 3
}
/// Knots of the fixed path's stabilising tables: one every 16 codes below [`FINE_END`], where
/// the transform bends most, then one every 64, and the end.
const KNOTS: usize = FINE_END / 16 + (65536 - FINE_END) / 64 + 1;
/// Where the fixed path's tables change from fine to coarse knots.
const FINE_END: usize = 4096;

/// The input code of knot `i` of a fixed table.
const fn knot_input(i: usize) -> usize {
    if i < FINE_END / 16 {
        16 * i
    } else {
        FINE_END + 64 * (i - FINE_END / 16)
    }
}
/// The fixed path's stabilised values are in 1/256 of the noise's deviation.
const FIXED_SCALE: f32 = 256.0;
/// The fixed path's terms: differences are clamped at 80 deviations (in 1/256).
const FIXED_DIFF_CAP: u32 = 80 * 256;
/// The fixed path's weight of 1 (Q15).
const FIXED_ONE: u32 = 1 << 15;

/// The search window: how far a packed pixel looks for similar ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Search {
    /// 5x5 packed pixels (10x10 mosaic pixels), 12 offsets computed: the default, for stills.
    #[default]
    Wide,
    /// 3x3 packed pixels, 4 offsets computed: the fast setting, for firmware and video.
    Fast,
}

impl Search {
    /// Both settings.
    pub const ALL: [Search; 2] = [Search::Wide, Search::Fast];

    /// The window's radius in packed pixels.
    pub const fn radius(self) -> usize {
        match self {
            Self::Wide => 2,
            Self::Fast => 1,
        }
    }

    /// The setting's name (`wide`, `fast`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Wide => "wide",
            Self::Fast => "fast",
        }
    }

    /// The setting of a name.
    pub fn from_name(name: &str) -> Result<Self, IspError> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or(IspError::InvalidParameter {
                name: "denoise search",
                allowed: "wide (5x5 packed pixels, the default) or fast (3x3)",
            })
    }

    /// The offsets `(dx, dy)` the schedule computes: `dy > 0`, or `dy = 0` and `dx > 0`, row by
    /// row, left to right. Each serves itself and its opposite.
    pub fn half_window(self) -> impl Iterator<Item = (isize, isize)> {
        let r = self.radius() as isize;
        (0..=r)
            .flat_map(move |dy| (-r..=r).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| dy > 0 || dx > 0)
    }

    /// Offsets in the half window.
    pub const fn half_len(self) -> usize {
        let side = 2 * self.radius() + 1;
        (side * side - 1) / 2
    }
}

/// Checks a strength: in `(0, MAX_STRENGTH]`.
fn check_strength(strength: f32) -> Result<f32, IspError> {
    if strength > 0.0 && strength <= MAX_STRENGTH {
        Ok(strength)
    } else {
        Err(IspError::InvalidParameter {
            name: "denoise strength",
            allowed: "(0, 4] (1 is the profile's default)",
        })
    }
}

/// `1 / (8 * 72 * h^2)` for a strength and search.
fn inv_span(strength: f32, search: Search) -> f64 {
    let h = f64::from(H_AT_STRENGTH_1[search as usize]) * f64::from(strength);
    1.0 / (8.0 * f64::from(TERMS) * 2.0 * h * h)
}

/// The variance-stabilising transform of one colour: see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stabiliser {
    /// The knee `t` where the floor stops binding (0 when it never binds).
    knee: f32,
    /// `1 / sqrt(Q)`: the slope below the knee.
    below: f32,
    /// `t / sqrt(Q)`: the value at the knee.
    at_knee: f32,
    scale: f32,
    offset: f32,
    /// `sqrt(S t + O)`.
    root_at_knee: f32,
}

impl Stabiliser {
    fn new(scale: f32, offset: f32) -> Self {
        let below = 1.0 / math::sqrt_f32(VAR_FLOOR);
        let knee = if offset >= VAR_FLOOR {
            0.0
        } else if scale > 0.0 {
            (VAR_FLOOR - offset) / scale
        } else {
            f32::MAX
        };
        let root_at_knee = math::sqrt_f32(scale * knee.min(1.0) + offset).max(1.0 / below);
        Self {
            knee,
            below,
            at_knee: knee.min(1.0) * below,
            scale,
            offset,
            root_at_knee,
        }
    }

    /// `v(x)` for `x` in `[0, 1]`, in units of the noise's deviation.
    #[inline(always)]
    fn apply(&self, x: f32) -> f32 {
        let linear = x * self.below;
        let root = math::sqrt_f32(self.scale * x + self.offset);
        let curved = self.at_knee + 2.0 * (x - self.knee) / (root + self.root_at_knee);
        if x <= self.knee {
            linear
        } else {
            curved
        }
    }
}

/// The stabilisers of the three colours of a profile.
fn stabilisers(profile: &NoiseProfile) -> [Stabiliser; 3] {
    let (s, o) = (profile.scale(), profile.offset());
    core::array::from_fn(|c| Stabiliser::new(s[c], o[c]))
}

/// The colour index of each CFA position `k` (row-major in the 2x2 block).
fn colours(pattern: CfaPattern) -> [usize; 4] {
    core::array::from_fn(|k| pattern.colour_at(k & 1, k >> 1).index())
}

/// The filter's float parameters: a profile's transform per colour and the strength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatParams {
    by_colour: [Stabiliser; 3],
    /// `1 / (8 * 72 * h^2)`.
    inv_span: f32,
}

impl FloatParams {
    /// The float filter for `profile` at `strength` (`(0, 4]`, 1 the default) with `search`.
    pub fn new(profile: &NoiseProfile, strength: f32, search: Search) -> Result<Self, IspError> {
        let strength = check_strength(strength)?;
        Ok(Self {
            by_colour: stabilisers(profile),
            inv_span: inv_span(strength, search) as f32,
        })
    }

    /// The parameters for a raw of `pattern`.
    pub fn for_pattern(&self, pattern: CfaPattern) -> FloatNlm {
        FloatNlm {
            by_position: colours(pattern).map(|c| self.by_colour[c]),
            inv_span: self.inv_span,
        }
    }
}

/// [`FloatParams`] for one CFA pattern: what a [`Stream`] of the float path runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloatNlm {
    by_position: [Stabiliser; 4],
    inv_span: f32,
}

/// The filter's fixed-point parameters: a stabilising table per colour (6 KiB) and the weight's
/// constants.
#[derive(Clone, PartialEq, Eq)]
pub struct FixedParams {
    tables: [[u32; KNOTS]; 3],
    /// `round(2^23 / span)`, at most 2^31.
    drop_per_unit: u32,
    /// The excess (in 1/256 of a variance) from which the weight is 0 whatever is added.
    excess_cap: u32,
}

impl core::fmt::Debug for FixedParams {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FixedParams")
            .field("drop_per_unit", &self.drop_per_unit)
            .finish_non_exhaustive()
    }
}

impl FixedParams {
    /// The fixed-point filter for `profile` at `strength` (`(0, 4]`) with `search`.
    pub fn new(profile: &NoiseProfile, strength: f32, search: Search) -> Result<Self, IspError> {
        let strength = check_strength(strength)?;
        let by_colour = stabilisers(profile);
        let mut tables = [[0u32; KNOTS]; 3];
        for c in 0..3 {
            // A colour with the same transform as an earlier one (a profile uniform over the
            // colours, as most are) copies its table: a third of the start-up each.
            if let Some(same) = (0..c).find(|&e| by_colour[e] == by_colour[c]) {
                tables[c] = tables[same];
                continue;
            }
            for (i, knot) in tables[c].iter_mut().enumerate() {
                let x = (knot_input(i) as f32 / 65535.0).min(1.0);
                // At most 256 / sqrt(Q) = 2^20.
                *knot = (by_colour[c].apply(x) * FIXED_SCALE + 0.5) as u32;
            }
        }
        // 2^23 / span: an excess of `span` (in 1/256 of a variance) drops u by 2^15 << 16.
        let per_unit =
            (f64::from(1u32 << 23) * inv_span(strength, search) + 0.5).clamp(1.0, 2_147_483_648.0);
        let drop_per_unit = per_unit as u32;
        Ok(Self {
            tables,
            drop_per_unit,
            excess_cap: ((1u64 << 31).div_ceil(u64::from(drop_per_unit))) as u32,
        })
    }

    /// The parameters for a raw of `pattern`.
    pub fn for_pattern(&self, pattern: CfaPattern) -> FixedNlm<'_> {
        FixedNlm {
            tables: colours(pattern).map(|c| &self.tables[c]),
            drop_per_unit: self.drop_per_unit,
            excess_cap: self.excess_cap,
        }
    }
}

/// [`FixedParams`] for one CFA pattern: what a [`Stream`] of the fixed path runs.
#[derive(Debug, Clone, Copy)]
pub struct FixedNlm<'p> {
    tables: [&'p [u32; KNOTS]; 4],
    drop_per_unit: u32,
    excess_cap: u32,
}

/// What the float and fixed filters compute differently; [`Stream`] is the one schedule.
pub trait Nlm: Copy {
    /// Samples and stabilised values.
    type S: Copy + Default + 'static;
    /// Terms, distances, weights and the weights' sums.
    type W: Copy + Default + core::ops::Add<Output = Self::W> + 'static;
    /// Weighted sums of samples.
    type A: Copy + Default + 'static;
    /// `v[i] = v_k(x[i])`: the stabilising transform of CFA position `k` (its values in the
    /// work type).
    fn stabilise(&self, k: usize, x: &[Self::S], v: &mut [Self::W]);
    /// One channel's term of a distance, from two stabilised values.
    fn term(a: Self::W, b: Self::W) -> Self::W;
    /// The weight of a distance.
    fn weight(&self, distance: Self::W) -> Self::W;
    /// `acc + w x`.
    fn mul_add(acc: Self::A, w: Self::W, x: Self::S) -> Self::A;
    /// The weight of 1 (the centre's).
    fn one() -> Self::W;
    /// The weighted mean `num / den`.
    fn output(num: Self::A, den: Self::W) -> Self::S;
}

impl Nlm for FloatNlm {
    type S = f32;
    type W = f32;
    type A = f32;

    #[inline(always)]
    fn stabilise(&self, k: usize, x: &[f32], v: &mut [f32]) {
        let stab = self.by_position[k];
        for (v, &x) in v.iter_mut().zip(x) {
            *v = stab.apply(x);
        }
    }

    #[inline(always)]
    fn term(a: f32, b: f32) -> f32 {
        let d = a - b;
        d * d
    }

    #[inline(always)]
    fn weight(&self, distance: f32) -> f32 {
        let excess = distance - 2.0 * TERMS;
        let excess = if excess > 0.0 { excess } else { 0.0 };
        let u = 1.0 - excess * self.inv_span;
        let u = if u > 0.0 { u } else { 0.0 };
        let u2 = u * u;
        let u4 = u2 * u2;
        u4 * u4
    }

    #[inline(always)]
    fn mul_add(acc: f32, w: f32, x: f32) -> f32 {
        acc + w * x
    }

    #[inline(always)]
    fn one() -> f32 {
        1.0
    }

    #[inline(always)]
    fn output(num: f32, den: f32) -> f32 {
        num / den
    }
}

impl Nlm for FixedNlm<'_> {
    type S = u16;
    type W = u32;
    type A = u64;

    #[inline(always)]
    fn stabilise(&self, k: usize, x: &[u16], v: &mut [u32]) {
        let table = self.tables[k];
        for (v, &x) in v.iter_mut().zip(x) {
            // Knots 16 codes apart below FINE_END, 64 above.
            let fine = usize::from(x) < FINE_END;
            let shift = if fine { 4 } else { 6 };
            let i = if fine {
                usize::from(x >> 4)
            } else {
                FINE_END / 16 - FINE_END / 64 + usize::from(x >> 6)
            };
            let f = u32::from(x) & ((1 << shift) - 1);
            // The table is non-decreasing, so the step is at least 0 (and below 2^21); i + 1
            // < KNOTS.
            let (a, b) = (table[i], table[i + 1]);
            *v = a + (((b - a) * f + (1 << (shift - 1))) >> shift);
        }
    }

    #[inline(always)]
    fn term(a: u32, b: u32) -> u32 {
        // The square in 1/65536 of a variance (below 2^29), rounded to 1/256.
        let d = a.abs_diff(b).min(FIXED_DIFF_CAP);
        (d * d + 128) >> 8
    }

    #[inline(always)]
    fn weight(&self, distance: u32) -> u32 {
        let excess = distance.saturating_sub(72 << 8).min(self.excess_cap);
        // excess * drop_per_unit <= 2^31 + drop_per_unit: fits u32; the drop is rounded.
        let drop = ((((excess * self.drop_per_unit) >> 15) + 1) >> 1).min(1 << 15);
        let u = (1 << 15) - drop;
        let square = |a: u32| (a * a + (1 << 14)) >> 15;
        square(square(square(u)))
    }

    #[inline(always)]
    fn mul_add(acc: u64, w: u32, x: u16) -> u64 {
        // A 32 x 32 -> 64-bit product (one instruction on a Cortex-M4, `pmuludq` on x86).
        acc + u64::from(w) * u64::from(x)
    }

    #[inline(always)]
    fn one() -> u32 {
        FIXED_ONE
    }

    #[inline(always)]
    fn output(num: u64, den: u32) -> u16 {
        // The centre's weight is 2^15, so `den` is never 0; the mean is at most 65535.
        div_round(num, den.max(1)) as u16
    }
}

/// `round(num / den)` (half up) for `num < 2^40` and `1 <= den < 2^22`. On x86-64 in `f64`,
/// which vectorises (the quotient of integers below 2^53 in `f64`, truncated, is the integer
/// quotient: one that is not an integer lies at least `1 / den` from the next, far more than
/// the division's rounding); elsewhere as integers.
#[inline(always)]
fn div_round(num: u64, den: u32) -> u64 {
    let num = num + u64::from(den / 2);
    #[cfg(target_arch = "x86_64")]
    {
        (num as f64 / f64::from(den)) as u64
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        num / u64::from(den)
    }
}

/// The sizes of a stream's rings for a search and a packed width.
#[derive(Debug, Clone, Copy)]
struct Layout {
    radius: usize,
    half: usize,
    wp: usize,
    /// Reflected packed pixels either side of a held row: the patch and twice the radius.
    pad: usize,
    /// Elements of one plane of a held row.
    plane: usize,
    /// Elements of one row of terms: packed columns `-R - 1 ..= wp + R`.
    terms: usize,
    /// Weights of one anchor row: packed columns `-R .. wp + R`.
    weights: usize,
}

impl Layout {
    fn new(search: Search, wp: usize) -> Option<Self> {
        let radius = search.radius();
        let pad = 2 * radius + 1;
        Some(Self {
            radius,
            half: search.half_len(),
            wp,
            pad,
            plane: wp.checked_add(2 * pad)?,
            terms: wp.checked_add(2 * radius + 2)?,
            weights: wp.checked_add(2 * radius)?,
        })
    }

    /// Samples: the held rows, each four planes.
    fn samples(&self) -> Option<usize> {
        held_rows(self.radius)
            .checked_mul(4)?
            .checked_mul(self.plane)
    }

    /// Work elements: the held rows' stabilised values (four planes each), three term rows per
    /// offset, a row of column sums, the weights, and the weights' sums of `R + 1` rows.
    fn work(&self) -> Option<usize> {
        let stable = self.samples()?;
        let terms = self
            .half
            .checked_mul(3)?
            .checked_add(1)?
            .checked_mul(self.terms)?;
        let dens = (self.radius + 1).checked_mul(self.wp)?;
        stable
            .checked_add(terms)?
            .checked_add(self.weights)?
            .checked_add(dens)
    }

    /// Weighted sums: four channels of `R + 1` rows.
    fn sums(&self) -> Option<usize> {
        (self.radius + 1).checked_mul(4)?.checked_mul(self.wp)
    }
}

/// Scratch a [`Stream`] needs for a packed width `wp`: `(samples, work, sums)` elements (of
/// the path's sample type, `f32` or `u16`, its work type, `f32` or `u32`, and its sums' type,
/// `f32` or `u64`).
pub fn scratch_len(search: Search, wp: usize) -> Option<(usize, usize, usize)> {
    let layout = Layout::new(search, wp)?;
    Some((layout.samples()?, layout.work()?, layout.sums()?))
}

/// "No row": the tag of an empty slot.
const NONE: isize = isize::MIN;

/// Non-local means over a packed mosaic, streamed packed row by packed row in caller scratch
/// (see the module docs for the schedule). [`Stream::row`] gives packed row `j`, filtered,
/// reading the rows it needs through a callback; asking for the row after the last one given
/// continues the stream, any other row starts it again there (a band's first row), with the
/// same output.
pub struct Stream<'s, A: Nlm> {
    nlm: A,
    layout: Layout,
    hp: usize,
    offsets: [(isize, isize); MAX_HALF],
    /// Held rows: [`held_rows`] slots of four planes of samples, and of their stabilised
    /// values.
    rows: &'s mut [A::S],
    stable: &'s mut [A::W],
    row_tags: [isize; held_rows(MAX_RADIUS)],
    /// Three rows of terms per offset, then a row of column sums.
    terms: &'s mut [A::W],
    term_tags: [isize; 3],
    weights: &'s mut [A::W],
    /// `R + 1` rows of the weights' sums, and of the four channels' weighted sums.
    dens: &'s mut [A::W],
    sums: &'s mut [A::A],
    sum_tags: [isize; MAX_RADIUS + 1],
    /// The packed row given next if the stream continues.
    next: Option<usize>,
}

impl<'s, A: Nlm> Stream<'s, A> {
    /// A stream over a packed frame `wp` x `hp` (both at least 1) with `samples` and `work`
    /// of at least [`scratch_len`] elements.
    pub fn new(
        nlm: A,
        search: Search,
        wp: usize,
        hp: usize,
        samples: &'s mut [A::S],
        work: &'s mut [A::W],
        sums: &'s mut [A::A],
    ) -> Result<Self, IspError> {
        if wp == 0 || hp == 0 {
            return Err(IspError::InvalidParameter {
                name: "denoise size",
                allowed: "at least one 2x2 block",
            });
        }
        let too_wide = IspError::InvalidParameter {
            name: "width",
            allowed: "a size that fits in memory",
        };
        let layout = Layout::new(search, wp).ok_or(too_wide)?;
        let (need_samples, need_work, need_sums) = (
            layout.samples().ok_or(too_wide)?,
            layout.work().ok_or(too_wide)?,
            layout.sums().ok_or(too_wide)?,
        );
        if samples.len() < need_samples {
            return Err(IspError::BufferTooSmall {
                needed: need_samples,
                provided: samples.len(),
            });
        }
        if work.len() < need_work {
            return Err(IspError::BufferTooSmall {
                needed: need_work,
                provided: work.len(),
            });
        }
        if sums.len() < need_sums {
            return Err(IspError::BufferTooSmall {
                needed: need_sums,
                provided: sums.len(),
            });
        }
        let mut offsets = [(0, 0); MAX_HALF];
        for (slot, o) in offsets.iter_mut().zip(search.half_window()) {
            *slot = o;
        }
        let (stable, rest) = work.split_at_mut(need_samples);
        let (terms, rest) = rest.split_at_mut((3 * layout.half + 1) * layout.terms);
        let (weights, rest) = rest.split_at_mut(layout.weights);
        let dens = &mut rest[..(layout.radius + 1) * wp];
        let sums = &mut sums[..need_sums];
        Ok(Self {
            nlm,
            layout,
            hp,
            offsets,
            rows: &mut samples[..need_samples],
            stable,
            row_tags: [NONE; held_rows(MAX_RADIUS)],
            terms,
            term_tags: [NONE; 3],
            weights,
            dens,
            sums,
            sum_tags: [NONE; MAX_RADIUS + 1],
            next: None,
        })
    }

    /// Filtered packed row `j` (below `hp`) into `out`, four planes of `wp` samples (CFA
    /// positions row-major in the 2x2 block). `fill(r, planes)` must write packed row `r`'s
    /// four planes (`wp` samples each) of the normalised mosaic; it is called for the rows the
    /// filter reads that it does not hold.
    #[inline(always)]
    pub fn row(
        &mut self,
        j: usize,
        mut fill: impl FnMut(usize, [&mut [A::S]; 4]) -> Result<(), IspError>,
        out: [&mut [A::S]; 4],
    ) -> Result<(), IspError> {
        let wp = self.layout.wp;
        if j >= self.hp || out.iter().any(|p| p.len() < wp) {
            return Err(IspError::InvalidParameter {
                name: "denoise row",
                allowed: "a packed row of the frame, four planes of its width",
            });
        }
        let r = self.layout.radius as isize;
        let j = j as isize;
        let first = match self.next {
            Some(next) if next as isize == j => j,
            // Start again: every anchor row that adds to row j, from j - R.
            _ => {
                self.sum_tags = [NONE; MAX_RADIUS + 1];
                j - r
            }
        };
        for anchor in first..=j {
            self.anchor_row(anchor, &mut fill)?;
        }
        self.finish(j, out);
        self.next = Some(j as usize + 1);
        Ok(())
    }

    /// The slot of held row `r` (a virtual row: the frame's row `reflect(r)`).
    fn row_slot(&self, r: isize) -> usize {
        r.rem_euclid(held_rows(self.layout.radius) as isize) as usize
    }

    /// Makes virtual packed rows `lo..=hi` held.
    #[inline(always)]
    fn hold_rows(
        &mut self,
        lo: isize,
        hi: isize,
        fill: &mut impl FnMut(usize, [&mut [A::S]; 4]) -> Result<(), IspError>,
    ) -> Result<(), IspError> {
        let Layout { wp, pad, plane, .. } = self.layout;
        for r in lo..=hi {
            let slot = self.row_slot(r);
            if self.row_tags[slot] == r {
                continue;
            }
            self.row_tags[slot] = NONE;
            let samples = &mut self.rows[slot * 4 * plane..(slot + 1) * 4 * plane];
            let stabilised = &mut self.stable[slot * 4 * plane..(slot + 1) * 4 * plane];
            let real = reflect(r, self.hp);
            {
                let [a, b, c, d] = planes_mut(samples, plane);
                fill(
                    real,
                    [
                        &mut a[pad..pad + wp],
                        &mut b[pad..pad + wp],
                        &mut c[pad..pad + wp],
                        &mut d[pad..pad + wp],
                    ],
                )?;
            }
            for (k, (x, v)) in samples
                .chunks_exact_mut(plane)
                .zip(stabilised.chunks_exact_mut(plane))
                .enumerate()
            {
                for i in 0..pad {
                    x[i] = x[pad + reflect(i as isize - pad as isize, wp)];
                    x[pad + wp + i] = x[pad + reflect((wp + i) as isize, wp)];
                }
                self.nlm.stabilise(k, x, v);
            }
            self.row_tags[slot] = r;
        }
        Ok(())
    }

    /// The four planes of the held row in `slot`, of samples or of stabilised values.
    fn planes<T>(rows: &[T], slot: usize, plane: usize) -> [&[T]; 4] {
        let row = &rows[slot * 4 * plane..(slot + 1) * 4 * plane];
        core::array::from_fn(|k| &row[k * plane..(k + 1) * plane])
    }

    /// The terms of every offset on virtual row `r` into their ring slot `r mod 3`.
    #[inline(always)]
    fn term_row(&mut self, r: isize) {
        let slot = r.rem_euclid(3) as usize;
        if self.term_tags[slot] == r {
            return;
        }
        let Layout {
            radius,
            half,
            pad,
            plane,
            terms,
            ..
        } = self.layout;
        let here = Self::planes(self.stable, self.row_slot(r), plane);
        for (t, &(dx, dy)) in self.offsets[..half].iter().enumerate() {
            let there = Self::planes(self.stable, self.row_slot(r + dy), plane);
            // Term column c (packed column c - R - 1) reads here at c - R - 1 and there at
            // c - R - 1 + dx, in padded indices.
            let base = pad - radius - 1;
            let shifted = (base as isize + dx) as usize;
            let dst = &mut self.terms[(3 * t + slot) * terms..(3 * t + slot + 1) * terms];
            let h: [&[A::W]; 4] = core::array::from_fn(|k| &here[k][base..base + terms]);
            let o: [&[A::W]; 4] = core::array::from_fn(|k| &there[k][shifted..shifted + terms]);
            for (i, e) in dst.iter_mut().enumerate() {
                *e = A::term(o[0][i], h[0][i])
                    + A::term(o[1][i], h[1][i])
                    + A::term(o[2][i], h[2][i])
                    + A::term(o[3][i], h[3][i]);
            }
        }
        self.term_tags[slot] = r;
    }

    /// Adds anchor row `a`'s contributions: for each offset, its weights, to row `a` from row
    /// `a + dy` and to row `a + dy` from row `a`.
    #[inline(always)]
    fn anchor_row(
        &mut self,
        a: isize,
        fill: &mut impl FnMut(usize, [&mut [A::S]; 4]) -> Result<(), IspError>,
    ) -> Result<(), IspError> {
        let Layout {
            radius,
            half,
            wp,
            pad,
            plane,
            terms,
            weights,
        } = self.layout;
        let r = radius as isize;
        self.hold_rows(a - 1, a + 1 + r, fill)?;
        for row in a - 1..=a + 1 {
            self.term_row(row);
        }
        // The sums of the rows this anchor adds to: a fresh slot for row a + R.
        for row in a..=a + r {
            let slot = row.rem_euclid(r + 1) as usize;
            if self.sum_tags[slot] != row {
                self.sums[slot * 4 * wp..(slot + 1) * 4 * wp].fill(A::A::default());
                self.dens[slot * wp..(slot + 1) * wp].fill(A::W::default());
                self.sum_tags[slot] = row;
            }
        }
        let hp = self.hp as isize;
        for t in 0..half {
            let (dx, dy) = self.offsets[t];
            // Column sums of the three term rows, then the 3-column sums and their weights.
            let (rings, column) = self.terms.split_at_mut(3 * half * terms);
            let ring = &rings[3 * t * terms..3 * (t + 1) * terms];
            let column = &mut column[..terms];
            let [e0, e1, e2] = [a - 1, a, a + 1].map(|row| {
                let s = row.rem_euclid(3) as usize;
                &ring[s * terms..(s + 1) * terms]
            });
            for (((c, &x), &y), &z) in column.iter_mut().zip(e0).zip(e1).zip(e2) {
                *c = x + y + z;
            }
            let (left, mid, right) = (
                &column[..weights],
                &column[1..1 + weights],
                &column[2..2 + weights],
            );
            for (((w, &x), &y), &z) in self.weights.iter_mut().zip(left).zip(mid).zip(right) {
                *w = self.nlm.weight(x + y + z);
            }
            let weights_row: &[A::W] = self.weights;
            let sum_slot = |row: isize| row.rem_euclid(r + 1) as usize;
            // To row a, from row a + dy at column + dx (anchor columns 0..wp: weights R..).
            if a >= 0 {
                let from = Self::planes(self.rows, self.row_slot(a + dy), plane);
                let at = (pad as isize + dx) as usize;
                let w = &weights_row[radius..radius + wp];
                let slot = sum_slot(a);
                let sums = &mut self.sums[slot * 4 * wp..(slot + 1) * 4 * wp];
                let dens = &mut self.dens[slot * wp..(slot + 1) * wp];
                accumulate::<A>(sums, dens, wp, w, from.map(|p| &p[at..at + wp]));
            }
            // To row a + dy at column q, from row a at column q - dx (anchor q - dx).
            let to = a + dy;
            if to >= 0 && to < hp {
                let from = Self::planes(self.rows, self.row_slot(a), plane);
                let at = (pad as isize - dx) as usize;
                let first = (radius as isize - dx) as usize;
                let w = &weights_row[first..first + wp];
                let slot = sum_slot(to);
                let sums = &mut self.sums[slot * 4 * wp..(slot + 1) * 4 * wp];
                let dens = &mut self.dens[slot * wp..(slot + 1) * wp];
                accumulate::<A>(sums, dens, wp, w, from.map(|p| &p[at..at + wp]));
            }
        }
        Ok(())
    }

    /// Row `j`'s output: its sums with the centre added, divided.
    #[inline(always)]
    fn finish(&mut self, j: isize, out: [&mut [A::S]; 4]) {
        let Layout {
            radius, wp, pad, ..
        } = self.layout;
        let plane = self.layout.plane;
        let slot = j.rem_euclid(radius as isize + 1) as usize;
        let sums = &self.sums[slot * 4 * wp..(slot + 1) * 4 * wp];
        let den = &self.dens[slot * wp..(slot + 1) * wp];
        let centre = Self::planes(self.rows, self.row_slot(j), plane);
        for (k, out) in out.into_iter().enumerate() {
            let num = &sums[k * wp..(k + 1) * wp];
            let x = &centre[k][pad..pad + wp];
            for (((o, &n), &d), &x) in out[..wp].iter_mut().zip(num).zip(den).zip(x) {
                *o = A::output(A::mul_add(n, A::one(), x), d + A::one());
            }
        }
    }
}

/// `sums` (four channels' numerators, `wp` each) plus `w` times `from`, and `den` plus `w`.
#[inline(always)]
fn accumulate<A: Nlm>(
    num: &mut [A::A],
    den: &mut [A::W],
    wp: usize,
    w: &[A::W],
    from: [&[A::S]; 4],
) {
    for (k, x) in from.iter().enumerate() {
        let num = &mut num[k * wp..(k + 1) * wp];
        for ((n, &w), &x) in num.iter_mut().zip(w).zip(*x) {
            *n = A::mul_add(*n, w, x);
        }
    }
    for (d, &w) in den[..wp].iter_mut().zip(w) {
        *d = *d + w;
    }
}

/// The four planes of a held row's half (samples or stabilised values).
fn planes_mut<T>(row: &mut [T], plane: usize) -> [&mut [T]; 4] {
    let (a, rest) = row.split_at_mut(plane);
    let (b, rest) = rest.split_at_mut(plane);
    let (c, d) = rest.split_at_mut(plane);
    [a, b, c, &mut d[..plane]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A packed frame of a noisy ramp with an edge (a deterministic generator), `u16`.
    fn frame(scale: f64, seed: u64) -> [[u16; W * H]; 4] {
        let mut next = math::xorshift(seed);
        let mut planes = [[0u16; W * H]; 4];
        for plane in planes.iter_mut() {
            for y in 0..H {
                for x in 0..W {
                    let noise = (next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    let level = if x < W / 2 { 0.05 } else { 0.4 } + 0.3 * y as f64 / H as f64;
                    let v = (level + noise * 3.46 * (scale * level + 1e-5).sqrt()).clamp(0.0, 1.0);
                    plane[y * W + x] = (v * 65535.0).round() as u16;
                }
            }
        }
        planes
    }

    /// The test frame's packed size.
    const W: usize = 13;
    const H: usize = 9;

    /// The definition, pixel by pixel over the whole window, in the path's own arithmetic.
    fn direct<A: Nlm>(nlm: &A, search: Search, x: &[[A::S; W * H]; 4], out: &mut [[A::S; W * H]; 4])
    where
        A::S: Default,
    {
        let at = |k: usize, r: isize, c: isize| x[k][reflect(r, H) * W + reflect(c, W)];
        let v = |k: usize, r: isize, c: isize| {
            let mut o = [A::W::default()];
            nlm.stabilise(k, &[at(k, r, c)], &mut o);
            o[0]
        };
        let r = search.radius() as isize;
        for py in 0..H as isize {
            for px in 0..W as isize {
                let (mut num, mut den) = ([A::A::default(); 4], A::W::default());
                for oy in -r..=r {
                    for ox in -r..=r {
                        let mut d = A::W::default();
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                for k in 0..4 {
                                    d = d + A::term(
                                        v(k, py + oy + dy, px + ox + dx),
                                        v(k, py + dy, px + dx),
                                    );
                                }
                            }
                        }
                        let w = if (ox, oy) == (0, 0) {
                            A::one()
                        } else {
                            nlm.weight(d)
                        };
                        for (k, n) in num.iter_mut().enumerate() {
                            *n = A::mul_add(*n, w, at(k, py + oy, px + ox));
                        }
                        den = den + w;
                    }
                }
                for k in 0..4 {
                    out[k][py as usize * W + px as usize] = A::output(num[k], den);
                }
            }
        }
    }

    /// Runs the stream over the whole frame, or from row `start`, into `out`.
    #[allow(clippy::too_many_arguments)] // a test helper: the stream's own arguments
    fn streamed<A: Nlm>(
        nlm: A,
        search: Search,
        x: &[[A::S; W * H]; 4],
        start: usize,
        out: &mut [[A::S; W * H]; 4],
        samples: &mut [A::S],
        work: &mut [A::W],
        sums: &mut [A::A],
    ) {
        let mut stream = Stream::new(nlm, search, W, H, samples, work, sums).unwrap();
        for j in start..H {
            let mut row = [[A::S::default(); W]; 4];
            let [a, b, c, d] = &mut row;
            stream
                .row(
                    j,
                    |r, planes| {
                        for (k, p) in planes.into_iter().enumerate() {
                            p.copy_from_slice(&x[k][r * W..(r + 1) * W]);
                        }
                        Ok(())
                    },
                    [a, b, c, d],
                )
                .unwrap();
            for k in 0..4 {
                out[k][j * W..(j + 1) * W].copy_from_slice(&row[k]);
            }
        }
    }

    /// The fixed path's stream is its definition bit for bit (integer sums are exact in any
    /// order), whole and restarted at any row, for both windows and several noise levels.
    #[test]
    fn fixed_stream_is_the_definition() {
        for (seed, scale) in [(1u64, 0.0008f32), (2, 0.0032), (3, 0.0128)] {
            let profile =
                NoiseProfile::new([scale, scale * 0.8, scale * 1.3], [2e-6, 1e-6, 3e-6]).unwrap();
            let planes = frame(f64::from(scale), seed);
            for search in Search::ALL {
                let params = FixedParams::new(&profile, 1.0, search).unwrap();
                for pattern in CfaPattern::ALL {
                    let nlm = params.for_pattern(pattern);
                    let mut want = [[0u16; W * H]; 4];
                    direct(&nlm, search, &planes, &mut want);
                    let (ns, nw, na) = scratch_len(search, W).unwrap();
                    let mut samples = [0u16; 4096];
                    let mut work = [0u32; 4096];
                    let mut sums = [0u64; 1024];
                    assert!(ns <= samples.len() && nw <= work.len() && na <= sums.len());
                    for start in [0, 1, 2, H - 1] {
                        let mut got = [[0u16; W * H]; 4];
                        streamed(
                            nlm,
                            search,
                            &planes,
                            start,
                            &mut got,
                            &mut samples,
                            &mut work,
                            &mut sums,
                        );
                        for k in 0..4 {
                            assert_eq!(
                                got[k][start * W..],
                                want[k][start * W..],
                                "{search:?} {pattern:?} S {scale} from row {start}, plane {k}"
                            );
                        }
                    }
                    // The filter does something: the noisy frame changes.
                    assert_ne!(want, planes);
                }
            }
        }
    }

    /// The float path's stream is its definition to rounding (sums formed in another order).
    #[test]
    fn float_stream_is_the_definition() {
        let profile = NoiseProfile::new([0.003, 0.002, 0.004], [1e-5, 0.0, 2e-6]).unwrap();
        let planes = frame(0.003, 7);
        let x: [[f32; W * H]; 4] =
            core::array::from_fn(|k| core::array::from_fn(|i| f32::from(planes[k][i]) / 65535.0));
        for search in Search::ALL {
            let params = FloatParams::new(&profile, 1.3, search).unwrap();
            let nlm = params.for_pattern(CfaPattern::Gbrg);
            let mut want = [[0.0f32; W * H]; 4];
            direct(&nlm, search, &x, &mut want);
            let mut samples = [0.0f32; 4096];
            let mut work = [0.0f32; 4096];
            let mut sums = [0.0f32; 1024];
            for start in [0, 3] {
                let mut got = [[0.0f32; W * H]; 4];
                streamed(
                    nlm,
                    search,
                    &x,
                    start,
                    &mut got,
                    &mut samples,
                    &mut work,
                    &mut sums,
                );
                for k in 0..4 {
                    for (g, w) in got[k][start * W..].iter().zip(&want[k][start * W..]) {
                        assert!((g - w).abs() < 2e-6, "{search:?}: {g} against {w}");
                    }
                }
            }
        }
    }

    /// The stabilised value's differences are in units of the noise's deviation: its slope is
    /// `1 / sqrt(var)` at every level, above and below the floor's knee.
    #[test]
    fn stabiliser_has_unit_noise() {
        for (s, o) in [
            (0.003f32, 1e-5f32),
            (0.0008, 0.0),
            (0.0, 1e-4),
            (0.01, 1e-9),
        ] {
            let stab = Stabiliser::new(s, o);
            for x in [1e-5f32, 1e-3, 0.01, 0.1, 0.5, 0.99] {
                let dx = 1e-2 * x;
                let slope = (stab.apply(x + dx) - stab.apply(x - dx)) / (2.0 * dx);
                let var = (s * x + o).max(VAR_FLOOR);
                let want = 1.0 / var.sqrt();
                assert!(
                    (slope / want - 1.0).abs() < 2e-3,
                    "S {s} O {o} x {x}: {slope} against {want}"
                );
            }
            assert_eq!(stab.apply(0.0), 0.0);
        }
    }

    /// The fixed tables follow the float transform to within half a table unit at the knots
    /// and are non-decreasing (the interpolation relies on it).
    #[test]
    fn fixed_tables_follow_the_transform() {
        let profile = NoiseProfile::new([0.0128, 0.0008, 0.0], [2.5e-4, 0.0, 1e-7]).unwrap();
        let params = FixedParams::new(&profile, 1.0, Search::Wide).unwrap();
        let float = stabilisers(&profile);
        for (table, stab) in params.tables.iter().zip(&float) {
            assert!(table.windows(2).all(|w| w[0] <= w[1]));
            for (i, &t) in table.iter().enumerate() {
                let x = (knot_input(i) as f32 / 65535.0).min(1.0);
                let want = stab.apply(x) * FIXED_SCALE;
                assert!(
                    (t as f32 - want).abs() <= 0.5 + 1e-6 * want,
                    "{i}: {t} {want}"
                );
            }
        }
    }

    /// The fixed weight is the float weight to within eight units of Q15 (2.4e-4), at every
    /// distance the fixed path can form around the threshold: the rounded drop's half unit
    /// grows eightfold through `u^8`, and each of the three squarings rounds.
    #[test]
    fn fixed_weight_tracks_the_float_weight() {
        let profile = NoiseProfile::uniform(0.002, 1e-5).unwrap();
        for strength in [0.05f32, 0.5, 1.0, 2.5, 4.0] {
            let fixed = FixedParams::new(&profile, strength, Search::Fast).unwrap();
            let float = FloatParams::new(&profile, strength, Search::Fast).unwrap();
            let (x, f) = (
                fixed.for_pattern(CfaPattern::Rggb),
                float.for_pattern(CfaPattern::Rggb),
            );
            for d in (0..(72 << 8) * 100).step_by(97).chain([u32::MAX >> 6]) {
                let want = f.weight(d as f32 / 256.0) * 32768.0;
                let got = x.weight(d) as f32;
                assert!(
                    (got - want).abs() <= 8.0,
                    "strength {strength} D {d}: {got} {want}"
                );
            }
        }
    }

    #[test]
    fn settings_and_sizes_are_checked() {
        let profile = NoiseProfile::uniform(0.002, 1e-5).unwrap();
        assert!(FloatParams::new(&profile, 0.0, Search::Wide).is_err());
        assert!(FixedParams::new(&profile, 4.5, Search::Wide).is_err());
        assert!(FloatParams::new(&profile, f32::NAN, Search::Fast).is_err());
        assert_eq!(Search::from_name("fast"), Ok(Search::Fast));
        assert!(Search::from_name("narrow").is_err());
        assert_eq!(Search::Wide.half_window().count(), Search::Wide.half_len());
        assert_eq!(Search::Fast.half_window().count(), 4);
        let nlm = FloatParams::new(&profile, 1.0, Search::Wide)
            .unwrap()
            .for_pattern(CfaPattern::Rggb);
        let (mut s, mut w, mut a) = ([0.0f32; 8], [0.0f32; 8], [0.0f32; 8]);
        assert!(matches!(
            Stream::new(nlm, Search::Wide, 4, 4, &mut s, &mut w, &mut a),
            Err(IspError::BufferTooSmall { .. })
        ));
        assert!(Stream::new(nlm, Search::Wide, 0, 4, &mut s, &mut w, &mut a).is_err());
    }
}
