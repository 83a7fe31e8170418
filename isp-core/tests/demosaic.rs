//! Bilinear demosaicing against a slow, obviously-correct version written here, over random
//! sizes (including 1, 2, 3 and odd), all four patterns, both sample types and strides > width.

use isp_core::demosaic::{bilinear, Border};
use isp_core::frame::{IntSample, MosaicView, RawFrame, RgbViewMut};
use isp_core::{CfaColour, CfaPattern, IspError};
use proptest::prelude::*;

fn channel(c: CfaColour) -> usize {
    match c {
        CfaColour::Red => 0,
        CfaColour::Green => 1,
        CfaColour::Blue => 2,
    }
}

/// Reflect-101 reference: each missing colour is the rounded mean of the same-colour pixels in
/// the mirrored 3x3 window (a pixel mirrored twice counts twice); in a 1-pixel line, of the
/// distinct in-frame neighbours, falling back to the own sample.
fn reference_reflect101(m: &[u32], w: usize, h: usize, p: CfaPattern) -> Vec<[u32; 3]> {
    let refl = |i: isize, n: usize| -> Option<usize> {
        if n == 1 {
            (i == 0).then_some(0)
        } else if i < 0 {
            Some((-i) as usize)
        } else if i as usize >= n {
            Some(2 * n - 2 - i as usize)
        } else {
            Some(i as usize)
        }
    };
    let line = w == 1 || h == 1;
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let own = m[y * w + x];
            let (mut sum, mut count) = ([0u32; 3], [0u32; 3]);
            for dy in -1isize..=1 {
                for dx in -1isize..=1 {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let (nx, ny) = (x as isize + dx, y as isize + dy);
                    let (rx, ry) = if line {
                        if nx < 0 || ny < 0 || nx as usize >= w || ny as usize >= h {
                            continue;
                        }
                        (nx as usize, ny as usize)
                    } else {
                        (refl(nx, w).unwrap(), refl(ny, h).unwrap())
                    };
                    let c = channel(p.colour_at(rx, ry));
                    sum[c] += m[ry * w + rx];
                    count[c] += 1;
                }
            }
            let mut rgb = [own; 3];
            for c in 0..3 {
                if c != channel(p.colour_at(x, y)) && count[c] > 0 {
                    rgb[c] = (sum[c] + count[c] / 2) / count[c];
                }
            }
            out.push(rgb);
        }
    }
    out
}

/// OpenCV reference: interior by the same rule, then column then row copies; zero below 3x3.
fn reference_opencv(m: &[u32], w: usize, h: usize, p: CfaPattern) -> Vec<[u32; 3]> {
    if w < 3 || h < 3 {
        return vec![[0; 3]; w * h];
    }
    let mut out = reference_reflect101(m, w, h, p); // equal on the interior
    for y in 1..h - 1 {
        out[y * w] = out[y * w + 1];
        out[y * w + w - 1] = out[y * w + w - 2];
    }
    for x in 0..w {
        out[x] = out[w + x];
        out[(h - 1) * w + x] = out[(h - 2) * w + x];
    }
    out
}

fn run<T: IntSample>(
    m: &[u32],
    w: usize,
    h: usize,
    pad: usize,
    p: CfaPattern,
    border: Border,
) -> Vec<[u32; 3]> {
    let stride = w + pad;
    let mut data = vec![T::default(); (h - 1) * stride + w];
    for y in 0..h {
        for x in 0..w {
            data[y * stride + x] = T::from_u32(m[y * w + x]);
        }
    }
    let mosaic = MosaicView::new(&data, w, h, stride, p).unwrap();
    let out_stride = 3 * w + pad;
    let mut rgb = vec![T::default(); (h - 1) * out_stride + 3 * w];
    let mut view = RgbViewMut::new(&mut rgb, w, h, out_stride).unwrap();
    bilinear(&mosaic, border, &mut view).unwrap();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| view.get(x, y).unwrap().map(|v| v.to_u32()))
        .collect()
}

fn pattern() -> impl Strategy<Value = CfaPattern> {
    prop::sample::select(CfaPattern::ALL.to_vec())
}

