//! Tooth-groove contact of a toothed (synchronous) belt: the nonlinear hysteresis normal force
//! of seed paper "arc-tooth-synchronous-belt-recurdyn" eq. 3 and its stick-slip friction
//! (eq. 4-5), at the contact points of each belt tooth (`belt::teeth`) against the circular-arc
//! grooves of the pulleys, with a side gap (backlash) between tooth and groove.
//!
//! Groove geometry: pulley `j` has z = 2 pi r / p grooves, groove k centred at the angle
//! theta_j + phase_j + 2 pi k / z; its profile is a circular arc of radius R_g = R_t + g / 2
//! centred on the land circle (radius r - pitch_line_offset), so a tooth centred in its groove
//! has the clearance g / 2 on each flank and at the tip: the side gap g is the groove's width
//! less the tooth's at the land line. A tooth point inside the land circle and outside the
//! groove arc is in the pulley: its penetration is its distance from the groove centre less
//! R_g (paper eq. 2 with the groove arc as the target surface).
//!
//! Numerics: the normal force is explicit (the tooth stiffness, ~1e6 N/m, is far below the
//! cord's axial stiffness per element, which sets the step; `ToothMesh::stable_step_limit_s`
//! checks it), the friction implicit per contact point like the land contact's
//! (`FrictionLaw::solve_implicit`).

pub use crate::config::ToothContactConfig;
use std::f64::consts::PI;

use super::FrictionLaw;
use crate::belt::teeth::{contact_points, ToothRegion, POINTS_PER_TOOTH};
use crate::belt::Belt;
use crate::config::TeethConfig;
use crate::pulley::Pulley;

impl ToothContactConfig {
    /// The stick-slip friction of eq. 4-5 as the land contact's Stribeck law: the coefficient
    /// rises from 0 at rest to about mu_s at v_s (the regularisation tanh(v / v_s)) and falls
    /// to mu_d at v_d along the cubic step.
    pub fn friction_law(&self) -> FrictionLaw {
        FrictionLaw::Stribeck {
            static_mu: self.static_friction,
            dynamic_mu: self.dynamic_friction,
            stribeck_speed_m_s: self.dynamic_speed_m_s,
            velocity_threshold_m_s: self.static_speed_m_s,
        }
    }
}

/// The haversine step from h0 at x0 to h1 at x1: h0 + (h1 - h0) (1 - cos(pi s)) / 2,
/// s = (x - x0) / (x1 - x0) clamped to [0, 1] (RecurDyn's HAVSIN step, used by seed paper
/// "arc-tooth-synchronous-belt-recurdyn" eq. 3).
#[inline]
pub fn haversine_step(x: f64, x0: f64, h0: f64, x1: f64, h1: f64) -> f64 {
    let s = ((x - x0) / (x1 - x0)).clamp(0.0, 1.0);
    h0 + (h1 - h0) * 0.5 * (1.0 - (PI * s).cos())
}

/// Normal force of one contact point, seed paper "arc-tooth-synchronous-belt-recurdyn" eq. 3:
/// F = K delta^m1 + step(delta, 0, 0, delta_max, c0) sign(v) |v|^m2 delta^m3, at penetration
/// `delta_m` > 0 and penetration rate `rate_m_s` (positive while penetrating); never pulling
/// (F >= 0). Returns (F, its damping part), N.
#[inline]
pub fn hysteresis_normal_force_n(
    stiffness: f64,
    c: &ToothContactConfig,
    delta_m: f64,
    rate_m_s: f64,
) -> (f64, f64) {
    if delta_m <= 0.0 {
        return (0.0, 0.0);
    }
    let elastic = if c.stiffness_exponent == 1.0 {
        stiffness * delta_m
    } else {
        stiffness * delta_m.powf(c.stiffness_exponent)
    };
    let damping_coeff = haversine_step(
        delta_m,
        0.0,
        0.0,
        c.damping_full_penetration_m,
        c.damping_c0,
    );
    let rate = if c.damping_exponent == 1.0 {
        rate_m_s
    } else {
        rate_m_s.signum() * rate_m_s.abs().powf(c.damping_exponent)
    };
    let indent = if c.indentation_exponent == 1.0 {
        delta_m
    } else {
        delta_m.powf(c.indentation_exponent)
    };
    let damping = damping_coeff * rate * indent;
    let total = (elastic + damping).max(0.0);
    (total, total - elastic)
}

