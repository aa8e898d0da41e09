//! Planar Timoshenko beam-force element between two rigid belt segments (RecurDyn "beam force",
//! seed paper section 3.2, eq. 3), in co-rotational form (Crisfield, Non-linear Finite Element
//! Analysis of Solids and Structures, vol. 1, sec. 7.3): the element axis is the chord d from
//! segment i to segment j, of length L and angle beta. Deformations:
//! axial stretch e = L - l0, chord rotation psi = beta - (theta_i + theta_j) / 2 and relative
//! rotation phi = theta_j - theta_i. Strain energy
//! U = EA/(2 l0) e^2 + k_psi/2 psi^2 + EI/(2 l0) phi^2, k_psi = 12 EI / (l0 (1 + P)),
//! P = 12 EI / (kappa G A l0^2): the exact two-node Timoshenko stiffness (Przemieniecki, Theory
//! of Matrix Structural Analysis, 1968, sec. 5.6) split into its antisymmetric and symmetric
//! modes. Because the stretch is the chord length, tension does not couple to the segment
//! rotations. Body i receives the reaction force and the moment -M_j - d x F_j (paper eq. 3),
//! so the element is free of net force and moment.

use crate::config::BeltConfig;

/// Constant stiffness and damping data of one beam-force element.
#[derive(Debug, Clone, Copy)]
pub struct BeamElement {
    /// Unstretched length l0, m.
    pub l0_m: f64,
    /// EA / l0, N/m.
    pub k_axial: f64,
    /// Axial damping coefficient eta_a * EA / l0, N s/m.
    pub c_axial: f64,
    /// Chord-rotation (shear/antisymmetric bending) stiffness 12 EI / (l0 (1 + P)), N m.
    pub k_psi: f64,
    /// Relative-rotation (uniform bending) stiffness EI / l0, N m.
    pub k_phi: f64,
    /// Stiffness-proportional damping time constant of the shear/bending block, s.
    pub eta_bending_s: f64,
}

/// Forces of one element evaluated at a state.
#[derive(Debug, Clone, Copy, Default)]
pub struct BeamForce {
    /// Force on body j in the global frame, N (body i receives the negative).
    pub fx: f64,
    pub fy: f64,
    /// Moment on body j, N m.
    pub mj: f64,
    /// Moment on body i, N m.
    pub mi: f64,
    /// Axial force (tension positive), N.
    pub axial_n: f64,
    /// Power dissipated by the element's damping, W.
    pub damping_power_w: f64,
    /// Unit vector along the chord from body i to body j.
    pub chord: [f64; 2],
    /// Chord length, m.
    pub length_m: f64,
}

impl BeamElement {
    pub fn new(cfg: &BeltConfig, l0_m: f64) -> Self {
        let ei = cfg.bending_stiffness_n_m2;
        // Timoshenko shear parameter P = 12 EI / (kappa G A l^2) (Przemieniecki eq. 5.112).
        let p = 12.0 * ei / (cfg.shear_stiffness_n * l0_m * l0_m);
        let k_axial = cfg.axial_stiffness_n / l0_m;
        Self {
            l0_m,
            k_axial,
            c_axial: cfg.axial_damping_s * k_axial,
            k_psi: 12.0 * ei / (l0_m * (1.0 + p)),
            k_phi: ei / l0_m,
            eta_bending_s: cfg.bending_damping_s,
        }
    }

    /// Transverse stiffness of one node against its neighbours' chord rotation, N/m.
    pub fn transverse_stiffness_n_m(&self) -> f64 {
        self.k_psi / (self.l0_m * self.l0_m)
    }

