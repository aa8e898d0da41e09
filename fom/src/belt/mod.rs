//! The belt: a closed chain of N rigid segments (finite segment method, seed paper section 3.2)
//! joined by Timoshenko beam-force elements. Element e joins segment e to segment e + 1 (mod N).

pub mod beam;
pub mod teeth;

use crate::config::BeltConfig;
use beam::{BeamElement, BeamForce};
use std::f64::consts::PI;

/// Viscoelastic arm of every axial element: a spring k2 in series with a dashpot c = k2 tau,
/// parallel to the elastic axial spring (standard linear solid, Zener; Findley, Lai & Onaran,
/// Creep and Relaxation of Nonlinear Viscoelastic Materials, 1976, sec. 5.2). The arm's force
/// obeys dF/dt = k2 dx/dt - F / tau, integrated exactly over a step at constant extension rate.
/// The extension increment is the element's own chord-length change over the step: a rate from
/// the velocities misses the chord growth of a rotating element (first order in the step) and
/// made the arm dissipate 6-10 % less than the law on the elements' strain histories.
#[derive(Debug, Clone)]
pub struct AxialHysteresis {
    /// Arm stiffness k2 per element, N/m.
    pub stiffness_n_m: f64,
    /// Relaxation time tau, s.
    pub relaxation_s: f64,
    /// exp(-dt / tau) and k2 tau (1 - exp(-dt / tau)) for the step dt.
    decay: f64,
    gain: f64,
    /// 1 / c = 1 / (k2 tau), m/(N s).
    inv_damping_m_n_s: f64,
    step_s: f64,
    /// Each element's chord length at the previous step, m.
    length_m: Vec<f64>,
    /// The arm's force in each element, N.
    pub force_n: Vec<f64>,
    /// Energy the arms' dashpots have dissipated, J.
    pub dissipated_j: f64,
}

impl AxialHysteresis {
    /// Arms of stiffness `stiffness_n_m` and relaxation time `relaxation_s`, unloaded, on
    /// elements of chord lengths `length_m`, for steps of `step_s`.
    pub fn new(length_m: Vec<f64>, stiffness_n_m: f64, relaxation_s: f64, step_s: f64) -> Self {
        let n = length_m.len();
        let mut arms = Self {
            stiffness_n_m,
            relaxation_s,
            decay: 0.0,
            gain: 0.0,
            inv_damping_m_n_s: 1.0 / (stiffness_n_m * relaxation_s),
            step_s,
            length_m,
            force_n: vec![0.0; n],
            dissipated_j: 0.0,
        };
        arms.set_step(step_s);
        arms
    }

    /// Sets the step the arms advance by, s.
    pub fn set_step(&mut self, step_s: f64) {
        self.decay = (-step_s / self.relaxation_s).exp();
        self.gain = self.stiffness_n_m * self.relaxation_s * (1.0 - self.decay);
        self.step_s = step_s;
    }

    /// Advances every arm by one step to its element's chord length (from the node positions
    /// `x`, `y`, computed as `BeamElement::force_at` does) and adds its force along the chord
    /// to the elements' forces `efx`, `efy` (on node j; i takes the negative), axial forces
    /// `axial_n` and damping powers `damping_w` (the dashpot's f^2 / c). Counts the energy
    /// the dashpots dissipate over the step.
    fn advance(
        &mut self,
        x: &[f64],
        y: &[f64],
        efx: &mut [f64],
        efy: &mut [f64],
        axial_n: &mut [f64],
        damping_w: &mut [f64],
    ) {
        let n = x.len();
        let (lengths, forces) = (&mut self.length_m[..n], &mut self.force_n[..n]);
        let (y, efx, efy) = (&y[..n], &mut efx[..n], &mut efy[..n]);
        let (axial_n, damping_w) = (&mut axial_n[..n], &mut damping_w[..n]);
        let mut power_sum_w = 0.0;
        for e in 0..n {
            let j = if e + 1 == n { 0 } else { e + 1 };
            let d = [x[j] - x[e], y[j] - y[e]];
            let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
            let inv_len = 1.0 / len;
            let rate_m_s = (len - lengths[e]) / self.step_s;
            lengths[e] = len;
            let f = self.decay * forces[e] + self.gain * rate_m_s;
            forces[e] = f;
            let power_w = f * f * self.inv_damping_m_n_s;
            efx[e] -= f * (d[0] * inv_len);
            efy[e] -= f * (d[1] * inv_len);
            axial_n[e] += f;
            damping_w[e] += power_w;
            power_sum_w += power_w;
        }
        self.dissipated_j += power_sum_w * self.step_s;
    }