/// The grooves of one pulley.
#[derive(Debug, Clone, Copy)]
struct Grooves {
    count: usize,
    /// Angle of groove 0 at pulley angle 0, rad.
    phase_rad: f64,
    /// Radius of the land circle (outside diameter / 2), m.
    land_radius_m: f64,
    /// Radius of the circle the groove arcs are centred on, m: the land circle, or outside it
    /// by g / 2 - tip clearance (`ToothContactConfig::tip_clearance_m`).
    centre_radius_m: f64,
}

/// One active contact point of a step, kept for the friction solve.
#[derive(Debug, Clone, Copy)]
struct PointContact {
    tooth: usize,
    point: usize,
    pulley: usize,
    /// Contact point, m.
    px: f64,
    py: f64,
    /// Unit normal of the force on the tooth (towards the groove centre).
    mx: f64,
    my: f64,
    normal_n: f64,
}

/// Loads of every tooth at one instant: normal force on flank a, flank b and the tip, N.
pub type ToothLoads = [f64; 3];

/// The tooth-groove contact of a toothed belt against all pulleys, with its state.
#[derive(Debug, Clone)]
pub struct ToothMesh {
    /// Belt segments per tooth; tooth i sits on segment i * stride.
    pub stride: usize,
    pub teeth: usize,
    pub pitch_m: f64,
    pitch_line_offset_m: f64,
    /// Radius of the tooth arc R_t, m.
    pub tooth_radius_m: f64,
    groove_radius_m: f64,
    /// Penalty stiffness K per contact point on the flanks and the tip (eq. 3), N/m^m1.
    pub flank_point_stiffness: f64,
    pub tip_point_stiffness: f64,
    pub law: ToothContactConfig,
    friction: FrictionLaw,
    points: [(f64, f64, ToothRegion); POINTS_PER_TOOTH],
    grooves: Vec<Grooves>,
    contacts: Vec<PointContact>,
    /// Reaction torque of the tooth normal forces on each pulley during the step, N m.
    normal_torque_nm: Vec<f64>,
    friction_v_prev: Vec<f64>,
    /// This step's loads per tooth.
    pub loads_n: Vec<ToothLoads>,
    /// Largest penetration of a tooth point since the last reset, m.
    pub max_penetration_m: f64,
}

