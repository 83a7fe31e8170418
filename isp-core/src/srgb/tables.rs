//! The fixed-point sRGB encoding's tables ([`super::EncodeLut`]), computed from the exact curve
//! in `f64`. Shared by the build script, which evaluates them once and writes them into the
//! library as `static` tables (a camera's firmware then starts without evaluating 5121 `f64`
//! powers in software: 51 million instructions on a Cortex-M4), and by the tests, which
//! evaluate them again and compare. Plain functions of `core` and `libm` only, so the build
//! script can compile this file on its own.

/// Linear value above which the power segment applies (IEC 61966-2-1).
pub const LINEAR_THRESHOLD: f32 = 0.003_130_8;
/// Entries of the direct table for the darkest inputs.
pub const LOW_ENTRIES: usize = 1024;
/// Entries of the interpolated table: one every 16 input steps, plus the end.
pub const HIGH_ENTRIES: usize = 65536 / 16 + 1;
/// Runs of 16 inputs in the 16-bit linear range.
pub const RUNS: usize = 65536 / 16;
/// Tables of 32 thresholds for the eight steps of a binary search over the 8-bit codes.
pub const SEARCH8_TABLES: usize = 12;

/// The encoding of linear input `v` (65535 is 1.0) with 8 fractional bits at output maximum
/// `max`: `f64`, so the table's entries carry no `f32` error of their own.
pub fn exact_q8(v: f64, max: u32) -> u32 {
    let x = (v / 65535.0).clamp(0.0, 1.0);
    let e = if x <= LINEAR_THRESHOLD as f64 {
        12.92 * x
    } else {
        1.055 * libm::pow(x, 1.0 / 2.4) - 0.055
    };
    (e.clamp(0.0, 1.0) * max as f64 * 256.0 + 0.5) as u32
}

/// The direct table: inputs `0..LOW_ENTRIES`.
pub fn low(max: u32) -> [u32; LOW_ENTRIES] {
    core::array::from_fn(|i| exact_q8(i as f64, max))
}

/// The interpolated table: inputs `16 i`.
pub fn high(max: u32) -> [u32; HIGH_ENTRIES] {
    core::array::from_fn(|i| exact_q8((16 * i) as f64, max))
}

/// The encoded value of `linear` with 8 fractional bits from the two tables.
pub fn lookup_q8(low: &[u32; LOW_ENTRIES], high: &[u32; HIGH_ENTRIES], linear: u16) -> u32 {
    let v = linear as usize;
    if v < LOW_ENTRIES {
        low[v]
    } else {
        let (i, f) = (v >> 4, (v & 15) as u32);
        (high[i] * (16 - f) + high[i + 1] * f + 8) >> 4
    }
}

/// The encoded value rounded to the output depth.
pub fn interpolated(
    low: &[u32; LOW_ENTRIES],
    high: &[u32; HIGH_ENTRIES],
    max: u32,
    linear: u16,
) -> u32 {
    ((lookup_q8(low, high, linear) + 128) >> 8).min(max)
}

/// The 8-bit runs table (see [`super::EncodeLut::lookup8`]): per run of 16 inputs, the code at
/// its start and the offset in the run from which the code is one more, folded into one word.
pub fn runs8(low: &[u32; LOW_ENTRIES], high: &[u32; HIGH_ENTRIES]) -> [u16; RUNS] {
    core::array::from_fn(|run| {
        let first = (16 * run) as u16;
        let code = |v: u16| interpolated(low, high, 255, v);
        let base = code(first);
        let step = (1..16u16).find(|i| code(first + i) > base).unwrap_or(16);
        // The code and its step in the high and low byte; the run's first input taken off,
        // so the input itself can be added.
        ((base as u16) << 8 | (256 - step)).wrapping_sub(first)
    })
}

/// The 8-bit code of `linear` from the runs table.
pub fn lookup8(runs8: &[u16; RUNS], linear: u16) -> u32 {
    let entry = runs8[usize::from(linear >> 4)];
    u32::from(entry.wrapping_add(linear) >> 8)
}

/// The thresholds of the 8-bit codes arranged for a binary search (see
/// `EncodeLut::search8_tables`'s use in the AVX-512 encoder): the search's step `s` (from 7
/// down to 0) holds a code that is a multiple of 2^(s+1) and asks whether the input reaches
/// the threshold of `code + 2^s`, so its candidates are those thresholds indexed by
/// `code >> (s + 1)`: one for step 7 and 128 for step 0. Steps 7 to 2 take a table each, step
/// 1 two, step 0 four. Threshold `k` is the smallest input whose code is at least `k`.
pub fn search8(runs8: &[u16; RUNS]) -> [[u16; 32]; SEARCH8_TABLES] {
    let mut threshold = [u16::MAX; 256];
    threshold[0] = 0;
    let mut next = 1;
    for linear in 0..=u16::MAX {
        let code = lookup8(runs8, linear) as usize;
        while next <= code.min(255) {
            threshold[next] = linear;
            next += 1;
        }
    }
    let mut tables = [[u16::MAX; 32]; SEARCH8_TABLES];
    let mut first_table = 0;
    for step in (0..8).rev() {
        let candidates = 128 >> step;
        for j in 0..candidates {
            tables[first_table + j / 32][j % 32] = threshold[(j << (step + 1)) + (1 << step)];
        }
        first_table += candidates.div_ceil(32);
    }
    tables
}