fn mosaic(max: u32) -> impl Strategy<Value = (usize, usize, Vec<u32>)> {
    (1usize..24, 1usize..24).prop_flat_map(move |(w, h)| {
        let value = prop_oneof![Just(0u32), Just(max), 0..=max];
        (Just(w), Just(h), proptest::collection::vec(value, w * h))
    })
}

proptest! {
    #[test]
    fn reflect101_matches_reference_u16((w, h, m) in mosaic(65535), p in pattern(), pad in 0usize..3) {
        prop_assert_eq!(run::<u16>(&m, w, h, pad, p, Border::Reflect101), reference_reflect101(&m, w, h, p));
    }

    #[test]
    fn reflect101_matches_reference_u8((w, h, m) in mosaic(255), p in pattern(), pad in 0usize..3) {
        prop_assert_eq!(run::<u8>(&m, w, h, pad, p, Border::Reflect101), reference_reflect101(&m, w, h, p));
    }

    #[test]
    fn opencv_border_matches_reference((w, h, m) in mosaic(65535), p in pattern(), pad in 0usize..3) {
        prop_assert_eq!(run::<u16>(&m, w, h, pad, p, Border::OpenCv), reference_opencv(&m, w, h, p));
    }

    /// A flat field stays exactly flat, every size, pattern and mode (OpenCV's is zero below 3x3).
    #[test]
    fn flat_field_stays_flat(w in 1usize..12, h in 1usize..12, v in 0u32..=65535, p in pattern()) {
        let m = vec![v; w * h];
        prop_assert!(run::<u16>(&m, w, h, 0, p, Border::Reflect101).iter().all(|px| *px == [v; 3]));
        let expected = if w < 3 || h < 3 { 0 } else { v };
        prop_assert!(run::<u16>(&m, w, h, 1, p, Border::OpenCv).iter().all(|px| *px == [expected; 3]));
    }
}

#[test]
fn views_reject_inconsistent_sizes() {
    let data = [0u16; 12];
    assert!(MosaicView::new(&data, 0, 3, 4, CfaPattern::Rggb).is_err());
    assert!(MosaicView::new(&data, 4, 3, 3, CfaPattern::Rggb).is_err());
    assert_eq!(
        MosaicView::new(&data, 4, 4, 4, CfaPattern::Rggb).unwrap_err(),
        IspError::BufferTooSmall {
            needed: 16,
            provided: 12
        }
    );
    assert!(MosaicView::new(&data, 3, 3, 4, CfaPattern::Rggb).is_ok()); // (3-1)*4 + 3 = 11
    assert!(MosaicView::new(&data, usize::MAX, 2, usize::MAX, CfaPattern::Rggb).is_err());
    let mut rgb = [0u16; 10];
    assert!(RgbViewMut::new(&mut rgb, 2, 2, 6).is_err());
    assert!(RgbViewMut::new(&mut rgb, usize::MAX, 1, usize::MAX).is_err());
    // Raw frame levels.
    assert!(RawFrame::new(&data, 4, 3, 4, 12, CfaPattern::Rggb, [64; 4], 4095).is_ok());
    assert!(RawFrame::new(&data, 4, 3, 4, 7, CfaPattern::Rggb, [0; 4], 100).is_err());
    assert!(RawFrame::new(&data, 4, 3, 4, 17, CfaPattern::Rggb, [0; 4], 100).is_err());
    assert!(RawFrame::new(&data, 4, 3, 4, 12, CfaPattern::Rggb, [0; 4], 4096).is_err());
    assert!(RawFrame::new(
        &data,
        4,
        3,
        4,
        12,
        CfaPattern::Rggb,
        [64, 64, 4095, 64],
        4095
    )
    .is_err());
    let ok = RawFrame::new(&data, 4, 3, 4, 12, CfaPattern::Rggb, [4094; 4], 4095).unwrap(); // black = white - 1
    assert_eq!(ok.black_at(1, 1), 4094);
    // Demosaic output must match the input size.
    let m = MosaicView::new(&data, 4, 3, 4, CfaPattern::Rggb).unwrap();
    let mut rgb = [0u16; 36];
    let mut small = RgbViewMut::new(&mut rgb, 3, 3, 9).unwrap();
    assert!(bilinear(&m, Border::Reflect101, &mut small).is_err());
}

