//! The teeth of a toothed (synchronous) belt: one circular-arc tooth per pitch on the cord, each
//! a compliant rubber body whose shear and bending compliance is lumped into the penalty
//! stiffness of its contact points (the tooth-spring model of toothed-belt load distribution;
//! Gerbert, "Toothed belt mechanics", in Traction Belt Mechanics, 1999, ch. 17).
//!
//! Geometry in the frame of the tooth's cord segment (t: the segment's direction, the belt's
//! running direction; n: the inward normal, towards the pulley): the land line lies
//! `pitch_line_offset_m` inside the cord (pitch line); the tooth is a semicircle of radius
//! `profile_radius_m` centred on the land line (an R-type arc tooth, seed paper
//! "arc-tooth-synchronous-belt-recurdyn", section III). Flank a faces +t, flank b faces -t, the
//! tip faces n. The tooth is described by contact points on its arc (paper eq. 1-2: contact
//! points on the belt body against the pulley's surface).

pub use crate::config::TeethConfig;
use std::f64::consts::PI;

/// Contact points per region of the tooth arc (flank a, tip, flank b).
pub const POINTS_PER_REGION: usize = 5;
/// Contact points per tooth.
pub const POINTS_PER_TOOTH: usize = 3 * POINTS_PER_REGION;
/// Where the flanks end and the tip begins on the arc, rad from the land (60 degrees: the arc
/// split in thirds, flank a [0, 60), tip [60, 120], flank b (120, 180]).
pub const FLANK_END_RAD: f64 = PI / 3.0;
/// Timoshenko's shear coefficient of a rectangular section, 5/6 (Timoshenko & Gere, Mechanics
/// of Materials, 1972, sec. 10.2).
const SHEAR_COEFFICIENT: f64 = 5.0 / 6.0;

impl TeethConfig {
    /// Shear modulus G = E / (2 (1 + nu)) of the tooth rubber (isotropic elasticity; Timoshenko
    /// & Goodier, Theory of Elasticity, 1970, sec. 3), Pa.
    pub fn shear_modulus_pa(&self) -> f64 {
        self.rubber_modulus_pa / (2.0 * (1.0 + self.rubber_poisson))
    }

    /// Mean width of the semicircular tooth, its area over its height: (pi R^2 / 2) / R, m.
    fn mean_width_m(&self) -> f64 {
        0.5 * PI * self.profile_radius_m
    }

    /// Tangential stiffness of one tooth under a flank load at mid-height a = h / 2: a
    /// cantilever of height h, width b and mean thickness w, bending plus shear in series,
    /// 1 / k = a^3 / (3 E I) + a / (kappa G A), I = b w^3 / 12, A = b w (Timoshenko & Gere,
    /// Mechanics of Materials, 1972, sec. 10.2), N/m.
    pub fn flank_stiffness_n_m(&self) -> f64 {
        let a = 0.5 * self.profile_radius_m;
        let w = self.mean_width_m();
        let area = self.width_m * w;
        let inertia = self.width_m * w.powi(3) / 12.0;
        let bending = a.powi(3) / (3.0 * self.rubber_modulus_pa * inertia);
        let shear = a / (SHEAR_COEFFICIENT * self.shear_modulus_pa() * area);
        1.0 / (bending + shear)
    }

    /// Radial stiffness of one tooth pressed on its tip: a column of height h and section b w in
    /// plane strain, k = E / (1 - nu^2) b w / h (Timoshenko & Goodier, Theory of Elasticity,
    /// 1970, sec. 17), N/m.
    pub fn tip_stiffness_n_m(&self) -> f64 {
        let plane_strain = self.rubber_modulus_pa / (1.0 - self.rubber_poisson.powi(2));
        plane_strain * self.width_m * self.mean_width_m() / self.profile_radius_m
    }
}

/// Which part of the tooth a contact point belongs to; the discriminant indexes `ToothLoads`
/// (flank a, flank b, tip).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToothRegion {
    FlankA = 0,
    FlankB = 1,
    Tip = 2,
}

/// The contact points of one tooth on its arc: angle from the land on the +t side, (cos, sin),
/// and region; the midpoints of `POINTS_PER_REGION` equal parts of each region.
pub fn contact_points() -> [(f64, f64, ToothRegion); POINTS_PER_TOOTH] {
    let mut pts = [(0.0, 0.0, ToothRegion::FlankA); POINTS_PER_TOOTH];
    let part = FLANK_END_RAD / POINTS_PER_REGION as f64;
    for (k, p) in pts.iter_mut().enumerate() {
        let phi = (k as f64 + 0.5) * part;
        let region = match k / POINTS_PER_REGION {
            0 => ToothRegion::FlankA,
            1 => ToothRegion::Tip,
            _ => ToothRegion::FlankB,
        };
        *p = (phi.cos(), phi.sin(), region);
    }
    pts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper_teeth() -> TeethConfig {
        TeethConfig {
            count: 60,
            pitch_m: 9.525e-3,
            profile_radius_m: 2.8e-3,
            pitch_line_offset_m: 0.7e-3,
            width_m: 0.024,
            rubber_modulus_pa: 45e6,
            rubber_poisson: 0.46,
        }
    }

    #[test]
    fn points_cover_the_arc_symmetrically() {
        let pts = contact_points();
        for k in 0..POINTS_PER_TOOTH {
            let (c, s, r) = pts[k];
            let (c2, s2, r2) = pts[POINTS_PER_TOOTH - 1 - k];
            assert!((c + c2).abs() < 1e-12 && (s - s2).abs() < 1e-12);
            assert!(s > 0.0);
            match r {
                ToothRegion::FlankA => assert_eq!(r2, ToothRegion::FlankB),
                ToothRegion::Tip => assert_eq!(r2, ToothRegion::Tip),
                ToothRegion::FlankB => assert_eq!(r2, ToothRegion::FlankA),
            }
        }
    }

    #[test]
    fn tooth_stiffness_follows_the_cantilever_formulas() {
        let t = paper_teeth();
        // Hand computation: G = 45e6 / 2.92 = 15.41 MPa, w = pi 2.8 / 2 = 4.398 mm,
        // A = 1.0556e-4 m^2, I = 1.7016e-10 m^4, a = 1.4 mm:
        // 1/k = 2.744e-9 / (3 * 45e6 * 1.7016e-10) + 1.4e-3 / (0.8333 * 15.41e6 * 1.0556e-4).
        let inv = 2.744e-9 / (3.0 * 45e6 * 1.7016e-10) + 1.4e-3 / (0.83333 * 15.411e6 * 1.0556e-4);
        assert!((t.flank_stiffness_n_m() * inv - 1.0).abs() < 2e-3);
        let tip = 45e6 / (1.0 - 0.46 * 0.46) * 0.024 * 4.398e-3 / 2.8e-3;
        assert!((t.tip_stiffness_n_m() / tip - 1.0).abs() < 1e-3);
        // Stiffer with a stiffer rubber, in proportion.
        let mut hard = t.clone();
        hard.rubber_modulus_pa *= 2.0;
        assert!((hard.flank_stiffness_n_m() / t.flank_stiffness_n_m() - 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_tooth_wider_than_its_pitch_is_refused() {
        let mut t = paper_teeth();
        t.profile_radius_m = 5e-3;
        assert!(t.check().unwrap_err().contains("profile_radius_m"));
    }
}
