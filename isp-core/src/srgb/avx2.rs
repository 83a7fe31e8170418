//! The float path's 8-bit encoding with AVX2 and FMA, eight samples per vector and no
//! gathers: [`EncodeThresholds8::code_clamped`]'s codes, bit for bit (a test compares every
//! `f32` in `[0, 1]`).
//!
//! The scalar encoder looks each sample up in two tables (a byte load, a word load, a
//! compare, about 7 instructions per sample). AVX2 has no safe gather, so here the curve is
//! evaluated instead, closely enough to decide almost every code, and the few samples it
//! cannot decide are looked up:
//!
//! - Below the linear threshold the value is `255 * 12.92 x + 0.5`, as the exact curve has it.
//! - Above it, `x = 2^e m` with `m` in `[1, 2)`, and `x^(1/2.4) = 2^(e/2.4) m^(1/2.4)`. The
//!   factor `255 * 1.055 * 2^(e/2.4)` comes from a table of eight indexed by the exponent
//!   (the power segment spans nine octaves, so the ninth is a blend), and `m^(1/2.4)` from a
//!   cubic per eighth of the octave, its coefficients picked per lane by a register permute
//!   from four tables of eight. The cubics interpolate the curve at Chebyshev nodes (computed
//!   in `f64` when the tables are built).
//! - The code is the value plus a half, truncated. Where the value lies within
//!   [`UNDECIDED`] of a whole number (the exact encoding rounds `f32` products of its own
//!   there, so the approximation cannot tell which side it falls on), the group of sixteen
//!   pixels is looked up instead: 2e-4 of samples where the values' fractions spread evenly,
//!   about 1 group in 100.
//!
//! About 44 instructions per vector of eight (27 of them the method; the rest reloads and
//! spills, since the tables and constants want 17 of the 16 `ymm` registers), against about
//! 56 scalar: on a Zen 3, float MHC went from 4.39 to 4.14 ns per pixel and float directional
//! from 10.00 to 9.86 (best of 5 x 20 repeats each, `camsim bench isp`).

use core::arch::x86_64::*;

use bytemuck::must_cast;

use super::{chunked_halves, encode_pairs, encode_rest, EncodeThresholds8};

/// Distance from a whole number below which a value is looked up, not rounded. The
/// approximation and the exact encoding's rounding of its own `f32` products differ by under
/// 3e-5 codes: the exhaustive test passes with 3e-5 here and fails with 1.5e-5. Three times
/// that leaves 2e-4 of samples undecided where the fractions spread evenly.
const UNDECIDED: f32 = 1e-4;

/// The largest `f32` below 1.0: its code is 255, as 1.0's is, and it keeps every input's
/// exponent below 0, so the octave table needs no entry for 1.0.
const BELOW_ONE: f32 = 0.999_999_94;

/// The approximation's tables, built once with the thresholds.
#[derive(Clone, Copy)]
pub(crate) struct PowerTables {
    /// Cubic coefficients (constant term first) of `m^(1/2.4)` on eighth `j` of the octave,
    /// in `u = (f - 1/2) / 8` where `f` in `[0, 1)` is the position within the eighth (the
    /// mantissa's low 20 bits as a float's mantissa are `1 + f / 8`, so `u` is that less
    /// 17/16, exactly); indexed by `j`.
    cubic: [[f32; 8]; 4],
    /// `255 * 1.055 * 2^(e/2.4)` for the exponent field `e + 127` in `118..=125`, indexed by
    /// the field's low three bits.
    octave: [f32; 8],
    /// The same for the field 126 (the octave `[0.5, 1)`), whose low bits are 118's.
    top_octave: f32,
}

/// Exponent field of the octave that [`PowerTables::top_octave`] holds.
const TOP_FIELD: i32 = 126;

