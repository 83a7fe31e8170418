//! The whole-frame bilinear and MHC kernels (`demosaic::demosaic`, which runs the
//! parity-split strips) give exactly what `demosaic::row` gives row by row: for any size
//! (across the 256-column strips and down to the smallest frames), pattern and sample type, in
//! the baseline build and the AVX2 build.

use isp_core::demosaic::{demosaic, reflect, row, Method};
use isp_core::frame::{MosaicView, RgbViewMut, Sample};
use isp_core::CfaPattern;
use proptest::prelude::*;

/// The frame through `row`, the reference.
fn by_rows<T: Sample>(method: Method, m: &MosaicView<'_, T>, data: &[T]) -> Vec<T> {
    let (w, h) = (m.width(), m.height());
    let mut out = vec![T::default(); 3 * w * h];
    for y in 0..h {
        let rows: [&[T]; 5] = std::array::from_fn(|i| {
            let r = reflect(y as isize + i as isize - 2, h);
            &data[r * w..(r + 1) * w]
        });
        row(
            method,
            rows,
            y,
            h,
            m.pattern(),
            &mut out[3 * w * y..3 * w * (y + 1)],
        )
        .unwrap();
    }
    out
}

/// The frame through `demosaic` and, where the CPU has AVX2, `demosaic_avx2`.
fn whole<T: Sample>(method: Method, m: &MosaicView<'_, T>) -> Vec<(&'static str, Vec<T>)> {
    let (w, h) = (m.width(), m.height());
    let mut runs = Vec::new();
    let mut out = vec![T::default(); 3 * w * h];
    demosaic(
        method,
        m,
        &mut RgbViewMut::new(&mut out, w, h, 3 * w).unwrap(),
    )
    .unwrap();
    runs.push(("demosaic", out));
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        let mut out = vec![T::default(); 3 * w * h];
        let mut view = RgbViewMut::new(&mut out, w, h, 3 * w).unwrap();
        // SAFETY: AVX2 was detected at run time.
        unsafe { isp_core::demosaic::demosaic_avx2(method, m, &mut view) }.unwrap();
        runs.push(("demosaic_avx2", out));
    }
    runs
}

fn check<T: Sample>(method: Method, data: &[T], w: usize, h: usize, p: CfaPattern) {
    let m = MosaicView::new(data, w, h, w, p).unwrap();
    let reference = by_rows(method, &m, data);
    for (name, out) in whole(method, &m) {
        let first = out.iter().zip(&reference).position(|(a, b)| a != b);
        assert!(
            first.is_none(),
            "{method:?} {w}x{h} {p:?}: {name} differs at {first:?}"
        );
    }
}

fn size() -> impl Strategy<Value = (usize, usize, usize, u64)> {
    (
        prop_oneof![1usize..=12, 250usize..=262, 500usize..=530],
        1usize..=9,
        0usize..4,
        any::<u64>(),
    )
}

/// Samples with the extremes and ties that rounding depends on.
fn samples(n: usize, seed: u64, max: u32) -> Vec<u32> {
    let mut state = seed | 1;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            match state % 8 {
                0 => 0,
                1 => max,
                _ => (state >> 16) as u32 % (max + 1),
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn strips_equal_rows((w, h, p, seed) in size()) {
        let pattern = CfaPattern::ALL[p];
        for method in [Method::Bilinear, Method::Mhc] {
            let u16s: Vec<u16> = samples(w * h, seed, 65535).iter().map(|v| *v as u16).collect();
            check(method, &u16s, w, h, pattern);
            let u8s: Vec<u8> = samples(w * h, seed, 255).iter().map(|v| *v as u8).collect();
            check(method, &u8s, w, h, pattern);
            let f32s: Vec<f32> = samples(w * h, seed, 1000).iter().map(|v| *v as f32 / 1000.0).collect();
            check(method, &f32s, w, h, pattern);
        }
    }
}

/// A smooth frame wide enough for several strips, whose output is not flat: equal, and the
/// comparison has something to compare.
#[test]
fn strips_equal_rows_on_a_wide_frame() {
    let (w, h) = (777, 19);
    let data: Vec<u16> = (0..w * h)
        .map(|i| ((i % w) * 61 + (i / w) * 997 + (i * 7919) % 300) as u16)
        .collect();
    for method in [Method::Bilinear, Method::Mhc] {
        let m = MosaicView::new(&data, w, h, w, CfaPattern::Grbg).unwrap();
        let reference = by_rows(method, &m, &data);
        let distinct: std::collections::BTreeSet<u16> = reference.iter().copied().collect();
        assert!(
            distinct.len() > 1000,
            "{method:?}: {} distinct values",
            distinct.len()
        );
        for (name, out) in whole(method, &m) {
            assert!(out == reference, "{method:?}: {name} differs from row");
        }
    }
}
