//! What `camsim tune` tells an engineer: the tables as Markdown (printed, and `report.md`
//! with `--report`), the same as JSON (`--json`), and with `--report` SVG charts in the
//! bench's style: per-patch CIEDE2000 before and after the matrix (`delta_e.svg`), the
//! white-balance locus with its lights (`locus.svg`), each flat field's residual after the
//! shading correction (`shading.svg`) and the photon-transfer curves with their fits
//! (`photon_transfer.svg`).

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;
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

/// Writes `report.md` and the charts into `dir`.
pub fn write(tuned: &Tuned, dir: &Path) -> Result<(), Error> {
    let path = dir.join("report.md");
    let mut text = markdown(tuned);
    text += "\n## Charts\n\n![per-patch CIEDE2000](delta_e.svg)\n\n![white-balance locus](locus.svg)\n\n\
             ![shading residual](shading.svg)\n";
    for shot in &tuned.charts {
        let stem = shot
            .path
            .file_stem()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        text += &format!("\n![patches sampled in {stem}](sampled_{stem}.png)\n");
    }
    if !tuned.transfer.is_empty() {
        text += "\n![photon transfer](photon_transfer.svg)\n";
    }
    std::fs::write(&path, text).map_err(|e| raw_formats::FormatError::io(&path, e))?;
    let charts: [(&str, DrawFn); 3] = [
        ("delta_e.svg", draw_delta_e),
        ("locus.svg", draw_locus),
        ("shading.svg", draw_shading),
    ];
    for (name, draw) in charts {
        let path = dir.join(name);
        draw(tuned, &path)
            .map_err(|e| Error::Message(format!("drawing {}: {e}", path.display())))?;
    }
    for shot in &tuned.charts {
        let stem = shot
            .path
            .file_stem()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        shot_preview(tuned, shot, &dir.join(format!("sampled_{stem}.png")))?;
    }
    if !tuned.transfer.is_empty() {
        let path = dir.join("photon_transfer.svg");
        draw_transfer(tuned, &path)
            .map_err(|e| Error::Message(format!("drawing {}: {e}", path.display())))?;
    }
    Ok(())
}

/// A chart shot at half size (2x2 superpixels, white-balanced by the shot's light, sRGB
/// encoded) with the square each patch was sampled over outlined in magenta.
fn shot_preview(tuned: &Tuned, shot: &super::ChartShot, path: &Path) -> Result<(), Error> {
    let dng = raw_formats::dng::Dng::read(&shot.path)?;
    let raw = &dng.image;
    let t = &tuned.tuning;
    let (w, h) = (raw.width / 2, raw.height / 2);
    let range = f64::from(raw.white_level) - t.black_level.values[0];
    let mut data = vec![0u16; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let mut rgb = [0.0f64; 3];
            let mut n = [0.0f64; 3];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (px, py) = (2 * x + dx, 2 * y + dy);
                let c = raw.pattern.colour_at(px, py).index();
                rgb[c] += f64::from(raw.samples[py * raw.width + px])
                    - t.black_level.values[(py % 2) * 2 + px % 2];
                n[c] += 1.0;
            }
            for c in 0..3 {
                let v = (rgb[c] / n[c] / range / shot.neutral[c]).clamp(0.0, 1.0);
                data[3 * (y * w + x) + c] =
                    (255.0 * isp_core::srgb::encode(v as f32)).round() as u16;
            }
        }
    }
    if let Some(map) = super::chart::ChartMap::from_corners(&shot.corners) {
        for i in 0..super::chart::PATCHES {
            let [cu, cv] = super::chart::patch_centre_units(i);
            let corners = [(-0.3, -0.3), (0.3, -0.3), (0.3, 0.3), (-0.3, 0.3)]
                .map(|(du, dv)| map.apply([cu + du, cv + dv]));
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                for step in 0..=100 {
                    let f = step as f64 / 100.0;
                    let (x, y) = (
                        (a[0] + f * (b[0] - a[0])) / 2.0,
                        (a[1] + f * (b[1] - a[1])) / 2.0,
                    );
                    if x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h {
                        let i = 3 * ((y as usize) * w + x as usize);
                        data[i..i + 3].copy_from_slice(&[255, 0, 255]);
                    }
                }
            }
        }
    }
    let image = raw_formats::Image {
        width: w,
        height: h,
        channels: 3,
        bits: 8,
        data,
    };
    raw_formats::image::write(path, &image)?;
    Ok(())
}

