//! Helpers the pipeline tests share.

use isp_core::frame::RgbViewMut;

/// Runs `run(rows, view)` over bands of the given heights (cycled) into one output.
pub fn in_bands<O: Copy + Default>(
    w: usize,
    h: usize,
    bands: &[usize],
    mut run: impl FnMut(std::ops::Range<usize>, &mut RgbViewMut<'_, O>),
) -> Vec<O> {
    let mut out = vec![O::default(); w * h * 3];
    let mut y = 0;
    for &band in bands.iter().cycle() {
        if y >= h {
            break;
        }
        let end = (y + band).min(h);
        let slice = &mut out[3 * w * y..3 * w * end];
        run(
            y..end,
            &mut RgbViewMut::new(slice, w, end - y, 3 * w).unwrap(),
        );
        y = end;
    }
    out
}
