//! Spectral data on one grid, 380..=780 nm at 5 nm (81 samples), built into the binary so it
//! works on any machine: CIE 1931 2-degree colour matching functions, CIE illuminants (A, D50,
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

/// Named columns of samples on the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    /// Parses a CSV: `#` comment lines, a header `wavelength_nm,NAME,...`, then one row per
    /// grid wavelength. Errors name the line.
    pub fn parse(text: &str) -> Result<Table, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
        let (_, header) = lines.next().ok_or("no header line")?;
        let mut fields = header.split(',');
        if fields.next() != Some("wavelength_nm") {
            return Err("the first column must be wavelength_nm".into());
        }
        let names: Vec<String> = fields.map(str::to_owned).collect();
        let mut columns = vec![Vec::with_capacity(SAMPLES); names.len()];
        for (k, (n, line)) in lines.enumerate() {
            let values: Result<Vec<f64>, _> = line.split(',').map(str::parse::<f64>).collect();
            let values = values.map_err(|e| format!("line {}: {e}", n + 1))?;
            let expected_nm = FIRST_NM + STEP_NM * k as f64;
            if values.len() != names.len() + 1 || values[0] != expected_nm {
                return Err(format!(
                    "line {}: expected {expected_nm} nm and {} values",
                    n + 1,
                    names.len()
                ));
            }
            for (column, v) in columns.iter_mut().zip(&values[1..]) {
                column.push(*v);
            }
        }
        if columns.iter().any(|c| c.len() != SAMPLES) {
            return Err(format!("expected {SAMPLES} rows, 380..=780 nm"));
        }
        Ok(Table { names, columns })
    }

    /// The column names, in file order.
    pub fn names(&self) -> &[String] {
        &self.names
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
pub fn colorchecker(illuminant: &str, camera: &str) -> Result<PatchValues, String> {
    let cmfs = Table::parse(CIE1931)?;
    let illuminants = Table::parse(ILLUMINANTS)?;
    let patches = Table::parse(COLORCHECKER)?;
    let sensor = CAMERAS
        .iter()
        .find(|(n, _)| *n == camera)
        .ok_or_else(|| {
            format!(
                "unknown camera {camera:?}; known: {}",
                CAMERAS.map(|c| c.0).join(", ")
            )
        })
        .and_then(|(_, text)| Table::parse(text))?;
    let light = illuminants.column(illuminant).ok_or_else(|| {
        format!(
            "unknown illuminant {illuminant:?}; known: {}",
            illuminants.names().join(", ")
        )
    })?;
    let ones = vec![1.0; SAMPLES];
    let channels = |t: &Table, names: [&str; 3]| -> Result<[Vec<f64>; 3], String> {
        let get = |n: &str| {
            t.column(n)
                .map(<[f64]>::to_vec)
                .ok_or(format!("no column {n}"))
        };
        Ok([get(names[0])?, get(names[1])?, get(names[2])?])
    };
    let xyz_bar = channels(&cmfs, ["x_bar", "y_bar", "z_bar"])?;
    let rgb_bar = channels(&sensor, ["r", "g", "b"])?;
    let white_y = integrate(&xyz_bar[1], light, &ones);
    let white_g = integrate(&rgb_bar[1], light, &ones);
    let (mut xyz, mut rgb) = (Vec::new(), Vec::new());
    for i in 0..patches.names().len() {
        let r = patches.column_at(i).ok_or("missing patch")?;
        xyz.push(std::array::from_fn(|c| {
            integrate(&xyz_bar[c], light, r) / white_y
        }));
        rgb.push(std::array::from_fn(|c| {
            integrate(&rgb_bar[c], light, r) / white_g
        }));
    }
    Ok((xyz, rgb))
}