type Drawn = Result<(), Box<dyn std::error::Error>>;
type DrawFn = fn(&Tuned, &Path) -> Drawn;

/// Okabe and Ito's colour-blind-safe palette, as the bench's charts use it.
const PALETTE: [RGBColor; 4] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
];
const FONT: &str = "sans-serif";

fn draw_delta_e(tuned: &Tuned, path: &Path) -> Drawn {
    let n = tuned.charts.len().max(1);
    let root = SVGBackend::new(path, (1200, 320 * n as u32 + 40)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = root.titled(
        "CIEDE2000 per patch: white-balanced camera RGB (light) and after the colour matrix (dark)",
        (FONT, 20),
    )?;
    let worst = tuned
        .charts
        .iter()
        .flat_map(|c| c.delta_e_before.iter())
        .fold(1.0f64, |a, &b| a.max(b));
    for (panel, shot) in body.split_evenly((n, 1)).iter().zip(&tuned.charts) {
        let name = shot
            .path
            .file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{name} ({} K)", shot.cct), (FONT, 15))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.5..24.5, 0.0..worst * 1.1)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(24)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .x_desc("patch (1 dark skin .. 24 black)")
            .y_desc("CIEDE2000")
            .label_style((FONT, 11))
            .draw()?;
        chart.draw_series(shot.delta_e_before.iter().enumerate().map(|(i, &e)| {
            let x = i as f64 + 1.0;
            Rectangle::new([(x - 0.4, 0.0), (x, e)], PALETTE[2].mix(0.35).filled())
        }))?;
        chart.draw_series(shot.delta_e_after.iter().enumerate().map(|(i, &e)| {
            let x = i as f64 + 1.0;
            Rectangle::new([(x, 0.0), (x + 0.4, e)], PALETTE[2].filled())
        }))?;
    }
    root.present()?;
    Ok(())
}

fn draw_locus(tuned: &Tuned, path: &Path) -> Drawn {
    let root = SVGBackend::new(path, (800, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let t = &tuned.tuning;
    let points: Vec<(f64, [f64; 2])> = tuned
        .charts
        .iter()
        .map(|c| (c.cct, super::fit::chromaticity(c.neutral)))
        .collect();
    let (r0, r1) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1[0]), b.max(p.1[0]))
        });
    let (b0, b1) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1[1]), b.max(p.1[1]))
        });
    let (pad_r, pad_b) = ((r1 - r0).max(0.01) * 0.3, (b1 - b0).max(0.01) * 0.3);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "White-balance locus: the lights' camera colours and the fitted curve with its band",
            (FONT, 16),
        )
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(r0 - pad_r..r1 + pad_r, b0 - pad_b..b1 + pad_b)?;
    chart
        .configure_mesh()
        .x_desc("r = R / (R + G + B)")
        .y_desc("b = B / (R + G + B)")
        .label_style((FONT, 12))
        .draw()?;
    let [c0, c1, c2] = t.awb.coefficients;
    let curve = |offset: f64| {
        (0..=200).map(move |k| {
            let r = r0 - pad_r + (r1 - r0 + 2.0 * pad_r) * k as f64 / 200.0;
            (r, c0 + c1 * r + c2 * r * r + offset)
        })
    };
    chart.draw_series(LineSeries::new(curve(0.0), PALETTE[2].stroke_width(2)))?;
    for offset in [t.awb.transverse_positive, -t.awb.transverse_negative] {
        chart.draw_series(LineSeries::new(curve(offset), PALETTE[2].mix(0.4)))?;
    }
    chart.draw_series(
        points
            .iter()
            .map(|(_, p)| Circle::new((p[0], p[1]), 5, PALETTE[0].filled())),
    )?;
    chart.draw_series(
        points
            .iter()
            .map(|(cct, p)| Text::new(format!("{cct} K"), (p[0], p[1]), (FONT, 13).into_font())),
    )?;
    root.present()?;
    Ok(())
}

