//! `camsim dof`: depth of field, hyperfocal distance, focus position and magnification of a
//! thin lens, from optics-core's float equations.

use optics_core::dof::{depth_of_field, depth_of_field_approx};
use optics_core::lens::{lateral_magnification, sensor_distance_for_focus};
use optics_core::Distance;
use serde_json::{json, Value};

use crate::cli_args::{number, number_or_infinity, ArgError};

/// Smallest f-number accepted (the fastest lenses made are around f/0.7; 0.5 is the thin-lens
/// limit of an aperture as wide as twice the focal length).
pub const MIN_F_NUMBER: f64 = 0.5;

/// Checked inputs of the calculator, in millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DofInput {
    /// Focal length, > 0.
    pub focal_length_mm: f64,
    /// f-number, >= 0.5.
    pub f_number: f64,
    /// Acceptable circle of confusion on the sensor, > 0.
    pub coc_mm: f64,
    /// Focus distance, > focal length, or infinite.
    pub focus_mm: f64,
}

impl DofInput {
    /// Parses and checks the four values as given on the command line.
    pub fn parse(
        focal_length: &str,
        f_number: &str,
        coc: &str,
        focus: &str,
    ) -> Result<Self, ArgError> {
        let focal_length_mm = number(
            "--focal-length-mm",
            focal_length,
            "a number > 0 (millimetres)",
            |x| x > 0.0,
        )?;
        let f_number = number("--f-number", f_number, "a number >= 0.5", |x| {
            x >= MIN_F_NUMBER
        })?;
        let coc_mm = number("--coc-mm", coc, "a number > 0 (millimetres)", |x| x > 0.0)?;
        let allowed = format!("a number > the focal length ({focal_length_mm} mm), or inf");
        let focus_mm = number_or_infinity("--focus-mm", focus, &allowed, |x| x > focal_length_mm)?;
        Ok(Self {
            focal_length_mm,
            f_number,
            coc_mm,
            focus_mm,
        })
    }
}

/// The calculator's results; `None` stands for infinity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DofReport {
    /// Hyperfocal distance.
    pub hyperfocal_mm: f64,
    /// Near limit of acceptable sharpness.
    pub near_mm: f64,
    /// Far limit (`None`: infinite).
    pub far_mm: Option<f64>,
    /// Total depth of field (`None`: infinite).
    pub dof_mm: Option<f64>,
    /// The approximation `2 u^2 N c / f^2` (`None` when focused at infinity).
    pub dof_approx_mm: Option<f64>,
    /// Sensor-to-lens distance that focuses the subject.
    pub image_distance_mm: f64,
    /// Lateral magnification `-s_i / s_o` (negative: inverted image).
    pub magnification: f64,
}

/// Computes the report. Inputs from [`DofInput::parse`] always succeed; others may be refused.
pub fn compute(input: &DofInput) -> Result<DofReport, optics_core::OpticsError> {
    let DofInput {
        focal_length_mm: f,
        f_number: n,
        coc_mm: c,
        focus_mm: s,
    } = *input;
    let dof = depth_of_field(f, n, c, s)?;
    let hyperfocal_mm =
        dof.hyperfocal
            .finite()
            .ok_or(optics_core::OpticsError::InvalidParameter {
                name: "coc_mm",
                allowed: "> 0",
            })?;
    Ok(DofReport {
        hyperfocal_mm,
        near_mm: dof.near,
        far_mm: dof.far.finite(),
        dof_mm: dof.total.finite(),
        dof_approx_mm: match depth_of_field_approx(f, n, c, s)? {
            Distance::Finite(x) => Some(x),
            Distance::Infinite => None,
        },
        image_distance_mm: sensor_distance_for_focus(f, s)?,
        magnification: lateral_magnification(f, s)?,
    })
}

impl DofReport {
    /// One JSON object with the keys of the command's documentation; infinity is `null`.
    pub fn to_json(&self) -> Value {
        json!({
            "hyperfocal_mm": self.hyperfocal_mm,
            "near_mm": self.near_mm,
            "far_mm": self.far_mm,
            "dof_mm": self.dof_mm,
            "dof_approx_mm": self.dof_approx_mm,
            "image_distance_mm": self.image_distance_mm,
            "magnification": self.magnification,
        })
    }

    /// A readable table.
    pub fn to_table(&self, input: &DofInput) -> String {
        let mm = |x: Option<f64>| x.map_or("infinity".to_string(), |v| format!("{v:.3} mm"));
        let focus = if input.focus_mm.is_infinite() {
            "infinity".to_string()
        } else {
            format!("{} mm", input.focus_mm)
        };
        let approx = match (self.dof_approx_mm, self.dof_mm) {
            (Some(a), Some(e)) if e > 0.0 => {
                format!("{a:.3} mm ({:+.2}% against exact)", 100.0 * (a - e) / e)
            }
            (a, _) => mm(a),
        };
        let ratio = if self.magnification == 0.0 {
            String::from("subject at infinity")
        } else {
            format!(
                "1:{:.1}, {}",
                1.0 / self.magnification.abs(),
                if self.magnification < 0.0 {
                    "inverted"
                } else {
                    "upright"
                }
            )
        };
        let rows = [
            (
                "hyperfocal distance",
                format!("{:.3} mm", self.hyperfocal_mm),
            ),
            ("near limit", format!("{:.3} mm", self.near_mm)),
            ("far limit", mm(self.far_mm)),
            ("depth of field", mm(self.dof_mm)),
            ("approximation 2u²Nc/f²", approx),
            (
                "sensor-to-lens distance",
                format!("{:.3} mm", self.image_distance_mm),
            ),
            (
                "magnification",
                format!("{:.6} ({ratio})", self.magnification),
            ),
        ];
        let mut out = format!(
            "{} mm lens at f/{}, circle of confusion {} mm, focused at {focus}\n",
            input.focal_length_mm, input.f_number, input.coc_mm
        );
        for (name, value) in rows {
            out.push_str(&format!("  {name:<26}{value}\n"));
        }
        out
    }
}
