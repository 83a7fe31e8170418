//! Colour calibration: render the ColorChecker under an illuminant, capture it through the
//! sensor model (noise off), fit the camera-to-XYZ matrix and measure it in CIE 2000.
//!
//! The chart scene is the 24 BabelColor patches alone under a constant environment of the
//! illuminant's spectrum. Every ray that leaves a flat patch sees the same radiance, so the
//! path tracer's estimate at a patch is exact (reflectance x environment) and one sample per
//! pixel suffices. The reference XYZ of each patch comes from the same render's bands, scaled so
//! the illuminant itself has `Y = 1`; the camera values are the raw means over each patch's
//! centre, black subtracted, as fractions of the ADC range.
//!
//! The fit is 3x3 least squares (isp-core's [`isp_core::ccm::fit`], the matrix the ISP and
//! the DNG use). A second-order root-polynomial fit (Finlayson, Mackiewicz and Hurlbert 2015:
//! terms R, G, B, sqrt(RG), sqrt(GB), sqrt(RB)) is offered for comparison; it is exposure
//! invariant but not a 3x3 matrix, so only its errors are reported, beside the matrix's.

use std::path::Path;

use isp_core::ccm::fit;
use isp_core::colour::{self, Mat3};
use isp_core::metrics::mean_max;
use raw_formats::calibration::{CalibrationEntry, CalibrationFile};

use crate::error::{Error, Result};
use crate::sensor::{self, LensGeometry, Response, SensorConfig};
use crate::spectra::{bands_xyz, illuminant_bands, xyz_weights, Table, BANDS, COLORCHECKER};
use crate::tracer::render::{render, RenderSettings};
use crate::tracer::scene_file;

/// Pixels per patch side in the chart render.
const PATCH_PX: usize = 16;

/// One illuminant's calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibrated {
    /// Illuminant name (a column of [`crate::spectra::ILLUMINANTS`]).
    pub illuminant: String,
    /// Its correlated colour temperature (McCamy 1992 from its XYZ), kelvin.
    pub cct_k: f64,
    /// The fitted 3x3 camera-to-XYZ matrix.
    pub camera_to_xyz: Mat3,
    /// Per-patch CIE 2000 error of the 3x3 fit.
    pub delta_e_matrix: Vec<f64>,
    /// Per-patch CIE 2000 error of the root-polynomial fit.
    pub delta_e_root_polynomial: Vec<f64>,
    /// Per-patch CIE 2000 error of the 3x3 fit made without that patch (leave-one-out: how
    /// the matrix does on a colour it was not fitted to).
    pub delta_e_matrix_held_out: Vec<f64>,
    /// The same for the root-polynomial fit.
    pub delta_e_root_polynomial_held_out: Vec<f64>,
    /// The 24 patches' camera values and reference XYZ.
    pub patches: Vec<([f64; 3], [f64; 3])>,
    /// The illuminant's colour in camera RGB (green 1): the neutral a white balance aims for.
    pub neutral: [f64; 3],
}

/// The chart scene as TOML: 6 x 4 patches, 0.1 apart with 0.07 faces, seen square-on by a
/// pinhole that frames them exactly.
fn chart_scene(illuminant: &str) -> Result<String> {
    let names = Table::parse(COLORCHECKER)?.names().to_vec();
    let mut text = format!(
        "[film]\nwidth = {}\nheight = {}\nspp = 1\nmax_depth = 2\n\n\
         [camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n\
         focal_length_mm = 50.0\nsensor_width_mm = 30.0\n\n\
         [environment]\nilluminant = {illuminant:?}\nluminance = 1.0\n\n[materials]\n",
        6 * PATCH_PX,
        4 * PATCH_PX
    );
    for (i, name) in names.iter().enumerate() {
        text += &format!("p{i:02} = {{ colorchecker = {name:?} }}\n");
    }
    for i in 0..names.len() {
        let (col, row) = ((i % 6) as f64, (i / 6) as f64);
        let (cx, cy) = (-0.25 + 0.1 * col, 0.15 - 0.1 * row);
        let (x0, x1, y0, y1) = (cx - 0.035, cx + 0.035, cy - 0.035, cy + 0.035);
        text += &format!(
            "\n[[shape]]\ntype = \"quad\"\nmaterial = \"p{i:02}\"\n\
             corners = [[{x0}, {y0}, 0.0], [{x1}, {y0}, 0.0], [{x1}, {y1}, 0.0], [{x0}, {y1}, 0.0]]\n"
        );
    }
    Ok(text)
}