impl PowerTables {
    /// The tables, from the curve evaluated in `f64`.
    pub(crate) fn new() -> Self {
        let per_eighth: [[f32; 4]; 8] = core::array::from_fn(|j| {
            // Interpolation at the four Chebyshev nodes of s = 16 u in [-1, 1]: the
            // Chebyshev series' coefficients, then the monomials in u.
            let f = |s: f64| libm::pow(1.0 + (j as f64 + 0.5 + s / 2.0) / 8.0, 1.0 / 2.4);
            let nodes: [f64; 4] = core::array::from_fn(|k| {
                libm::cos(core::f64::consts::PI * (2 * k + 1) as f64 / 8.0)
            });
            let series: [f64; 4] = core::array::from_fn(|n| {
                let sum: f64 = nodes
                    .iter()
                    .map(|&s| f(s) * libm::cos(n as f64 * libm::acos(s)))
                    .sum();
                sum / if n == 0 { 4.0 } else { 2.0 }
            });
            let [c0, c1, c2, c3] = series;
            // T2 = 2 s^2 - 1, T3 = 4 s^3 - 3 s, and s = 16 u.
            let in_s = [c0 - c2, c1 - 3.0 * c3, 2.0 * c2, 4.0 * c3];
            core::array::from_fn(|power| (in_s[power] * libm::pow(16.0, power as f64)) as f32)
        });
        let cubic = core::array::from_fn(|power| core::array::from_fn(|j| per_eighth[j][power]));
        let factor =
            |field: i32| (255.0 * 1.055 * libm::pow(2.0, f64::from(field - 127) / 2.4)) as f32;
        let mut octave = [0.0f32; 8];
        for field in 118..=125 {
            octave[(field & 7) as usize] = factor(field);
        }
        Self {
            cubic,
            octave,
            top_octave: factor(TOP_FIELD),
        }
    }
}

/// The tables as vectors, loaded once per row.
struct Vectors {
    cubic: [__m256; 4],
    octave: __m256,
    top_octave: __m256,
}

impl Vectors {
    #[target_feature(enable = "avx2")]
    fn new(tables: &PowerTables) -> Self {
        Self {
            cubic: tables.cubic.map(must_cast::<[f32; 8], __m256>),
            octave: must_cast(tables.octave),
            top_octave: _mm256_set1_ps(tables.top_octave),
        }
    }

    /// The codes of eight clamped inputs (as [`EncodeThresholds8::code_clamped`] takes them),
    /// and the lanes whose code is undecided (all bits set).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn codes(&self, x: __m256) -> (__m256i, __m256) {
        let below_one = _mm256_min_ps(x, _mm256_set1_ps(BELOW_ONE));
        let bits = _mm256_castps_si256(below_one);
        // The position f within the eighth of the octave as 1 + f / 8, then u = (f - 1/2) / 8.
        let mantissa_low = _mm256_and_si256(bits, _mm256_set1_epi32(0x000f_ffff));
        let f_eighth_plus_one = _mm256_castsi256_ps(_mm256_or_si256(
            mantissa_low,
            _mm256_set1_epi32(0x3f80_0000),
        ));
        let u = _mm256_sub_ps(f_eighth_plus_one, _mm256_set1_ps(1.0625));
        // The permute reads the low three bits of each index: the eighth, the top three
        // mantissa bits.
        let eighth = _mm256_srli_epi32::<20>(bits);
        let [c0, c1, c2, c3] = self.cubic.map(|c| _mm256_permutevar8x32_ps(c, eighth));
        let root = _mm256_fmadd_ps(_mm256_fmadd_ps(_mm256_fmadd_ps(c3, u, c2), u, c1), u, c0);
        let field = _mm256_srli_epi32::<23>(bits);
        let octave = _mm256_blendv_ps(
            _mm256_permutevar8x32_ps(self.octave, field),
            self.top_octave,
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(field, _mm256_set1_epi32(TOP_FIELD))),
        );
        // Plus a half: the code is then the value truncated.
        let power = _mm256_fmadd_ps(octave, root, _mm256_set1_ps(0.5 - 255.0 * 0.055));
        let linear = _mm256_fmadd_ps(x, _mm256_set1_ps(255.0 * 12.92), _mm256_set1_ps(0.5));
        let in_linear = _mm256_cmp_ps::<_CMP_LE_OQ>(x, _mm256_set1_ps(super::LINEAR_THRESHOLD));
        let value = _mm256_blendv_ps(power, linear, in_linear);
        let nearest = _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(value);
        let distance = _mm256_andnot_ps(_mm256_set1_ps(-0.0), _mm256_sub_ps(value, nearest));
        let undecided = _mm256_cmp_ps::<_CMP_LT_OQ>(distance, _mm256_set1_ps(UNDECIDED));
        (_mm256_cvttps_epi32(value), undecided)
    }
}