    /// Energy stored in the arms' springs, sum f^2 / (2 k2), J.
    pub fn stored_energy_j(&self) -> f64 {
        self.force_n.iter().map(|f| f * f).sum::<f64>() / (2.0 * self.stiffness_n_m)
    }
}

/// Planar state of all segments, struct-of-arrays for the step loop.
#[derive(Debug, Clone)]
pub struct Belt {
    pub n: usize,
    /// Segment mass rho_A * l0, kg.
    pub mass_kg: f64,
    /// Segment rotary inertia rho_A * l0^3 / 12 (thin rod), kg m^2.
    pub inertia_kg_m2: f64,
    /// Half thickness: distance from the pitch line to the pulley-side surface, m.
    pub half_thickness_m: f64,
    pub element: BeamElement,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Continuous angle, grows by 2 pi around the loop (theta[N-1] ~ theta[0] + 2 pi).
    pub th: Vec<f64>,
    /// Unit direction (cos theta, sin theta) of each segment, advanced with theta so that the
    /// step needs no trigonometric calls (`rotate_directions`).
    pub cth: Vec<f64>,
    pub sth: Vec<f64>,
    pub vx: Vec<f64>,
    pub vy: Vec<f64>,
    pub w: Vec<f64>,
    /// Accumulated forces and moments of the current step.
    pub fx: Vec<f64>,
    pub fy: Vec<f64>,
    pub tq: Vec<f64>,
    /// Axial force of each element at the last force evaluation, N.
    pub axial_n: Vec<f64>,
    /// Viscoelastic arm of the axial elements (an effect; none in the baseline).
    pub hysteresis: Option<AxialHysteresis>,
    // Per-element forces of the last evaluation (force on j, moments on j and i).
    efx: Vec<f64>,
    efy: Vec<f64>,
    emj: Vec<f64>,
    emi: Vec<f64>,
    /// Power dissipated by each element's damping at the last evaluation, W.
    edamp_w: Vec<f64>,
}

impl Belt {
    /// Segments of unstretched length l0 = L0 / N placed at `poses` (x, y, theta).
    pub fn new(cfg: &BeltConfig, unstretched_length_m: f64, poses: &[([f64; 2], f64)]) -> Self {
        let n = poses.len();
        let l0 = unstretched_length_m / n as f64;
        let mass_kg = cfg.mass_per_length_kg_m * l0;
        Self {
            n,
            mass_kg,
            inertia_kg_m2: mass_kg * l0 * l0 / 12.0,
            half_thickness_m: 0.5 * cfg.thickness_m,
            element: BeamElement::new(cfg, l0),
            x: poses.iter().map(|p| p.0[0]).collect(),
            y: poses.iter().map(|p| p.0[1]).collect(),
            th: poses.iter().map(|p| p.1).collect(),
            cth: poses.iter().map(|p| p.1.cos()).collect(),
            sth: poses.iter().map(|p| p.1.sin()).collect(),
            vx: vec![0.0; n],
            vy: vec![0.0; n],
            w: vec![0.0; n],
            fx: vec![0.0; n],
            fy: vec![0.0; n],
            tq: vec![0.0; n],
            axial_n: vec![0.0; n],
            hysteresis: None,
            efx: vec![0.0; n],
            efy: vec![0.0; n],
            emj: vec![0.0; n],
            emi: vec![0.0; n],
            edamp_w: vec![0.0; n],
        }
    }

