//! What the chart's patches should look like: the ColorChecker's reflectances (BabelColor
//! average) under a light of the shot's colour temperature, adapted (Bradford) to D65 and
//! given as linear sRGB, the output `camsim isp` renders and the truth `camsim demo` measures
//! against. The light for a CCT is CIE's: a blackbody below 4000 K, the CIE daylight at that
//! CCT from 4000 K (CIE 15:2004, basis functions S0, S1, S2).

use host_tracer::spectra::{integrate, Table, CIE1931, COLORCHECKER, SAMPLES};
use isp_core::colour::{self, Mat3};

use crate::Error;

/// The CIE daylight basis functions (380..780 nm, 5 nm).
pub const DAYLIGHT_BASIS: &str = include_str!("../../../data/spectra/cie_daylight_basis.csv");

/// The wavelength of grid sample `i`, nm.
fn nm(i: usize) -> f64 {
    380.0 + 5.0 * i as f64
}

/// A light of correlated colour temperature `cct` kelvin on the 380..780 nm, 5 nm grid:
/// Planck's law below 4000 K, CIE daylight from 4000 K to 25000 K.
pub fn light_for_cct(cct: f64) -> Result<Vec<f64>, Error> {
    if !(1000.0..=25000.0).contains(&cct) {
        return Err(Error::Option {
            option: "colour temperature",
            value: format!("{cct} K"),
            allowed: "1000..=25000 K".into(),
        });
    }
    if cct < 4000.0 {
        const C2: f64 = 1.4388e-2; // m K
        return Ok((0..SAMPLES)
            .map(|i| {
                let l = nm(i) * 1e-9;
                1.0 / (l.powi(5) * ((C2 / (l * cct)).exp() - 1.0))
            })
            .collect());
    }
    let [x, y] = colour::cct_to_xy_daylight(cct)?;
    let m = 0.0241 + 0.2562 * x - 0.7341 * y;
    let m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
    let m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
    let basis = Table::parse(DAYLIGHT_BASIS)?;
    let s = |name: &'static str| basis.named("daylight basis", name).map(<[f64]>::to_vec);
    let (s0, s1, s2) = (s("S0")?, s("S1")?, s("S2")?);
    Ok((0..SAMPLES)
        .map(|i| s0[i] + m1 * s1[i] + m2 * s2[i])
        .collect())
}

/// The light of a chart shot: the tabulated spectrum when its file name names a CIE
/// illuminant of host-tracer's table (`A`, `D50`, `D65`, `FL2`, `FL11`, `LED-B3`) as a part
/// of its `<name>`, else [`light_for_cct`] of its colour temperature.
pub fn light_for_shot(file_stem: &str, cct: f64) -> Result<(Vec<f64>, String), Error> {
    let table = Table::parse(host_tracer::spectra::ILLUMINANTS)?;
    for part in file_stem.split('_') {
        if let Some(column) = table.column(part) {
            return Ok((column.to_vec(), format!("CIE {part}")));
        }
    }
    let kind = if cct < 4000.0 {
        "blackbody"
    } else {
        "CIE daylight"
    };
    Ok((light_for_cct(cct)?, format!("{kind} at {cct} K")))
}

/// The chromaticity of [`light_for_cct`]'s light.
pub fn light_xy(cct: f64) -> Result<[f64; 2], Error> {
    let light = light_for_cct(cct)?;
    let cmfs = Table::parse(CIE1931)?;
    let ones = vec![1.0; SAMPLES];
    let mut xyz = [0.0; 3];
    for (c, name) in ["x_bar", "y_bar", "z_bar"].iter().enumerate() {
        xyz[c] = integrate(cmfs.named("CMF", name)?, &light, &ones);
    }
    Ok(colour::xyz_to_xy(xyz)?)
}

/// The 24 patches' reflectances.
pub fn reflectances() -> Result<Vec<Vec<f64>>, Error> {
    let table = Table::parse(COLORCHECKER)?;
    (0..24)
        .map(|i| {
            table
                .column_at(i)
                .map(<[f64]>::to_vec)
                .ok_or(Error::Message(format!(
                    "ColorChecker table: column {i} missing"
                )))
        })
        .collect()
}

/// The 24 patches under `light` (on the 5 nm grid), adapted to D65, in linear sRGB with the
/// perfect white at 1.
pub fn chart_srgb(light: &[f64]) -> Result<Vec<[f64; 3]>, Error> {
    let cmfs = Table::parse(CIE1931)?;
    let bar = |n: &'static str| cmfs.named("CMF", n).map(<[f64]>::to_vec);
    let xyz_bar = [bar("x_bar")?, bar("y_bar")?, bar("z_bar")?];
    let ones = vec![1.0; SAMPLES];
    let white_y = integrate(&xyz_bar[1], light, &ones);
    let white: [f64; 3] = std::array::from_fn(|c| integrate(&xyz_bar[c], light, &ones) / white_y);
    let d65 = colour::xy_to_xyz(colour::D65_XY)?;
    let adapt: Mat3 = colour::bradford_adaptation(white, d65)?;
    let to_srgb = colour::mat3_mul(&colour::XYZ_TO_LINEAR_SRGB, &adapt);
    reflectances()?
        .iter()
        .map(|r| {
            let xyz: [f64; 3] = std::array::from_fn(|c| integrate(&xyz_bar[c], light, r) / white_y);
            Ok(colour::mat3_mul_vec(&to_srgb, xyz))
        })
        .collect()
}

/// CIEDE2000 between two linear sRGB colours (D65 white at 1).
pub fn delta_e_srgb(a: [f64; 3], b: [f64; 3]) -> f64 {
    let white = [0.95047, 1.0, 1.08883];
    let lab = |v: [f64; 3]| {
        colour::xyz_to_lab(colour::mat3_mul_vec(&colour::LINEAR_SRGB_TO_XYZ, v), white)
            .unwrap_or([f64::NAN; 3])
    };
    colour::delta_e_2000(lab(a), lab(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The daylight at 6504 K is D65 and Planck at 2856 K is A, on the table's grid.
    #[test]
    fn lights_for_cct_match_the_tabulated_illuminants() {
        let table = Table::parse(host_tracer::spectra::ILLUMINANTS).unwrap();
        for (name, cct) in [("D65", 6504.0), ("A", 2856.0)] {
            let light = light_for_cct(cct).unwrap();
            let tabulated = table.named("illuminant", name).unwrap();
            let refs = chart_srgb(tabulated).unwrap();
            let ours = chart_srgb(&light).unwrap();
            let worst = refs
                .iter()
                .zip(&ours)
                .map(|(a, b)| delta_e_srgb(*a, *b))
                .fold(0.0, f64::max);
            assert!(worst < 0.2, "{name}: {worst}");
        }
        assert!(light_for_cct(500.0).is_err());
    }
}
