//! Building a drive model from its configuration: belt length, layout on the pulleys, numerics.

use std::sync::Arc;

use crate::belt::{AxialHysteresis, Belt};
use crate::belt_kind::BeltContact;
use crate::config::{StepSize, ValidConfig};
pub use crate::config::{DRIVEN, DRIVER};
use crate::contact::{contact_energy_j, ContactLaw};
use crate::effects::{Effect, Effects};
use crate::error::FomError;
use crate::geometry::{polygon_compensated_radius_m, OpenBeltPath};
use crate::integration_parameters::IntegrationParameters;
use crate::pulley::Pulley;
use crate::statics::{open_belt_length_m, static_strain, static_tension_n, unstretched_length_m};

/// Energy bookkeeping over the run, J (for the power balance).
#[derive(Debug, Clone, Copy, Default)]
pub struct EnergyLedger {
    /// Work done by motors and prescribed-speed drives.
    pub input_j: f64,
    /// Work absorbed by loads.
    pub load_j: f64,
    /// Work dissipated by friction, contact damping, belt damping and bearings.
    pub dissipated_j: f64,
}

/// The complete mechanical system and its state.
#[derive(Debug, Clone)]
pub struct Model {
    pub belt: Belt,
    /// Driver first, driven second; further pulleys (idlers) may follow.
    pub pulleys: Vec<Pulley>,
    pub contact: ContactLaw,
    /// What the belt's kind adds to the land contact (`belt_kind`; none for flat and V-belts).
    pub belt_contact: Box<dyn BeltContact>,
    /// Optional physics acting through the step's hooks (none by default).
    pub effects: Effects,
    pub gravity_m_s2: [f64; 2],
    pub params: IntegrationParameters,
    /// Unstretched belt length L0, m.
    pub unstretched_length_m: f64,
    /// Open-belt pitch length L(d) at the configured centre distance, m.
    pub pitch_path_length_m: f64,
    /// Layout path through the node circles (used for span midpoints).
    pub path: OpenBeltPath,
    pub time_s: f64,
    pub ledger: EnergyLedger,
    /// Largest penetration seen since the last reset, m.
    pub max_penetration_m: f64,
    // Per-segment warm start of the friction solve: last relative velocity and its pulley.
    pub(crate) friction_v_prev: Vec<f64>,
    pub(crate) friction_pulley: Vec<usize>,
    /// Belt torque on each pulley during the last step, N m (counter-clockwise positive).
    pub belt_torque_nm: Vec<f64>,
    /// Drive torque on each pulley during the last step (motor, load, or the torque a
    /// prescribed-speed drive had to supply), N m.
    pub drive_torque_nm: Vec<f64>,
}

impl ValidConfig {
    /// The integrator step a run of this configuration takes, s: the fixed `step_s`, or the one
    /// `"auto"` picks for the model it builds (`Model::resolve_step`).
    pub fn resolved_step_s(&self) -> Result<f64, FomError> {
        match self.simulation.step_s {
            StepSize::Seconds(s) => Ok(s),
            StepSize::Auto => Ok(Model::from_config(self)?.params.step_s),
        }
    }
}