    /// Advances the angles by w dt and rotates the unit directions by the same angle
    /// (Taylor series of cos and sin to 5th order: exact to rounding for |w dt| < 0.01).
    #[inline(always)]
    pub fn rotate_directions(&mut self, dt: f64) {
        for i in 0..self.n {
            let a = self.w[i] * dt;
            let a2 = a * a;
            let ca = 1.0 - 0.5 * a2 * (1.0 - a2 / 12.0);
            let sa = a * (1.0 - a2 / 6.0 * (1.0 - a2 / 20.0));
            let (c, s) = (self.cth[i], self.sth[i]);
            self.cth[i] = c * ca - s * sa;
            self.sth[i] = s * ca + c * sa;
            self.th[i] += a;
        }
    }

    /// Re-derives the unit directions from the angles (removes rounding drift).
    pub fn renormalise_directions(&mut self) {
        for i in 0..self.n {
            let (s, c) = self.th[i].sin_cos();
            self.cth[i] = c;
            self.sth[i] = s;
        }
    }

    /// Angle difference across element e, with the loop closure removed.
    #[inline]
    fn dphi(&self, e: usize, j: usize) -> f64 {
        let d = self.th[j] - self.th[e];
        if j == 0 {
            d + 2.0 * PI
        } else {
            d
        }
    }

    /// Mean section direction of element e, unnormalised: the sum of its segments' unit
    /// directions points at angle (theta_e + theta_j) / 2 for |theta_j - theta_e| < pi. The
    /// element only uses it through an angle, so its length does not matter.
    #[inline]
    fn mean_direction(&self, e: usize, j: usize) -> (f64, f64) {
        (self.cth[e] + self.cth[j], self.sth[e] + self.sth[j])
    }

    #[inline]
    fn element_force(&self, e: usize, j: usize) -> BeamForce {
        let d = [self.x[j] - self.x[e], self.y[j] - self.y[e]];
        let dv = [self.vx[j] - self.vx[e], self.vy[j] - self.vy[e]];
        let (cm, sm) = self.mean_direction(e, j);
        let wm = 0.5 * (self.w[e] + self.w[j]);
        self.element
            .force(cm, sm, d, dv, wm, self.dphi(e, j), self.w[j] - self.w[e])
    }

    /// Sets the force accumulators to gravity plus all beam-element forces.
    /// Returns the power dissipated by the elements' damping, W.
    #[inline(always)]
    pub fn assemble_internal_forces(&mut self, gravity: [f64; 2]) -> f64 {
        self.element_pass();
        if let Some(h) = &mut self.hysteresis {
            h.advance(
                &self.x,
                &self.y,
                &mut self.efx,
                &mut self.efy,
                &mut self.axial_n,
                &mut self.edamp_w,
            );
        }
        let diss = self.edamp_w.iter().sum();
        // Node pass: segment i is "j" of element i - 1 and "i" of element i.
        let n = self.n;
        let (gx, gy) = (self.mass_kg * gravity[0], self.mass_kg * gravity[1]);
        for i in 0..n {
            let p = if i == 0 { n - 1 } else { i - 1 };
            self.fx[i] = gx + self.efx[p] - self.efx[i];
            self.fy[i] = gy + self.efy[p] - self.efy[i];
            self.tq[i] = self.emj[p] + self.emi[i];
        }
        diss
    }