/// Calibrates `camera` under `illuminant`.
pub fn calibrate(camera: &str, illuminant: &str) -> Result<Calibrated> {
    let response = Response::named(camera)?;
    let scene = scene_file::parse(
        &chart_scene(illuminant)?,
        "<ColorChecker chart>",
        Path::new("."),
    )?;
    let settings = RenderSettings::for_scene(&scene);
    let image = render(&scene, &settings)?;
    let (w, h) = (image.width as usize, image.height as usize);
    if image.bands.len() != w * h * BANDS {
        return Err(Error::Isp {
            step: "the chart render",
            source: isp_core::IspError::InvalidParameter {
                name: "chart render",
                allowed: "spectral",
            },
        });
    }
    let config = SensorConfig {
        camera: camera.into(),
        ..SensorConfig::ideal()
    };
    let (focal_mm, aperture_mm, sensor_mm) = scene.camera.lens_mm(image.width, image.height);
    let lens = LensGeometry::thin_lens(focal_mm, aperture_mm, sensor_mm);
    let camera_rgb = response.camera_rgb(&image.bands, &image.rgb);
    let capture = sensor::capture(&camera_rgb, w, h, lens, &config)?;
    let weights = xyz_weights();
    let raw = &capture.raw;
    let black = raw.black_level[0];
    let range = (raw.white_level - black) as f64;

    let mut patches = Vec::with_capacity(24);
    for i in 0..24 {
        let (x0, y0) = ((i % 6) * PATCH_PX, (i / 6) * PATCH_PX);
        let (mut rgb, mut counts, mut xyz) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        let mut n = 0.0;
        for y in y0 + PATCH_PX / 4..y0 + 3 * PATCH_PX / 4 {
            for x in x0 + PATCH_PX / 4..x0 + 3 * PATCH_PX / 4 {
                let c = raw.pattern.colour_at(x, y).index();
                let v = raw.samples[y * w + x] as f64 - black as f64;
                rgb[c] += v / range;
                counts[c] += 1.0;
                let bands = &image.bands[(y * w + x) * BANDS..][..BANDS];
                for (b, wt) in bands.iter().zip(&weights) {
                    for k in 0..3 {
                        xyz[k] += (*b * wt[k]) as f64;
                    }
                }
                n += 1.0;
            }
        }
        patches.push((
            std::array::from_fn(|c| rgb[c] / counts[c]),
            xyz.map(|v| v / n),
        ));
    }
    let (white_xyz, neutral) = illuminant_colour(illuminant, &response)?;
    let camera_values: Vec<[f64; 3]> = patches.iter().map(|p| p.0).collect();
    let reference: Vec<[f64; 3]> = patches.iter().map(|p| p.1).collect();
    let isp = |step: &'static str| move |source| Error::Isp { step, source };
    let camera_to_xyz = fit(&camera_values, &reference).map_err(isp("3x3 fit"))?;
    let lab = |v: [f64; 3]| colour::xyz_to_lab(v, white_xyz).map_err(isp("L*a*b*"));
    let mut delta_e_matrix = Vec::new();
    for (c, r) in camera_values.iter().zip(&reference) {
        let fitted = colour::mat3_mul_vec(&camera_to_xyz, *c);
        delta_e_matrix.push(colour::delta_e_2000(lab(fitted)?, lab(*r)?));
    }
    let root = fit_root_polynomial(&camera_values, &reference)?;
    let apply_root = |m: &[[f64; 6]; 3], c: [f64; 3]| -> [f64; 3] {
        let terms = root_terms(c);
        std::array::from_fn(|k| (0..6).map(|j| m[k][j] * terms[j]).sum())
    };
    let mut delta_e_root_polynomial = Vec::new();
    for (c, r) in camera_values.iter().zip(&reference) {
        delta_e_root_polynomial.push(colour::delta_e_2000(lab(apply_root(&root, *c))?, lab(*r)?));
    }
    // Leave one out: each patch scored by the fits to the other 23.
    let (mut delta_e_matrix_held_out, mut delta_e_root_polynomial_held_out) =
        (Vec::new(), Vec::new());
    for held in 0..camera_values.len() {
        let others = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
            v.iter()
                .enumerate()
                .filter(|(i, _)| *i != held)
                .map(|(_, x)| *x)
                .collect()
        };
        let (c, r) = (others(&camera_values), others(&reference));
        let (camera, truth) = (camera_values[held], lab(reference[held])?);
        let matrix = fit(&c, &r).map_err(isp("3x3 fit"))?;
        delta_e_matrix_held_out.push(colour::delta_e_2000(
            lab(colour::mat3_mul_vec(&matrix, camera))?,
            truth,
        ));
        let root = fit_root_polynomial(&c, &r)?;
        delta_e_root_polynomial_held_out
            .push(colour::delta_e_2000(lab(apply_root(&root, camera))?, truth));
    }
    let cct_k = colour::xy_to_cct_mccamy(colour::xyz_to_xy(white_xyz).map_err(isp("xy"))?)
        .map_err(isp("CCT"))?;
    Ok(Calibrated {
        illuminant: illuminant.into(),
        cct_k,
        camera_to_xyz,
        delta_e_matrix,
        delta_e_root_polynomial,
        delta_e_matrix_held_out,
        delta_e_root_polynomial_held_out,
        patches,
        neutral,
    })
}

