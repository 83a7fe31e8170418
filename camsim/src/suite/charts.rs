//! The suites' SVG charts (plotters' SVG backend: text is SVG text in a generic font family,
//! so no font files are needed to draw or to view them).

use std::path::Path;

use plotters::prelude::*;

use super::{caption, DemosaicPoint, SuiteResults};
use crate::error::Error;

type Drawn = Result<(), Box<dyn std::error::Error>>;

/// Okabe and Ito's colour-blind-safe palette (Color Universal Design, 2002).
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

const FONT: &str = "sans-serif";

fn failed(path: &Path) -> impl Fn(Box<dyn std::error::Error>) -> Error + '_ {
    move |e| Error::Message(format!("drawing {}: {e}", path.display()))
}

/// The figure's area less a caption line at the bottom, with the title drawn.
fn figure<'a>(
    root: &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    title: &str,
    r: &SuiteResults,
) -> Result<DrawingArea<SVGBackend<'a>, plotters::coord::Shift>, Box<dyn std::error::Error>> {
    captioned(root, title, 22, &caption(r))
}

/// The figure's area filled white, less the `caption` line at the bottom, with the title drawn
/// at `title_size`.
pub(super) fn captioned<'a>(
    root: &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    title: &str,
    title_size: u32,
    caption: &str,
) -> Result<DrawingArea<SVGBackend<'a>, plotters::coord::Shift>, Box<dyn std::error::Error>> {
    root.fill(&WHITE)?;
    let (_, height) = root.dim_in_pixel();
    let (body, foot) = root.split_vertically(height - 28);
    foot.draw(&Text::new(
        caption.to_string(),
        (10, 6),
        (FONT, 13).into_font().color(&BLACK.mix(0.7)),
    ))?;
    Ok(body.titled(title, (FONT, title_size))?)
}

/// Chart 1: Mpix/s (log) against CPSNR, a panel per set and depth, every method of every
/// library, and the Pareto front (no other point is both faster and more accurate).
pub fn demosaic_pareto(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_pareto(r, path).map_err(failed(path))
}

fn draw_pareto(r: &SuiteResults, path: &Path) -> Drawn {
    let root = SVGBackend::new(path, (1400, 1050)).into_drawing_area();
    let body = figure(
        &root,
        "Demosaicing: speed against accuracy (one thread; up and right is better)",
        r,
    )?;
    let libraries = ["camsim", "OpenCV", "colour-demosaicing", "demosaicnet"];
    for (panel, (set, bits)) in body.split_evenly((2, 2)).iter().zip([
        ("kodak", 8),
        ("kodak", 16),
        ("mcmaster", 8),
        ("mcmaster", 16),
    ]) {
        let points: Vec<&DemosaicPoint> = r
            .demosaic
            .points
            .iter()
            .filter(|p| p.dataset == set && p.bits == bits && p.mpix_per_s > 0.0)
            .collect();
        if points.is_empty() {
            continue;
        }
        let (lo_db, hi_db) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
            (a.min(p.cpsnr_db), b.max(p.cpsnr_db))
        });
        let (lo_s, hi_s) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
            (a.min(p.mpix_per_s), b.max(p.mpix_per_s))
        });
        let name = if set == "kodak" { "Kodak" } else { "McMaster" };
        let images = points.iter().map(|p| p.images).max().unwrap_or(0);
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{name}, {bits}-bit ({images} images)"), (FONT, 17))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(62)
            .build_cartesian_2d(
                (lo_db - 1.0)..(hi_db + 2.5),
                (lo_s / 2.0..hi_s * 2.0).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("CPSNR (dB)")
            .y_desc("throughput (Mpix/s, log)")
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 12))
            .draw()?;
        // The Pareto front: sorted by accuracy, each point faster than every more accurate one.
        let mut sorted = points.clone();
        sorted.sort_by(|a, b| b.cpsnr_db.total_cmp(&a.cpsnr_db));
        let mut front = Vec::new();
        let mut fastest = 0.0;
        for p in sorted {
            if p.mpix_per_s > fastest {
                fastest = p.mpix_per_s;
                front.push((p.cpsnr_db, p.mpix_per_s));
            }
        }
        chart
            .draw_series(DashedLineSeries::new(
                front,
                6,
                4,
                BLACK.mix(0.5).stroke_width(1),
            ))?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.mix(0.5)));
        let offsets = label_offsets(&chart, &points);
        for (k, library) in libraries.iter().enumerate() {
            let colour = PALETTE[k];
            let mine: Vec<_> = points
                .iter()
                .zip(&offsets)
                .filter(|(p, _)| p.library == *library)
                .collect();
            if mine.is_empty() {
                continue;
            }
            chart
                .draw_series(mine.iter().map(|(p, offset)| {
                    EmptyElement::at((p.cpsnr_db, p.mpix_per_s))
                        + Circle::new((0, 0), 5, colour.filled())
                        + Text::new(
                            p.method.clone(),
                            **offset,
                            (FONT, 11).into_font().color(&colour),
                        )
                }))?
                .label(*library)
                .legend(move |(x, y)| Circle::new((x + 9, y), 5, colour.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::LowerLeft, 12)?;
    }
    root.present()?;
    Ok(())
}

