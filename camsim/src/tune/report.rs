//! What `camsim tune` tells an engineer: the tables as Markdown (printed, and `report.md`
//! with `--report`), and the same as JSON (`--json`).

use std::fmt::Write as _;
use std::path::Path;

use serde_json::json;

use super::{chart, Tuned};
use crate::Error;

/// The report as Markdown.
pub fn markdown(tuned: &Tuned) -> String {
    let t = &tuned.tuning;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Tuning of {} ({}x{}, {}, {}-bit)\n",
        t.camera, t.width, t.height, t.pattern, t.bits
    );
    let b = &t.black_level.values;
    let _ = writeln!(
        s,
        "Black level ({}): {:.2} {:.2} {:.2} {:.2} DN per CFA position; white {}.\n",
        t.black_level.source, b[0], b[1], b[2], b[3], t.white_level
    );
    let _ = writeln!(
        s,
        "## Noise profile (variance = S x + O, x a fraction of white - black)\n"
    );
    let _ = writeln!(
        s,
        "| ISO | source | S red | S green | S blue | O red | O green | O blue |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for n in &t.noise {
        let _ = writeln!(
            s,
            "| {} | {} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.3e} |",
            n.iso,
            n.source,
            n.scale[0],
            n.scale[1],
            n.scale[2],
            n.offset[0],
            n.offset[1],
            n.offset[2]
        );
    }
    let d = &t.defects;
    let _ = writeln!(
        s,
        "\n## Defects\n\n{} hot, {} dead, {} stuck.\n",
        d.hot.len(),
        d.dead.len(),
        d.stuck.len()
    );
    let sh = &t.shading;
    let corner = |v: &[f64]| {
        let (gw, gh) = (sh.grid_width, sh.grid_height);
        [v[0], v[gw - 1], v[(gh - 1) * gw], v[gh * gw - 1]]
    };
    let _ = writeln!(
        s,
        "## Lens shading ({} x {} nodes)\n",
        sh.grid_width, sh.grid_height
    );
    let c = corner(&sh.luminance);
    let _ = writeln!(
        s,
        "Luminance gain at the corners: {:.3} {:.3} {:.3} {:.3} (1 at the brightest point).\n",
        c[0], c[1], c[2], c[3]
    );
    let _ = writeln!(
        s,
        "| CCT | red/green at the corners | blue/green at the corners |"
    );
    let _ = writeln!(s, "|---|---|---|");
    for table in &sh.colour {
        let (r, b) = (corner(&table.red), corner(&table.blue));
        let _ = writeln!(
            s,
            "| {} | {:.3} {:.3} {:.3} {:.3} | {:.3} {:.3} {:.3} {:.3} |",
            table.cct, r[0], r[1], r[2], r[3], b[0], b[1], b[2], b[3]
        );
    }
    let _ = writeln!(
        s,
        "\n## White balance locus\n\nb = {:.5} + {:.5} r + {:.5} r^2, transverse bounds -{:.4} / +{:.4}.\n",
        t.awb.coefficients[0], t.awb.coefficients[1], t.awb.coefficients[2], t.awb.transverse_negative, t.awb.transverse_positive
    );
    let _ = writeln!(s, "| CCT | red gain | blue gain |");
    let _ = writeln!(s, "|---|---|---|");
    for p in &t.awb.points {
        let _ = writeln!(s, "| {} | {:.4} | {:.4} |", p.cct, p.red_gain, p.blue_gain);
    }
    let _ = writeln!(s, "\n## Colour matrices (CIEDE2000 over the 24 patches)\n");
    let _ = writeln!(
        s,
        "| chart | CCT | found | before: mean | max | after: mean | max |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for shot in &tuned.charts {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let max = |v: &[f64]| v.iter().fold(0.0f64, |a, &b| a.max(b));
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            shot.path
                .file_name()
                .map(|n| n.to_string_lossy())
                .unwrap_or_default(),
            shot.cct,
            if shot.found { "yes" } else { "given" },
            mean(&shot.delta_e_before),
            max(&shot.delta_e_before),
            mean(&shot.delta_e_after),
            max(&shot.delta_e_after)
        );
    }
    for e in &t.ccm {
        let m = &e.matrix;
        let _ = writeln!(
            s,
            "\n{} K: [{:.4} {:.4} {:.4}; {:.4} {:.4} {:.4}; {:.4} {:.4} {:.4}]",
            e.cct, m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]
        );
    }
    if !tuned.warnings.is_empty() {
        let _ = writeln!(s, "\n## Warnings\n");
        for w in &tuned.warnings {
            let _ = writeln!(s, "- {w}");
        }
    }
    s
}

/// The tuning and per-chart results as JSON.
pub fn json(tuned: &Tuned) -> serde_json::Value {
    json!({
        "tuning": serde_json::to_value(&tuned.tuning).unwrap_or_default(),
        "charts": tuned.charts.iter().map(|c| json!({
            "file": c.path.display().to_string(),
            "cct": c.cct,
            "corners": c.corners,
            "found": c.found,
            "neutral": c.neutral,
            "patch_means": c.patches,
            "delta_e_before": c.delta_e_before,
            "delta_e_after": c.delta_e_after,
        })).collect::<Vec<_>>(),
        "photon_transfer": tuned.transfer.iter().map(|(iso, points)| json!({
            "iso": iso,
            "points": points.iter().map(|p| p.iter().map(|q| [q.mean, q.variance]).collect::<Vec<_>>()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "patches": chart::PATCHES,
        "warnings": tuned.warnings,
    })
}

/// Writes `report.md` into `dir`.
pub fn write(tuned: &Tuned, dir: &Path) -> Result<(), Error> {
    let path = dir.join("report.md");
    std::fs::write(&path, markdown(tuned)).map_err(|e| raw_formats::FormatError::io(&path, e))?;
    Ok(())
}
