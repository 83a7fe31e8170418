//! Colorimetry for calibration, white balance and colour correction, in `f64`: the sRGB / XYZ
//! matrices, Bradford chromatic adaptation, correlated colour temperature, CIE L*a*b* and the
//! CIEDE2000 colour difference. Checked against colour-science 0.4.7 by the oracle tests
//! (`tests/tests/oracle_colour.rs`).
//!
//! ```
//! use isp_core::colour::{delta_e_2000, xy_to_cct_mccamy};
//! // D65's chromaticity is about 6504 K.
//! let cct = xy_to_cct_mccamy([0.3127, 0.3290]).unwrap();
//! assert!((cct - 6505.08).abs() < 0.01);
//! // Sharma, Wu and Dalal's test pair 1.
//! let de = delta_e_2000([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485]);
//! assert!((de - 2.0425).abs() < 1e-4);
//! ```

use crate::math;
use crate::IspError;

/// A 3x3 matrix, row-major: `out[i] = sum_j m[i][j] * in[j]`.
pub type Mat3 = [[f64; 3]; 3];

/// CIE XYZ (D65) to linear sRGB, IEC 61966-2-1's four-decimal constants (as colour-science
/// uses them; not the exact inverse of [`LINEAR_SRGB_TO_XYZ`]).
pub const XYZ_TO_LINEAR_SRGB: Mat3 = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// Linear sRGB to CIE XYZ (D65), IEC 61966-2-1's four-decimal constants.
pub const LINEAR_SRGB_TO_XYZ: Mat3 = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// Bradford cone-response matrix (Lam 1985), as in colour-science's `CAT_BRADFORD`.
pub const BRADFORD: Mat3 = [
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
];

/// CIE 1931 2-degree chromaticity of D65 (0.3127, 0.3290).
pub const D65_XY: [f64; 2] = [0.3127, 0.3290];

/// D50's chromaticity as the DNG specification's profile connection space states it (ICC).
pub const D50_XY: [f64; 2] = [0.3457, 0.3585];

/// `m * v`.
pub fn mat3_mul_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// `a * b`.
pub fn mat3_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    out
}

/// The inverse of `m`, or an error when it is singular (or not finite).
pub fn mat3_inverse(m: &Mat3) -> Result<Mat3, IspError> {
    let cof =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let c = [
        [cof(1, 2, 1, 2), -cof(1, 2, 0, 2), cof(1, 2, 0, 1)],
        [-cof(0, 2, 1, 2), cof(0, 2, 0, 2), -cof(0, 2, 0, 1)],
        [cof(0, 1, 1, 2), -cof(0, 1, 0, 2), cof(0, 1, 0, 1)],
    ];
    let det = m[0][0] * c[0][0] + m[0][1] * c[0][1] + m[0][2] * c[0][2];
    if !(det.is_finite() && det != 0.0) {
        return Err(IspError::InvalidParameter {
            name: "matrix",
            allowed: "finite and invertible",
        });
    }
    // inverse = adjugate / det, the adjugate being the transposed cofactor matrix.
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = c[j][i] / det;
        }
    }
    Ok(inv)
}

fn chromaticity(xy: [f64; 2]) -> Result<[f64; 2], IspError> {
    if xy[0].is_finite() && xy[1].is_finite() && xy[1] > 0.0 {
        Ok(xy)
    } else {
        Err(IspError::InvalidParameter {
            name: "xy",
            allowed: "finite with y > 0",
        })
    }
}

/// XYZ with `Y = 1` of chromaticity `xy`.
pub fn xy_to_xyz(xy: [f64; 2]) -> Result<[f64; 3], IspError> {
    let [x, y] = chromaticity(xy)?;
    Ok([x / y, 1.0, (1.0 - x - y) / y])
}