/// Chart 3: the histogram of the 8-bit difference between the paths, per method, and each
/// path's whole-pipeline throughput.
pub fn fixed_vs_float(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_fixed_vs_float(r, path).map_err(failed(path))
}

fn draw_fixed_vs_float(r: &SuiteResults, path: &Path) -> Drawn {
    let root = SVGBackend::new(path, (1400, 620)).into_drawing_area();
    let body = figure(
        &root,
        "Fixed-point against float: the whole pipeline's 8-bit output, and its speed",
        r,
    )?;
    let (left, right) = body.split_horizontally(760);
    let f = &r.fixed_vs_float;
    let reach = f
        .agreement
        .iter()
        .map(|a| a.worst_lsb as i32)
        .max()
        .unwrap_or(1)
        .max(2);
    let floor = 1e-6;
    let mut chart = ChartBuilder::on(&left)
        .caption(
            format!("fixed - float over {} images as 12-bit raw", f.images),
            (FONT, 17),
        )
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (-reach as f64 - 0.6)..(reach as f64 + 0.6),
            (floor..200.0).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("difference (8-bit LSB)")
        .y_desc("share of output samples (%, log)")
        .y_label_formatter(&|v| tick(*v))
        .x_labels(2 * reach as usize + 1)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style((FONT, 12))
        .draw()?;
    let n = f.agreement.len().max(1) as f64;
    let width = 0.8 / n;
    for (k, a) in f.agreement.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let offset = -0.4 + width * k as f64;
        let total = a.samples.max(1) as f64;
        chart
            .draw_series(a.histogram.iter().map(|&(d, count)| {
                let share = 100.0 * count as f64 / total;
                let x = d as f64 + offset;
                Rectangle::new([(x, floor), (x + width, share.max(floor))], colour.filled())
            }))?
            .label(format!(
                "{}: {} of {} samples beyond 1 LSB, worst {}",
                a.method,
                a.histogram
                    .iter()
                    .filter(|(d, _)| d.abs() > 1)
                    .map(|(_, n)| n)
                    .sum::<u64>(),
                a.samples,
                a.worst_lsb
            ))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 12)?;

    let speeds: Vec<_> = f
        .speed
        .iter()
        .filter(|q| q.threads == 1 && q.sharpen == 0.0)
        .chain(&f.speed_opencv)
        .collect();
    let fastest = speeds.iter().map(|s| s.mpix_per_s).fold(1.0, f64::max);
    let rows = speeds.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&right)
        .caption("throughput, one thread", (FONT, 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(10)
        .build_cartesian_2d(0.0..fastest * 1.45, 0.0..rows)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc("Mpix/s")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 12))
        .draw()?;
    for (i, s) in speeds.iter().enumerate() {
        let colour = match s.path.as_str() {
            "fixed" => PALETTE[3],
            "float" => PALETTE[0],
            _ => RGBColor(90, 90, 90),
        };
        let y = rows - i as f64 - 1.0;
        chart.draw_series([Rectangle::new(
            [(0.0, y + 0.15), (s.mpix_per_s, y + 0.85)],
            colour.filled(),
        )])?;
        chart.draw_series([Text::new(
            format!("{} {}: {:.0}", s.path, s.method, s.mpix_per_s),
            (s.mpix_per_s + fastest * 0.02, y + 0.62),
            (FONT, 12),
        )])?;
    }
    let (_, h) = right.dim_in_pixel();
    right.draw(&Text::new(
        f.speed_frame.clone(),
        (16, h as i32 - 18),
        (FONT, 11).into_font().color(&BLACK.mix(0.7)),
    ))?;
    root.present()?;
    Ok(())
}

/// Chart 6: depth of field against subject distance, exact and approximated, and the
/// approximation's relative error against the distance over the hyperfocal distance.
pub fn depth_of_field(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_dof(r, path).map_err(failed(path))
}