    /// Element forces. `(cm, sm)` points along the mean section angle (theta_i + theta_j) / 2
    /// (any positive length);
    /// `dphi` = theta_j - theta_i (loop closure removed); `d`, `dv` are x_j - x_i, v_j - v_i;
    /// `wm` the mean angular velocity and `dw` = w_j - w_i.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn force(
        &self,
        cm: f64,
        sm: f64,
        d: [f64; 2],
        dv: [f64; 2],
        wm: f64,
        dphi: f64,
        dw: f64,
    ) -> BeamForce {
        self.force_at(chord_rotation(cm, sm, d), d, dv, wm, dphi, dw)
    }

    /// Element forces with the chord rotation `psi` (rad) already known (see `force`).
    #[inline(always)]
    pub fn force_at(
        &self,
        psi: f64,
        d: [f64; 2],
        dv: [f64; 2],
        wm: f64,
        dphi: f64,
        dw: f64,
    ) -> BeamForce {
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let inv_len = 1.0 / len;
        let (ex, ey) = (d[0] * inv_len, d[1] * inv_len);
        let (nx, ny) = (-ey, ex);
        // Rates: dL/dt = e_c . dv, dbeta/dt = n_c . dv / L.
        let len_rate = ex * dv[0] + ey * dv[1];
        let psi_rate = (nx * dv[0] + ny * dv[1]) * inv_len - wm;
        let axial_d = self.c_axial * len_rate;
        let axial_n = self.k_axial * (len - self.l0_m) + axial_d;
        let q_d = self.eta_bending_s * self.k_psi * psi_rate;
        let q = self.k_psi * psi + q_d;
        let m_d = self.eta_bending_s * self.k_phi * dw;
        let m = self.k_phi * dphi + m_d;
        // F_j = -dU/dx_j = -(N e_c + Q / L n_c); moments -dU/dtheta with dpsi/dtheta = -1/2.
        let qn = q * inv_len;
        BeamForce {
            fx: -(axial_n * ex + qn * nx),
            fy: -(axial_n * ey + qn * ny),
            mj: 0.5 * q - m,
            mi: 0.5 * q + m,
            axial_n,
            damping_power_w: axial_d * len_rate + q_d * psi_rate + m_d * dw,
            chord: [ex, ey],
            length_m: len,
        }
    }

    /// Elastic strain energy at a state, J.
    pub fn strain_energy(&self, cm: f64, sm: f64, d: [f64; 2], dphi: f64) -> f64 {
        let e = (d[0] * d[0] + d[1] * d[1]).sqrt() - self.l0_m;
        let psi = chord_rotation(cm, sm, d);
        0.5 * (self.k_axial * e * e + self.k_psi * psi * psi + self.k_phi * dphi * dphi)
    }
}

/// Angle from the mean section direction (cm, sm), of any positive length, to the chord d, rad.
#[inline]
fn chord_rotation(cm: f64, sm: f64, d: [f64; 2]) -> f64 {
    let small = chord_rotation_small(cm, sm, d);
    if small.is_nan() {
        let cross = cm * d[1] - sm * d[0];
        let dot = cm * d[0] + sm * d[1];
        cross.atan2(dot)
    } else {
        small
    }
}

