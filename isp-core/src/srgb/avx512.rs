//! The fixed path's 8-bit encoding with AVX-512 (F and BW), 32 samples per vector and no
//! gathers: [`EncodeLut::lookup8`]'s codes, bit for bit (a test compares every input).
//!
//! A code is the number of the 255 code thresholds at or below the input (the table's codes
//! never fall as the input rises, so they are those counts). A binary search finds it in
//! eight steps of compare and masked add, each step's candidate thresholds held in registers
//! and picked per lane by a word permute: one to 32 candidates fit one register, 64 two, 128
//! four. The first step's one candidate is a broadcast and the second's two a blend (this
//! took the fixed pipeline's MHC frame from 3.40 to 3.32 ns per pixel). The table look-up it replaces is a load per lane, which LLVM vectorises as an
//! extract and an insert per lane, the costliest part of the fixed pipeline's encoding.

use core::arch::x86_64::*;

use bytemuck::must_cast;

use super::{chunked_halves, encode_rest, EncodeLut, SEARCH8_TABLES};

/// The search tables as vectors, loaded once per row, and the first two steps' thresholds
/// broadcast (those steps have one and two candidates: a compare and a blend, not a shift
/// and a permute each).
struct Tables {
    /// Each step's candidates, as [`EncodeLut`]'s `search8` holds them.
    steps: [__m512i; SEARCH8_TABLES],
    /// The thresholds of codes 128, 64 and 192.
    first_two: [__m512i; 3],
}

impl Tables {
    #[target_feature(enable = "avx512f,avx512bw")]
    fn new(lut: &EncodeLut) -> Self {
        let t = lut.search8;
        let broadcast = |v: u16| _mm512_set1_epi16(v as i16);
        Self {
            steps: t.map(must_cast::<[u16; 32], __m512i>),
            first_two: [broadcast(t[0][0]), broadcast(t[1][0]), broadcast(t[1][1])],
        }
    }

    /// The codes of 32 linear inputs.
    #[target_feature(enable = "avx512f,avx512bw")]
    #[inline]
    fn codes(&self, x: __m512i) -> __m512i {
        let (t, [at128, at64, at192]) = (&self.steps, &self.first_two);
        // Step `s` asks whether the threshold of `code + 2^s` is at or below `x`; `code` is a
        // multiple of 2^(s+1) there, so its candidates are indexed by `code >> (s + 1)`.
        // The first step's one candidate is the threshold of 128, the second's those of 64
        // and 192, picked by the first step's answer.
        let upper = _mm512_cmpge_epu16_mask(x, *at128);
        let mut code = _mm512_maskz_mov_epi16(upper, _mm512_set1_epi16(128));
        code = take(code, x, _mm512_mask_blend_epi16(upper, *at64, *at192), 64);
        code = take(
            code,
            x,
            _mm512_permutexvar_epi16(_mm512_srli_epi16::<6>(code), t[2]),
            32,
        );
        code = take(
            code,
            x,
            _mm512_permutexvar_epi16(_mm512_srli_epi16::<5>(code), t[3]),
            16,
        );
        code = take(
            code,
            x,
            _mm512_permutexvar_epi16(_mm512_srli_epi16::<4>(code), t[4]),
            8,
        );
        code = take(
            code,
            x,
            _mm512_permutexvar_epi16(_mm512_srli_epi16::<3>(code), t[5]),
            4,
        );
        let j = _mm512_srli_epi16::<2>(code);
        code = take(code, x, _mm512_permutex2var_epi16(t[6], j, t[7]), 2);
        let j = _mm512_srli_epi16::<1>(code);
        let low = _mm512_permutex2var_epi16(t[8], j, t[9]);
        let high = _mm512_permutex2var_epi16(t[10], j, t[11]);
        let upper = _mm512_test_epi16_mask(j, _mm512_set1_epi16(64));
        take(code, x, _mm512_mask_blend_epi16(upper, low, high), 1)
    }
}

/// `code + bit` in the lanes whose threshold is at or below `x`.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn take(code: __m512i, x: __m512i, threshold: __m512i, bit: i16) -> __m512i {
    let at_or_above = _mm512_cmpge_epu16_mask(x, threshold);
    _mm512_mask_add_epi16(code, at_or_above, code, _mm512_set1_epi16(bit))
}

/// Word indices that interleave three vectors of words `a`, `b`, `c` as `a0 b0 c0 a1 b1 c1
/// ...`: output vector `part` (0 to 2) is `permutex2var(a, AB[part], b)` with the lanes of
/// `C_LANES[part]` then taken from `c` at `C[part]`.
const fn interleave3() -> ([[u16; 32]; 3], [[u16; 32]; 3], [u32; 3]) {
    let mut ab = [[0u16; 32]; 3];
    let mut c = [[0u16; 32]; 3];
    let mut c_lanes = [0u32; 3];
    let mut part = 0;
    while part < 3 {
        let mut lane = 0;
        while lane < 32 {
            let word = 32 * part + lane;
            let (pixel, source) = ((word / 3) as u16, word % 3);
            match source {
                0 => ab[part][lane] = pixel,
                1 => ab[part][lane] = 32 + pixel,
                _ => {
                    c[part][lane] = pixel;
                    c_lanes[part] |= 1 << lane;
                }
            }
            lane += 1;
        }
        part += 1;
    }
    (ab, c, c_lanes)
}

