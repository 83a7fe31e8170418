//! Spectral data, in one place for the tracer, the sensor model and calibration: the tables on
//! one grid, 380..=780 nm at 5 nm (81 samples), and the renderer's band grid ([`BANDS`] bands of
//! 10 nm, 400..700 nm centres) with conversions between them. The tables are built into the
//! binary so it works on any machine: CIE 1931 2-degree colour matching functions, CIE illuminants (A, D50,
//! D65, FL2, FL11, LED-B3), the 24 ColorChecker reflectances (BabelColor average) and three
//! cameras' sensitivities (Nikon 5100 and Sigma SDMerill measured by NPL, Canon EOS 5D Mark II
//! from rawtoaces). All exported from colour-science 0.4.7; each file in `data/spectra/` names
//! its source on its first line.
//!
//! ```
//! use host_tracer::spectra::{Table, COLORCHECKER, ILLUMINANTS};
//! let patches = Table::parse(COLORCHECKER).unwrap();
//! assert_eq!(patches.names().len(), 24);
//! let d65 = Table::parse(ILLUMINANTS).unwrap();
//! assert_eq!(d65.column("D65").unwrap().len(), 81);
//! ```

use crate::error::{Error, Result};

/// First wavelength of the grid, nm.
pub const FIRST_NM: f64 = 380.0;
/// Grid step, nm.
pub const STEP_NM: f64 = 5.0;
/// Samples on the grid.
pub const SAMPLES: usize = 81;

/// CIE 1931 2-degree colour matching functions: columns `x_bar`, `y_bar`, `z_bar`.
pub const CIE1931: &str = include_str!("../../data/spectra/cie1931_2deg_cmfs.csv");
/// CIE illuminants, unnormalised: columns `A`, `D50`, `D65`, `FL2`, `FL11`, `LED-B3`.
pub const ILLUMINANTS: &str = include_str!("../../data/spectra/illuminants.csv");
/// ColorChecker 24 reflectances, one column per patch, row by row from dark skin to black.
pub const COLORCHECKER: &str =
    include_str!("../../data/spectra/colorchecker_babelcolor_average.csv");
/// Cameras' RGB sensitivities (columns `r`, `g`, `b`), by name.
pub const CAMERAS: [(&str, &str); 3] = [
    (
        "nikon-5100",
        include_str!("../../data/spectra/camera_nikon_5100.csv"),
    ),
    (
        "canon-eos-5d-mark-ii",
        include_str!("../../data/spectra/camera_canon_eos_5d_mark_ii.csv"),
    ),
    (
        "sigma-sdmerill",
        include_str!("../../data/spectra/camera_sigma_sdmerill.csv"),
    ),
];

/// Spectral bands of the spectral path.
pub const BANDS: usize = 31;
/// Centre of the first band, nm; bands are [`BAND_NM`] wide (so 395..705 nm in all).
pub const FIRST_BAND_NM: f64 = 400.0;
/// Width of one band, nm.
pub const BAND_NM: f64 = 10.0;

/// Centre wavelength of band `i`, nm.
pub fn band_centre_nm(i: usize) -> f64 {
    FIRST_BAND_NM + BAND_NM * i as f64
}

/// Averages a spectrum sampled on the 380..=780 nm, 5 nm grid over each
/// band (trapezoid weights 1/4, 1/2, 1/4 at the band's edges and centre).
pub fn bands_from_grid(samples: &[f64]) -> [f32; BANDS] {
    let at = |nm: f64| -> f64 {
        let i = ((nm - FIRST_NM) / STEP_NM).round() as usize;
        samples.get(i.min(SAMPLES - 1)).copied().unwrap_or_default()
    };
    std::array::from_fn(|b| {
        let c = band_centre_nm(b);
        (0.25 * at(c - 5.0) + 0.5 * at(c) + 0.25 * at(c + 5.0)) as f32
    })
}

/// Band averages of a spectrum given at arbitrary increasing wavelengths (linear
/// interpolation, held constant beyond the ends).
pub fn bands_from_samples(wavelengths_nm: &[f64], values: &[f64]) -> [f32; BANDS] {
    let at = |nm: f64| -> f64 {
        let n = wavelengths_nm.len().min(values.len());
        if n == 0 {
            return 0.0;
        }
        if nm <= wavelengths_nm[0] {
            return values[0];
        }
        for i in 1..n {
            if nm <= wavelengths_nm[i] {
                let t = (nm - wavelengths_nm[i - 1]) / (wavelengths_nm[i] - wavelengths_nm[i - 1]);
                return values[i - 1] + t * (values[i] - values[i - 1]);
            }
        }
        values[n - 1]
    };
    std::array::from_fn(|b| {
        let c = band_centre_nm(b);
        (0.25 * at(c - 5.0) + 0.5 * at(c) + 0.25 * at(c + 5.0)) as f32
    })
}