impl ToothMesh {
    /// The mesh of a belt of `segments` segments with these teeth and contact law, on pulleys
    /// of the given pitch radii.
    pub fn new(
        teeth: &TeethConfig,
        law: &ToothContactConfig,
        segments: usize,
        pitch_radii_m: &[f64],
    ) -> Result<Self, String> {
        if !segments.is_multiple_of(teeth.count) {
            return Err(format!(
                "belt.segments = {segments} must be a multiple of belt.teeth.count = {} (each \
                 tooth sits on a segment)",
                teeth.count
            ));
        }
        let points = contact_points();
        let (flank_point_stiffness, tip_point_stiffness) = point_stiffnesses(
            &points,
            teeth.flank_stiffness_n_m(),
            teeth.tip_stiffness_n_m(),
        )?;
        // With m1 != 1 the stiffness is matched at 0.1 mm penetration.
        let scale = 1e-4_f64.powf(1.0 - law.stiffness_exponent);
        let mut grooves = Vec::with_capacity(pitch_radii_m.len());
        for (j, &r) in pitch_radii_m.iter().enumerate() {
            let z = 2.0 * PI * r / teeth.pitch_m;
            let count = z.round();
            if (z - count).abs() > 1e-3 * z || count < 6.0 {
                return Err(format!(
                    "pulley {j}: pitch diameter {:.6} m holds {z:.4} teeth of pitch {} m; a \
                     toothed pulley needs a whole number (pitch diameter = z p / pi)",
                    2.0 * r,
                    teeth.pitch_m
                ));
            }
            grooves.push(Grooves {
                count: count as usize,
                phase_rad: 0.0,
                land_radius_m: r - teeth.pitch_line_offset_m,
                centre_radius_m: r - teeth.pitch_line_offset_m + 0.5 * law.side_gap_m
                    - law.tip_clearance_m.unwrap_or(0.5 * law.side_gap_m),
            });
        }
        Ok(Self {
            stride: segments / teeth.count,
            teeth: teeth.count,
            pitch_m: teeth.pitch_m,
            pitch_line_offset_m: teeth.pitch_line_offset_m,
            tooth_radius_m: teeth.profile_radius_m,
            groove_radius_m: teeth.profile_radius_m + 0.5 * law.side_gap_m,
            flank_point_stiffness: flank_point_stiffness * scale,
            tip_point_stiffness: tip_point_stiffness * scale,
            law: law.clone(),
            friction: law.friction_law(),
            points,
            grooves,
            contacts: Vec::new(),
            normal_torque_nm: vec![0.0; pitch_radii_m.len()],
            friction_v_prev: vec![0.0; teeth.count * POINTS_PER_TOOTH],
            loads_n: vec![[0.0; 3]; teeth.count],
            max_penetration_m: 0.0,
        })
    }