const INTERLEAVE3: ([[u16; 32]; 3], [[u16; 32]; 3], [u32; 3]) = interleave3();

/// Encodes a row of planes in halves (each plane its `even` even columns, then its `odd` odd
/// columns; `w = even + odd`) to interleaved 8-bit sRGB in `out` (`3 w` bytes), as the
/// planar schedule's encoding does with [`EncodeLut::lookup8`]. `lut` is an 8-bit table.
#[target_feature(enable = "avx512f,avx512bw")]
pub(crate) fn encode_halves8(
    lut: &EncodeLut,
    planes: [&[u16]; 3],
    even: usize,
    odd: usize,
    out: &mut [u8],
) {
    let w = even + odd;
    if even < odd || planes.iter().any(|p| p.len() < w) || out.len() < 3 * w {
        // Not a planar row; the caller passes only those.
        return;
    }
    let tables = Tables::new(lut);
    let (ab, c, c_lanes) = INTERLEAVE3;
    let ab = ab.map(must_cast::<[u16; 32], __m512i>);
    let c = c.map(must_cast::<[u16; 32], __m512i>);
    let [r, g, b] = planes;
    let ([re, ro], [ge, go], [be, bo]) = (
        chunked_halves::<_, 32>(r, even, odd),
        chunked_halves::<_, 32>(g, even, odd),
        chunked_halves::<_, 32>(b, even, odd),
    );
    let (chunks, _) = out[..6 * odd].as_chunks_mut::<192>();
    let done = chunks.len() * 32;
    for (i, dst) in chunks.iter_mut().enumerate() {
        let code = |plane: &[[u16; 32]]| tables.codes(must_cast(plane[i]));
        // Two codes per word, in output order: (R, G) even, (B even, R odd), (G, B) odd.
        let pair = |low: __m512i, high: __m512i| _mm512_or_si512(low, _mm512_slli_epi16::<8>(high));
        let words = [
            pair(code(re), code(ge)),
            pair(code(be), code(ro)),
            pair(code(go), code(bo)),
        ];
        let part = |k: usize| {
            let ab = _mm512_permutex2var_epi16(words[0], ab[k], words[1]);
            _mm512_mask_permutexvar_epi16(ab, c_lanes[k], c[k], words[2])
        };
        *dst = must_cast([part(0), part(1), part(2)]);
    }
    encode_rest(|v: u16| lut.lookup8(v) as u8, planes, even, odd, done, out);
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    /// The planar schedule's encoding of a row in halves, one table load per sample.
    fn encode_scalar(lut: &EncodeLut, planes: [&[u16]; 3], even: usize, odd: usize) -> Vec<u8> {
        let w = even + odd;
        (0..w)
            .flat_map(|x| {
                let at = if x % 2 == 0 { x / 2 } else { even + x / 2 };
                planes.map(|p| lut.lookup8(p[at]) as u8)
            })
            .collect()
    }

    /// Every input in every plane and both halves, and every width to 200 (the tails past
    /// the last 32 pixel pairs, odd widths), give the table's codes.
    #[test]
    fn codes_are_the_tables_at_every_input_and_width() {
        if !(std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw"))
        {
            std::eprintln!("no AVX-512 F and BW on this CPU: the encoder is not run here");
            return;
        }
        let lut = EncodeLut::new(8).unwrap();
        let mut widths: Vec<usize> = (1..200).collect();
        widths.push(2 * 65536 + 1);
        for w in widths {
            let (even, odd) = (w.div_ceil(2), w / 2);
            // Each plane visits every input once per 65536 samples, in a different order.
            let plane = |k: u32| -> Vec<u16> {
                (0..w as u32)
                    .map(|i| (i.wrapping_mul(k).wrapping_add(w as u32 * 977)) as u16)
                    .collect()
            };
            let (r, g, b) = (plane(1), plane(40503), plane(65535));
            let planes = [&r[..], &g[..], &b[..]];
            let mut out = std::vec![0u8; 3 * w];
            // SAFETY: the features were detected above.
            #[allow(unsafe_code)]
            unsafe {
                encode_halves8(&lut, planes, even, odd, &mut out)
            };
            let expected = encode_scalar(&lut, planes, even, odd);
            if let Some(i) = (0..3 * w).find(|i| out[*i] != expected[*i]) {
                panic!("width {w}: byte {i} is {} not {}", out[i], expected[i]);
            }
        }
    }
}