/// The CIE 1931 colour matching functions averaged over each band and normalised so a spectrum
/// of constant 1 has Y = 1 (the tracer's luminance unit): `XYZ = sum_b w[b] * L[b]`.
pub fn xyz_weights() -> [[f32; 3]; BANDS] {
    let table = Table::parse(CIE1931).expect("the built-in CIE 1931 table parses");
    let cols: Vec<[f32; BANDS]> = ["x_bar", "y_bar", "z_bar"]
        .iter()
        .map(|name| bands_from_grid(table.column(name).expect("CIE 1931 has x, y, z")))
        .collect();
    let y_sum: f32 = cols[1].iter().sum();
    std::array::from_fn(|b| [cols[0][b] / y_sum, cols[1][b] / y_sum, cols[2][b] / y_sum])
}

/// isp-core's XYZ -> linear sRGB matrix (the one copy of the IEC constants) in `f32`.
const XYZ_TO_LINEAR_SRGB: [[f32; 3]; 3] = {
    let m = isp_core::colour::XYZ_TO_LINEAR_SRGB;
    let mut out = [[0.0f32; 3]; 3];
    let mut i = 0;
    while i < 9 {
        out[i / 3][i % 3] = m[i / 3][i % 3] as f32;
        i += 1;
    }
    out
};

/// Linear sRGB of a band spectrum, with `weights` from [`xyz_weights`].
pub fn bands_to_linear_srgb(bands: &[f32], weights: &[[f32; 3]; BANDS]) -> [f32; 3] {
    let mut xyz = [0.0f32; 3];
    for (v, w) in bands.iter().zip(weights) {
        for c in 0..3 {
            xyz[c] += v * w[c];
        }
    }
    std::array::from_fn(|r| (0..3).map(|c| XYZ_TO_LINEAR_SRGB[r][c] * xyz[c]).sum())
}

/// An illuminant of [`ILLUMINANTS`] on the band grid (unnormalised).
pub fn illuminant_bands(illuminant: &str) -> Result<[f32; BANDS]> {
    let table = Table::parse(ILLUMINANTS)?;
    Ok(bands_from_grid(table.named("illuminant", illuminant)?))
}

/// CIE XYZ of a band spectrum (weights from [`xyz_weights`]: constant 1 has `Y = 1`).
pub fn bands_xyz(bands: &[f32; BANDS]) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    for (b, w) in bands.iter().zip(&xyz_weights()) {
        for k in 0..3 {
            xyz[k] += (*b * w[k]) as f64;
        }
    }
    xyz
}

/// Named columns of samples on the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    /// Parses a CSV: `#` comment lines, a header `wavelength_nm,NAME,...`, then one row per
    /// grid wavelength. Errors name the line.
    pub fn parse(text: &str) -> Result<Table> {
        let problem = |line: Option<usize>, problem: String| Error::Table { line, problem };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
        let (_, header) = lines
            .next()
            .ok_or_else(|| problem(None, "no header line".into()))?;
        let mut fields = header.split(',');
        if fields.next() != Some("wavelength_nm") {
            return Err(problem(
                None,
                "the first column must be wavelength_nm".into(),
            ));
        }
        let names: Vec<String> = fields.map(str::to_owned).collect();
        let mut columns = vec![Vec::with_capacity(SAMPLES); names.len()];
        for (k, (n, line)) in lines.enumerate() {
            let values: std::result::Result<Vec<f64>, _> =
                line.split(',').map(str::parse::<f64>).collect();
            let values = values.map_err(|e| problem(Some(n + 1), e.to_string()))?;
            let expected_nm = FIRST_NM + STEP_NM * k as f64;
            if values.len() != names.len() + 1 || values[0] != expected_nm {
                return Err(problem(
                    Some(n + 1),
                    format!("expected {expected_nm} nm and {} values", names.len()),
                ));
            }
            for (column, v) in columns.iter_mut().zip(&values[1..]) {
                column.push(*v);
            }
        }
        if columns.iter().any(|c| c.len() != SAMPLES) {
            return Err(problem(
                None,
                format!("expected {SAMPLES} rows, 380..=780 nm"),
            ));
        }
        Ok(Table { names, columns })
    }

    /// The column names, in file order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The column called `name`, or an error naming the `kind` of name and the known ones.
    pub fn named(&self, kind: &'static str, name: &str) -> Result<&[f64]> {
        self.column(name).ok_or_else(|| Error::Unknown {
            kind,
            name: name.to_owned(),
            known: self.names.clone(),
        })
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[i])
    }

    /// Column `i`.
    pub fn column_at(&self, i: usize) -> Option<&[f64]> {
        self.columns.get(i).map(Vec::as_slice)
    }
}

