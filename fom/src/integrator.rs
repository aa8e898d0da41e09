//! The time step: the one place where forces are assembled and the state advanced.
//!
//! Scheme: symplectic (semi-implicit) Euler for the belt and pulleys, with the regularised
//! friction of every contact solved by backward Euler on the contact's effective mass
//! (docs/fom-numerics.md: "treating friction implicitly, even locally per contact, removes the
//! friction limit"). Optional physics acts through the hooks of `effects` (contact circle,
//! shaft torque, friction law), a belt kind's extra contact through those of `belt_kind`; the
//! step never names an effect, a law or a kind.
//! The explicit part is limited only by the axial, shear/bending and penalty stiffness, which
//! `Model::stable_step_estimate_s` checks before a run starts.
//!
//! Order inside one step of length dt:
//! 1. belt elastic and damping forces and gravity at (x_n, v_n); predicted velocities
//!    v* = v_n + dt M^-1 F; contact detection on the predicted end-of-step penetration
//!    delta_n - dt vn* (docs/fom-numerics.md, "Contact on the predicted penetration");
//! 2. per contact, the penalty normal force solved linearly implicitly on the node's normal
//!    velocity; pulley speeds from their shaft torques;
//! 3. per contact, implicit friction between the node and the pulley surface; the impulse
//!    goes to the segment, its reaction to the pulley;
//! 4. positions x_{n+1} = x_n + dt v_{n+1}.
//!
//! Both contact laws are implicit, so the explicit part is limited only by the belt's own
//! axial, shear and bending stiffness.

use crate::contact::{contact_energy_j, implicit_normal_force_n};
use crate::error::FomError;
use crate::model::Model;

/// What a step does with friction and pulleys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepMode {
    /// Normal dynamics.
    Dynamic,
    /// Static equilibrium search: pulleys held, belt velocities damped by exp(-damping * dt)
    /// each step (dynamic relaxation), friction on or off.
    Relax { damping_1_s: f64, friction: bool },
}

#[cfg(test)]
impl StepMode {
    /// Step k of the schedule the step's bit-for-bit tests run: 100 steps of the equilibrium
    /// search without friction, 100 with, then dynamics.
    pub(crate) fn test_schedule(k: usize) -> Self {
        if k < 200 {
            StepMode::Relax {
                damping_1_s: 50.0,
                friction: k >= 100,
            }
        } else {
            StepMode::Dynamic
        }
    }
}

/// One contact found in step 1, kept for the friction solve of step 3.
#[derive(Debug, Clone, Copy)]
struct ActiveContact {
    segment: usize,
    pulley: usize,
    /// Outward unit normal (pulley centre -> node).
    ux: f64,
    uy: f64,
    /// Distance of the node from the contact circle's centre, m.
    dist: f64,
    /// Lever of a tangential force about the shaft, m: `dist` plus the contact centre's
    /// offset from the shaft along the normal (equal to `dist` without runout).
    lever: f64,
    /// offset x u: the contact centre's offset from the shaft crossed with the normal, m; the
    /// surface's normal speed is omega times it, and the normal force's moment about the shaft
    /// F_n times it (both zero without runout).
    runout_cross: f64,
    normal_n: f64,
}

/// Scratch storage reused across steps so the hot loop does not allocate.
#[derive(Debug, Clone, Default)]
pub struct StepWorkspace {
    contacts: Vec<ActiveContact>,
    omega_pred: Vec<f64>,
    /// Pulley speed friction acts against (predicted with the last belt torque).
    omega_surface: Vec<f64>,
    belt_torque: Vec<f64>,
    /// External shaft torque of each pulley at the start of the step, N m.
    shaft_torque: Vec<f64>,
}