fn draw_dof(r: &SuiteResults, path: &Path) -> Drawn {
    let root = SVGBackend::new(path, (1400, 620)).into_drawing_area();
    let body = figure(
        &root,
        &format!(
            "Depth of field: the approximation 2u²Nc/f² (dashed) against the exact limits (solid), c = {} mm",
            r.depth_of_field.coc_mm
        ),
        r,
    )?;
    let (left, right) = body.split_horizontally(700);
    let lenses = &r.depth_of_field.lenses;
    let (mut lo_s, mut hi_s, mut lo_d, mut hi_d) = (f64::MAX, 0.0f64, f64::MAX, 0.0f64);
    for l in lenses {
        for &(s, exact, approx) in &l.curve {
            lo_s = lo_s.min(s);
            hi_s = hi_s.max(s);
            for d in exact.into_iter().chain([approx]) {
                if d.is_finite() && d > 0.0 {
                    lo_d = lo_d.min(d);
                    hi_d = hi_d.max(d);
                }
            }
        }
    }
    let hi_d = hi_d.min(1e4);
    let mut chart = ChartBuilder::on(&left)
        .caption("total depth of field", (FONT, 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d((lo_s..hi_s).log_scale(), (lo_d..hi_d).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("subject distance (m, log)")
        .y_desc("depth of field (m, log)")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, 12))
        .draw()?;
    for (k, l) in lenses.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let exact: Vec<_> = l
            .curve
            .iter()
            .filter_map(|&(s, e, _)| e.filter(|e| *e <= hi_d).map(|e| (s, e)))
            .collect();
        chart
            .draw_series(LineSeries::new(exact, colour.stroke_width(2)))?
            .label(format!(
                "{} mm f/{}: hyperfocal {:.1} m",
                l.focal_length_mm, l.f_number, l.hyperfocal_m
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
        let approx: Vec<_> = l
            .curve
            .iter()
            .filter(|p| p.2 <= hi_d)
            .map(|&(s, _, a)| (s, a))
            .collect();
        chart.draw_series(DashedLineSeries::new(approx, 6, 4, colour.stroke_width(2)))?;
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 12)?;

    let mut chart = ChartBuilder::on(&right)
        .caption(
            "the approximation's error (colours as on the left)",
            (FONT, 17),
        )
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d((1e-4..1.0f64).log_scale(), -100.0..120.0f64)?;
    chart
        .configure_mesh()
        .x_desc("subject distance / hyperfocal distance (log)")
        .y_desc("(approximation - exact) / exact (%)")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 12))
        .draw()?;
    for bound in [-10.0, 10.0] {
        chart.draw_series(DashedLineSeries::new(
            [(1e-4, bound), (1.0, bound)],
            4,
            4,
            BLACK.mix(0.5).stroke_width(1),
        ))?;
    }
    chart.draw_series([Text::new(
        "within ±10 % between the dashed lines",
        (1.5e-4, 14.0),
        (FONT, 12),
    )])?;
    for (k, l) in lenses.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let error: Vec<_> = l
            .curve
            .iter()
            .filter_map(|&(s, e, a)| {
                let x = s / l.hyperfocal_m;
                e.filter(|_| (1e-4..1.0).contains(&x))
                    .map(|e| (x, (100.0 * (a - e) / e).clamp(-100.0, 120.0)))
            })
            .collect();
        chart.draw_series(LineSeries::new(error, colour.stroke_width(2)))?;
    }
    root.present()?;
    Ok(())
}

/// A tick label with as many decimals as its size needs (log axes span decades).
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || a >= 10.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.1}")
    } else {
        let decimals = (-a.log10()).ceil() as usize + 1;
        format!("{v:.decimals$}")
    }
}

/// Where each point's label goes, in pixels from the point: to its right, moved down or up a
/// line where it would overlap a label placed before it (points close in accuracy and speed,
/// like the bilinear variants, would otherwise print over each other).
fn label_offsets<DB: DrawingBackend>(
    chart: &ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, LogCoord<f64>>,
    >,
    points: &[&DemosaicPoint],
) -> Vec<(i32, i32)> {
    // The naive text metrics: about 6 pixels per character at 11 points, 12 per line.
    let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
    let mut offsets = Vec::new();
    for p in points {
        let (x, y) = chart.backend_coord(&(p.cpsnr_db, p.mpix_per_s));
        let width = 6 * p.method.chars().count() as i32;
        let mut chosen = (7, -5);
        for dy in [-5, 7, -17, 19, -29, 31] {
            let (left, top) = (x + 7, y + dy);
            let overlaps = placed
                .iter()
                .any(|&(l, t, r, b)| left < r && left + width > l && top < b && top + 12 > t);
            if !overlaps {
                chosen = (7, dy);
                break;
            }
        }
        placed.push((x + 7, y + chosen.1, x + 7 + width, y + chosen.1 + 12));
        offsets.push(chosen);
    }
    offsets
}

/// Chart 7: each AWB method's angular error under each illuminant, a panel per scene.
pub fn awb(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_awb(r, path).map_err(failed(path))
}

fn draw_awb(r: &SuiteResults, path: &Path) -> Drawn {
    let a = &r.awb;
    let root = SVGBackend::new(path, (1400, 620)).into_drawing_area();
    let body = figure(
        &root,
        &format!(
            "Auto white balance: angular error under six illuminants (simulated {}, {})",
            a.camera, a.render
        ),
        r,
    )?;
    let illuminants = distinct(a.points.iter().map(|p| p.illuminant.as_str()));
    let methods = distinct(a.points.iter().map(|p| p.method.as_str()));
    let worst = a.points.iter().map(|p| p.error_deg).fold(1.0, f64::max);
    let panels = body.split_evenly((1, a.scenes.len().max(1)));
    for (panel, (scene, _)) in panels.iter().zip(&a.scenes) {
        let label = category_labels(illuminants.clone());
        let mut chart = ChartBuilder::on(panel)
            .caption(scene.as_str(), (FONT, 17))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..(illuminants.len() as f64 - 0.5), 0.0..worst * 1.25)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(2 * illuminants.len() + 1)
            .x_label_formatter(&label)
            .x_desc("illuminant the scene is lit by")
            .y_desc("angular error (degrees)")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 12))
            .draw()?;
        let width = 0.8 / methods.len().max(1) as f64;
        for (k, method) in methods.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let bars: Vec<_> = a
                .points
                .iter()
                .filter(|p| &p.scene == scene && p.method == *method)
                .filter_map(|p| {
                    let i = illuminants.iter().position(|n| *n == p.illuminant)? as f64;
                    let x = i - 0.4 + width * k as f64;
                    Some(Rectangle::new(
                        [(x, 0.0), (x + width * 0.9, p.error_deg)],
                        colour.filled(),
                    ))
                })
                .collect();
            chart
                .draw_series(bars)?
                .label(*method)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.filled())
                });
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight, 12)?;
    }
    root.present()?;
    Ok(())
}

