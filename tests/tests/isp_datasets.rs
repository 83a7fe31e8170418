//! The ISP over real images: Kodak and McMaster turned into 12-bit raw mosaics. The fixed-point
//! path's 8-bit output is within 1 LSB of the float path on at least 99.9% of samples and
//! within 2 everywhere; `camsim isp`'s development reproduces the documented float semantics (the f64
//! reference) within 1 LSB on a Kodak image.

use camsim::develop::{develop, RawInput, RunOptions};
use camsim::isp_options;
use camsim_tests::dataset;
use camsim_tests::isp_reference::{reference, Frame, Settings};
use isp_core::demosaic::Method;
use isp_core::distortion::{BrownConrady, LensDistortion};
use isp_core::frame::{RawFrame, RgbViewMut};
use isp_core::noise::NoiseProfile;
use isp_core::pipeline::{FixedPipeline, FloatPipeline, IspConfig};
use isp_core::tone::Look;
use isp_core::CfaPattern;
use raw_formats::image::{self as imageio, Image};
use raw_formats::RawImage;

const BLACK: u16 = 64;
const WHITE: u16 = 4095;

/// A 12-bit RGGB mosaic of an 8-bit RGB image: black 64, 255 maps to 64 + 255 * 15 = 3889.
fn raw12(rgb: &Image) -> Vec<u16> {
    (0..rgb.height)
        .flat_map(|y| (0..rgb.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = CfaPattern::Rggb.colour_at(x, y).index();
            BLACK + rgb.data[3 * (y * rgb.width + x) + c] * 15
        })
        .collect()
}

/// How closely two outputs agree, sample by sample.
#[derive(Default)]
struct Agreement {
    total: usize,
    within1: usize,
    worst: u16,
}

impl Agreement {
    fn add<T: Copy + Into<u16>>(&mut self, a: &[T], b: &[T]) {
        for (a, b) in a.iter().zip(b) {
            let d = (*a).into().abs_diff((*b).into());
            self.total += 1;
            self.within1 += usize::from(d <= 1);
            self.worst = self.worst.max(d);
        }
    }

    /// The share of samples within 1.
    fn share_within1(&self) -> f64 {
        self.within1 as f64 / self.total as f64
    }
}

/// Runs both paths over every Kodak and McMaster image with `config_for(index, width,
/// height)` and checks the 8-bit outputs agree within 1 LSB on at least 99.9 % of samples and
/// within 2 everywhere.
fn paths_agree_over_kodak_and_mcmaster(
    what: &str,
    config_for: impl Fn(usize, usize, usize) -> IspConfig<'static>,
) {
    let mut agreement = Agreement::default();
    for (i, path) in dataset("kodak")
        .into_iter()
        .chain(dataset("mcmaster"))
        .enumerate()
    {
        let rgb = imageio::read(&path).unwrap();
        let (w, h) = (rgb.width, rgb.height);
        let data = raw12(&rgb);
        let raw = RawFrame::new(&data, w, h, w, 12, CfaPattern::Rggb, [BLACK; 4], WHITE).unwrap();
        let config = config_for(i, w, h);
        let mut float = vec![0u8; w * h * 3];
        let mut fixed = vec![0u8; w * h * 3];
        FloatPipeline::new(&config)
            .unwrap()
            .run(
                &raw,
                0..h,
                &mut vec![0.0; config.scratch_len(w, h).unwrap()],
                &mut RgbViewMut::new(&mut float, w, h, 3 * w).unwrap(),
            )
            .unwrap();
        FixedPipeline::new(&config, 8)
            .unwrap()
            .run(
                &raw,
                0..h,
                &mut vec![0; config.scratch_len(w, h).unwrap()],
                &mut RgbViewMut::new(&mut fixed, w, h, 3 * w).unwrap(),
            )
            .unwrap();
        agreement.add(&float, &fixed);
    }
    let (share, worst, total) = (agreement.share_within1(), agreement.worst, agreement.total);
    println!(
        "{what}: fixed vs float {:.5}% within 1 LSB, worst {worst} LSB, {total} samples",
        100.0 * share
    );
    assert!(share >= 0.999, "{what}: {share}");
    assert!(worst <= 2, "{what}: worst {worst}");
}