/// Byte shuffles that interleave four pixel pairs per 128-bit lane. The lane's bytes are
/// `R even 0-3, R odd 0-3, G even 0-3, G odd 0-3` in one vector and `B even 0-3, B odd 0-3`
/// in the other; output byte `n` (pair `n / 6`, sample `n % 6` of `R G B R G B`) comes from
/// the first or the second, -1 (zero) in the other: `[from the first, from the second]` for
/// the first 16 output bytes, then for the last 8.
const INTERLEAVE: [[i8; 32]; 4] = {
    let mut masks = [[-1i8; 32]; 4];
    let mut n = 0;
    while n < 24 {
        let (pair, sample) = (n / 6, n % 6);
        let (from_rg, byte) = match sample {
            0 => (true, pair),
            1 => (true, 8 + pair),
            2 => (false, pair),
            3 => (true, 4 + pair),
            4 => (true, 12 + pair),
            _ => (false, 4 + pair),
        };
        let (mask, at) = match (from_rg, n < 16) {
            (true, true) => (0, n),
            (false, true) => (1, n),
            (true, false) => (2, n - 16),
            (false, false) => (3, n - 16),
        };
        masks[mask][at] = byte as i8;
        masks[mask][16 + at] = byte as i8;
        n += 1;
    }
    masks
};

