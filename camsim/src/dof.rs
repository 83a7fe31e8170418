//! `camsim dof`: depth of field, hyperfocal distance, focus position and magnification of a
//! thin lens, from optics-core's float equations.

use optics_core::dof::{depth_of_field, depth_of_field_approx};
use optics_core::lens::{lateral_magnification, sensor_distance_for_focus};
use optics_core::Distance;

/// Smallest f-number accepted (the fastest lenses made are around f/0.7; 0.5 is the thin-lens
/// limit of an aperture as wide as twice the focal length).
pub const MIN_F_NUMBER: f64 = 0.5;

/// Inputs of the calculator, in millimetres (the command line checks them as it parses).
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

/// The calculator's results; `None` stands for infinity (`null` in JSON).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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

/// Computes the report; inputs outside the documented ranges may be refused.
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