/// [`chord_rotation`] for the usual small angle, without a branch (so a loop over elements
/// vectorises): the atan series, error < x^9 / 9 ~ 1e-10 rad for x = tan(psi) within 0.1;
/// NaN outside that range (the caller then takes [`chord_rotation`]).
#[inline(always)]
pub fn chord_rotation_small(cm: f64, sm: f64, d: [f64; 2]) -> f64 {
    let cross = cm * d[1] - sm * d[0];
    let dot = cm * d[0] + sm * d[1];
    let x = cross / dot;
    let x2 = x * x;
    let series = x * (1.0 - x2 * (1.0 / 3.0 - x2 * (0.2 - x2 / 7.0)));
    if dot > 0.0 && x.abs() < 0.1 {
        series
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn element() -> BeamElement {
        let cfg = crate::config::DriveConfig::default_hvac().belt;
        BeamElement::new(&cfg, 0.011)
    }

    #[test]
    fn rigid_rotation_of_a_straight_pair_is_force_free() {
        let e = element();
        let a: f64 = 0.7;
        let d = [e.l0_m * a.cos(), e.l0_m * a.sin()];
        let f = e.force(a.cos(), a.sin(), d, [0.0, 0.0], 0.0, 0.0, 0.0);
        assert!(f.fx.abs() < 1e-9 && f.fy.abs() < 1e-9 && f.mj.abs() < 1e-12 && f.mi.abs() < 1e-12);
    }

    #[test]
    fn rigid_spin_of_a_straight_pair_is_undamped() {
        // Both bodies spin at w about body i: v_j - v_i = w x d; no deformation rate.
        let e = element();
        let w = 50.0;
        let d = [e.l0_m, 0.0];
        let dv = [-w * d[1], w * d[0]];
        let f = e.force(1.0, 0.0, d, dv, w, 0.0, 0.0);
        assert!(f.fx.abs() < 1e-9 && f.fy.abs() < 1e-9 && f.damping_power_w.abs() < 1e-9);
    }

    #[test]
    fn uniform_bending_gives_moment_ei_kappa_and_no_shear() {
        // Two bodies on an arc of radius R: moment ~ EI / R (Euler-Bernoulli limit within the
        // element's shear correction).
        let cfg = crate::config::DriveConfig::default_hvac().belt;
        let e = BeamElement::new(&cfg, 0.011);
        let r = 0.05;
        let b = e.l0_m / r;
        let d = [r * b.sin(), r * (1.0 - b.cos())];
        let (sm, cm) = (0.5 * b).sin_cos();
        let f = e.force(cm, sm, d, [0.0, 0.0], 0.0, b, 0.0);
        let expected = cfg.bending_stiffness_n_m2 / r;
        // Exact for the element: M = EI * phi / l0 = EI / R; the chord is l0 (1 - (l0/R)^2/24),
        // so the axial force is -EA (l0/R)^2/24 (~ -40 N here).
        assert!(
            (f.mj + expected).abs() < 1e-9 * expected,
            "mj = {}, EI/R = {expected}",
            f.mj
        );
        let chord_force = -cfg.axial_stiffness_n * (b * b / 24.0);
        assert!((f.axial_n - chord_force).abs() < 0.01 * chord_force.abs());
        assert!(f.fx.abs() > 0.0 || f.fy.abs() > 0.0);
    }

    #[test]
    fn element_is_free_of_net_moment() {
        let e = element();
        let d = [0.0105, 0.0012];
        let f = e.force(0.99f64, 0.1411, d, [0.3, -0.2], 4.0, 0.08, -3.0);
        // Moments about body i: M_i + M_j + d x F_j = 0.
        let net = f.mi + f.mj + (d[0] * f.fy - d[1] * f.fx);
        assert!(net.abs() < 1e-12);
    }
}

#[cfg(test)]
mod energy_consistency {
    use super::*;

    /// Generalised forces must be minus the gradient of the strain energy (conservative
    /// element), checked by central differences at a generic deformed state.
    #[test]
    fn forces_are_minus_the_energy_gradient() {
        let cfg = crate::config::DriveConfig::default_hvac().belt;
        let e = BeamElement::new(&cfg, 0.011);
        // State: (xi, yi, thi, xj, yj, thj).
        let s0: [f64; 6] = [0.001, -0.002, 0.3, 0.0115, 0.0021, 0.52];
        let energy = |s: &[f64; 6]| {
            let dphi = s[5] - s[2];
            let (sm, cm) = (s[2] + 0.5 * dphi).sin_cos();
            e.strain_energy(cm, sm, [s[3] - s[0], s[4] - s[1]], dphi)
        };
        let dphi = s0[5] - s0[2];
        let (sm, cm) = (s0[2] + 0.5 * dphi).sin_cos();
        let f = e.force(
            cm,
            sm,
            [s0[3] - s0[0], s0[4] - s0[1]],
            [0.0; 2],
            0.0,
            dphi,
            0.0,
        );
        let analytic = [-f.fx, -f.fy, f.mi, f.fx, f.fy, f.mj];
        for k in 0..6 {
            let h = 1e-7;
            let (mut sp, mut sn) = (s0, s0);
            sp[k] += h;
            sn[k] -= h;
            let numeric = -(energy(&sp) - energy(&sn)) / (2.0 * h);
            let scale = analytic[k].abs().max(1e-3);
            // Central differences with h = 1e-7 are accurate to ~1e-6 relative here.
            assert!(
                (numeric - analytic[k]).abs() < 1e-4 * scale,
                "component {k}: numeric {numeric}, analytic {}",
                analytic[k]
            );
        }
    }
}