/// Encodes a row of clamped planes in halves (each plane its `even` even columns, then its
/// `odd` odd columns; `w = even + odd`) to interleaved 8-bit sRGB in `out` (`3 w` bytes), as
/// the planar schedule's encoding does with [`EncodeThresholds8::code_clamped`].
///
/// Sixteen pixels at a time: the six half-planes' vectors of eight, packed to bytes and
/// interleaved by byte shuffles; the sixteen looked up if any of their samples is undecided.
/// (A first pass per half-plane into byte rows, one vector in flight, then the interleave,
/// was 10 % slower on a Zen 3.)
#[target_feature(enable = "avx2,fma")]
pub(crate) fn encode_halves8(
    codes: &EncodeThresholds8,
    planes: [&[f32]; 3],
    even: usize,
    odd: usize,
    out: &mut [u8],
) {
    let w = even + odd;
    if even < odd || planes.iter().any(|p| p.len() < w) || out.len() < 3 * w {
        // Not a planar row; the caller passes only those.
        return;
    }
    let vectors = Vectors::new(&codes.power);
    let masks = INTERLEAVE.map(must_cast::<[i8; 32], __m256i>);
    let [r, g, b] = planes;
    let ([re, ro], [ge, go], [be, bo]) = (
        chunked_halves::<_, 8>(r, even, odd),
        chunked_halves::<_, 8>(g, even, odd),
        chunked_halves::<_, 8>(b, even, odd),
    );
    let code = |v: f32| codes.code_clamped(v);
    let (chunks, _) = out[..6 * odd].as_chunks_mut::<48>();
    let done = chunks.len() * 8;
    for (i, dst) in chunks.iter_mut().enumerate() {
        // A plane at a time, packed at once (fewer vectors live than all six first).
        let plane = |even: &[[f32; 8]], odd: &[[f32; 8]]| {
            let (even, undecided_even) = vectors.codes(must_cast(even[i]));
            let (odd, undecided_odd) = vectors.codes(must_cast(odd[i]));
            // Words per lane: even 0-3 then odd 0-3 (lane 0) and 4-7 (lane 1).
            (
                _mm256_packs_epi32(even, odd),
                _mm256_or_ps(undecided_even, undecided_odd),
            )
        };
        let (red, undecided_red) = plane(re, ro);
        let (green, undecided_green) = plane(ge, go);
        let (blue, undecided_blue) = plane(be, bo);
        let undecided = _mm256_or_ps(_mm256_or_ps(undecided_red, undecided_green), undecided_blue);
        if _mm256_movemask_ps(undecided) != 0 {
            encode_pairs(code, planes, even, 8 * i, dst);
            continue;
        }
        let rg = _mm256_packus_epi16(red, green);
        let bb = _mm256_packus_epi16(blue, blue);
        let shuffled = |from_rg: __m256i, from_b: __m256i| {
            _mm256_or_si256(
                _mm256_shuffle_epi8(rg, from_rg),
                _mm256_shuffle_epi8(bb, from_b),
            )
        };
        let first: [u8; 32] = must_cast(shuffled(masks[0], masks[1]));
        let last: [u8; 32] = must_cast(shuffled(masks[2], masks[3]));
        dst[..16].copy_from_slice(&first[..16]);
        dst[16..24].copy_from_slice(&last[..8]);
        dst[24..40].copy_from_slice(&first[16..]);
        dst[40..].copy_from_slice(&last[16..24]);
    }
    encode_rest(code, planes, even, odd, done, out);
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    fn have_features() -> bool {
        let yes = std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma");
        if !yes {
            std::eprintln!("no AVX2 and FMA on this CPU: the encoder is not run here");
        }
        yes
    }

    /// Inputs `from..=to` (bit patterns) eight at a time: how many lanes were undecided, and
    /// the first decided input whose code is not the thresholds' code.
    #[target_feature(enable = "avx2,fma")]
    fn sweep(codes: &EncodeThresholds8, from: u32, to: u32) -> (u64, Option<u32>) {
        let vectors = Vectors::new(&codes.power);
        let mut undecided = 0u64;
        for start in (from..=to).step_by(8) {
            let x: [f32; 8] = core::array::from_fn(|k| f32::from_bits((start + k as u32).min(to)));
            let (got, open) = vectors.codes(must_cast(x));
            let (got, open): ([i32; 8], [u32; 8]) = (must_cast(got), must_cast(open));
            for k in 0..8 {
                if open[k] != 0 {
                    undecided += 1;
                } else if got[k] != i32::from(codes.code_clamped(x[k])) {
                    return (undecided, Some(x[k].to_bits()));
                }
            }
        }
        (undecided, None)
    }

    /// Every `f32` in `[0, 1]`: each decided lane's code is the thresholds' code (and so the
    /// exact encoding's), and under 0.1 % of lanes are undecided.
    #[test]
    fn decided_codes_are_the_thresholds_at_every_input() {
        if !have_features() {
            return;
        }
        let codes = EncodeThresholds8::new();
        let one = 1.0f32.to_bits();
        let parts = [(0, one / 2), (one / 2 + 1, one)];
        let results: Vec<(u64, Option<u32>)> = std::thread::scope(|s| {
            let codes = &codes;
            let handles: Vec<_> = parts
                .iter()
                .map(|&(from, to)| {
                    // SAFETY: the features were detected above.
                    #[allow(unsafe_code)]
                    s.spawn(move || unsafe { sweep(codes, from, to) })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let mut undecided = 0;
        for (open, wrong) in results {
            if let Some(bits) = wrong {
                let x = f32::from_bits(bits);
                panic!("{x:e} ({bits:#x}): code {} expected", codes.code_clamped(x));
            }
            undecided += open;
        }
        let total = u64::from(one) + 1;
        std::eprintln!("undecided lanes: {undecided} of {total}");
        assert!(undecided * 1000 < total, "{undecided} of {total} undecided");
    }

    /// A row through [`encode_halves8`] against the scalar encoding, at every width to 100
    /// and one long row, with values that make some groups undecided.
    #[test]
    fn rows_are_the_scalar_encoding() {
        if !have_features() {
            return;
        }
        let codes = EncodeThresholds8::new();
        let thresholds = codes.thresholds();
        let mut widths: Vec<usize> = (1..100).collect();
        widths.push(4099);
        for w in widths {
            let (even, odd) = (w.div_ceil(2), w / 2);
            let plane = |k: u32| -> Vec<f32> {
                (0..w as u32)
                    .map(|i| {
                        let h = i.wrapping_mul(2_654_435_761).wrapping_add(k * 40503) >> 8;
                        match h % 8 {
                            // A threshold itself, or the float below it: undecided groups.
                            0 => thresholds[(h / 8 % 255) as usize],
                            1 => f32::from_bits(thresholds[(h / 8 % 255) as usize].to_bits() - 1),
                            2 => 0.0,
                            3 => 1.0,
                            _ => (h % 1_000_003) as f32 / 1_000_003.0,
                        }
                    })
                    .collect()
            };
            let (r, g, b) = (plane(1), plane(2), plane(3));
            let planes = [&r[..], &g[..], &b[..]];
            let mut out = std::vec![0u8; 3 * w];
            // SAFETY: the features were detected above.
            #[allow(unsafe_code)]
            unsafe {
                encode_halves8(&codes, planes, even, odd, &mut out)
            };
            for x in 0..w {
                let at = if x % 2 == 0 { x / 2 } else { even + x / 2 };
                let expected = planes.map(|p| codes.code_clamped(p[at]));
                assert_eq!(out[3 * x..3 * x + 3], expected, "width {w}, pixel {x}");
            }
        }
    }
}
