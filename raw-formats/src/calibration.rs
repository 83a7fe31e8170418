//! camsim's colour calibration file (TOML): a camera's name and, for one or two illuminants,
//! the camera-to-XYZ matrix fitted on a ColorChecker, as `camsim calibrate` writes it and
//! `camsim isp --calibration` and `camsim demo --calibration` read it.
//!
//! ```
//! use raw_formats::calibration::{CalibrationEntry, CalibrationFile};
//! let file = CalibrationFile {
//!     camera: "nikon-5100".into(),
//!     entries: vec![CalibrationEntry {
//!         illuminant: "D65".into(),
//!         cct_k: 6504.0,
//!         camera_to_xyz: [[0.6, 0.3, 0.1], [0.3, 0.7, 0.0], [0.0, 0.1, 0.9]],
//!         delta_e_2000_mean: Some(0.98),
//!         delta_e_2000_max: None,
//!     }],
//! };
//! let back = CalibrationFile::parse(&file.to_toml(), "cal.toml".as_ref()).unwrap();
//! assert_eq!(back.entries[0].camera_to_xyz, file.entries[0].camera_to_xyz);
//! assert!(back.to_isp().is_ok());
//! ```

use std::path::Path;

use isp_core::ccm::Calibration;
use isp_core::colour::Mat3;

use crate::error::{FormatError, Result};

/// One illuminant's calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationEntry {
    /// Illuminant name (`A`, `D65`, ... as the spectral tables name them).
    pub illuminant: String,
    /// Its correlated colour temperature, kelvin.
    pub cct_k: f64,
    /// Raw camera RGB (black subtracted, not white balanced) to CIE XYZ.
    pub camera_to_xyz: Mat3,
    /// Mean CIE 2000 error of the fit on the chart, if known.
    pub delta_e_2000_mean: Option<f64>,
    /// Largest CIE 2000 error of the fit, if known.
    pub delta_e_2000_max: Option<f64>,
}

/// A calibration file: the camera and one or two entries.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFile {
    /// Camera name.
    pub camera: String,
    /// One entry per illuminant.
    pub entries: Vec<CalibrationEntry>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FileEntry {
    illuminant: String,
    cct_k: f64,
    camera_to_xyz: [[f64; 3]; 3],
    delta_e_2000_mean: Option<f64>,
    delta_e_2000_max: Option<f64>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FileBody {
    camera: String,
    calibration: Vec<FileEntry>,
}

impl CalibrationFile {
    /// The file's text.
    pub fn to_toml(&self) -> String {
        let mut out = format!(
            "# camsim colour calibration, written by `camsim calibrate`.\n\
             # camera_to_xyz maps raw camera RGB (black subtracted, not white balanced) to CIE XYZ.\n\
             camera = {:?}\n",
            self.camera
        );
        for c in &self.entries {
            let m = c.camera_to_xyz;
            out += &format!(
                "\n[[calibration]]\nilluminant = {:?}\ncct_k = {:.0}\ncamera_to_xyz = [\n  [{:.6}, {:.6}, {:.6}],\n  [{:.6}, {:.6}, {:.6}],\n  [{:.6}, {:.6}, {:.6}],\n]\n",
                c.illuminant, c.cct_k, m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]
            );
            if let Some(mean) = c.delta_e_2000_mean {
                out += &format!("delta_e_2000_mean = {mean:.3}\n");
            }
            if let Some(max) = c.delta_e_2000_max {
                out += &format!("delta_e_2000_max = {max:.3}\n");
            }
        }
        out
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_toml()).map_err(|e| FormatError::io(path, e))
    }

    /// Reads a file written by [`Self::write`].
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parses a file's text (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let body: FileBody = toml::from_str(text).map_err(|e| {
            FormatError::Toml {
                message: e.message().to_owned(),
            }
            .in_file(path)
        })?;
        if body.calibration.is_empty() || body.calibration.len() > 2 {
            return Err(FormatError::OutOfRange {
                field: "[[calibration]] entries",
                value: body.calibration.len().to_string(),
                allowed: "one or two".into(),
            }
            .in_file(path));
        }
        let entries = body
            .calibration
            .into_iter()
            .map(|e| CalibrationEntry {
                illuminant: e.illuminant,
                cct_k: e.cct_k,
                camera_to_xyz: e.camera_to_xyz,
                delta_e_2000_mean: e.delta_e_2000_mean,
                delta_e_2000_max: e.delta_e_2000_max,
            })
            .collect();
        let file = CalibrationFile {
            camera: body.camera,
            entries,
        };
        file.to_isp().map_err(|e| e.in_file(path))?;
        Ok(file)
    }

    /// isp-core's calibration (one or two matrices, interpolated by CCT).
    pub fn to_isp(&self) -> Result<Calibration> {
        match self.entries.as_slice() {
            [e] => Calibration::single(e.cct_k, e.camera_to_xyz),
            [a, b] => Calibration::new([a.cct_k, b.cct_k], [a.camera_to_xyz, b.camera_to_xyz]),
            _ => {
                return Err(FormatError::OutOfRange {
                    field: "calibration entries",
                    value: self.entries.len().to_string(),
                    allowed: "one or two".into(),
                })
            }
        }
        .map_err(|source| FormatError::Colour {
            field: "calibration",
            source,
        })
    }
}
