use glam::Vec2;
use optics_core::aperture::*;
use optics_core::OpticsError;
use proptest::prelude::*;

/// SplitMix64: a small, seedable generator so each case is reproducible from its seed.
struct Rng(u64);
impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn u2(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Upper critical value of chi-square with `df` degrees of freedom, z standard deviations out
/// (Wilson-Hilferty). z = 5 keeps false alarms below one in a million runs.
fn chi2_critical(df: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * df);
    df * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Draws `n` samples, checks each is inside, and tests uniformity over the shape's area with a
/// chi-square test on a grid whose expected counts come from `contains` on a fine lattice
/// (independent of the sampler).
fn assert_uniform<S: ApertureShape>(shape: &S, seed: u64, n: usize) -> Result<(), TestCaseError> {
    const G: usize = 12;
    const SUB: usize = 24;
    let mut rng = Rng(seed);
    let mut observed = [[0u32; G]; G];
    for _ in 0..n {
        let p = shape.sample(rng.u2());
        prop_assert!(shape.contains(p), "sample {:?} outside the shape", p);
        prop_assert!(p.x.abs() <= 1.0 + 1e-5 && p.y.abs() <= 1.0 + 1e-5);
        let cx = (((p.x + 1.0) / 2.0 * G as f32) as usize).min(G - 1);
        let cy = (((p.y + 1.0) / 2.0 * G as f32) as usize).min(G - 1);
        observed[cy][cx] += 1;
    }
    let mut coverage = [[0.0f64; G]; G];
    let mut covered_total = 0.0;
    for (cy, row) in coverage.iter_mut().enumerate() {
        for (cx, cell) in row.iter_mut().enumerate() {
            let mut inside = 0;
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let x = -1.0 + 2.0 * (cx as f32 + (sx as f32 + 0.5) / SUB as f32) / G as f32;
                    let y = -1.0 + 2.0 * (cy as f32 + (sy as f32 + 0.5) / SUB as f32) / G as f32;
                    inside += shape.contains(Vec2::new(x, y)) as u32;
                }
            }
            *cell = inside as f64 / (SUB * SUB) as f64;
            covered_total += *cell;
        }
    }
    // The lattice also measures the area: it must agree with area().
    let lattice_area = covered_total * 4.0 / (G * G) as f64;
    prop_assert!(
        (lattice_area - shape.area() as f64).abs() < 0.02 * shape.area() as f64,
        "area {} vs lattice {}",
        shape.area(),
        lattice_area
    );
    let (mut chi2, mut cells) = (0.0, 0);
    for cy in 0..G {
        for cx in 0..G {
            let expected = n as f64 * coverage[cy][cx] / covered_total;
            if expected >= 20.0 {
                let d = observed[cy][cx] as f64 - expected;
                chi2 += d * d / expected;
                cells += 1;
            } else if expected == 0.0 {
                // A sliver of shape the lattice missed may hold a few samples, no more.
                prop_assert!(
                    observed[cy][cx] as usize <= n / 2000,
                    "{} samples in an empty cell",
                    observed[cy][cx]
                );
            }
        }
    }
    let critical = chi2_critical((cells - 1) as f64, 5.0);
    prop_assert!(
        chi2 < critical,
        "chi-square {} over {} cells, critical {}",
        chi2,
        cells,
        critical
    );
    Ok(())
}