/// Chart 2: the whole pipeline's Mpix/s (log) against its output's PSNR for each path
/// (marker), method (colour) and denoise strength (label), with the copy's rate as a line and
/// the OpenCV pipeline as a point.
pub fn pipeline(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_pipeline(r, path).map_err(failed(path))
}

fn draw_pipeline(r: &SuiteResults, path: &Path) -> Drawn {
    let p = &r.pipeline;
    let root = SVGBackend::new(path, (1500, 760)).into_drawing_area();
    let body = figure(
        &root,
        "The whole ISP: speed against output quality (one thread; up and right is better)",
        r,
    )?;
    let (head, body) = body.split_vertically(22);
    head.draw(&Text::new(
        p.scene.clone(),
        (12, 2),
        (FONT, 13).into_font().color(&BLACK.mix(0.8)),
    ))?;
    let scenes = distinct(p.points.iter().map(|q| q.scene.as_str()));
    let methods = distinct(p.points.iter().map(|q| q.method.as_str()));
    // One speed axis for every panel, so they compare.
    let speeds = p
        .points
        .iter()
        .map(|q| q.mpix_per_s)
        .chain([p.copy.mpix_per_s])
        .chain(p.opencv.iter().map(|o| o.mpix_per_s));
    let (lo_s, hi_s) = speeds.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let panels = body.split_evenly((1, scenes.len().max(1)));
    for (panel, scene) in panels.iter().zip(&scenes) {
        let peers: Vec<_> = p
            .opencv
            .iter()
            .filter(|o| o.scene == *scene)
            .filter_map(|o| o.psnr_db.map(|d| (o, d)))
            .collect();
        let (mut lo_db, mut hi_db) = (f64::MAX, f64::MIN);
        for d in p
            .points
            .iter()
            .filter(|q| q.scene == *scene)
            .map(|q| q.psnr_db)
            .chain(peers.iter().map(|x| x.1))
        {
            lo_db = lo_db.min(d);
            hi_db = hi_db.max(d);
        }
        let (x0, x1) = (lo_db - 0.5, hi_db + 0.8);
        let mut chart = ChartBuilder::on(panel)
            .caption(*scene, (FONT, 16))
            .margin(14)
            .x_label_area_size(42)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, (lo_s / 1.6..hi_s * 1.6).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("PSNR of the 8-bit output against the truth (dB)")
            .y_desc("throughput (Mpix/s, log)")
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 12))
            .draw()?;
        chart
            .draw_series(DashedLineSeries::new(
                [(x0, p.copy.mpix_per_s), (x1, p.copy.mpix_per_s)],
                6,
                4,
                BLACK.mix(0.6).stroke_width(1),
            ))?
            .label(format!("{} ({:.0} Mpix/s)", p.copy.what, p.copy.mpix_per_s))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.mix(0.6)));
        for (k, method) in methods.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            for fixed in [false, true] {
                let mine = p.points.iter().filter(|q| {
                    q.scene == *scene && q.method == *method && (q.path == "fixed") == fixed
                });
                let series = chart.draw_series(mine.map(|q| {
                    let at = EmptyElement::at((q.psnr_db, q.mpix_per_s));
                    let label = Text::new(
                        format!("dn {}", q.denoise),
                        (8, if fixed { 2 } else { -12 }),
                        (FONT, 10).into_font().color(&colour),
                    );
                    if fixed {
                        at + TriangleMarker::new((0, 0), 7, colour.filled()).into_dyn() + label
                    } else {
                        at + Circle::new((0, 0), 5, colour.filled()).into_dyn() + label
                    }
                }))?;
                let name = format!("{method}, {} path", if fixed { "fixed" } else { "float" });
                if fixed {
                    series
                        .label(name)
                        .legend(move |(x, y)| TriangleMarker::new((x + 9, y), 7, colour.filled()));
                } else {
                    series
                        .label(name)
                        .legend(move |(x, y)| Circle::new((x + 9, y), 5, colour.filled()));
                }
            }
        }
        let grey = RGBColor(90, 90, 90);
        for (peer, db) in &peers {
            chart
                .draw_series([EmptyElement::at((*db, peer.mpix_per_s))
                    + Cross::new((0, 0), 7, grey.stroke_width(2))
                    + Text::new("OpenCV", (9, -12), (FONT, 11).into_font().color(&grey))])?
                .label("OpenCV's pipeline (bilinear; no defects, shading or denoise)")
                .legend(move |(x, y)| Cross::new((x + 9, y), 6, grey.stroke_width(2)));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft, 11)?;
    }
    root.present()?;
    Ok(())
}