    /// The element pass: elements 0..N-2 in one branch-free loop over the segment arrays and
    /// their one-ahead shifts, which the compiler vectorises; the closing element and any
    /// element whose chord rotation is not small (NaN from `chord_rotation_small`) again
    /// through `element_force`. Fills the per-element forces, moments, axial forces and
    /// damping powers.
    #[inline(always)]
    fn element_pass(&mut self) {
        let n = self.n;
        let m = n - 1;
        let el = self.element;
        let (x0, x1) = (&self.x[..m], &self.x[1..]);
        let (y0, y1) = (&self.y[..m], &self.y[1..]);
        let (vx0, vx1) = (&self.vx[..m], &self.vx[1..]);
        let (vy0, vy1) = (&self.vy[..m], &self.vy[1..]);
        let (w0, w1) = (&self.w[..m], &self.w[1..]);
        let (th0, th1) = (&self.th[..m], &self.th[1..]);
        let (c0, c1) = (&self.cth[..m], &self.cth[1..]);
        let (s0, s1) = (&self.sth[..m], &self.sth[1..]);
        let (efx, efy) = (&mut self.efx[..m], &mut self.efy[..m]);
        let (emj, emi) = (&mut self.emj[..m], &mut self.emi[..m]);
        let (axial, edamp) = (&mut self.axial_n[..m], &mut self.edamp_w[..m]);
        for e in 0..m {
            let d = [x1[e] - x0[e], y1[e] - y0[e]];
            let dv = [vx1[e] - vx0[e], vy1[e] - vy0[e]];
            let (cm, sm) = (c0[e] + c1[e], s0[e] + s1[e]);
            let psi = beam::chord_rotation_small(cm, sm, d);
            let f = el.force_at(
                psi,
                d,
                dv,
                0.5 * (w0[e] + w1[e]),
                th1[e] - th0[e],
                w1[e] - w0[e],
            );
            efx[e] = f.fx;
            efy[e] = f.fy;
            emj[e] = f.mj;
            emi[e] = f.mi;
            axial[e] = f.axial_n;
            edamp[e] = f.damping_power_w;
        }
        for e in 0..n {
            if e == m || self.emi[e].is_nan() {
                let j = if e == m { 0 } else { e + 1 };
                let f = self.element_force(e, j);
                self.efx[e] = f.fx;
                self.efy[e] = f.fy;
                self.emj[e] = f.mj;
                self.emi[e] = f.mi;
                self.axial_n[e] = f.axial_n;
                self.edamp_w[e] = f.damping_power_w;
            }
        }
    }

    /// Kinetic energy of the belt, J.
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for i in 0..self.n {
            e += 0.5 * self.mass_kg * (self.vx[i] * self.vx[i] + self.vy[i] * self.vy[i])
                + 0.5 * self.inertia_kg_m2 * self.w[i] * self.w[i];
        }
        e
    }

    /// Elastic energy of the beam elements plus gravitational potential energy, J.
    pub fn potential_energy(&self, gravity: [f64; 2]) -> f64 {
        let mut e = 0.0;
        for k in 0..self.n {
            let j = if k + 1 == self.n { 0 } else { k + 1 };
            let (cm, sm) = self.mean_direction(k, j);
            let d = [self.x[j] - self.x[k], self.y[j] - self.y[k]];
            e += self.element.strain_energy(cm, sm, d, self.dphi(k, j));
            e -= self.mass_kg * (gravity[0] * self.x[k] + gravity[1] * self.y[k]);
        }
        if let Some(h) = &self.hysteresis {
            e += h.stored_energy_j();
        }
        e
    }

    /// Chord length of every element, m.
    pub fn element_lengths_m(&self) -> Vec<f64> {
        (0..self.n)
            .map(|e| {
                let j = if e + 1 == self.n { 0 } else { e + 1 };
                (self.x[j] - self.x[e]).hypot(self.y[j] - self.y[e])
            })
            .collect()
    }

    /// Index of the element whose midpoint is nearest to `p`.
    pub fn element_nearest(&self, p: [f64; 2]) -> usize {
        let mut best = (f64::INFINITY, 0);
        for e in 0..self.n {
            let j = if e + 1 == self.n { 0 } else { e + 1 };
            let mx = 0.5 * (self.x[e] + self.x[j]) - p[0];
            let my = 0.5 * (self.y[e] + self.y[j]) - p[1];
            let d2 = mx * mx + my * my;
            if d2 < best.0 {
                best = (d2, e);
            }
        }
        best.1
    }

    /// Axial force along the belt: (arc length from `start` element, force), following travel.
    pub fn tension_profile(&self, start: usize) -> Vec<(f64, f64)> {
        let mut out = Vec::with_capacity(self.n);
        let mut s = 0.0;
        for k in 0..self.n {
            let e = (start + k) % self.n;
            let j = (e + 1) % self.n;
            let len = (self.x[j] - self.x[e]).hypot(self.y[j] - self.y[e]);
            out.push((s + 0.5 * len, self.axial_n[e]));
            s += len;
        }
        out
    }

    /// True when every state value is finite.
    pub fn is_finite(&self) -> bool {
        self.x
            .iter()
            .chain(&self.y)
            .chain(&self.th)
            .chain(&self.vx)
            .chain(&self.vy)
            .chain(&self.w)
            .all(|v| v.is_finite())
    }
}