fn assert_pdf_is_reciprocal_area<S: ApertureShape>(shape: &S) {
    let inside = shape.sample(Vec2::new(0.37, 0.61));
    assert!((shape.pdf(inside) * shape.area() - 1.0).abs() < 1e-5);
    assert_eq!(shape.pdf(Vec2::new(5.0, 5.0)), 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn disk_is_uniform(seed in any::<u64>()) {
        assert_uniform(&Disk, seed, 40_000)?;
    }

    #[test]
    fn polygon_is_uniform(blades in 3u32..12, rotation in 0.0f32..6.3, seed in any::<u64>()) {
        assert_uniform(&RegularPolygon::new(blades, rotation).unwrap(), seed, 40_000)?;
    }

    #[test]
    fn heart_is_uniform(seed in any::<u64>()) {
        assert_uniform(&Heart::new(), seed, 40_000)?;
    }

    /// Binary masks are sampled uniformly over their open cells.
    #[test]
    fn binary_mask_is_uniform(bits in proptest::collection::vec(any::<bool>(), 64), seed in any::<u64>()) {
        prop_assume!(bits.iter().any(|b| *b));
        let mask: Vec<u8> = bits.iter().map(|b| if *b { 255 } else { 0 }).collect();
        let mut cdf = vec![0u32; 64];
        let shape = BitmapMask::new(&mask, 8, 8, &mut cdf).unwrap();
        assert_uniform(&shape, seed, 40_000)?;
    }
}

proptest! {
    /// Soft masks: each cell is chosen in proportion to its transmission (chi-square per cell).
    #[test]
    fn soft_mask_density_follows_weights(weights in proptest::collection::vec(0u8..=255, 15), seed in any::<u64>()) {
        prop_assume!(weights.iter().map(|w| *w as u32).sum::<u32>() > 0);
        let (w, h) = (5, 3);
        let mut cdf = vec![0u32; 15];
        let shape = BitmapMask::new(&weights, w, h, &mut cdf).unwrap();
        let total: f64 = weights.iter().map(|x| *x as f64).sum();
        let n = 30_000;
        let mut counts = [0u32; 15];
        let mut rng = Rng(seed);
        for _ in 0..n {
            let p = shape.sample(rng.u2());
            prop_assert!(shape.contains(p));
            let col = ((p.x + 1.0) / 2.0 * w as f32) as usize;
            let row = ((1.0 - p.y) / 2.0 * h as f32) as usize;
            counts[row * w + col] += 1;
        }
        let (mut chi2, mut cells) = (0.0, 0);
        for (i, &c) in counts.iter().enumerate() {
            let expected = n as f64 * weights[i] as f64 / total;
            if weights[i] == 0 { prop_assert_eq!(c, 0); }
            if expected >= 20.0 { chi2 += (c as f64 - expected).powi(2) / expected; cells += 1; }
        }
        if cells > 1 {
            prop_assert!(chi2 < chi2_critical((cells - 1) as f64, 5.0), "chi2 {}", chi2);
        }
    }

    /// Whatever u is (including the edges of [0,1] and beyond), a sample stays inside.
    #[test]
    fn samples_inside_for_any_u(ux in -1.0f32..2.0, uy in -1.0f32..2.0, blades in 3u32..9) {
        let u = Vec2::new(ux, uy);
        prop_assert!(Disk.contains(Disk.sample(u)));
        let poly = RegularPolygon::new(blades, 0.3).unwrap();
        prop_assert!(poly.contains(poly.sample(u)));
        prop_assert!(Heart::new().contains(Heart::new().sample(u)));
    }
}

#[test]
fn pdfs_and_areas() {
    assert_pdf_is_reciprocal_area(&Disk);
    assert_pdf_is_reciprocal_area(&RegularPolygon::new(6, 0.1).unwrap());
    assert_pdf_is_reciprocal_area(&Heart::new());
    let square = RegularPolygon::new(4, std::f32::consts::FRAC_PI_4).unwrap();
    assert!((square.area() - 2.0).abs() < 1e-6);
    assert!(square.contains(Vec2::new(0.70, 0.70)) && !square.contains(Vec2::new(0.72, 0.72)));
    // The heart fits the unit disk and touches it.
    let heart = Heart::new();
    let mut max_r: f32 = 0.0;
    for i in 0..2000 {
        for j in 0..20 {
            let p = heart.sample(Vec2::new(i as f32 / 2000.0, 1.0 - j as f32 / 2000.0));
            max_r = max_r.max(p.length());
        }
    }
    assert!(max_r <= 1.0 + 1e-5 && max_r > 0.99, "max radius {max_r}");
    // A heart is not symmetric top to bottom: the point is at the bottom.
    assert!(heart.contains(Vec2::new(0.0, -0.8)) && !heart.contains(Vec2::new(0.0, 0.8)));
}

#[test]
fn bitmap_errors_and_pdf() {
    let mut cdf = [0u32; 4];
    assert_eq!(
        BitmapMask::new(&[0, 0, 0, 0], 2, 2, &mut cdf).unwrap_err(),
        OpticsError::EmptyMask
    );
    assert!(matches!(
        BitmapMask::new(&[1, 2, 3], 2, 2, &mut cdf),
        Err(OpticsError::BufferTooSmall { .. })
    ));
    let mut small = [0u32; 3];
    assert!(matches!(
        BitmapMask::new(&[1, 2, 3, 4], 2, 2, &mut small),
        Err(OpticsError::BufferTooSmall { .. })
    ));
    assert!(BitmapMask::new(&[1], 0, 1, &mut cdf).is_err());
    assert!(BitmapMask::new(&[1; 8193], 8193, 1, &mut [0u32; 8193]).is_err());
    assert!(BitmapMask::cdf_len(usize::MAX, 2).is_err());
    // Fully open 2x2 mask: pdf = 1/4 over [-1,1]^2, area 4.
    let mut cdf = [0u32; 4];
    let open = BitmapMask::new(&[255; 4], 2, 2, &mut cdf).unwrap();
    assert!((open.pdf(Vec2::new(0.3, -0.2)) - 0.25).abs() < 1e-6);
    assert!((open.area() - 4.0).abs() < 1e-6);
    assert_eq!(open.pdf(Vec2::new(1.5, 0.0)), 0.0);
    // Top-left cell only: samples land in x < 0, y > 0.
    let mut cdf = [0u32; 4];
    let corner = BitmapMask::new(&[255, 0, 0, 0], 2, 2, &mut cdf).unwrap();
    for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::splat(0.999_999)] {
        let p = corner.sample(u);
        assert!(p.x < 0.0 && p.y > 0.0, "{p:?}");
    }
}