/// Chart 8: colour calibration error. Top: each camera's mean CIE 2000 error per illuminant
/// for the 3x3 and root-polynomial fits, in-sample and held out; bottom: each camera's error
/// per patch under D65.
pub fn calibration(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_calibration(r, path).map_err(failed(path))
}

fn draw_calibration(r: &SuiteResults, path: &Path) -> Drawn {
    let c = &r.calibration;
    let root = SVGBackend::new(path, (1500, 900)).into_drawing_area();
    let body = figure(
        &root,
        "Colour calibration: CIE 2000 error of the fitted camera-to-XYZ mapping (lower is better)",
        r,
    )?;
    let cameras = distinct(c.fits.iter().map(|f| f.camera.as_str()));
    let illuminants = distinct(c.fits.iter().map(|f| f.illuminant.as_str()));
    type Errors = fn(&super::CalibrationFit) -> &[f64];
    let variants: [(&str, Errors); 4] = [
        ("3x3, in-sample", |f| &f.matrix),
        ("3x3, held out", |f| &f.matrix_held_out),
        ("root-polynomial, in-sample", |f| &f.root_polynomial),
        ("root-polynomial, held out", |f| &f.root_polynomial_held_out),
    ];
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let top_max = c
        .fits
        .iter()
        .flat_map(|f| variants.iter().map(move |(_, get)| mean(get(f))))
        .fold(0.5, f64::max);
    let (top, bottom) = body.split_vertically(430);
    let label = category_labels(illuminants.clone());
    for (panel, camera) in top
        .split_evenly((1, cameras.len().max(1)))
        .iter()
        .zip(&cameras)
    {
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{camera}: mean over the 24 patches"), (FONT, 15))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.5..(illuminants.len() as f64 - 0.5), 0.0..top_max * 1.3)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(2 * illuminants.len() + 1)
            .x_label_formatter(&label)
            .x_desc("illuminant")
            .y_desc("mean CIE 2000 error")
            .y_label_formatter(&|v| format!("{v:.1}"))
            .label_style((FONT, 11))
            .draw()?;
        let width = 0.8 / variants.len() as f64;
        for (k, (name, get)) in variants.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let bars: Vec<_> = c
                .fits
                .iter()
                .filter(|f| f.camera == *camera)
                .filter_map(|f| {
                    let i = illuminants.iter().position(|n| *n == f.illuminant)? as f64;
                    let x = i - 0.4 + width * k as f64;
                    Some(Rectangle::new(
                        [(x, 0.0), (x + width * 0.9, mean(get(f)))],
                        colour.filled(),
                    ))
                })
                .collect();
            chart.draw_series(bars)?.label(*name).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.filled())
            });
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft, 11)?;
    }
    let patch_max = c
        .fits
        .iter()
        .filter(|f| f.illuminant == "D65")
        .flat_map(|f| {
            variants
                .iter()
                .flat_map(move |(_, get)| get(f).iter().copied())
        })
        .fold(0.5, f64::max);
    for (panel, camera) in bottom
        .split_evenly((1, cameras.len().max(1)))
        .iter()
        .zip(&cameras)
    {
        let Some(fit) = c
            .fits
            .iter()
            .find(|f| f.camera == *camera && f.illuminant == "D65")
        else {
            continue;
        };
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{camera} under D65: each patch"), (FONT, 15))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(0.5..(c.patches.len() as f64 + 0.5), 0.0..patch_max * 1.1)?;
        chart
            .configure_mesh()
            .x_labels(12)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .x_desc("ColorChecker patch (1 dark skin ... 19-24 neutrals)")
            .y_desc("CIE 2000 error")
            .y_label_formatter(&|v| format!("{v:.1}"))
            .label_style((FONT, 11))
            .draw()?;
        for (k, (_, get)) in variants.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let points: Vec<_> = get(fit)
                .iter()
                .enumerate()
                .map(|(i, e)| (i as f64 + 1.0, *e))
                .collect();
            chart.draw_series(LineSeries::new(points.clone(), colour.stroke_width(1)))?;
            chart.draw_series(
                points
                    .into_iter()
                    .map(|p| Circle::new(p, 3, colour.filled())),
            )?;
        }
    }
    root.present()?;
    Ok(())
}

/// Chart 5: where each demosaicing method fails (CPSNR and false colour against the zone
/// plate's frequency) and how output noise grows with ISO, with and without noise reduction.
pub fn failures(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_failures(r, path).map_err(failed(path))
}