impl Model {
    /// Advances the model by one step (the order of `integrator.rs`'s module documentation).
    /// On x86-64 processors with AVX2 the step is compiled for four lanes instead of SSE2's
    /// two (detected at run time, as `fastmath::exp_in_place`), with the same results bit for
    /// bit: Rust never fuses a multiply and an add on its own, so the arithmetic is the same
    /// IEEE operations in either build (docs/validation/speed.md, "AVX2 at run time").
    pub fn step(&mut self, mode: StepMode, ws: &mut StepWorkspace) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2, checked just above.
            unsafe { self.step_avx2(mode, ws) };
            return;
        }
        self.step_portable(mode, ws);
    }

    /// [`Self::step`] compiled for AVX2; call only where the processor has it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn step_avx2(&mut self, mode: StepMode, ws: &mut StepWorkspace) {
        self.step_portable(mode, ws);
    }

    /// The step's body, inlined into both builds (with the functions it calls, which are
    /// `#[inline(always)]` so that the AVX2 build compiles them for AVX2 too).
    #[inline(always)]
    fn step_portable(&mut self, mode: StepMode, ws: &mut StepWorkspace) {
        let dt = self.params.step_s;
        let t_next = self.time_s + dt;
        let relax = matches!(mode, StepMode::Relax { .. });
        let friction_on = !matches!(
            mode,
            StepMode::Relax {
                friction: false,
                ..
            }
        );
        let mut dissipated_w = self.belt.assemble_internal_forces(self.gravity_m_s2);
        self.shaft_torques(ws);
        // Explicit forces of the belt kind's extra contact (`belt_kind`; none by default).
        dissipated_w += self
            .belt_contact
            .explicit_forces(&mut self.belt, &self.pulleys);

        // 1. Predicted velocities from the explicit forces (elastic, damping,
        // gravity); contact is detected on the positions they lead to.
        let b = &mut self.belt;
        let inv_m = 1.0 / b.mass_kg;
        let inv_i = 1.0 / b.inertia_kg_m2;
        for i in 0..b.n {
            b.vx[i] += dt * b.fx[i] * inv_m;
            b.vy[i] += dt * b.fy[i] * inv_m;
            b.w[i] += dt * b.tq[i] * inv_i;
        }
        let speed2_max = max_speed2(&b.vx, &b.vy);
        self.detect_contacts(ws, dt, speed2_max);

        // 2. Normal contact, then the pulleys' predicted speeds.
        self.solve_normal_contacts(ws, dt, &mut dissipated_w);
        let np = self.pulleys.len();
        ws.omega_pred.resize(np, 0.0);
        ws.belt_torque.clear();
        ws.belt_torque.resize(np, 0.0);
        self.belt_contact.add_reaction_torques(&mut ws.belt_torque);
        if !self.effects.is_empty() {
            // With the contact circle off the shaft (runout), the normal force has a moment
            // about the shaft: r x (-F_n u) with r = dist u + offset.
            for ct in &ws.contacts {
                ws.belt_torque[ct.pulley] -= ct.normal_n * ct.runout_cross;
            }
        }
        self.predict_pulleys(ws, relax, t_next, dt);

        // 3. Friction: the land contact's, then the belt kind's extra contact's.
        if friction_on {
            self.solve_land_friction(ws, dt, &mut dissipated_w);
            dissipated_w += self.belt_contact.friction(
                &mut self.belt,
                &self.pulleys,
                &ws.omega_surface,
                dt,
                &mut ws.belt_torque,
            );
        }
        self.finish_pulleys(ws, relax, t_next, dt, &mut dissipated_w);
        self.ledger.dissipated_j += dissipated_w * dt;

        // 4. Positions.
        self.advance_positions(mode, dt);
        self.time_s = t_next;
    }

    /// Where effects act on the pulleys: contact circle and external shaft torque.
    #[inline(always)]
    fn shaft_torques(&mut self, ws: &mut StepWorkspace) {
        let np = self.pulleys.len();
        ws.shaft_torque.resize(np, 0.0);
        for (k, p) in self.pulleys.iter_mut().enumerate() {
            let baseline = p.shaft_torque_nm(self.time_s, p.omega_rad_s);
            ws.shaft_torque[k] = if self.effects.is_empty() {
                baseline
            } else {
                p.contact_center_m = self.effects.contact_center_m(k, p.center_m, p.angle_rad);
                self.effects
                    .shaft_torque_nm(k, self.time_s, p.angle_rad, p.omega_rad_s, baseline)
            };
        }
    }

    /// Contact detection on the predicted velocities.
    #[inline(always)]
    fn detect_contacts(&mut self, ws: &mut StepWorkspace, dt: f64, speed2_max: f64) {
        let b = &self.belt;
        // Contact detection: every node against every pulley's node circle, on the predicted
        // end-of-step penetration delta_0 - dt vn_pred (contact::normal).
        ws.contacts.clear();
        for (pi, p) in self.pulleys.iter().enumerate() {
            let rn = p.node_radius_m;
            let center = p.contact_center_m;
            // Offset of the contact centre from the shaft (runout), m.
            let (ox, oy) = (center[0] - p.center_m[0], center[1] - p.center_m[1]);
            // No node moves further than this towards the surface within the step, m.
            let reach = dt * (speed2_max.sqrt() + (p.omega_rad_s * ox.hypot(oy)).abs());
            let reach2 = (rn + reach) * (rn + reach);
            for i in 0..b.n {
                let ex = b.x[i] - center[0];
                let ey = b.y[i] - center[1];
                let d2 = ex * ex + ey * ey;
                if d2 >= reach2 {
                    continue;
                }
                let dist = d2.sqrt();
                let delta = rn - dist;
                if delta > self.max_penetration_m {
                    self.max_penetration_m = delta;
                }
                let (ux, uy) = (ex / dist, ey / dist);
                let runout_cross = ox * uy - oy * ux;
                // Normal speed of the node relative to the pulley surface (which moves along
                // the normal only with runout).
                let vn_pred = b.vx[i] * ux + b.vy[i] * uy - p.omega_rad_s * runout_cross;
                if delta - dt * vn_pred <= 0.0 {
                    continue;
                }
                ws.contacts.push(ActiveContact {
                    segment: i,
                    pulley: pi,
                    ux,
                    uy,
                    dist,
                    lever: dist + (ox * ux + oy * uy),
                    runout_cross,
                    normal_n: 0.0,
                });
            }
        }
    }

    /// Normal contact forces on the predicted velocities; adds the power the contact
    /// dissipates to `dissipated_w`.
    #[inline(always)]
    fn solve_normal_contacts(&mut self, ws: &mut StepWorkspace, dt: f64, dissipated_w: &mut f64) {
        let c = self.contact;
        let b = &mut self.belt;
        let inv_m = 1.0 / b.mass_kg;
        // 2. Normal contact (paper eq. 4), linearly implicit per node so that the
        // penalty stiffness sets no step limit.
        for ct in ws.contacts.iter_mut() {
            let i = ct.segment;
            let p = &self.pulleys[ct.pulley];
            let delta = p.node_radius_m - ct.dist;
            let vn_pred = b.vx[i] * ct.ux + b.vy[i] * ct.uy - p.omega_rad_s * ct.runout_cross;
            let fnorm = implicit_normal_force_n(
                c.stiffness_n_m,
                c.damping_s_m,
                c.exponent,
                delta - dt * vn_pred,
                vn_pred,
                dt * inv_m,
                dt,
            );
            if fnorm > 0.0 {
                b.vx[i] += dt * fnorm * inv_m * ct.ux;
                b.vy[i] += dt * fnorm * inv_m * ct.uy;
                // Dissipated in the contact: work the node did on it, F (delta_1 - delta_0),
                // less the change of its elastic energy (physical and backward-Euler damping).
                let delta_end = delta - dt * (vn_pred + dt * fnorm * inv_m);
                let stored = contact_energy_j(c.stiffness_n_m, c.exponent, delta_end)
                    - contact_energy_j(c.stiffness_n_m, c.exponent, delta);
                *dissipated_w += (fnorm * (delta_end - delta) - stored) / dt;
            }
            ct.normal_n = fnorm;
        }
    }

    /// Predicted pulley speeds and the surface speeds friction acts against.
    #[inline(always)]
    fn predict_pulleys(&self, ws: &mut StepWorkspace, relax: bool, t_next: f64, dt: f64) {
        let np = self.pulleys.len();
        let omega_pred = &mut ws.omega_pred;
        let omega_surface = &mut ws.omega_surface;
        omega_surface.resize(np, 0.0);
        for (k, p) in self.pulleys.iter().enumerate() {
            omega_pred[k] = if relax {
                0.0
            } else if let Some(w) = p.prescribed_omega(t_next) {
                w
            } else {
                let torque = ws.shaft_torque[k] - p.bearing_damping_n_m_s * p.omega_rad_s;
                p.omega_rad_s + dt * torque / p.inertia_kg_m2
            };
            // The surface speed friction acts against: the end-of-step speed with the belt's
            // torque of the previous step standing in for this step's (a free pulley only).
            // Without it the friction saw the shaft torque's acceleration but not the belt's
            // reaction: on the light motor pulley 6e-4 m/s too fast, a first-order error of
            // ~1 % in slip at the default step (`docs/fom-numerics.md`, "The pulley speed friction
            // acts against").
            omega_surface[k] = if relax || p.prescribed_omega(t_next).is_some() {
                omega_pred[k]
            } else {
                omega_pred[k] + dt * self.belt_torque_nm[k] / p.inertia_kg_m2
            };
        }
    }

    /// The land contact's implicit friction; adds the power it dissipates to `dissipated_w`.
    #[inline(always)]
    fn solve_land_friction(&mut self, ws: &mut StepWorkspace, dt: f64, dissipated_w: &mut f64) {
        let c = self.contact;
        let b = &mut self.belt;
        let inv_m = 1.0 / b.mass_kg;
        // 3. Implicit regularised friction (paper eq. 5) on the pitch line. The contact surface
        // lies h/2 inside the pitch line on both belt and groove, so the node rests on the
        // pitch circle; the friction traction is carried to the cords by the rubber's shear,
        // which a rigid segment cannot represent: applying it with a lever h/2 spins whole
        // segments and gives a resolution-dependent spurious slip (`docs/model.md`,
        // "Friction on the pitch line"). Relative velocity: node speed minus pulley speed at the
        // node radius.
        if c.friction.is_active() {
            for ct in &ws.contacts {
                let i = ct.segment;
                let (tx, ty) = (-ct.uy, ct.ux);
                let v_pred = b.vx[i] * tx + b.vy[i] * ty - ws.omega_surface[ct.pulley] * ct.lever;
                let guess = if self.friction_pulley[i] == ct.pulley {
                    self.friction_v_prev[i]
                } else {
                    v_pred
                };
                let (v, dv) = c
                    .friction
                    .solve_implicit(v_pred, ct.normal_n, inv_m, dt, guess);
                self.friction_v_prev[i] = v;
                self.friction_pulley[i] = ct.pulley;
                b.vx[i] += dv * tx;
                b.vy[i] += dv * ty;
                // Force on the belt along the tangent; its reaction acts on the pulley at the
                // lever `lever` about the shaft.
                let force = dv * b.mass_kg / dt;
                ws.belt_torque[ct.pulley] -= force * ct.lever;
                *dissipated_w -= force * v;
            }
        }
    }

    /// Pulley speeds at the end of the step; energy exchanged with shafts and bearings.
    #[inline(always)]
    fn finish_pulleys(
        &mut self,
        ws: &mut StepWorkspace,
        relax: bool,
        t_next: f64,
        dt: f64,
        dissipated_w: &mut f64,
    ) {
        for (k, p) in self.pulleys.iter_mut().enumerate() {
            let omega_old = p.omega_rad_s;
            let drive_torque = if relax {
                0.0
            } else if p.prescribed_omega(t_next).is_some() {
                p.omega_rad_s = ws.omega_pred[k];
                // Torque the kinematic drive supplies: J dw/dt - belt + bearing.
                p.inertia_kg_m2 * (p.omega_rad_s - omega_old) / dt - ws.belt_torque[k]
                    + p.bearing_damping_n_m_s * p.omega_rad_s
            } else {
                p.omega_rad_s = ws.omega_pred[k] + dt * ws.belt_torque[k] / p.inertia_kg_m2;
                ws.shaft_torque[k]
            };
            let shaft_power = drive_torque * p.omega_rad_s;
            if shaft_power >= 0.0 {
                self.ledger.input_j += shaft_power * dt;
            } else {
                self.ledger.load_j -= shaft_power * dt;
            }
            *dissipated_w += p.bearing_damping_n_m_s * p.omega_rad_s * p.omega_rad_s;
            p.angle_rad += dt * p.omega_rad_s;
            self.belt_torque_nm[k] = ws.belt_torque[k];
            self.drive_torque_nm[k] = drive_torque;
        }
    }

    /// Damping of the equilibrium search, then positions x_{n+1} = x_n + dt v_{n+1}.
    #[inline(always)]
    fn advance_positions(&mut self, mode: StepMode, dt: f64) {
        let b = &mut self.belt;
        let damp = match mode {
            StepMode::Relax { damping_1_s, .. } => (-damping_1_s * dt).exp(),
            StepMode::Dynamic => 1.0,
        };
        for i in 0..b.n {
            if damp != 1.0 {
                b.vx[i] *= damp;
                b.vy[i] *= damp;
                b.w[i] *= damp;
            }
            b.x[i] += dt * b.vx[i];
            b.y[i] += dt * b.vy[i];
        }
        b.rotate_directions(dt);
    }

    /// Stops a run that has gone wrong: non-finite state or a penetration beyond half the belt
    /// thickness (the contact has lost the belt).
    pub fn check_health(&self) -> Result<(), FomError> {
        if !self.belt.is_finite() || self.pulleys.iter().any(|p| !p.omega_rad_s.is_finite()) {
            return Err(FomError::Numerical {
                time_s: self.time_s,
                message: "the state became NaN or infinite (step too large for the stiffness, \
                          or a parameter out of range)"
                    .into(),
            });
        }
        // No belt runs faster than its own axial wave, c = sqrt(EA / rho A) (Graff, Wave
        // Motion in Elastic Solids, 1975, sec. 2.1): at that speed the centrifugal tension
        // rho A v^2 equals EA, a strain of 100 %. A pulley rim beyond it means a parameter far
        // out of range (e.g. a motor torque of 1e30 N m), not a drive.
        let e = &self.belt.element;
        let wave_m_s = e.l0_m * (e.k_axial / self.belt.mass_kg).sqrt();
        if let Some(p) = self
            .pulleys
            .iter()
            .find(|p| (p.omega_rad_s * p.pitch_radius_m).abs() > wave_m_s)
        {
            return Err(FomError::Numerical {
                time_s: self.time_s,
                message: format!(
                    "a pulley rim runs at {:.3e} m/s, faster than the belt's axial wave speed \
                     sqrt(EA / rho A) = {wave_m_s:.0} m/s: no belt drive runs so (a parameter \
                     far out of range, e.g. the motor's torque)",
                    (p.omega_rad_s * p.pitch_radius_m).abs()
                ),
            });
        }
        self.belt_contact.check_health(self.time_s)?;
        if self.max_penetration_m > self.belt.half_thickness_m {
            return Err(FomError::Numerical {
                time_s: self.time_s,
                message: format!(
                    "runaway penetration {:.3e} m exceeds half the belt thickness {:.3e} m: \
                     contact stiffness too low for the load, or the belt has slipped off",
                    self.max_penetration_m, self.belt.half_thickness_m
                ),
            });
        }
        Ok(())
    }
}