    /// Centre of tooth `i`'s arc (on the land line) and the segment's frame: (centre, t, n).
    #[inline]
    fn tooth_frame(&self, b: &Belt, i: usize) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let s = i * self.stride;
        let t = [b.cth[s], b.sth[s]];
        // The loop runs counter-clockwise (geometry::OpenBeltPath): inside is on the left.
        let n = [-t[1], t[0]];
        let c = [
            b.x[s] + self.pitch_line_offset_m * n[0],
            b.y[s] + self.pitch_line_offset_m * n[1],
        ];
        (c, t, n)
    }

    /// Centre of pulley `j`'s groove nearest the point `c` (a tooth's arc centre), m, and the
    /// groove's angle in the fixed frame, rad.
    #[inline]
    fn nearest_groove(&self, p: &Pulley, j: usize, c: [f64; 2]) -> ([f64; 2], f64) {
        let o = p.contact_center_m;
        let g = self.grooves[j];
        let pitch_angle = 2.0 * PI / g.count as f64;
        let rel = (c[1] - o[1]).atan2(c[0] - o[0]) - p.angle_rad - g.phase_rad;
        let theta = p.angle_rad + g.phase_rad + (rel / pitch_angle).round() * pitch_angle;
        let cg = [
            o[0] + g.centre_radius_m * theta.cos(),
            o[1] + g.centre_radius_m * theta.sin(),
        ];
        (cg, theta)
    }

    /// Penalty stiffness of a contact point in `region` (eq. 3's K), N/m^m1.
    #[inline]
    fn point_stiffness(&self, region: ToothRegion) -> f64 {
        if region == ToothRegion::Tip {
            self.tip_point_stiffness
        } else {
            self.flank_point_stiffness
        }
    }

    /// Penetration of the tooth point at (cos phi, sin phi) = (`cp`, `sp`) of a tooth with
    /// frame (`c`, `t`, `n`) into pulley `j`'s groove centred at `cg`: the point, its
    /// penetration (m) and the groove's outward unit normal there; `None` outside the land
    /// circle (no groove wall) or without penetration.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn point_penetration(
        &self,
        p: &Pulley,
        j: usize,
        (c, t, n): ([f64; 2], [f64; 2], [f64; 2]),
        cg: [f64; 2],
        cp: f64,
        sp: f64,
    ) -> Option<([f64; 2], f64, [f64; 2])> {
        let o = p.contact_center_m;
        let land = self.grooves[j].land_radius_m;
        let px = c[0] + self.tooth_radius_m * (cp * t[0] + sp * n[0]);
        let py = c[1] + self.tooth_radius_m * (cp * t[1] + sp * n[1]);
        let (ex, ey) = (px - o[0], py - o[1]);
        if ex * ex + ey * ey >= land * land {
            return None;
        }
        let (gx, gy) = (px - cg[0], py - cg[1]);
        let dist = gx.hypot(gy);
        let delta = dist - self.groove_radius_m;
        (delta > 0.0).then(|| ([px, py], delta, [gx / dist, gy / dist]))
    }

    /// Turns each pulley's grooves so that the tooth nearest the middle of its wrap sits centred
    /// in a groove (the belt as installed; the others are off by the pitch difference only).
    pub fn align_grooves(&mut self, b: &Belt, pulleys: &[Pulley]) {
        for (j, p) in pulleys.iter().enumerate() {
            let o = p.contact_center_m;
            let g = self.grooves[j];
            // The wrapped teeth and the mean direction of the wrap.
            let mut best: Option<(f64, f64)> = None;
            let (mut sx, mut sy) = (0.0, 0.0);
            let mut wrapped = Vec::new();
            for i in 0..self.teeth {
                let (c, _, _) = self.tooth_frame(b, i);
                let (dx, dy) = (c[0] - o[0], c[1] - o[1]);
                let r = dx.hypot(dy);
                if (r - g.land_radius_m).abs() < 0.5 * self.tooth_radius_m {
                    sx += dx / r;
                    sy += dy / r;
                    wrapped.push(dy.atan2(dx));
                }
            }
            let mid = sy.atan2(sx);
            for a in wrapped {
                let off = wrap_angle(a - mid).abs();
                if best.is_none_or(|(_, o)| off < o) {
                    best = Some((a, off));
                }
            }
            if let Some((a, _)) = best {
                self.grooves[j].phase_rad = a - p.angle_rad;
            }
        }
    }

    /// Step part 1: the explicit normal forces of eq. 3 at every tooth point in a groove, added
    /// to the segments' forces; their reaction torques are kept for `add_reaction_torques`.
    /// Returns the power the contact damping dissipates, W.
    pub fn normal_forces(&mut self, b: &mut Belt, pulleys: &[Pulley]) -> f64 {
        self.contacts.clear();
        self.normal_torque_nm.iter_mut().for_each(|t| *t = 0.0);
        self.loads_n.iter_mut().for_each(|l| *l = [0.0; 3]);
        let mut dissipated_w = 0.0;
        let reach = self.tooth_radius_m + self.pitch_line_offset_m;
        for (j, p) in pulleys.iter().enumerate() {
            let o = p.contact_center_m;
            let near = self.grooves[j].land_radius_m + reach;
            for i in 0..self.teeth {
                let s = i * self.stride;
                let frame = self.tooth_frame(b, i);
                let c = frame.0;
                let (dx, dy) = (c[0] - o[0], c[1] - o[1]);
                if dx * dx + dy * dy > near * near {
                    continue;
                }
                let (cg, _) = self.nearest_groove(p, j, c);
                for (q, &(cp, sp, region)) in self.points.iter().enumerate() {
                    let Some(([px, py], delta, [ux, uy])) =
                        self.point_penetration(p, j, frame, cg, cp, sp)
                    else {
                        continue;
                    };
                    let (ex, ey) = (px - o[0], py - o[1]);
                    self.max_penetration_m = self.max_penetration_m.max(delta);
                    // Velocity of the tooth point less the pulley surface's there.
                    let (rx, ry) = (px - b.x[s], py - b.y[s]);
                    let vx = b.vx[s] - b.w[s] * ry + p.omega_rad_s * ey;
                    let vy = b.vy[s] + b.w[s] * rx - p.omega_rad_s * ex;
                    let rate = vx * ux + vy * uy;
                    let (f, f_damp) = hysteresis_normal_force_n(
                        self.point_stiffness(region),
                        &self.law,
                        delta,
                        rate,
                    );
                    if f <= 0.0 {
                        continue;
                    }
                    dissipated_w += f_damp * rate;
                    let (mx, my) = (-ux, -uy);
                    // Applied at the cord node, without a moment on the segment: the tooth's
                    // bending is in its stiffness (belt::teeth), and its root moment is taken
                    // by the land's pressure on the pulley, which one contact node per
                    // segment cannot carry; applied at the point, the segment rocked on its
                    // node and the tooth was several times softer than its rubber (test
                    // load_sharing_over_the_wrap_follows_the_tooth_spring_distribution).
                    b.fx[s] += f * mx;
                    b.fy[s] += f * my;
                    // Reaction on the pulley: -F m at the point, moment about the shaft.
                    self.normal_torque_nm[j] -= ex * f * my - ey * f * mx;
                    self.loads_n[i][region as usize] += f;
                    self.contacts.push(PointContact {
                        tooth: i,
                        point: q,
                        pulley: j,
                        px,
                        py,
                        mx,
                        my,
                        normal_n: f,
                    });
                }
            }
        }
        dissipated_w
    }

    /// Adds this step's normal-force reaction torques to the belt torque on each pulley.
    pub fn add_reaction_torques(&self, belt_torque_nm: &mut [f64]) {
        for (t, r) in belt_torque_nm.iter_mut().zip(&self.normal_torque_nm) {
            *t += r;
        }
    }

    /// Step part 3: implicit stick-slip friction (eq. 4-5) at every contact point of the step,
    /// on the velocities after the explicit forces, against the pulley surface moving at
    /// `omega_surface`. Impulses go to the segment's node, reactions to the pulleys' belt
    /// torque. Returns the power friction dissipates, W.
    pub fn friction(
        &mut self,
        b: &mut Belt,
        pulleys: &[Pulley],
        omega_surface: &[f64],
        dt: f64,
        belt_torque_nm: &mut [f64],
    ) -> f64 {
        if !self.friction.is_active() {
            return 0.0;
        }
        let inv_m = 1.0 / b.mass_kg;
        let mut dissipated_w = 0.0;
        for ct in &self.contacts {
            let s = ct.tooth * self.stride;
            let o = pulleys[ct.pulley].contact_center_m;
            let w = omega_surface[ct.pulley];
            let (tx, ty) = (-ct.my, ct.mx);
            let (rx, ry) = (ct.px - b.x[s], ct.py - b.y[s]);
            let (ex, ey) = (ct.px - o[0], ct.py - o[1]);
            let vx = b.vx[s] - b.w[s] * ry + w * ey;
            let vy = b.vy[s] + b.w[s] * rx - w * ex;
            let v_pred = vx * tx + vy * ty;
            // At the node, like the normal force: the impulse moves the segment, not its angle.
            let slot = ct.tooth * POINTS_PER_TOOTH + ct.point;
            let (v, dv) = self.friction.solve_implicit(
                v_pred,
                ct.normal_n,
                inv_m,
                dt,
                self.friction_v_prev[slot],
            );
            self.friction_v_prev[slot] = v;
            let impulse = dv / inv_m;
            b.vx[s] += impulse * inv_m * tx;
            b.vy[s] += impulse * inv_m * ty;
            let force = impulse / dt;
            belt_torque_nm[ct.pulley] -= ex * force * ty - ey * force * tx;
            // The force does work at the node, its reaction at the point on the pulley: the
            // power lost is F (v_node - v_surface), the slip velocity less the segment's
            // rotation about the node (w x r). Counted at the point's slip, the ledger took
            // 16 J of a 0.3 s run as dissipated that the run had not lost (energy balance
            // off by -14 %; it closed with the teeth's friction off).
            let v_node = v - b.w[s] * (rx * ty - ry * tx);
            dissipated_w -= force * v_node;
        }
        dissipated_w
    }

    /// Elastic energy stored in the tooth contacts at the current positions, J
    /// (K delta^(m1+1) / (m1+1), eq. 3's elastic part integrated).
    pub fn elastic_energy_j(&self, b: &Belt, pulleys: &[Pulley]) -> f64 {
        let mut e = 0.0;
        let m1 = self.law.stiffness_exponent;
        for (j, p) in pulleys.iter().enumerate() {
            for i in 0..self.teeth {
                let frame = self.tooth_frame(b, i);
                let (cg, _) = self.nearest_groove(p, j, frame.0);
                for &(cp, sp, region) in &self.points {
                    if let Some((_, delta, _)) = self.point_penetration(p, j, frame, cg, cp, sp) {
                        e += self.point_stiffness(region) * delta.powf(m1 + 1.0) / (m1 + 1.0);
                    }
                }
            }
        }
        e
    }

    /// Largest stable step of the explicit tooth contact on a segment of mass `mass_kg`: a
    /// fully engaged tooth (all its points) is a spring of at most the sum of its points'
    /// stiffnesses on the segment's node; symplectic Euler needs omega dt < 2 (Hairer, Lubich &
    /// Wanner, Geometric Numerical Integration, sec. I.1), s.
    pub fn stable_step_limit_s(&self, mass_kg: f64) -> f64 {
        let k_total: f64 = self
            .points
            .iter()
            .map(|p| self.point_stiffness(p.2))
            .sum::<f64>()
            * 1e-4_f64.powf(self.law.stiffness_exponent - 1.0);
        2.0 / (k_total / mass_kg).sqrt()
    }

    /// Angle of tooth `i` about pulley `j`'s centre in the fixed frame, and whether its arc
    /// centre lies within a tooth height of the land circle (the tooth is in the wrap), rad.
    pub fn tooth_angle_rad(&self, b: &Belt, pulleys: &[Pulley], i: usize, j: usize) -> (f64, bool) {
        let (c, _, _) = self.tooth_frame(b, i);
        let o = pulleys[j].contact_center_m;
        let (dx, dy) = (c[0] - o[0], c[1] - o[1]);
        let wrapped = (dx.hypot(dy) - self.grooves[j].land_radius_m).abs() < self.tooth_radius_m;
        (dy.atan2(dx), wrapped)
    }

    /// Offset of tooth `i`'s arc centre from the centre of its nearest groove on pulley `j`, in
    /// the groove's frame: (along the pulley's rotation, outward radial), m.
    pub fn groove_offset_m(&self, b: &Belt, pulleys: &[Pulley], i: usize, j: usize) -> (f64, f64) {
        let (c, _, _) = self.tooth_frame(b, i);
        let (cg, theta) = self.nearest_groove(&pulleys[j], j, c);
        let (u, v) = (theta.cos(), theta.sin());
        let (dx, dy) = (c[0] - cg[0], c[1] - cg[1]);
        (-dx * v + dy * u, dx * u + dy * v)
    }

    /// Number of grooves on pulley `j`.
    pub fn groove_count(&self, j: usize) -> usize {
        self.grooves[j].count
    }
}