fn draw_failures(r: &SuiteResults, path: &Path) -> Drawn {
    let f = &r.failures;
    let root = SVGBackend::new(path, (1500, 620)).into_drawing_area();
    let body = figure(
        &root,
        "Where methods fail: fine detail (zone plate) and noise (ISO)",
        r,
    )?;
    let panels = body.split_evenly((1, 3));
    let methods = distinct(f.zone_plate_bands.iter().map(|b| b.method.as_str()));
    let colour_of =
        |m: &str| PALETTE[methods.iter().position(|x| *x == m).unwrap_or(0) % PALETTE.len()];
    type Measure = fn(&super::ZonePlateBand) -> f64;
    let measures: [(&str, &str, Measure); 2] = [
        ("CPSNR against frequency", "CPSNR (dB)", |b| b.cpsnr_db),
        (
            "false colour on the grey pattern",
            "mean channel spread (8-bit steps)",
            |b| b.false_colour,
        ),
    ];
    for (panel, (title, axis, get)) in panels.iter().zip(measures) {
        let (lo, hi) = f
            .zone_plate_bands
            .iter()
            .map(get)
            .filter(|v| v.is_finite())
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let lo = if axis.starts_with("CPSNR") {
            lo - 2.0
        } else {
            0.0
        };
        let mut chart = ChartBuilder::on(panel)
            .caption(title, (FONT, 16))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..0.5, lo..hi * 1.08 + 0.5)?;
        chart
            .configure_mesh()
            .x_desc("spatial frequency (cycles per pixel; 0.5 is Nyquist)")
            .y_desc(axis)
            .x_label_formatter(&|v| format!("{v:.2}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style((FONT, 11))
            .draw()?;
        for m in &methods {
            let colour = colour_of(m);
            let line: Vec<_> = f
                .zone_plate_bands
                .iter()
                .filter(|b| b.method == *m)
                .map(|b| (b.cycles_per_pixel, get(b)))
                .filter(|p| p.1.is_finite())
                .collect();
            chart
                .draw_series(LineSeries::new(line, colour.stroke_width(2)))?
                .label(*m)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2))
                });
        }
        let corner = if axis.starts_with("CPSNR") {
            SeriesLabelPosition::UpperRight
        } else {
            SeriesLabelPosition::UpperLeft
        };
        legend(&mut chart, corner, 11)?;
    }
    let worst = f.noise.iter().map(|q| q.noise_lsb).fold(0.5, f64::max);
    // ISO on a log axis in stops above 100 (plotters' log axis crowds its ticks).
    let stops = |iso: f64| (iso / 100.0).log2();
    let top = f.noise.iter().map(|q| stops(q.iso)).fold(1.0, f64::max);
    let mut chart = ChartBuilder::on(&panels[2])
        .caption(
            "output noise against ISO (solid: no NR, dashed: NR from the profile)",
            (FONT, 16),
        )
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(56)
        .build_cartesian_2d(-0.3..top + 0.3, 0.0..worst * 1.15)?;
    chart
        .configure_mesh()
        .x_desc("ISO (log)")
        .y_desc("noise, standard deviation (8-bit steps)")
        .x_labels(2 * top as usize + 3)
        .x_label_formatter(&|v| {
            if (v - v.round()).abs() < 1e-6 {
                format!("{:.0}", 100.0 * 2f64.powf(v.round()))
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.1}"))
        .label_style((FONT, 11))
        .draw()?;
    let mut noisy: Vec<(&str, f32)> = Vec::new();
    for q in &f.noise {
        if !noisy.contains(&(q.method.as_str(), q.denoise)) {
            noisy.push((&q.method, q.denoise));
        }
    }
    for (m, denoise) in noisy {
        let colour = colour_of(m);
        let line: Vec<_> = f
            .noise
            .iter()
            .filter(|q| q.method == m && q.denoise == denoise)
            .map(|q| (stops(q.iso), q.noise_lsb))
            .collect();
        if denoise > 0.0 {
            chart.draw_series(DashedLineSeries::new(line, 6, 4, colour.stroke_width(2)))?;
        } else {
            chart
                .draw_series(LineSeries::new(line, colour.stroke_width(2)))?
                .label(m)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2))
                });
        }
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft, 11)?;
    root.present()?;
    Ok(())
}

/// Chart 4: RMSE against wall time for camsim and Mitsuba 3, pinhole and thin lens (log
/// axes), and each camera feature's time per sample over the pinhole's.
pub fn render(r: &SuiteResults, path: &Path) -> Result<(), Error> {
    draw_render(r, path).map_err(failed(path))
}

