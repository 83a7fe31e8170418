//! The suites' results as Markdown: `summary.md` (every figure in tables beside the charts)
//! and the README's generated blocks.

use super::*;

/// The README's generated blocks: name and Markdown. A README holds each between
/// `<!-- camsim bench: NAME -->` and `<!-- end camsim bench -->`; [`update_readme`] fills them.
pub fn readme_blocks(r: &SuiteResults) -> Vec<(&'static str, String)> {
    let provenance = format!(
        "Measured by `{}` on {}, {}{}; every figure is in [docs/bench/bench.json](docs/bench/bench.json) \
         and [docs/bench/summary.md](docs/bench/summary.md).",
        r.command,
        r.machine.describe(),
        r.date,
        if r.quick { " (a quick smoke run)" } else { "" }
    );
    let point = |set: &str, library: &str, method: &str| {
        r.demosaic.points.iter().find(|p| {
            p.dataset == set && p.bits == 16 && p.library == library && p.method == method
        })
    };
    let opencv = point("kodak", "OpenCV", "bilinear").map(|p| p.mpix_per_s);
    let mut demosaic = format!(
        "| library | method | Kodak dB | McMaster dB | Mpix/s | against OpenCV bilinear{} |\n|---|---|---|---|---|---|\n",
        opencv.map_or(String::new(), |s| format!(" ({s:.0} Mpix/s)"))
    );
    let mut seen: Vec<(&str, &str)> = Vec::new();
    for p in r.demosaic.points.iter().filter(|p| p.bits == 16) {
        if seen.contains(&(p.library.as_str(), p.method.as_str())) {
            continue;
        }
        seen.push((&p.library, &p.method));
        let kodak = point("kodak", &p.library, &p.method);
        let mcmaster = point("mcmaster", &p.library, &p.method);
        let db =
            |q: Option<&DemosaicPoint>| q.map_or("–".into(), |q| format!("{:.2}", q.cpsnr_db));
        let speed = kodak.map(|q| q.mpix_per_s);
        demosaic += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            p.library,
            p.method,
            db(kodak),
            db(mcmaster),
            speed.map_or("–".into(), |s| format!("{s:.1}")),
            match (speed, opencv) {
                (Some(s), Some(o)) => format!("{:.2}x", s / o),
                _ => "–".into(),
            }
        );
    }
    demosaic += &format!(
        "\n16-bit mosaics; CPSNR over the image less 10 pixels, averaged over the set; Mpix/s on one \
         thread on a {0} x {0} mosaic tiled from the first Kodak image. {provenance}\n",
        r.demosaic.tile
    );
    let p = &r.pipeline;
    let mut pipeline =
        "| scene | path | method | denoise | PSNR dB | Mpix/s |\n|---|---|---|---|---|---|\n"
            .to_string();
    for q in &p.points {
        pipeline += &format!(
            "| {} | {} | {} | {} | {:.2} | {:.1} |\n",
            q.scene, q.path, q.method, q.denoise, q.psnr_db, q.mpix_per_s
        );
    }
    for o in &p.opencv {
        pipeline += &format!(
            "| {} | OpenCV | bilinear (no defects, shading or denoise) | – | {} | {:.1} |\n",
            o.scene,
            o.psnr_db.map_or("–".into(), |v| format!("{v:.2}")),
            o.mpix_per_s
        );
    }
    pipeline += &format!("\n{}; {}. {provenance}\n", p.scene, p.stages);
    let f = &r.fixed_vs_float;
    let speed = format!(
        "{}\nOn the {}. OpenCV's pipeline (`cv2.subtract`, Bayer `cvtColor` at 16 bits, \
         `cv2.multiply`, `cv2.transform`, `cv2.convertScaleAbs`, `cv2.LUT`; with sharpening an \
         unsharp mask on YCrCb luma) has no defect correction. {provenance}\n",
        speed_table(f),
        f.speed_frame
    );
    let rs = &r.render;
    let mut features =
        "| variant | Msamples/s | time x | what it adds per sample |\n|---|---|---|---|\n"
            .to_string();
    for q in &rs.features {
        features += &format!(
            "| {} | {:.2} | {:.2} | {} |\n",
            q.variant, q.msamples_per_s, q.relative_time, q.what
        );
    }
    features += &format!("\n{}. {provenance}\n", rs.feature_setup);
    let mut convergence =
        "| renderer | camera | spp | seconds (one thread) | RMSE |\n|---|---|---|---|---|\n"
            .to_string();
    for q in &rs.convergence {
        convergence += &format!(
            "| {} | {} | {} | {:.3} | {:.4} |\n",
            q.renderer, q.camera, q.spp, q.seconds, q.rmse
        );
    }
    convergence += &format!("\n{}. {provenance}\n", rs.convergence_setup);
    vec![
        ("provenance", provenance + "\n"),
        ("demosaic", demosaic),
        ("pipeline", pipeline),
        ("isp-speed", speed),
        ("features", features),
        ("convergence", convergence),
    ]
}