/// Chromaticity `xy` of an XYZ triple; an error when `X + Y + Z` is not positive.
pub fn xyz_to_xy(xyz: [f64; 3]) -> Result<[f64; 2], IspError> {
    let sum = xyz[0] + xyz[1] + xyz[2];
    if !(sum.is_finite() && sum > 0.0) {
        return Err(IspError::InvalidParameter {
            name: "xyz",
            allowed: "finite with X + Y + Z > 0",
        });
    }
    Ok([xyz[0] / sum, xyz[1] / sum])
}

/// The von Kries adaptation matrix in Bradford cone space that maps colours seen under
/// `source_white` to how they look under `target_white` (both XYZ):
/// `M^-1 diag(rho_t / rho_s) M`.
pub fn bradford_adaptation(
    source_white: [f64; 3],
    target_white: [f64; 3],
) -> Result<Mat3, IspError> {
    let s = mat3_mul_vec(&BRADFORD, source_white);
    let t = mat3_mul_vec(&BRADFORD, target_white);
    if !s.iter().chain(t.iter()).all(|c| c.is_finite() && *c > 0.0) {
        return Err(IspError::InvalidParameter {
            name: "white",
            allowed: "finite XYZ whites with positive cone responses",
        });
    }
    let gain = [
        [t[0] / s[0], 0.0, 0.0],
        [0.0, t[1] / s[1], 0.0],
        [0.0, 0.0, t[2] / s[2]],
    ];
    Ok(mat3_mul(
        &mat3_inverse(&BRADFORD)?,
        &mat3_mul(&gain, &BRADFORD),
    ))
}

/// Correlated colour temperature (K) of chromaticity `xy` by McCamy's cubic (1992):
/// `n = (x - 0.3320) / (y - 0.1858)`, `CCT = -449 n^3 + 3525 n^2 - 6823.3 n + 5520.33`.
/// Accurate to a few kelvin from about 2850 K to 6500 K near the Planckian locus.
pub fn xy_to_cct_mccamy(xy: [f64; 2]) -> Result<f64, IspError> {
    let [x, y] = chromaticity(xy)?;
    if y == 0.1858 {
        return Err(IspError::InvalidParameter {
            name: "xy",
            allowed: "y != 0.1858 (McCamy's epicentre)",
        });
    }
    let n = (x - 0.3320) / (y - 0.1858);
    Ok(((-449.0 * n + 3525.0) * n - 6823.3) * n + 5520.33)
}

/// Robertson's isotemperature lines (1968): reciprocal temperature (mired), the CIE 1960 `uv`
/// where each line crosses the Planckian locus, and the line's slope. From Wyszecki and Stiles,
/// *Color Science* (2nd ed., 1982), table 1(3.11), with the 325-mired `u` as Bruce Lindbloom
/// corrected it (0.24792), as colour-science and the DNG SDK use it.
const ROBERTSON_1968: [[f64; 4]; 31] = [
    [0.0, 0.18006, 0.26352, -0.24341],
    [10.0, 0.18066, 0.26589, -0.25479],
    [20.0, 0.18133, 0.26846, -0.26876],
    [30.0, 0.18208, 0.27119, -0.28539],
    [40.0, 0.18293, 0.27407, -0.30470],
    [50.0, 0.18388, 0.27709, -0.32675],
    [60.0, 0.18494, 0.28021, -0.35156],
    [70.0, 0.18611, 0.28342, -0.37915],
    [80.0, 0.18740, 0.28668, -0.40955],
    [90.0, 0.18880, 0.28997, -0.44278],
    [100.0, 0.19032, 0.29326, -0.47888],
    [125.0, 0.19462, 0.30141, -0.58204],
    [150.0, 0.19962, 0.30921, -0.70471],
    [175.0, 0.20525, 0.31647, -0.84901],
    [200.0, 0.21142, 0.32312, -1.0182],
    [225.0, 0.21807, 0.32909, -1.2168],
    [250.0, 0.22511, 0.33439, -1.4512],
    [275.0, 0.23247, 0.33904, -1.7298],
    [300.0, 0.24010, 0.34308, -2.0637],
    [325.0, 0.24792, 0.34655, -2.4681],
    [350.0, 0.25591, 0.34951, -2.9641],
    [375.0, 0.26400, 0.35200, -3.5814],
    [400.0, 0.27218, 0.35407, -4.3633],
    [425.0, 0.28039, 0.35577, -5.3762],
    [450.0, 0.28863, 0.35714, -6.7262],
    [475.0, 0.29685, 0.35823, -8.5955],
    [500.0, 0.30505, 0.35907, -11.324],
    [525.0, 0.31320, 0.35968, -15.628],
    [550.0, 0.32129, 0.36011, -23.325],
    [575.0, 0.32931, 0.36038, -40.770],
    [600.0, 0.33724, 0.36051, -116.45],
];