/// The largest squared node speed, m^2/s^2, over four running maxima so that the loop
/// vectorises (the maximum does not depend on the order it is taken in).
#[inline(always)]
fn max_speed2(vx: &[f64], vy: &[f64]) -> f64 {
    let mut lanes = [0.0_f64; 4];
    let (cx, cy) = (vx.chunks_exact(4), vy.chunks_exact(4));
    let (rx, ry) = (cx.remainder(), cy.remainder());
    for (x, y) in cx.zip(cy) {
        for k in 0..4 {
            lanes[k] = lanes[k].max(x[k] * x[k] + y[k] * y[k]);
        }
    }
    for (x, y) in rx.iter().zip(ry) {
        lanes[0] = lanes[0].max(x * x + y * y);
    }
    lanes.iter().fold(0.0, |m, &v| m.max(v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ValidConfig;

    /// The step dispatched at run time (AVX2 where the processor has it) and the portable
    /// step reach the same state bit for bit: from rest through the equilibrium search into
    /// the motor's start, with contacts, friction and both pulleys moving.
    #[test]
    fn the_dispatched_step_and_the_portable_step_agree_bit_for_bit() {
        let cfg = ValidConfig::default_hvac();
        let mut a = Model::from_config(&cfg).unwrap();
        let mut b = a.clone();
        let (mut wa, mut wb) = (StepWorkspace::default(), StepWorkspace::default());
        for k in 0..20_000 {
            let mode = StepMode::test_schedule(k);
            a.step(mode, &mut wa);
            b.step_portable(mode, &mut wb);
        }
        assert!(!wa.contacts.is_empty(), "the belt touches the pulleys");
        let speeds: Vec<f64> = a.pulleys.iter().map(|p| p.omega_rad_s).collect();
        assert!(
            speeds.iter().all(|w| w.abs() > 1.0),
            "both pulleys turn: {speeds:?}"
        );
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.belt.x), bits(&b.belt.x));
        assert_eq!(bits(&a.belt.vx), bits(&b.belt.vx));
        assert_eq!(bits(&a.belt.w), bits(&b.belt.w));
        let omega = |m: &Model| {
            m.pulleys
                .iter()
                .map(|p| p.omega_rad_s.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(omega(&a), omega(&b));
        assert_eq!(
            a.ledger.dissipated_j.to_bits(),
            b.ledger.dissipated_j.to_bits()
        );
    }
}