/// Penalty stiffness per contact point on the flanks and on the tip, N/m, such that the tooth
/// at rest in a groove without side gap has the rubber's stiffness in both directions: pressed
/// tangentially by s, the points facing the press engage by s cos(phi) and push back with
/// k_flank s; pressed radially by s, every point engages by s sin(phi) and pushes back with
/// k_tip s. Two linear equations in the two point stiffnesses.
fn point_stiffnesses(
    points: &[(f64, f64, ToothRegion)],
    k_flank_n_m: f64,
    k_tip_n_m: f64,
) -> Result<(f64, f64), String> {
    let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
    for &(c, s, region) in points {
        let col = usize::from(region == ToothRegion::Tip);
        if c > 0.0 {
            a[col] += c * c; // tangential press towards +t
        }
        b[col] += s * s; // radial press
    }
    let det = a[0] * b[1] - a[1] * b[0];
    let k_f = (k_flank_n_m * b[1] - a[1] * k_tip_n_m) / det;
    let k_t = (a[0] * k_tip_n_m - b[0] * k_flank_n_m) / det;
    if !(k_f > 0.0 && k_t > 0.0) {
        return Err(format!(
            "belt.teeth: a tooth of tangential stiffness {k_flank_n_m:.3e} N/m and radial \
             stiffness {k_tip_n_m:.3e} N/m cannot be represented by its contact points (the \
             radial stiffness must exceed about {:.2} times the tangential one)",
            b[0] / a[0]
        ));
    }
    Ok((k_f, k_t))
}

