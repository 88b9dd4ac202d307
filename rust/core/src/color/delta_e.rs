//! CIELAB and the CIEDE2000 colour difference, for the render's own error estimates
//! (adaptive sampling, the AUTO grid). White is D65 at Y = 1, as
//! `polychrome.colordiff.image_delta_e` uses.

/// The D65 white of Y = 1 that [`lab`] is relative to.
pub const D65_WHITE: [f64; 3] = [0.950_47, 1.0, 1.088_83];

/// CIE 1976 L*a*b* of an XYZ colour relative to a D65 white of Y = 1.
pub fn lab(xyz: [f64; 3]) -> [f64; 3] {
    lab_relative(xyz, D65_WHITE)
}

/// CIE 1976 L*a*b* of `xyz` relative to the reference white `white` (CIE 15:2004 eq. 8.1).
pub fn lab_relative(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let f: [f64; 3] = std::array::from_fn(|k| lab_f(xyz[k] / white[k]).0);
    [116.0 * f[1] - 16.0, 500.0 * (f[0] - f[1]), 200.0 * (f[1] - f[2])]
}

/// CIELAB's f(t) (the cube root, linear below (6/29)³) and its derivative f'(t), which
/// the smooth uplift's Gauss–Newton fit needs for its Jacobian.
pub fn lab_f(t: f64) -> (f64, f64) {
    const D: f64 = 6.0 / 29.0;
    if t > D * D * D {
        let c = t.cbrt();
        (c, 1.0 / (3.0 * c * c))
    } else {
        (t / (3.0 * D * D) + 4.0 / 29.0, 1.0 / (3.0 * D * D))
    }
}

/// CIEDE2000 (Sharma, Wu & Dalal 2005) between two CIELAB colours.
pub fn de2000(l1: [f64; 3], l2: [f64; 3]) -> f64 {
    use std::f64::consts::PI;
    let (c1, c2) = (l1[1].hypot(l1[2]), l2[1].hypot(l2[2]));
    let cm = 0.5 * (c1 + c2);
    let g = 0.5 * (1.0 - (cm.powi(7) / (cm.powi(7) + 25f64.powi(7))).sqrt());
    let (a1, a2) = ((1.0 + g) * l1[1], (1.0 + g) * l2[1]);
    let (c1, c2) = (a1.hypot(l1[2]), a2.hypot(l2[2]));
    let hue = |b: f64, a: f64| {
        if a == 0.0 && b == 0.0 {
            0.0
        } else {
            b.atan2(a).rem_euclid(2.0 * PI)
        }
    };
    let (h1, h2) = (hue(l1[2], a1), hue(l2[2], a2));
    let dl = l2[0] - l1[0];
    let dc = c2 - c1;
    let dh = if c1 * c2 == 0.0 {
        0.0
    } else {
        let d = h2 - h1;
        if d > PI {
            d - 2.0 * PI
        } else if d < -PI {
            d + 2.0 * PI
        } else {
            d
        }
    };
    let dhh = 2.0 * (c1 * c2).sqrt() * (dh / 2.0).sin();
    let lm = 0.5 * (l1[0] + l2[0]);
    let cm = 0.5 * (c1 + c2);
    let hm = if c1 * c2 == 0.0 {
        h1 + h2
    } else if (h1 - h2).abs() <= PI {
        0.5 * (h1 + h2)
    } else if h1 + h2 < 2.0 * PI {
        0.5 * (h1 + h2 + 2.0 * PI)
    } else {
        0.5 * (h1 + h2 - 2.0 * PI)
    };
    let t = 1.0 - 0.17 * (hm - PI / 6.0).cos() + 0.24 * (2.0 * hm).cos() + 0.32 * (3.0 * hm + PI / 30.0).cos()
        - 0.20 * (4.0 * hm - 63f64.to_radians()).cos();
    let dtheta = 30f64.to_radians() * (-((hm.to_degrees() - 275.0) / 25.0).powi(2)).exp();
    let rc = 2.0 * (cm.powi(7) / (cm.powi(7) + 25f64.powi(7))).sqrt();
    let sl = 1.0 + 0.015 * (lm - 50.0).powi(2) / (20.0 + (lm - 50.0).powi(2)).sqrt();
    let sc = 1.0 + 0.045 * cm;
    let sh = 1.0 + 0.015 * cm * t;
    let rt = -(2.0 * dtheta).sin() * rc;
    let (x, y, z) = (dl / sl, dc / sc, dhh / sh);
    (x * x + y * y + z * z + rt * y * z).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ciede2000_matches_sharma_2005() {
        // Pairs 1, 7 and 17 of Sharma, Wu & Dalal's test data.
        assert!((de2000([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485]) - 2.0425).abs() < 1e-4);
        assert!((de2000([50.0, 0.0, 0.0], [50.0, -1.0, 2.0]) - 2.3669).abs() < 1e-4);
        assert!((de2000([50.0, 2.5, 0.0], [73.0, 25.0, -18.0]) - 27.1492).abs() < 1e-4);
    }
}