/// The illuminant's XYZ (Y = 1) and its colour in camera RGB (green 1), on the tracer's bands.
pub fn illuminant_colour(illuminant: &str, response: &Response) -> Result<([f64; 3], [f64; 3])> {
    let bands = illuminant_bands(illuminant)?;
    let xyz = bands_xyz(&bands);
    let rgb = response.of_bands(&bands).map(|v| v as f64);
    if !(xyz[1] > 0.0 && rgb[1] > 0.0) {
        return Err(Error::out_of_range(
            format!("illuminant {illuminant}"),
            "no light in 400..700 nm",
            "a spectrum with light in 400..700 nm",
        ));
    }
    Ok((xyz.map(|v| v / xyz[1]), rgb.map(|v| v / rgb[1])))
}

fn root_terms(c: [f64; 3]) -> [f64; 6] {
    let [r, g, b] = c.map(|v| v.max(0.0));
    [r, g, b, (r * g).sqrt(), (g * b).sqrt(), (r * b).sqrt()]
}

/// Least squares `reference ~ M * terms(camera)`, `M` 3 x 6, by the normal equations.
fn fit_root_polynomial(camera: &[[f64; 3]], reference: &[[f64; 3]]) -> Result<[[f64; 6]; 3]> {
    let mut gram = [[0.0f64; 6]; 6];
    let mut cross = [[0.0f64; 6]; 3];
    for (c, r) in camera.iter().zip(reference) {
        let t = root_terms(*c);
        for i in 0..6 {
            for j in 0..6 {
                gram[i][j] += t[i] * t[j];
            }
            for k in 0..3 {
                cross[k][i] += r[k] * t[i];
            }
        }
    }
    let mut out = [[0.0f64; 6]; 3];
    for k in 0..3 {
        out[k] = solve6(gram, cross[k]).ok_or(Error::Isp {
            step: "root-polynomial fit",
            source: isp_core::IspError::InvalidParameter {
                name: "patch terms",
                allowed: "a non-singular set (patches spanning six terms)",
            },
        })?;
    }
    Ok(out)
}

/// Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)] // matrix code reads best with indices
fn solve6(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..6 {
            let f = a[row][col] / a[col][col];
            for k in col..6 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let s: f64 = (row + 1..6).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The calibration file of `camera` under one or two illuminants, for
/// [`CalibrationFile::to_toml`] (`camsim isp --calibration`, `camsim demo --calibration`).
pub fn to_file(camera: &str, calibrations: &[Calibrated]) -> CalibrationFile {
    CalibrationFile {
        camera: camera.to_owned(),
        entries: calibrations
            .iter()
            .map(|c| {
                let (mean, max) = mean_max(&c.delta_e_matrix);
                CalibrationEntry {
                    illuminant: c.illuminant.clone(),
                    cct_k: c.cct_k,
                    camera_to_xyz: c.camera_to_xyz,
                    delta_e_2000_mean: Some(mean),
                    delta_e_2000_max: Some(max),
                }
            })
            .collect(),
    }
}

/// `camsim calibrate`'s report for one illuminant.
pub fn report_text(camera: &str, c: &Calibrated) -> String {
    let (mean, max) = mean_max(&c.delta_e_matrix);
    let (rp_mean, rp_max) = mean_max(&c.delta_e_root_polynomial);
    let m = c.camera_to_xyz;
    format!(
        "{camera} under {} ({:.0} K):\n  camera -> XYZ (3x3 least squares):\n    [{:9.5} {:9.5} {:9.5}]\n    [{:9.5} {:9.5} {:9.5}]\n    [{:9.5} {:9.5} {:9.5}]\n  CIE 2000 error on the 24 patches: 3x3 mean {mean:.2}, max {max:.2}; root-polynomial mean {rp_mean:.2}, max {rp_max:.2}\n",
        c.illuminant, c.cct_k, m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn solve6_inverts() {
        let mut a = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                a[i][j] = if i == j {
                    4.0
                } else {
                    1.0 / (1 + i + j) as f64
                };
            }
        }
        let x = [1.0, -2.0, 3.0, 0.5, 0.0, 7.0];
        let b: [f64; 6] = std::array::from_fn(|i| (0..6).map(|j| a[i][j] * x[j]).sum());
        let got = solve6(a, b).unwrap();
        for i in 0..6 {
            assert!((got[i] - x[i]).abs() < 1e-12);
        }
    }
}