/// `readme` with each generated block (see [`readme_blocks`]) replaced by this run's; an
/// error names a block whose end marker is missing.
pub fn update_readme(readme: &str, r: &SuiteResults) -> Result<String, Error> {
    const END: &str = "<!-- end camsim bench -->";
    let mut text = readme.to_string();
    for (name, block) in readme_blocks(r) {
        let start = format!("<!-- camsim bench: {name} -->");
        let mut from = 0;
        while let Some(at) = text[from..].find(&start) {
            let body = from + at + start.len();
            let Some(end) = text[body..].find(END) else {
                return Err(Error::Message(format!(
                    "the README's block {start} has no {END} after it"
                )));
            };
            text.replace_range(body..body + end, &format!("\n{block}"));
            from = body + block.len() + 1 + END.len();
        }
    }
    Ok(text)
}

/// The pipeline speeds as a Markdown table, each beside OpenCV's time in the same run.
fn speed_table(f: &FixedFloatSuite) -> String {
    let mut t = "| path | demosaic | threads | sharpen | ms per frame | Mpix/s | OpenCV, same run | time against OpenCV's |\n|---|---|---|---|---|---|---|---|\n".to_string();
    for q in &f.speed {
        t += &format!(
            "| {} | {} | {} | {} | {:.1} | {:.1} | {} | {} |\n",
            q.path,
            q.method,
            q.threads,
            q.sharpen,
            q.ms_per_frame,
            q.mpix_per_s,
            q.opencv_ms.map_or("–".into(), |o| format!("{o:.1} ms")),
            q.opencv_ms
                .map_or("–".into(), |o| format!("{:.2}x", q.ms_per_frame / o))
        );
    }
    t
}