fn draw_shading(tuned: &Tuned, path: &Path) -> Drawn {
    let rows = tuned.shading_residual.len().max(1);
    let root = SVGBackend::new(path, (1200, 300 * rows as u32 + 60)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = root.titled(
        "Flat fields after the shading correction: residual per 32-pixel block (white 0, red +2 %, blue -2 %)",
        (FONT, 18),
    )?;
    let panels = body.split_evenly((rows, 3));
    for (k, res) in tuned.shading_residual.iter().enumerate() {
        for c in 0..3 {
            let panel = &panels[k * 3 + c];
            let bw = res.blocks_across.max(1);
            let bh = res.residual[c].len() / bw;
            let worst = res.residual[c]
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0f64, |a, &b| a.max(b.abs()));
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!(
                        "{} K, {}: largest {:.2} %",
                        res.cct,
                        ["red", "green", "blue"][c],
                        100.0 * worst
                    ),
                    (FONT, 13),
                )
                .margin(8)
                .build_cartesian_2d(0.0..bw as f64, 0.0..bh as f64)?;
            chart.draw_series(res.residual[c].iter().enumerate().map(|(i, &v)| {
                let (x, y) = ((i % bw) as f64, (bh - 1 - i / bw) as f64);
                let t = if v.is_finite() {
                    (v / 0.02).clamp(-1.0, 1.0)
                } else {
                    0.0
                };
                let colour = if t >= 0.0 {
                    RGBColor(255, (255.0 * (1.0 - t)) as u8, (255.0 * (1.0 - t)) as u8)
                } else {
                    RGBColor((255.0 * (1.0 + t)) as u8, (255.0 * (1.0 + t)) as u8, 255)
                };
                Rectangle::new([(x, y), (x + 1.0, y + 1.0)], colour.filled())
            }))?;
        }
    }
    root.present()?;
    Ok(())
}

fn draw_transfer(tuned: &Tuned, path: &Path) -> Drawn {
    let n = tuned.transfer.len().max(1);
    let root = SVGBackend::new(path, (560 * n as u32, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = root.titled(
        "Photon transfer: temporal variance against mean (EMVA 1288), points and fit",
        (FONT, 18),
    )?;
    let t = &tuned.tuning;
    let range = f64::from(t.white_level) - t.black_level.values[0];
    for (panel, (iso, points)) in body.split_evenly((1, n)).iter().zip(&tuned.transfer) {
        let max_mean = points
            .iter()
            .flatten()
            .map(|p| p.mean)
            .fold(1.0f64, f64::max);
        let max_var = points
            .iter()
            .flatten()
            .map(|p| p.variance)
            .fold(1.0f64, f64::max);
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("ISO {iso}"), (FONT, 15))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max_mean * 1.05, 0.0..max_var * 1.1)?;
        chart
            .configure_mesh()
            .x_desc("mean above black (DN)")
            .y_desc("variance (DN^2)")
            .label_style((FONT, 11))
            .draw()?;
        let entry = t.noise.iter().find(|e| e.iso == *iso);
        for c in 0..3 {
            let colour = PALETTE[c];
            chart
                .draw_series(
                    points[c]
                        .iter()
                        .map(|p| Circle::new((p.mean, p.variance), 4, colour.filled())),
                )?
                .label(["red", "green", "blue"][c])
                .legend(move |(x, y)| Circle::new((x + 7, y), 4, colour.filled()));
            if let Some(e) = entry {
                let (s, o) = (e.scale[c] * range, e.offset[c] * range * range);
                chart.draw_series(LineSeries::new(
                    [(0.0, o), (max_mean, o + s * max_mean)],
                    colour.mix(0.6),
                ))?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .label_font((FONT, 12))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