/// An angle wrapped into (-pi, pi], rad.
fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w - 2.0 * PI
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law() -> ToothContactConfig {
        ToothContactConfig {
            side_gap_m: 2e-4,
            tip_clearance_m: None,
            stiffness_exponent: 1.0,
            damping_c0: 3e4,
            damping_exponent: 1.0,
            indentation_exponent: 1.0,
            damping_full_penetration_m: 1e-4,
            static_friction: 0.3,
            dynamic_friction: 0.25,
            static_speed_m_s: 1e-3,
            dynamic_speed_m_s: 2e-3,
        }
    }

    #[test]
    fn haversine_step_runs_from_h0_to_h1() {
        assert_eq!(haversine_step(-1.0, 0.0, 2.0, 1.0, 5.0), 2.0);
        assert_eq!(haversine_step(2.0, 0.0, 2.0, 1.0, 5.0), 5.0);
        assert!((haversine_step(0.5, 0.0, 2.0, 1.0, 5.0) - 3.5).abs() < 1e-12);
        // Smooth at both ends: slope zero.
        let h = 1e-6;
        assert!((haversine_step(h, 0.0, 0.0, 1.0, 1.0) / h) < 1e-5);
    }

    #[test]
    fn eq3_force_is_elastic_plus_stepped_damping() {
        let c = law();
        let k = 2e5;
        // At rest: the elastic part only.
        assert_eq!(hysteresis_normal_force_n(k, &c, 5e-5, 0.0), (10.0, 0.0));
        // Beyond the full-damping penetration: c0 v delta^m3 on top.
        let (f, d) = hysteresis_normal_force_n(k, &c, 2e-4, 0.01);
        assert!((d - 3e4 * 0.01 * 2e-4).abs() < 1e-12);
        assert!((f - (40.0 + d)).abs() < 1e-12);
        // Half-way up the step: half the damping coefficient.
        let (_, d) = hysteresis_normal_force_n(k, &c, 5e-5, 0.01);
        assert!((d - 0.5 * 3e4 * 0.01 * 5e-5).abs() < 1e-12);
        // Fast separation never pulls; no penetration, no force.
        assert_eq!(hysteresis_normal_force_n(k, &c, 5e-5, -100.0).0, 0.0);
        assert_eq!(hysteresis_normal_force_n(k, &c, -1e-6, 1.0), (0.0, 0.0));
    }

    #[test]
    fn bad_values_are_named() {
        let mut c = law();
        c.indentation_exponent = 0.5;
        assert!(c.check().unwrap_err().contains("indentation_exponent"));
        let mut c = law();
        c.dynamic_speed_m_s = 5e-4;
        assert!(c.check().unwrap_err().contains("dynamic_speed_m_s"));
        let mut c = law();
        c.side_gap_m = -1e-4;
        assert!(c.check().unwrap_err().contains("side_gap_m"));
    }
}