fn draw_render(r: &SuiteResults, path: &Path) -> Drawn {
    let rs = &r.render;
    let root = SVGBackend::new(path, (1500, 640)).into_drawing_area();
    let body = figure(
        &root,
        "Rendering: error against time on the Cornell box (one thread; down and left is better), and each feature's cost",
        r,
    )?;
    let (left, right) = body.split_horizontally(860);
    let points = || {
        rs.convergence
            .iter()
            .filter(|q| q.seconds > 0.0 && q.rmse > 0.0)
    };
    let (lo_t, hi_t) = points().fold((f64::MAX, f64::MIN), |(a, b), q| {
        (a.min(q.seconds), b.max(q.seconds))
    });
    let (lo_e, hi_e) = points().fold((f64::MAX, f64::MIN), |(a, b), q| {
        (a.min(q.rmse), b.max(q.rmse))
    });
    if lo_t < hi_t && lo_e < hi_e {
        let mut chart = ChartBuilder::on(&left)
            .caption(
                "RMSE against wall time (labels: samples per pixel)",
                (FONT, 16),
            )
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (lo_t / 1.5..hi_t * 1.5).log_scale(),
                (lo_e / 1.3..hi_e * 1.3).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("render time, one thread (s, log)")
            .y_desc("RMSE against the reference (linear RGB, log)")
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 11))
            .draw()?;
        let mut k = 0;
        for renderer in ["camsim", "Mitsuba 3"] {
            for camera in ["pinhole", "thin lens"] {
                let line: Vec<_> = points()
                    .filter(|q| q.renderer == renderer && q.camera == camera)
                    .collect();
                let colour = PALETTE[k % PALETTE.len()];
                k += 1;
                if line.is_empty() {
                    continue;
                }
                let xy: Vec<_> = line.iter().map(|q| (q.seconds, q.rmse)).collect();
                let style = colour.stroke_width(2);
                if camera == "pinhole" {
                    chart
                        .draw_series(LineSeries::new(xy, style))?
                        .label(format!("{renderer}, {camera}"))
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
                } else {
                    chart
                        .draw_series(DashedLineSeries::new(xy, 6, 4, style))?
                        .label(format!("{renderer}, {camera} (dashed)"))
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
                }
                chart.draw_series(line.iter().map(|q| {
                    EmptyElement::at((q.seconds, q.rmse))
                        + Circle::new((0, 0), 3, colour.filled())
                        + Text::new(
                            q.spp.to_string(),
                            (4, 2),
                            (FONT, 10).into_font().color(&colour),
                        )
                }))?;
            }
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight, 12)?;
    }
    let slowest = rs
        .features
        .iter()
        .map(|f| f.relative_time)
        .fold(1.0, f64::max);
    let rows = rs.features.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&right)
        .caption(
            "each feature alone: time per sample over the pinhole's",
            (FONT, 16),
        )
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(10)
        .build_cartesian_2d(0.0..slowest * 1.6, 0.0..rows)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc("time per sample (pinhole = 1)")
        .x_label_formatter(&|v| format!("{v:.1}"))
        .label_style((FONT, 11))
        .draw()?;
    for (i, f) in rs.features.iter().enumerate() {
        let y = rows - i as f64 - 1.0;
        chart.draw_series([Rectangle::new(
            [(0.0, y + 0.15), (f.relative_time, y + 0.85)],
            PALETTE[5].filled(),
        )])?;
        chart.draw_series([Text::new(
            format!("{}: {:.2}x", f.variant, f.relative_time),
            (f.relative_time + slowest * 0.02, y + 0.62),
            (FONT, 11),
        )])?;
    }
    root.present()?;
    Ok(())
}

/// The legend every chart draws: framed, on a pale background, at `corner`.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    corner: SeriesLabelPosition,
    size: u32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(corner)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT, size))
        .draw()
}

/// The distinct values of `items`, in the order they first appear.
fn distinct<'a>(items: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut seen: Vec<&str> = Vec::new();
    for item in items {
        if !seen.contains(&item) {
            seen.push(item);
        }
    }
    seen
}

/// Tick labels for categories placed at 0, 1, 2, ... on a numeric axis: the name at each
/// whole number, nothing between.
fn category_labels(names: Vec<&str>) -> impl Fn(&f64) -> String + '_ {
    move |x: &f64| {
        let i = x.round();
        if (x - i).abs() < 1e-6 && i >= 0.0 {
            names
                .get(i as usize)
                .map_or(String::new(), |n| n.to_string())
        } else {
            String::new()
        }
    }
}

/// Chart 9: mean PSNR against the noise level for each noise reducer and the noisy
/// development, and the mean of the two noisier levels against Mpix/s (log).
pub fn denoise(d: &super::DenoiseSuite, caption: &str, path: &Path) -> Result<(), Error> {
    draw_denoise(d, caption, path).map_err(failed(path))
}