/// Correlated colour temperature (K) of chromaticity `xy` by Robertson's method (1968): the
/// two isotemperature lines the point lies between, interpolated by its distance to each, in
/// CIE 1960 `uv`. The method the DNG specification's reference code uses to find the
/// temperature at which to interpolate a camera's two colour matrices. Saturates at the
/// table's ends: about 1667 K (600 mired) and 100000 K (10 mired).
///
/// ```
/// use isp_core::colour::xy_to_cct_robertson;
/// let cct = xy_to_cct_robertson([0.3127, 0.3290]).unwrap(); // D65
/// assert!((cct - 6504.0).abs() < 2.0);
/// ```
pub fn xy_to_cct_robertson(xy: [f64; 2]) -> Result<f64, IspError> {
    let [x, y] = chromaticity(xy)?;
    let denominator = -2.0 * x + 12.0 * y + 3.0;
    if !(denominator.is_finite() && denominator > 0.0) {
        return Err(IspError::InvalidParameter {
            name: "xy",
            allowed: "a chromaticity with -2x + 12y + 3 > 0",
        });
    }
    let (u, v) = (4.0 * x / denominator, 6.0 * y / denominator);
    // The first line (from the second row) the point is not beyond, with its distance and the
    // previous line's; past the last line, the last (saturating at 600 mired).
    let last = ROBERTSON_1968.len() - 1;
    let mut previous_distance = 0.0;
    let mut i = 1;
    let distance = loop {
        let [_, u_i, v_i, slope] = ROBERTSON_1968[i];
        let length = math::sqrt(1.0 + slope * slope);
        // Signed distance from the isotemperature line; it turns negative past the line.
        let distance = (v - v_i) / length - (u - u_i) * slope / length;
        if distance <= 0.0 || i == last {
            break -distance.min(0.0);
        }
        previous_distance = distance;
        i += 1;
    };
    let f = if i == 1 {
        0.0
    } else {
        distance / (previous_distance + distance)
    };
    let mired = ROBERTSON_1968[i - 1][0] * f + ROBERTSON_1968[i][0] * (1.0 - f);
    Ok(1e6 / mired)
}

/// Chromaticity of the CIE daylight (D-series) illuminant of correlated colour temperature
/// `cct` kelvin, 4000..=25000 K (CIE 015:2004).
pub fn cct_to_xy_daylight(cct: f64) -> Result<[f64; 2], IspError> {
    if !(4000.0..=25000.0).contains(&cct) {
        return Err(IspError::InvalidParameter {
            name: "cct",
            allowed: "4000..=25000 K",
        });
    }
    let (t, t2, t3) = (cct, cct * cct, cct * cct * cct);
    let x = if cct <= 7000.0 {
        -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040
    };
    Ok([x, -3.0 * x * x + 2.87 * x - 0.275])
}

