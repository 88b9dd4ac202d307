//! RGB working spaces defined by their primaries and white point (xy chromaticities).

/// A linear RGB space: the 3×3 matrices between it and CIE XYZ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSpace {
    pub rgb_to_xyz: [[f64; 3]; 3],
    pub xyz_to_rgb: [[f64; 3]; 3],
}

pub const D65_WHITE_XY: [f64; 2] = [0.3127, 0.3290];

impl RgbSpace {
    /// Linear Rec.709 / sRGB primaries with a D65 white: Blender's scene-linear space.
    pub fn rec709() -> Self {
        Self::from_primaries([0.64, 0.33], [0.30, 0.60], [0.15, 0.06], D65_WHITE_XY)
    }

    /// The standard construction (SMPTE RP 177): scale the primaries so that RGB
    /// (1,1,1) maps to the white point with Y = 1.
    pub fn from_primaries(r: [f64; 2], g: [f64; 2], b: [f64; 2], white: [f64; 2]) -> Self {
        let col = |p: [f64; 2]| [p[0] / p[1], 1.0, (1.0 - p[0] - p[1]) / p[1]];
        let (cr, cg, cb) = (col(r), col(g), col(b));
        let p = [[cr[0], cg[0], cb[0]], [cr[1], cg[1], cb[1]], [cr[2], cg[2], cb[2]]];
        let w = col(white);
        let s = mul_vec(&invert(&p), w);
        let mut m = p;
        for row in m.iter_mut() {
            for (k, v) in row.iter_mut().enumerate() {
                *v *= s[k];
            }
        }
        Self { rgb_to_xyz: m, xyz_to_rgb: invert(&m) }
    }

    pub fn xyz_to_rgb(&self, xyz: [f64; 3]) -> [f64; 3] {
        mul_vec(&self.xyz_to_rgb, xyz)
    }
    pub fn rgb_to_xyz(&self, rgb: [f64; 3]) -> [f64; 3] {
        mul_vec(&self.rgb_to_xyz, rgb)
    }
}

pub fn mul_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

pub fn invert(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let inv = 1.0 / det;
    [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * inv,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * inv,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * inv,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv,
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rec709_matches_iec_61966_2_1() {
        // IEC 61966-2-1 sRGB → XYZ matrix (4 decimals in the standard).
        let m = RgbSpace::rec709().rgb_to_xyz;
        let reference = [[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - reference[i][j]).abs() < 1e-4, "{i}{j}: {}", m[i][j]);
            }
        }
        let back = RgbSpace::rec709().xyz_to_rgb(RgbSpace::rec709().rgb_to_xyz([0.2, 0.5, 0.9]));
        assert!((back[2] - 0.9).abs() < 1e-12);
    }
}