/// `summary.md`: the charts and every figure in tables.
pub fn summary(r: &SuiteResults) -> String {
    let mut md = format!(
        "# camsim bench\n\n`{}` on {}, {}, in {:.0} s{}. Every figure is in `bench.json`; \
         single thread throughout.\n\n",
        r.command,
        r.machine.describe(),
        r.date,
        r.seconds,
        if r.quick {
            " (a `--quick` smoke run: two images per set, 512-pixel tiles; its speeds are not \
             comparable)"
        } else {
            ""
        }
    );
    if let Some(why) = &r.peers_skipped {
        md += &format!("**The peers were skipped:** {why}.\n\n");
    }
    md += "## Demosaicing: speed against accuracy\n\n![Demosaic Pareto front](demosaic_pareto.svg)\n\n";
    md += &format!(
        "Mpix/s on a {0} x {0} mosaic tiled from the set's first image; CPSNR over the image less a \
         10-pixel border, averaged over the set.",
        r.demosaic.tile
    );
    if let Some(v) = &r.demosaic.peer_versions {
        md += &format!(" Peers: {v}.");
    }
    match (&r.demosaic.learned_versions, &r.demosaic.learned_skipped) {
        (Some(v), _) => {
            md += &format!(" The learned peer, demosaicnet (Gharbi et al. 2016) on one CPU thread, timed on a {LEARNED_TILE} x {LEARNED_TILE} tile: {v}.")
        }
        (None, Some(why)) => md += &format!(" The learned peer did not run: {why}."),
        (None, None) => {}
    }
    md += "\n\n| set | bits | library | method | CPSNR dB | Mpix/s |\n|---|---|---|---|---|---|\n";
    let mut points = r.demosaic.points.clone();
    points.sort_by(|a, b| {
        (&a.dataset, a.bits)
            .cmp(&(&b.dataset, b.bits))
            .then(b.cpsnr_db.total_cmp(&a.cpsnr_db))
    });
    for p in &points {
        md += &format!(
            "| {} | {} | {} | {} | {:.2} | {:.1} |\n",
            p.dataset, p.bits, p.library, p.method, p.cpsnr_db, p.mpix_per_s
        );
    }
    let p = &r.pipeline;
    md += &format!(
        "\n## The whole ISP: speed against output quality\n\n![ISP configurations](pipeline.svg)\n\n\
         {} ({}), PSNR of the 8-bit output against the truth.\n\n\
         | scene | path | method | denoise | PSNR dB | ms per frame | Mpix/s |\n|---|---|---|---|---|---|---|\n",
        p.scene, p.stages
    );
    for q in &p.points {
        md += &format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.1} |\n",
            q.scene, q.path, q.method, q.denoise, q.psnr_db, q.ms_per_frame, q.mpix_per_s
        );
    }
    for peer in std::iter::once(&p.copy).chain(&p.opencv) {
        md += &format!(
            "| {} | {} | | | {} | {:.2} | {:.1} |\n",
            peer.scene,
            peer.what,
            peer.psnr_db.map_or("–".into(), |v| format!("{v:.2}")),
            peer.ms_per_frame,
            peer.mpix_per_s
        );
    }
    if !r.denoise.points.is_empty() {
        md += "\n## Noise reduction against its peers\n\n![Noise reduction](denoise.svg)\n\n";
        md += &denoise_table(&r.denoise);
    }
    if !r.tune.cameras.is_empty() {
        md += "\n## Camera tuning against its peers\n\n![Tuning](tune.svg)\n\n![CIEDE2000 per patch](tune_ccm.svg)\n\n";
        md += &r.tune.table();
    }
    let f = &r.fixed_vs_float;
    md += &format!(
        "\n## Fixed-point against float\n\n![Fixed against float](fixed_vs_float.svg)\n\n\
         The whole pipeline ({}) on {} images (Kodak and McMaster as 12-bit RGGB raw), 8-bit \
         output.\n\n| method | samples | within 1 LSB | beyond 1 LSB | worst |\n|---|---|---|---|---|\n",
        f.stages, f.images
    );
    for a in &f.agreement {
        let beyond: u64 = a
            .histogram
            .iter()
            .filter(|(d, _)| d.abs() > 1)
            .map(|(_, n)| n)
            .sum();
        md += &format!(
            "| {} | {} | {:.4} % | {} | {} LSB |\n",
            a.method,
            a.samples,
            100.0 * a.within_one_lsb,
            beyond,
            a.worst_lsb
        );
    }
    md += &format!("\nThroughput on the {}:\n\n", f.speed_frame);
    md += &speed_table(f);
    let a = &r.awb;
    md += &format!(
        "\n## Auto white balance under six illuminants\n\n![AWB error](awb.svg)\n\n\
         Angular error of each AWB method's neutral against the illuminant's, in camera RGB \
         (simulated {}, {}); the scene is relit for each illuminant \
         (`camsim demo --illuminant`).\n\n",
        a.camera, a.render
    );
    for (name, description) in &a.scenes {
        md += &format!("- **{name}**: {description}.\n");
    }
    for (name, _) in &a.scenes {
        md += &format!("\n{name}, degrees (estimated CCT):\n\n| illuminant |");
        for m in AWB_METHODS {
            md += &format!(" {m} |");
        }
        md += "\n|---|";
        md += &"---|".repeat(AWB_METHODS.len());
        md += "\n";
        for illuminant in ILLUMINANTS {
            md += &format!("| {illuminant} |");
            for m in AWB_METHODS {
                match a
                    .points
                    .iter()
                    .find(|p| p.scene == *name && p.illuminant == illuminant && p.method == m)
                {
                    Some(p) => md += &format!(" {:.2} ({:.0} K) |", p.error_deg, p.cct_k),
                    None => md += " – |",
                }
            }
            md += "\n";
        }
    }
    md += "\n## Colour calibration: CIE 2000 error per ColorChecker patch\n\n\
           ![Colour calibration](calibration.svg)\n\n\
           The chart rendered under each illuminant and captured by each camera (sensor noise off); \
           fits to all 24 patches (in-sample) and, for each patch, to the other 23 (held out). \
           Mean / max over the patches:\n\n\
           | camera | illuminant | 3x3 | 3x3 held out | root-polynomial | root-polynomial held out |\n\
           |---|---|---|---|---|---|\n";
    for f in &r.calibration.fits {
        let cell = |v: &[f64]| {
            let (mean, max) = isp_core::metrics::mean_max(v);
            format!("{mean:.2} / {max:.2}")
        };
        md += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            f.camera,
            f.illuminant,
            cell(&f.matrix),
            cell(&f.matrix_held_out),
            cell(&f.root_polynomial),
            cell(&f.root_polynomial_held_out)
        );
    }
    let rs = &r.render;
    md += &format!(
        "\n## Rendering: convergence and what each camera feature costs\n\n![Rendering](render.svg)\n\n\
         Convergence: {}{}.\n\n| renderer | camera | spp | seconds | RMSE |\n|---|---|---|---|---|\n",
        rs.convergence_setup,
        rs.mitsuba.as_ref().map_or(String::new(), |v| format!("; Mitsuba {v} scalar_rgb"))
    );
    for q in &rs.convergence {
        md += &format!(
            "| {} | {} | {} | {:.4} | {:.5} |\n",
            q.renderer, q.camera, q.spp, q.seconds, q.rmse
        );
    }
    md += &format!(
        "\nFeatures: {}.\n\n| variant | Msamples/s | time x | what |\n|---|---|---|---|\n",
        rs.feature_setup
    );
    for f in &rs.features {
        md += &format!(
            "| {} | {:.2} | {:.2} | {} |\n",
            f.variant, f.msamples_per_s, f.relative_time, f.what
        );
    }
    let fl = &r.failures;
    md += &format!(
        "\n## Where methods fail\n\n![Where methods fail](failures.svg)\n\n\
         Zone plate: {}. Noise: {}.\n\n| method | CPSNR dB below 0.25 cycles/pixel | \
         CPSNR dB, 0.25 to 0.5 | false colour, 0.25 to 0.5 (8-bit) |\n|---|---|---|---|\n",
        fl.zone_plate, fl.noise_setup
    );
    let mut zone_methods: Vec<&str> = Vec::new();
    for b in &fl.zone_plate_bands {
        if !zone_methods.contains(&b.method.as_str()) {
            zone_methods.push(&b.method);
        }
    }
    for m in zone_methods {
        let band = |low: bool| -> Vec<&ZonePlateBand> {
            fl.zone_plate_bands
                .iter()
                .filter(|b| b.method == m && (b.cycles_per_pixel < 0.25) == low)
                .collect()
        };
        let mean = |v: &[&ZonePlateBand], f: fn(&ZonePlateBand) -> f64| {
            v.iter().map(|b| f(b)).sum::<f64>() / v.len().max(1) as f64
        };
        let (low, high) = (band(true), band(false));
        md += &format!(
            "| {m} | {:.2} | {:.2} | {:.2} |\n",
            mean(&low, |b| b.cpsnr_db),
            mean(&high, |b| b.cpsnr_db),
            mean(&high, |b| b.false_colour)
        );
    }
    md += "\n| method | denoise |";
    for iso in ISOS {
        md += &format!(" ISO {iso} |");
    }
    md += "\n|---|---|";
    md += &"---|".repeat(ISOS.len());
    md += "\n";
    let mut seen: Vec<(&str, f32)> = Vec::new();
    for q in &fl.noise {
        if seen.contains(&(q.method.as_str(), q.denoise)) {
            continue;
        }
        seen.push((&q.method, q.denoise));
        md += &format!("| {} | {} |", q.method, q.denoise);
        for iso in ISOS {
            match fl
                .noise
                .iter()
                .find(|p| p.method == q.method && p.denoise == q.denoise && p.iso == iso)
            {
                Some(p) => md += &format!(" {:.2} |", p.noise_lsb),
                None => md += " – |",
            }
        }
        md += "\n";
    }
    md += &format!(
        "\n## Depth of field: where 2u²Nc/f² breaks down\n\n![Depth of field](depth_of_field.svg)\n\n\
         Circle of confusion {} mm.\n\n| lens | hyperfocal | approximation within 10 % from | to |\n|---|---|---|---|\n",
        r.depth_of_field.coc_mm
    );
    for l in &r.depth_of_field.lenses {
        md += &format!(
            "| {} mm f/{} | {:.2} m | {} |\n",
            l.focal_length_mm,
            l.f_number,
            l.hyperfocal_m,
            l.within_ten_percent_m
                .map_or("nowhere | ".into(), |(a, b)| format!("{a:.2} m | {b:.2} m"))
        );
    }
    md
}

