//! Highlights on a real camera file: the Canon 550D DNG (a ColorChecker under warm light,
//! as-shot gains of about 2.5 for red and 1.7 for blue) developed four stops brighter, so the
//! window lights behind the chart clip in the raw as an overexposed frame would. Without the
//! highlight stage the clipped lights come out magenta (white balance scales red and blue past
//! the clipped green); with it they come out neutral.

use camsim::develop::{develop, RawInput, RunOptions};
use camsim::isp_options::{CropChoice, IspOptions};

/// Mean and 99th-percentile chroma (largest minus smallest 8-bit channel) of the output pixels
/// whose 2x2 raw cell has a sample at the clip once gain and white balance are applied
/// (clipped in the raw, or scaled past the clip by white balance): where the ratio of the
/// channels, the colour, is lost.
///
/// Noise reduction is off: it runs before the gain, so it changes which samples the gain clips
/// (a cell the noise pushed past the clip may come out of it unclipped, with its colour), and
/// this measures the highlight stage on the cells the raw says are clipped.
fn chroma_where_green_clipped(knee: f32) -> (f64, u16, usize) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/real-dng/canon-550d-colorchart-14bit.dng");
    let input = RawInput::read(&path).unwrap();
    let gain = 4.0f32;
    let options = IspOptions {
        gain: Some(gain),
        highlight_knee: Some(knee),
        crop: Some(CropChoice::Active),
        baseline_exposure: Some(false),
        denoise: Some(0.0),
        ..IspOptions::default()
    };
    let (_, rgb) = develop(&input, &options, None, RunOptions::default()).unwrap();
    let raw = &input.raw;
    let (w, h) = (raw.width, raw.height);
    assert_eq!((rgb.width, rgb.height), (w, h));
    let Some(camsim::isp_options::WhiteBalance::Gains(wb)) = input.defaults.white_balance else {
        panic!("the file states its white balance");
    };
    let clipped = |x: usize, y: usize| {
        let p = (y % 2) * 2 + x % 2;
        let range = f32::from(raw.white_level - raw.black_level[p]);
        let v = f32::from(raw.samples[y * w + x].saturating_sub(raw.black_level[p]));
        (gain * v).min(range) * wb[raw.pattern.colour_at(x, y).index()] >= range
    };
    let mut chroma = Vec::new();
    for cy in (2..h - 2).step_by(2) {
        for cx in (2..w - 2).step_by(2) {
            let cell = [(0, 0), (1, 0), (0, 1), (1, 1)];
            if cell.iter().any(|(dx, dy)| clipped(cx + dx, cy + dy)) {
                let i = 3 * (cy * w + cx);
                let px = &rgb.data[i..i + 3];
                chroma.push(px.iter().max().unwrap() - px.iter().min().unwrap());
            }
        }
    }
    chroma.sort();
    let mean = chroma.iter().map(|c| f64::from(*c)).sum::<f64>() / chroma.len() as f64;
    (mean, chroma[chroma.len() * 99 / 100], chroma.len())
}

#[test]
fn clipped_highlights_of_a_real_file_come_out_neutral() {
    let (off_mean, off_p99, n) = chroma_where_green_clipped(1.0);
    let (on_mean, on_p99, _) = chroma_where_green_clipped(camsim::develop::DEFAULT_HIGHLIGHT_KNEE);
    println!(
        "{n} cells with a clipped channel: chroma mean {off_mean:.1} (99th percentile {off_p99}) without the highlight stage, {on_mean:.1} ({on_p99}) with it"
    );
    assert!(n > 10_000, "the gain clips a sizeable area ({n} cells)");
    assert!(
        off_mean > 20.0,
        "without the stage clipped areas are coloured: {off_mean:.1}"
    );
    assert!(
        on_mean < 2.0 && on_p99 <= 8,
        "with it they are neutral: {on_mean:.1}, {on_p99}"
    );
}