/// CIE 1976 L*a*b* of `xyz` relative to the reference white `white` (XYZ, any scale).
pub fn xyz_to_lab(xyz: [f64; 3], white: [f64; 3]) -> Result<[f64; 3], IspError> {
    if !white.iter().all(|w| w.is_finite() && *w > 0.0) {
        return Err(IspError::InvalidParameter {
            name: "white",
            allowed: "finite XYZ > 0",
        });
    }
    let f = |t: f64| {
        // Exact CIE constants: epsilon = (6/29)^3, kappa / 116 branch as a line through 4/29.
        const DELTA: f64 = 6.0 / 29.0;
        if t > DELTA * DELTA * DELTA {
            math::cbrt(t)
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (
        f(xyz[0] / white[0]),
        f(xyz[1] / white[1]),
        f(xyz[2] / white[2]),
    );
    Ok([116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)])
}

/// The CIEDE2000 colour difference of two L*a*b* colours (Sharma, Wu and Dalal 2005, with
/// k_L = k_C = k_H = 1).
pub fn delta_e_2000(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    use core::f64::consts::PI;
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let c_bar = (math::sqrt(a1 * a1 + b1 * b1) + math::sqrt(a2 * a2 + b2 * b2)) / 2.0;
    let c7 = math::pow(c_bar, 7.0);
    let g = 0.5 * (1.0 - math::sqrt(c7 / (c7 + math::pow(25.0, 7.0))));
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = (
        math::sqrt(a1p * a1p + b1 * b1),
        math::sqrt(a2p * a2p + b2 * b2),
    );
    let hue = |b: f64, a: f64| {
        if a == 0.0 && b == 0.0 {
            0.0
        } else {
            let h = math::atan2(b, a);
            if h < 0.0 {
                h + 2.0 * PI
            } else {
                h
            }
        }
    };
    let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
    let dl = l2 - l1;
    let dc = c2p - c1p;
    let dh_angle = if c1p * c2p == 0.0 {
        0.0
    } else if (h2p - h1p).abs() <= PI {
        h2p - h1p
    } else if h2p - h1p > PI {
        h2p - h1p - 2.0 * PI
    } else {
        h2p - h1p + 2.0 * PI
    };
    let dh = 2.0 * math::sqrt(c1p * c2p) * math::sin(dh_angle / 2.0);
    let l_bar = (l1 + l2) / 2.0;
    let c_bar_p = (c1p + c2p) / 2.0;
    let h_bar = if c1p * c2p == 0.0 {
        h1p + h2p
    } else if (h1p - h2p).abs() <= PI {
        (h1p + h2p) / 2.0
    } else if h1p + h2p < 2.0 * PI {
        (h1p + h2p + 2.0 * PI) / 2.0
    } else {
        (h1p + h2p - 2.0 * PI) / 2.0
    };
    let deg = PI / 180.0;
    let t = 1.0 - 0.17 * math::cos(h_bar - 30.0 * deg)
        + 0.24 * math::cos(2.0 * h_bar)
        + 0.32 * math::cos(3.0 * h_bar + 6.0 * deg)
        - 0.20 * math::cos(4.0 * h_bar - 63.0 * deg);
    let d_theta =
        30.0 * deg * math::exp(-((h_bar / deg - 275.0) / 25.0) * ((h_bar / deg - 275.0) / 25.0));
    let c_bar_p7 = math::pow(c_bar_p, 7.0);
    let r_c = 2.0 * math::sqrt(c_bar_p7 / (c_bar_p7 + math::pow(25.0, 7.0)));
    let l50 = (l_bar - 50.0) * (l_bar - 50.0);
    let s_l = 1.0 + 0.015 * l50 / math::sqrt(20.0 + l50);
    let s_c = 1.0 + 0.045 * c_bar_p;
    let s_h = 1.0 + 0.015 * c_bar_p * t;
    let r_t = -math::sin(2.0 * d_theta) * r_c;
    let (tl, tc, th) = (dl / s_l, dc / s_c, dh / s_h);
    math::sqrt(tl * tl + tc * tc + th * th + r_t * tc * th)
}