/// `sum over the grid of a * b * c` (a Riemann sum: the grid is uniform, so the step cancels in
/// every ratio the callers form).
pub fn integrate(a: &[f64], b: &[f64], c: &[f64]) -> f64 {
    a.iter().zip(b).zip(c).map(|((x, y), z)| x * y * z).sum()
}

/// The 24 ColorChecker patches' CIE XYZ and camera RGB, in patch order.
pub type PatchValues = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// The 24 ColorChecker patches under `illuminant` (a column of [`ILLUMINANTS`]): their CIE XYZ,
/// scaled so a perfect white has `Y = 1`, and the raw responses of `camera` (a name in
/// [`CAMERAS`]) scaled the same way by the white's green.
pub fn colorchecker(illuminant: &str, camera: &str) -> Result<PatchValues> {
    let cmfs = Table::parse(CIE1931)?;
    let illuminants = Table::parse(ILLUMINANTS)?;
    let patches = Table::parse(COLORCHECKER)?;
    let sensor = CAMERAS
        .iter()
        .find(|(n, _)| *n == camera)
        .ok_or_else(|| Error::Unknown {
            kind: "camera",
            name: camera.to_owned(),
            known: CAMERAS.iter().map(|c| c.0.to_owned()).collect(),
        })
        .and_then(|(_, text)| Table::parse(text))?;
    let light = illuminants.named("illuminant", illuminant)?;
    let ones = vec![1.0; SAMPLES];
    let channels = |t: &Table, names: [&'static str; 3]| -> Result<[Vec<f64>; 3]> {
        let get = |n: &'static str| t.named("spectral column", n).map(<[f64]>::to_vec);
        Ok([get(names[0])?, get(names[1])?, get(names[2])?])
    };
    let xyz_bar = channels(&cmfs, ["x_bar", "y_bar", "z_bar"])?;
    let rgb_bar = channels(&sensor, ["r", "g", "b"])?;
    let white_y = integrate(&xyz_bar[1], light, &ones);
    let white_g = integrate(&rgb_bar[1], light, &ones);
    let (mut xyz, mut rgb) = (Vec::new(), Vec::new());
    for i in 0..patches.names().len() {
        let r = patches.column_at(i).ok_or(Error::Table {
            line: None,
            problem: format!("ColorChecker column {i} missing"),
        })?;
        xyz.push(std::array::from_fn(|c| {
            integrate(&xyz_bar[c], light, r) / white_y
        }));
        rgb.push(std::array::from_fn(|c| {
            integrate(&rgb_bar[c], light, r) / white_g
        }));
    }
    Ok((xyz, rgb))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spectrum_has_unit_luminance() {
        let w = xyz_weights();
        let y: f32 = w.iter().map(|c| c[1]).sum();
        assert!((y - 1.0).abs() < 1e-6);
        // Equal energy is near-neutral in sRGB (E is not D65, so not exactly).
        let rgb = bands_to_linear_srgb(&[1.0; BANDS], &w);
        for c in rgb {
            assert!((c - 1.0).abs() < 0.25, "{rgb:?}");
        }
    }

    #[test]
    fn samples_interpolate_onto_bands() {
        let s = bands_from_samples(&[400.0, 700.0], &[0.0, 1.0]);
        assert!((s[15] - 0.5).abs() < 1e-6, "{}", s[15]);
    }

    #[test]
    fn xyz_to_srgb_is_isp_cores_matrix_in_f32() {
        // The literal the tracer used to carry, before isp-core's became the one copy.
        let literal: [[f32; 3]; 3] = [
            [3.2406, -1.5372, -0.4986],
            [-0.9689, 1.8758, 0.0415],
            [0.0557, -0.2040, 1.0570],
        ];
        assert_eq!(XYZ_TO_LINEAR_SRGB, literal);
    }
}