fn draw_denoise(d: &super::DenoiseSuite, caption: &str, path: &Path) -> Drawn {
    use super::denoise::SCALES;
    let root = SVGBackend::new(path, (1300, 560)).into_drawing_area();
    let body = captioned(
        &root,
        "Noise reduction on noisy 12-bit raws (Kodak, McMaster)",
        22,
        caption,
    )?;
    let panels = body.split_evenly((1, 2));
    let summary = d.summary();
    let (lo, hi) = summary
        .iter()
        .flat_map(|m| m.psnr_db)
        .filter(|v| v.is_finite())
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let x_of = |s: f64| s.log2();
    let mut chart = ChartBuilder::on(&panels[0])
        .caption("mean PSNR against noise level", (FONT, 16))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(56)
        .build_cartesian_2d(
            x_of(SCALES[0]) - 0.3..x_of(SCALES[2]) + 0.3,
            lo - 1.0..hi + 1.0,
        )?;
    chart
        .configure_mesh()
        .x_desc("noise scale S (log; variance S x + O)")
        .y_desc("PSNR (dB)")
        .x_labels(9)
        .x_label_formatter(&|v| {
            SCALES
                .iter()
                .find(|s| (s.log2() - v).abs() < 0.2)
                .map_or(String::new(), |s| format!("{s}"))
        })
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 11))
        .draw()?;
    for (i, m) in summary.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let line: Vec<_> = SCALES
            .iter()
            .zip(m.psnr_db)
            .filter(|p| p.1.is_finite())
            .map(|(s, p)| (x_of(*s), p))
            .collect();
        chart
            .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))?
            .label(m.method.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
        chart.draw_series(line.into_iter().map(|p| Circle::new(p, 3, colour.filled())))?;
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight, 11)?;
    let rated: Vec<_> = summary
        .iter()
        .enumerate()
        .filter(|(_, m)| m.mpix_per_s.is_finite() && m.noisier_mean().is_finite())
        .collect();
    let (slow, fast) = rated
        .iter()
        .map(|(_, m)| m.mpix_per_s.log10())
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let (worst, best) = rated
        .iter()
        .map(|(_, m)| m.noisier_mean())
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let mut chart = ChartBuilder::on(&panels[1])
        .caption(
            "mean PSNR of the two noisier levels against speed",
            (FONT, 16),
        )
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(56)
        .build_cartesian_2d(slow - 0.5..fast + 0.5, worst - 1.0..best + 1.0)?;
    chart
        .configure_mesh()
        .x_desc("Mpix/s, one thread (log)")
        .y_desc("PSNR (dB)")
        .x_label_formatter(&|v| tick(10f64.powf(*v)))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .label_style((FONT, 11))
        .draw()?;
    for (i, m) in rated {
        let colour = PALETTE[i % PALETTE.len()];
        let at = (m.mpix_per_s.log10(), m.noisier_mean());
        chart.draw_series([Circle::new(at, 5, colour.filled())])?;
        chart.draw_series([Text::new(
            m.method.clone(),
            (at.0, at.1),
            (FONT, 11).into_font().color(&colour),
        )])?;
    }
    root.present()?;
    Ok(())
}

/// `camsim lens --plot`: a lens's curves, a panel each (distortion, lateral colour, relative
/// illumination and RMS spot against the field; chromatic focal shift against the
/// wavelength), captioned with the lens and the command.
pub fn lens_curves(
    report: &crate::lens::LensReport,
    caption: &str,
    path: &Path,
) -> Result<(), Error> {
    draw_lens_curves(report, caption, path).map_err(failed(path))
}

/// One panel of the lens chart: title, x label, y label, points (fields where the ray was lost
/// left out).
type Panel<'a> = (&'a str, &'a str, &'a str, Vec<(f64, f64)>);

fn draw_lens_curves(report: &crate::lens::LensReport, caption: &str, path: &Path) -> Drawn {
    let root = SVGBackend::new(path, (1500, 860)).into_drawing_area();
    let body = captioned(
        &root,
        &format!(
            "{}: EFL {:.2} mm, f/{:.2}, at {} nm",
            report.name, report.efl_mm, report.f_number, report.wavelength_nm
        ),
        22,
        caption,
    )?;
    let panels = body.split_evenly((2, 3));
    let mut series: Vec<Panel> = Vec::new();
    if let Some(c) = &report.curves {
        let pick = |v: &[Option<f64>]| -> Vec<(f64, f64)> {
            c.field_deg
                .iter()
                .zip(v)
                .filter_map(|(&f, v)| v.map(|v| (f, v)))
                .collect()
        };
        series.push((
            "distortion",
            "field (degrees)",
            "distortion (%)",
            pick(&c.distortion_percent),
        ));
        series.push((
            "lateral colour, F - C",
            "field (degrees)",
            "micrometres",
            pick(&c.lateral_colour_um),
        ));
        series.push((
            "relative illumination",
            "field (degrees)",
            "against the axis",
            pick(&c.relative_illumination),
        ));
        series.push((
            "RMS spot radius (paraxial focus)",
            "field (degrees)",
            "micrometres",
            pick(&c.rms_spot_um),
        ));
    }
    series.push((
        "chromatic focal shift against the d line",
        "wavelength (nm)",
        "micrometres",
        report.chromatic_focal_shift.clone(),
    ));
    for (k, (title, x_desc, y_desc, points)) in series.into_iter().enumerate() {
        let Some(panel) = panels.get(k) else { break };
        if points.is_empty() {
            continue;
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in &points {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        let pad = ((y1 - y0) * 0.08).max(1e-6 * y1.abs().max(1.0));
        let (x1, y0, y1) = (x1.max(x0 + 1e-9), y0 - pad, y1 + pad);
        let mut chart = ChartBuilder::on(panel)
            .caption(title, (FONT, 16))
            .margin(12)
            .x_label_area_size(38)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| format!("{v:.3}"))
            .label_style((FONT, 12))
            .draw()?;
        let colour = PALETTE[k % PALETTE.len()];
        chart.draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?;
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
    }
    root.present()?;
    Ok(())
}