/// The denoise suite's table: each method's mean PSNR per noise level, the mean of the two
/// noisier levels (the criterion) and its speed, with how the figures were made.
pub fn denoise_table(d: &super::DenoiseSuite) -> String {
    use super::denoise::{H_GRID, SCALES};
    let images = {
        let mut names: Vec<&str> = d.points.iter().map(|p| p.image.as_str()).collect();
        names.sort();
        names.dedup();
        names.join(", ")
    };
    let mut md = format!(
        "{images} (central crops) as 12-bit RGGB raws (black 256, white 4095) with Poisson-Gaussian noise of \
         variance S x + O (O from the unprocessing fit, log O = 2.18 log S + 1.2). PSNR of the \
         8-bit development (camsim's float path, default demosaicing) against the noise-free \
         raw's, 8 pixels in from each edge. camsim: noise reduction from the profile at its \
         default strength, with the default 5x5 search and the fast 3x3 setting (`fast` \
         rows). OpenCV: fastNlMeansDenoisingColored on the noisy development at its \
         best h per level of {H_GRID:?}. CBM3D: on the noisy development with the true sigma. \
         BM3D planes: each CFA plane of the raw after the generalised Anscombe transform, then \
         developed like camsim's. Mpix/s, one thread: camsim's whole development with noise \
         reduction; a peer's filter alone.",
    );
    if let Some(v) = &d.peer_versions {
        md += &format!(" Peers: {v}.");
    }
    if let Some(why) = &d.bm3d_skipped {
        md += &format!(" BM3D did not run: {why}.");
    }
    md += "\n\n| method |";
    for s in SCALES {
        md += &format!(" S = {s} |");
    }
    md += " mean of the two noisier | Mpix/s |\n|---|---|---|---|---|---|\n";
    for m in d.summary() {
        md += &format!("| {} |", m.method);
        for (p, g) in m.psnr_db.iter().zip(m.gain_db) {
            md += &if m.method == "noisy" {
                format!(" {p:.2} |")
            } else {
                format!(" {p:.2} ({g:+.2}) |")
            };
        }
        md += &format!(
            " {:.2} | {} |\n",
            m.noisier_mean(),
            if m.mpix_per_s.is_finite() {
                format!("{:.2}", m.mpix_per_s)
            } else {
                "–".into()
            }
        );
    }
    md
}