const CCM: [[f32; 3]; 3] = [[1.55, -0.4, -0.15], [-0.25, 1.45, -0.2], [0.05, -0.45, 1.4]];

#[test]
fn fixed_path_agrees_with_float_over_kodak_and_mcmaster() {
    paths_agree_over_kodak_and_mcmaster("streaming methods", |i, w, h| {
        // Vary the configuration over the set so every stage is exercised on real content.
        IspConfig {
            gain: [1.0, 1.2, 0.9][i % 3],
            wb_gains: [[1.0; 3], [1.4, 1.0, 1.2], [0.9, 1.0, 1.6]][i % 3],
            demosaic: Method::STREAMING[i % 3],
            // Every fifth image through a barrel lens with tangential terms.
            distortion: (i % 5 == 0).then(|| {
                let model = BrownConrady::from_opencv([-0.25, 0.06, 0.001, -0.002, 0.0]).unwrap();
                let f = 0.9 * w as f64;
                LensDistortion::new(f, f, w as f64 / 2.0, h as f64 / 2.0, model)
                    .unwrap()
                    .fitted(w, h)
            }),
            denoise: [0.0, 1.0, 2.0][(i / 3) % 3],
            noise: Some(NoiseProfile::uniform(0.0032, 1.2e-5).unwrap()),
            // The highlight stage at its default knee on two images in three.
            highlight_knee: [0.9, 1.0, 0.8][i % 3],
            ccm: if i % 2 == 0 {
                CCM
            } else {
                isp_core::pipeline::IDENTITY
            },
            tone: Look::ALL[i % Look::ALL.len()].tone(),
            dpc: isp_core::dpc::DpcConfig {
                static_defects: &[],
                dynamic_threshold: (i % 4 == 0).then_some(600),
            },
            sharpen: [0.0, 1.0, 0.5][(i / 2) % 3],
            chroma_denoise: [0.0, 1.0, 2.0][(i / 4) % 3],
            ..IspConfig::default()
        }
    });
}

/// The directional method inside the pipeline, over every image, with the stages a camera
/// runs around it (issue 19's bound: 1 LSB on 99.9 %, 2 at most).
#[test]
fn directional_fixed_path_agrees_with_float_over_kodak_and_mcmaster() {
    paths_agree_over_kodak_and_mcmaster("directional", |i, _, _| IspConfig {
        demosaic: Method::Directional,
        wb_gains: [[1.0; 3], [1.4, 1.0, 1.2], [0.9, 1.0, 1.6]][i % 3],
        highlight_knee: [0.9, 1.0, 0.8][i % 3],
        denoise: [0.0, 1.0][i % 2],
        noise: Some(NoiseProfile::uniform(0.0032, 1.2e-5).unwrap()),
        chroma_denoise: [0.0, 1.0][(i / 2) % 2],
        ccm: CCM,
        tone: Look::ALL[i % Look::ALL.len()].tone(),
        dpc: isp_core::dpc::DpcConfig {
            static_defects: &[],
            dynamic_threshold: (i % 4 == 0).then_some(600),
        },
        ..IspConfig::default()
    });
}