impl Model {
    /// Builds the model with the belt laid on the tangent spans and arcs (not yet relaxed).
    pub fn from_config(cfg: &ValidConfig) -> Result<Self, FomError> {
        let d = cfg.center_distance_m();
        let r1 = 0.5 * cfg.driver.pitch_diameter_m;
        let r2 = 0.5 * cfg.driven.pitch_diameter_m;
        let l_d = open_belt_length_m(d, r1, r2);
        let l0 = unstretched_length_m(cfg)?;
        // Slack, overlapping or over-stretched: refused by the one definition.
        crate::statics::installed_strain(cfg)?;
        let n = cfg.belt.segments;
        // Chord of one stretched segment; node circles compensate the polygonal effect.
        let chord = l_d / n as f64;
        if chord > 0.5 * r1.min(r2) {
            return Err(FomError::Geometry(format!(
                "belt.segments = {n} is too few: a segment ({:.4} m) is longer than half the \
                 smaller pitch radius ({:.4} m)",
                chord,
                r1.min(r2)
            )));
        }
        let rn1 = polygon_compensated_radius_m(r1, chord);
        let rn2 = polygon_compensated_radius_m(r2, chord);
        let path = OpenBeltPath::new(cfg.driver.center_m, rn1, cfg.driven.center_m, rn2);
        let ds = path.length() / n as f64;
        // Start half a segment into the lower span so no node sits on a tangent point.
        let poses: Vec<([f64; 2], f64)> =
            (0..n).map(|i| path.point((i as f64 + 0.5) * ds)).collect();
        let belt = Belt::new(&cfg.belt, l0, &poses);
        let pulleys = vec![Pulley::new(&cfg.driver, rn1), Pulley::new(&cfg.driven, rn2)];
        let np = pulleys.len();
        let contact = ContactLaw::from_config(cfg);
        let belt_contact = crate::belt_kind::build(cfg, &belt, &pulleys, l0)?;
        let mut model = Self {
            belt,
            pulleys,
            contact,
            belt_contact,
            effects: Effects::default(),
            gravity_m_s2: cfg.simulation.gravity_m_s2,
            // Set by `resolve_step` below, once the belt and the effects are in place.
            params: IntegrationParameters { step_s: f64::NAN },
            unstretched_length_m: l0,
            pitch_path_length_m: l_d,
            path,
            time_s: 0.0,
            ledger: EnergyLedger::default(),
            max_penetration_m: 0.0,
            friction_v_prev: vec![0.0; n],
            friction_pulley: vec![usize::MAX; n],
            belt_torque_nm: vec![0.0; np],
            drive_torque_nm: vec![0.0; np],
        };
        for e in cfg.effects.build().iter() {
            model.add_effect(e.clone());
        }
        model.resolve_step(&cfg.simulation)?;
        Ok(model)
    }

    /// Sets the integrator step from the configuration (`StepSize`), checked against the
    /// stability estimate of the model as it now is (belt and effects). Call again after adding
    /// effects that stiffen the belt (`simulation::prepare_with` does).
    pub fn resolve_step(&mut self, sim: &crate::config::SimulationConfig) -> Result<(), FomError> {
        let limit = self.stable_step_estimate_s();
        // The largest step within the limit that divides the output interval, so the rows lie
        // on the interval's grid.
        let fitting = sim.output_interval_s / (sim.output_interval_s / limit).ceil();
        let step_s = match sim.step_s {
            StepSize::Auto => fitting,
            StepSize::Seconds(step_s) if step_s > limit => {
                return Err(FomError::Step(format!(
                    "simulation.step_s = {step_s:.3e} s exceeds the explicit stability limit \
                     {limit:.3e} s estimated from the axial, shear and bending stiffness of {} \
                     segments; a step of {fitting:.4e} s would run (it divides the output \
                     interval; step_s = \"auto\" picks it), or use fewer segments",
                    self.belt.n
                )));
            }
            StepSize::Seconds(step_s) => step_s,
        };
        crate::config::check_step_count(sim, step_s).map_err(|message| FomError::Config {
            origin: "configuration".into(),
            message,
        })?;
        self.params.step_s = step_s;
        if let Some(h) = &mut self.belt.hysteresis {
            h.set_step(step_s);
        }
        Ok(())
    }

    /// Static strain of the laid-out belt, (L(d) - L0) / L0.
    pub fn static_strain(&self) -> f64 {
        static_strain(self.pitch_path_length_m, self.unstretched_length_m)
    }

    /// A warning when the static strain is above `TYPICAL_WORKING_STRAIN`, else `None`.
    pub fn strain_warning(&self) -> Option<String> {
        let strain = self.static_strain();
        crate::config::strain_exceeds(strain, crate::config::TYPICAL_WORKING_STRAIN).then(|| {
            format!(
                "the belt is installed at {:.2} % static strain, above the {:.0} % typical of \
                 cord-reinforced belts: check belt.axial_stiffness_n and the installation \
                 (allowed up to belt.max_strain)",
                100.0 * strain,
                100.0 * crate::config::TYPICAL_WORKING_STRAIN
            )
        })
    }

    /// Static span tension of the laid-out belt, EA (L(d) - L0) / L0 (docs/fom-numerics.md), N.
    pub fn nominal_static_tension_n(&self) -> f64 {
        let ea = self.belt.element.k_axial * self.belt.element.l0_m;
        static_tension_n(ea, self.pitch_path_length_m, self.unstretched_length_m)
    }

