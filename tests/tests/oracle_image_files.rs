//! The image files camsim writes, read back by OpenCV: PNG and TIFF at 8 and 16 bits exactly,
//! JPEG within what its quality allows.

use camsim_tests::oracle::oracle_arrays;
use raw_formats::image::{write_with, WriteOptions};
use raw_formats::Image;

fn gradient(channels: usize, bits: u8) -> Image {
    let (width, height) = (37, 23);
    let max = (1u32 << bits) - 1;
    let data = (0..width * height * channels)
        .map(|i| {
            let (x, y, c) = (i / channels % width, i / channels / width, i % channels);
            ((x * 7 + y * 11 + c * 40) as u32 * max / 600).min(max) as u16
        })
        .collect();
    Image {
        width,
        height,
        channels,
        bits,
        data,
    }
}

fn read_back(path: &std::path::Path) -> Option<Vec<f64>> {
    oracle_arrays(
        "image_read",
        serde_json::json!({"path": path.to_str().unwrap()}),
        &[],
    )
    .map(|arrays| arrays[0].to_f64())
}

#[test]
fn png_and_tiff_read_back_exactly_at_8_and_16_bits() {
    let dir = std::env::temp_dir().join(format!("camsim-image-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for channels in [1, 3] {
        for bits in [8, 16] {
            for extension in ["png", "tif", "tiff"] {
                let image = gradient(channels, bits);
                let path = dir.join(format!("g{channels}-{bits}.{extension}"));
                write_with(&path, &image, &WriteOptions::default()).unwrap();
                let Some(back) = read_back(&path) else { return };
                let ours: Vec<f64> = image.data.iter().map(|v| f64::from(*v)).collect();
                assert!(back == ours, "{}", path.display());
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn jpeg_quality_trades_size_for_error_and_16_bits_are_refused() {
    let dir = std::env::temp_dir().join(format!("camsim-jpeg-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let image = gradient(3, 8);
    let mut last: Option<(u64, f64)> = None;
    for quality in [30, 70, 95] {
        let path = dir.join(format!("q{quality}.jpg"));
        write_with(
            &path,
            &image,
            &WriteOptions {
                jpeg_quality: quality,
            },
        )
        .unwrap();
        let size = std::fs::metadata(&path).unwrap().len();
        let Some(back) = read_back(&path) else { return };
        let mse = image
            .data
            .iter()
            .zip(&back)
            .map(|(a, b)| (f64::from(*a) - b).powi(2))
            .sum::<f64>()
            / back.len() as f64;
        let psnr = 10.0 * (255.0f64.powi(2) / mse.max(1e-9)).log10();
        assert!(psnr > 30.0, "quality {quality}: {psnr:.1} dB");
        if let Some((last_size, last_psnr)) = last {
            assert!(size > last_size && psnr > last_psnr, "quality {quality}");
        }
        last = Some((size, psnr));
    }
    let path = dir.join("deep.jpg");
    let refused = write_with(&path, &gradient(3, 16), &WriteOptions::default()).unwrap_err();
    assert!(refused.to_string().contains("JPEG"), "{refused}");
    let refused = write_with(&path, &image, &WriteOptions { jpeg_quality: 0 }).unwrap_err();
    assert!(refused.to_string().contains("quality"), "{refused}");
    std::fs::remove_dir_all(&dir).ok();
}
