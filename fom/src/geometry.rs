//! Layout of an open two-pulley belt: tangent points and the path the belt is laid on. The
//! static formulas (belt length, wrap angles) are `statics`.

use crate::statics::wrap_angles_rad;
use std::f64::consts::PI;

/// A closed path around two circles, traversed counter-clockwise, starting where the belt
/// leaves the driver on the lower span: lower span -> driven arc -> upper span -> driver arc.
#[derive(Debug, Clone)]
pub struct OpenBeltPath {
    pub c1: [f64; 2],
    pub c2: [f64; 2],
    pub r1: f64,
    pub r2: f64,
    /// Unit vector from c1 to c2.
    axis: [f64; 2],
    beta: f64,
    /// Cumulative arc length at the end of each of the four pieces.
    ends: [f64; 4],
}

impl OpenBeltPath {
    pub fn new(c1: [f64; 2], r1: f64, c2: [f64; 2], r2: f64) -> Self {
        let dx = c2[0] - c1[0];
        let dy = c2[1] - c1[1];
        let d = dx.hypot(dy);
        let axis = [dx / d, dy / d];
        let beta = ((r2 - r1) / d).asin();
        let span = d * beta.cos();
        let (a1, a2) = wrap_angles_rad(d, r1, r2);
        let e0 = span;
        let e1 = e0 + r2 * a2;
        let e2 = e1 + span;
        let e3 = e2 + r1 * a1;
        Self {
            c1,
            c2,
            r1,
            r2,
            axis,
            beta,
            ends: [e0, e1, e2, e3],
        }
    }

    pub fn length(&self) -> f64 {
        self.ends[3]
    }

    /// Angle of the axis c1 -> c2, rad.
    fn phi0(&self) -> f64 {
        self.axis[1].atan2(self.axis[0])
    }

    fn on_circle(c: [f64; 2], r: f64, ang: f64) -> [f64; 2] {
        [c[0] + r * ang.cos(), c[1] + r * ang.sin()]
    }

    /// Tangent points (lower-driver, lower-driven, upper-driven, upper-driver).
    pub fn tangent_points(&self) -> [[f64; 2]; 4] {
        let p = self.phi0();
        let lo = p - 0.5 * PI - self.beta;
        let up = p + 0.5 * PI + self.beta;
        [
            Self::on_circle(self.c1, self.r1, lo),
            Self::on_circle(self.c2, self.r2, lo),
            Self::on_circle(self.c2, self.r2, up),
            Self::on_circle(self.c1, self.r1, up),
        ]
    }

    /// Midpoints of the lower (slack, leaving the driver) and upper (tight, entering the driver)
    /// spans for a counter-clockwise drive.
    pub fn span_midpoints(&self) -> ([f64; 2], [f64; 2]) {
        let t = self.tangent_points();
        (
            [0.5 * (t[0][0] + t[1][0]), 0.5 * (t[0][1] + t[1][1])],
            [0.5 * (t[2][0] + t[3][0]), 0.5 * (t[2][1] + t[3][1])],
        )
    }

    /// Free span length (tangent to tangent), m.
    pub fn span_length(&self) -> f64 {
        self.ends[0]
    }

    /// Point and continuous tangent angle at arc length s in [0, L).
    /// The angle grows monotonically by 2 pi over one loop, starting at the lower span's angle.
    pub fn point(&self, s: f64) -> ([f64; 2], f64) {
        let p = self.phi0();
        let lo = p - 0.5 * PI - self.beta;
        let up = p + 0.5 * PI + self.beta;
        let t = self.tangent_points();
        let span_dir = p - self.beta; // direction of the lower span, driver -> driven
        let [e0, e1, e2, _] = self.ends;
        if s < e0 {
            let f = s / e0;
            (lerp(t[0], t[1], f), span_dir)
        } else if s < e1 {
            let ang = lo + (s - e0) / self.r2;
            (Self::on_circle(self.c2, self.r2, ang), ang + 0.5 * PI)
        } else if s < e2 {
            let f = (s - e1) / e0;
            (lerp(t[2], t[3], f), span_dir + PI + 2.0 * self.beta)
        } else {
            let ang = up + (s - e2) / self.r1;
            (Self::on_circle(self.c1, self.r1, ang), ang + 0.5 * PI)
        }
    }
}

fn lerp(a: [f64; 2], b: [f64; 2], f: f64) -> [f64; 2] {
    [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
}

/// Radius at which a polygon of chords of length `chord_m` has the perimeter of the circle of
/// radius `r_m` (polygonal-effect compensation): 2 r' sin(chord / (2 r)) = chord.
pub fn polygon_compensated_radius_m(r_m: f64, chord_m: f64) -> f64 {
    chord_m / (2.0 * (chord_m / (2.0 * r_m)).sin())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::statics::open_belt_length_m;

    #[test]
    fn path_length_matches_open_belt_formula() {
        let p = OpenBeltPath::new([0.0, 0.0], 0.05, [0.42, 0.0], 0.1);
        let l = open_belt_length_m(0.42, 0.05, 0.1);
        assert!((p.length() - l).abs() < 1e-12);
        // Equal pulleys: 2 d + 2 pi r.
        assert!((open_belt_length_m(0.3, 0.05, 0.05) - (0.6 + 0.1 * PI)).abs() < 1e-12);
    }

    #[test]
    fn path_is_continuous_and_closes() {
        let p = OpenBeltPath::new([0.0, 0.0], 0.05, [0.42, 0.0], 0.1);
        let n = 4000;
        let ds = p.length() / n as f64;
        let mut prev = p.point(0.0);
        for i in 1..=n {
            let s = (i as f64 * ds).min(p.length() - 1e-12);
            let cur = p.point(s);
            let step = (cur.0[0] - prev.0[0]).hypot(cur.0[1] - prev.0[1]);
            // Consecutive points one arc-length step apart (chord <= arc, equal on spans).
            assert!(
                step <= ds * (1.0 + 1e-9) && step > 0.99 * ds,
                "gap at s = {s}"
            );
            assert!(
                cur.1 >= prev.1 - 1e-12,
                "tangent angle decreases at s = {s}"
            );
            prev = cur;
        }
        let start = p.point(0.0);
        assert!((prev.0[0] - start.0[0]).hypot(prev.0[1] - start.0[1]) < 2.0 * ds);
        assert!((prev.1 - (start.1 + 2.0 * PI)).abs() < 0.1);
    }

    #[test]
    fn compensated_radius_restores_perimeter() {
        let r = 0.05;
        let chord = 0.011;
        let rc = polygon_compensated_radius_m(r, chord);
        let n = 2.0 * PI * r / chord; // chords per turn
        let theta = 2.0 * PI / n;
        assert!((2.0 * rc * (0.5 * theta).sin() - chord).abs() < 1e-15);
        assert!(rc > r);
    }
}