    /// Estimate of the largest stable step of the explicit part of the scheme, s.
    ///
    /// Highest frequencies of one segment (docs/fom-numerics.md): axial chain 2 sqrt(k_a / m);
    /// transverse 2 sqrt(k_psi / (l^2 m)); rotation sqrt(k_rot / I). Symplectic Euler is stable
    /// for omega dt < 2 (sqrt(1 + z^2) - z) with damping ratio z (Hairer, Lubich & Wanner,
    /// Geometric Numerical Integration, sec. I.1). Contact and friction are implicit and set no
    /// limit. Safety factor 0.9: on the default drive the estimate without it is 1.17e-5 s and
    /// the measured limit lies between 1.0e-5 s (stable) and 1.15e-5 s (fails). A step that
    /// passes this check and still diverges is caught by `check_health`.
    pub fn stable_step_estimate_s(&self) -> f64 {
        let b = &self.belt;
        let e = &b.element;
        let m = b.mass_kg;
        // A viscoelastic arm stiffens the axial element at high frequency (its dashpot locks).
        let k_axial = e.k_axial + b.hysteresis.as_ref().map_or(0.0, |h| h.stiffness_n_m);
        let w_axial = 2.0 * (k_axial / m).sqrt();
        let w_trans = 2.0 * (e.transverse_stiffness_n_m() / m).sqrt();
        // Rotating one segment by a: phi changes by a in both elements, psi by a/2.
        let k_rot = 2.0 * e.k_phi + 0.5 * e.k_psi;
        let w_rot = (k_rot / b.inertia_kg_m2).sqrt();
        let limit = |w: f64, z: f64| 2.0 * ((1.0 + z * z).sqrt() - z) / w;
        let eta_a = e.c_axial / k_axial;
        let z_b = 0.5 * e.eta_bending_s * w_trans.max(w_rot);
        let kind = self.belt_contact.stable_step_limit_s(m);
        0.9 * limit(w_axial, 0.5 * eta_a * w_axial)
            .min(limit(w_trans, z_b))
            .min(limit(w_rot, z_b))
            .min(kind)
    }

    /// Total mechanical energy: kinetic (belt, pulleys), elastic (belt, contact), gravity, J.
    pub fn mechanical_energy_j(&self) -> f64 {
        let mut e = self.belt.kinetic_energy() + self.belt.potential_energy(self.gravity_m_s2);
        for p in &self.pulleys {
            e += 0.5 * p.inertia_kg_m2 * p.omega_rad_s * p.omega_rad_s;
        }
        let c = &self.contact;
        for i in 0..self.belt.n {
            for p in &self.pulleys {
                let o = p.contact_center_m;
                let dist = (self.belt.x[i] - o[0]).hypot(self.belt.y[i] - o[1]);
                e += contact_energy_j(c.stiffness_n_m, c.exponent, p.node_radius_m - dist);
            }
        }
        e + self
            .belt_contact
            .elastic_energy_j(&self.belt, &self.pulleys)
    }

    /// Adds an optional effect (see `effects`); it acts from the next step on. A belt
    /// hysteresis hook relaxes the elastic spring to (1 - g) EA; the unstretched length stays the
    /// one laid out from the configuration, so configure `[effects.belt-hysteresis]` (not an
    /// added effect) for the installation tension to follow the relaxed stiffness.
    pub fn add_effect(&mut self, effect: Arc<dyn Effect>) {
        self.contact.friction = effect.friction_law(self.contact.friction);
        if let Some((ratio, relaxation_s)) = effect.belt_hysteresis() {
            // One-term Prony series: the arm takes the share g of the instantaneous stiffness,
            // the elastic spring keeps the relaxed rest (DriveConfig::relaxed_stiffness_share).
            let k_instant = self.belt.element.k_axial;
            self.belt.element.k_axial = (1.0 - ratio) * k_instant;
            self.belt.hysteresis = Some(AxialHysteresis::new(
                self.belt.element_lengths_m(),
                ratio * k_instant,
                relaxation_s,
                self.params.step_s,
            ));
        }
        self.effects.push(effect);
    }

    /// The belt kind's extra contact as a `T` (e.g. `contact::tooth::ToothMesh` of a toothed
    /// belt), if it is one.
    pub fn belt_contact_as<T: 'static>(&self) -> Option<&T> {
        self.belt_contact.as_any().downcast_ref()
    }

    /// [`Model::belt_contact_as`], mutable.
    pub fn belt_contact_as_mut<T: 'static>(&mut self) -> Option<&mut T> {
        self.belt_contact.as_any_mut().downcast_mut()
    }

    /// Transmission ratio R_t from the pulleys' pitch radii (paper eq. 1).
    pub fn transmission_ratio(&self) -> f64 {
        crate::slip::transmission_ratio(
            self.pulleys[DRIVER].pitch_radius_m,
            self.pulleys[DRIVEN].pitch_radius_m,
        )
    }
}