/// The paper's 5x5 filters in eighths, as printed (symmetric, so correlation = convolution).
const G_AT_RB: [[f64; 5]; 5] = [
    [0., 0., -1., 0., 0.],
    [0., 0., 2., 0., 0.],
    [-1., 2., 4., 2., -1.],
    [0., 0., 2., 0., 0.],
    [0., 0., -1., 0., 0.],
];
const C_AT_G_ROW: [[f64; 5]; 5] = [
    [0., 0., 0.5, 0., 0.],
    [0., -1., 0., -1., 0.],
    [-1., 4., 5., 4., -1.],
    [0., -1., 0., -1., 0.],
    [0., 0., 0.5, 0., 0.],
];
const C_AT_OPPOSITE: [[f64; 5]; 5] = [
    [0., 0., -1.5, 0., 0.],
    [0., 2., 0., 2., 0.],
    [-1.5, 0., 6., 0., -1.5],
    [0., 2., 0., 2., 0.],
    [0., 0., -1.5, 0., 0.],
];

// Indexing both ways (plain and transposed) reads clearer than iterators here.
#[allow(clippy::needless_range_loop)]
fn reference_mhc(m: &[u32], w: usize, h: usize, p: CfaPattern, max: u32) -> Vec<[u32; 3]> {
    if w < 3 || h < 3 {
        return reference_reflect101(m, w, h, p);
    }
    let refl = |i: isize, n: usize| {
        if i < 0 {
            (-i) as usize
        } else if i as usize >= n {
            2 * n - 2 - i as usize
        } else {
            i as usize
        }
    };
    let filter = |k: &[[f64; 5]; 5], x: usize, y: usize, transpose: bool| {
        let mut s = 0.0;
        for j in 0..5 {
            for i in 0..5 {
                let weight = if transpose { k[i][j] } else { k[j][i] };
                let (sx, sy) = (
                    refl(x as isize + i as isize - 2, w),
                    refl(y as isize + j as isize - 2, h),
                );
                s += weight / 8.0 * m[sy * w + sx] as f64;
            }
        }
        // Round half up, clamp to the sample range.
        ((s + 0.5).floor()).clamp(0.0, max as f64) as u32
    };
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let own = p.colour_at(x, y);
            let mut rgb = [m[y * w + x]; 3];
            if own == CfaColour::Green {
                rgb[channel(p.colour_at(x + 1, y))] = filter(&C_AT_G_ROW, x, y, false);
                rgb[channel(p.colour_at(x, y + 1))] = filter(&C_AT_G_ROW, x, y, true);
            } else {
                rgb[1] = filter(&G_AT_RB, x, y, false);
                rgb[2 - channel(own)] = filter(&C_AT_OPPOSITE, x, y, false);
            }
            out.push(rgb);
        }
    }
    out
}

fn run_mhc<T: IntSample>(m: &[u32], w: usize, h: usize, p: CfaPattern) -> Vec<[u32; 3]> {
    let data: Vec<T> = m.iter().map(|v| T::from_u32(*v)).collect();
    let mosaic = MosaicView::new(&data, w, h, w, p).unwrap();
    let mut rgb = vec![T::default(); 3 * w * h];
    let mut view = RgbViewMut::new(&mut rgb, w, h, 3 * w).unwrap();
    isp_core::demosaic::mhc(&mosaic, &mut view).unwrap();
    rgb.chunks(3)
        .map(|c| [c[0].to_u32(), c[1].to_u32(), c[2].to_u32()])
        .collect()
}

proptest! {
    #[test]
    fn mhc_matches_reference((w, h, m) in mosaic(65535), p in pattern()) {
        prop_assert_eq!(run_mhc::<u16>(&m, w, h, p), reference_mhc(&m, w, h, p, 65535));
    }

    #[test]
    fn mhc_matches_reference_u8((w, h, m) in mosaic(255), p in pattern()) {
        prop_assert_eq!(run_mhc::<u8>(&m, w, h, p), reference_mhc(&m, w, h, p, 255));
    }

    #[test]
    fn mhc_keeps_flat_fields_flat(w in 1usize..12, h in 1usize..12, v in 0u32..=65535, p in pattern()) {
        prop_assert!(run_mhc::<u16>(&vec![v; w * h], w, h, p).iter().all(|px| *px == [v; 3]));
    }
}