#[test]
fn camsim_isp_reproduces_the_float_semantics_on_kodak() {
    let path = &dataset("kodak")[22]; // kodim23: saturated colours
    let rgb = imageio::read(path).unwrap();
    let (w, h) = (rgb.width, rgb.height);
    let data = raw12(&rgb);
    let input = RawInput::plain(
        RawImage::new(w, h, CfaPattern::Rggb, 16, [0; 4], 65535, data.clone()).unwrap(),
    );
    // The options as `camsim isp --config` reads them (keys are the flags' names).
    let options = isp_options::from_toml(
        r#"
        bits = 12
        pattern = "RGGB"
        black-level = 64
        white-level = 4095
        gain = 1.1
        wb = [1.3, 1, 1.15]
        ccm = [[1.5, -0.35, -0.15], [-0.2, 1.4, -0.2], [0.02, -0.4, 1.38]]
        demosaic = "bilinear"
        denoise = 1.5
        noise-profile = [0.004, 2e-5]
        look = "vivid"
        sharpen = 0.6
        path = "float"
        out-bits = 8
        "#,
        "isp.toml".as_ref(),
    )
    .unwrap();
    let (report, out) = develop(&input, &options, None, RunOptions::default()).unwrap();
    assert_eq!(out.bits, 8);
    assert!(report.stages.contains(&"denoise") && report.stages.contains(&"colour matrix"));
    assert_eq!(report.stages.last(), Some(&"sharpening"));
    let frame = Frame {
        data,
        w,
        h,
        stride: w,
        bits: 12,
        pattern: CfaPattern::Rggb,
        black: [BLACK; 4],
        white: WHITE,
    };
    let settings = Settings {
        gain: 1.1,
        wb: [1.3, 1.0, 1.15],
        ccm: [[1.5, -0.35, -0.15], [-0.2, 1.4, -0.2], [0.02, -0.4, 1.38]],
        denoise: 1.5,
        noise: Some(NoiseProfile::uniform(0.004, 2e-5).unwrap()),
        highlight_knee: camsim::develop::DEFAULT_HIGHLIGHT_KNEE,
        tone: Look::Vivid.tone(),
        sharpen: 0.6,
        // Chroma noise reduction's default where noise reduction is on.
        chroma_denoise: 1.0,
        ..Settings::plain()
    };
    let expected = reference(&frame, &settings);
    let mut worst: f64 = 0.0;
    for (o, e) in out.data.chunks(3).zip(&expected) {
        for c in 0..3 {
            worst = worst.max((o[c] as f64 - e[c] * 255.0).abs());
        }
    }
    // Rounding leaves at most 0.5; the f32 pipeline against the f64 reference adds a little.
    assert!(worst <= 1.0, "worst {worst}");
    println!("camsim isp vs reference: worst {worst:.4} LSB before rounding");
}

/// The integer directional method tracks the float one on every Kodak and McMaster image as a
/// 16-bit mosaic: every sample within 32 LSB of 65535 (an eighth of an 8-bit step) and 99.8 %
/// within 1 (measured 2026-11-23 with 32-bit intermediates: worst 26, 99.87 %).
#[test]
fn directional_fixed_tracks_the_float_method_over_kodak_and_mcmaster() {
    use isp_core::demosaic::directional::{directional, directional_fixed, scratch_len};
    use isp_core::frame::MosaicView;
    let mut agreement = Agreement::default();
    for path in dataset("kodak").into_iter().chain(dataset("mcmaster")) {
        let rgb = imageio::read(&path).unwrap();
        let (w, h) = (rgb.width, rgb.height);
        let data: Vec<u16> = (0..w * h)
            .map(|i| {
                let c = CfaPattern::Rggb.colour_at(i % w, i / w).index();
                rgb.data[3 * i + c] * 257
            })
            .collect();
        let mosaic = MosaicView::new(&data, w, h, w, CfaPattern::Rggb).unwrap();
        let mut float = vec![0u16; 3 * w * h];
        let mut fixed = vec![0u16; 3 * w * h];
        let mut view = RgbViewMut::new(&mut float, w, h, 3 * w).unwrap();
        directional(&mosaic, &mut view, &mut vec![0.0; scratch_len(w).unwrap()]).unwrap();
        let mut view = RgbViewMut::new(&mut fixed, w, h, 3 * w).unwrap();
        directional_fixed(&mosaic, &mut view, &mut vec![0; scratch_len(w).unwrap()]).unwrap();
        agreement.add(&float, &fixed);
    }
    let (share, worst) = (agreement.share_within1(), agreement.worst);
    println!(
        "directional fixed vs float at 16 bits: {:.4}% within 1 LSB, worst {worst}",
        100.0 * share
    );
    assert!(share >= 0.998 && worst <= 32, "{share} {worst}");
}
