//! Toothed (synchronous) belts: the tooth-groove contact of `contact::tooth` (seed paper
//! "arc-tooth-synchronous-belt-recurdyn", eq. 3-5) on top of the land contact, and the tooth
//! loads a run records ([`ToothRecord`], over the tooth-load window of
//! [`tooth_load_window_start_s`]).

use std::any::Any;
use std::sync::Arc;

use super::tooth_record::{tooth_load_window_start_s, ToothRecord};
use super::{BeltContact, KindRecord, Recorder};
use crate::belt::Belt;
use crate::config::{ValidConfig, DRIVEN, DRIVER};
use crate::contact::tooth::ToothMesh;
use crate::error::FomError;
use crate::pulley::Pulley;

/// The tooth mesh of a `belt.kind = "toothed"` configuration, its grooves aligned with the
/// belt as laid out. The unstretched length must be the tooth count times the pitch.
pub fn build(
    cfg: &ValidConfig,
    belt: &Belt,
    pulleys: &[Pulley],
    l0_m: f64,
) -> Result<Box<dyn BeltContact>, FomError> {
    let (Some(teeth), Some(law)) = (&cfg.belt.teeth, &cfg.contact.tooth) else {
        unreachable!("a valid toothed configuration has [belt.teeth] and [contact.tooth]")
    };
    let l0 = l0_m;
    let teeth_length_m = teeth.count as f64 * teeth.pitch_m;
    if (l0 - teeth_length_m).abs() > 1e-3 * teeth_length_m {
        return Err(FomError::Geometry(format!(
            "a toothed belt's unstretched length is its tooth count times its pitch, \
             {} x {} m = {teeth_length_m:.5} m, but the belt length given makes it \
             {l0:.5} m: set belt.unstretched_length_m = {teeth_length_m:.5}",
            teeth.count, teeth.pitch_m
        )));
    }
    let radii: Vec<f64> = pulleys.iter().map(|p| p.pitch_radius_m).collect();
    let mut mesh = ToothMesh::new(teeth, law, cfg.belt.segments, &radii).map_err(|message| {
        FomError::Config {
            origin: "configuration".into(),
            message,
        }
    })?;
    mesh.align_grooves(belt, pulleys);
    Ok(Box::new(mesh))
}

impl BeltContact for ToothMesh {
    fn name(&self) -> &str {
        "toothed"
    }

    fn clone_box(&self) -> Box<dyn BeltContact> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }

    fn explicit_forces(&mut self, belt: &mut Belt, pulleys: &[Pulley]) -> f64 {
        self.normal_forces(belt, pulleys)
    }

    fn add_reaction_torques(&self, belt_torque_nm: &mut [f64]) {
        ToothMesh::add_reaction_torques(self, belt_torque_nm)
    }

    fn friction(
        &mut self,
        belt: &mut Belt,
        pulleys: &[Pulley],
        omega_surface_rad_s: &[f64],
        dt_s: f64,
        belt_torque_nm: &mut [f64],
    ) -> f64 {
        ToothMesh::friction(
            self,
            belt,
            pulleys,
            omega_surface_rad_s,
            dt_s,
            belt_torque_nm,
        )
    }

    fn elastic_energy_j(&self, belt: &Belt, pulleys: &[Pulley]) -> f64 {
        ToothMesh::elastic_energy_j(self, belt, pulleys)
    }

    fn stable_step_limit_s(&self, mass_kg: f64) -> f64 {
        ToothMesh::stable_step_limit_s(self, mass_kg)
    }

    fn check_health(&self, time_s: f64) -> Result<(), FomError> {
        let limit = self.tooth_radius_m;
        if self.max_penetration_m > limit {
            return Err(FomError::Numerical {
                time_s,
                message: format!(
                    "a belt tooth penetrated {:.3e} m into a groove wall, beyond the \
                     tooth's profile radius {limit:.3e} m: the tooth jumped its groove (ratcheting: \
                     too little belt tension for the torque) or the tooth stiffness is too \
                     low for the load",
                    self.max_penetration_m
                ),
            });
        }
        Ok(())
    }

    /// A toothed belt on a frictionless land floats within the side gap: its circulation
    /// around the loop is a neutral mode until a tooth meets a flank, and it crept on at
    /// ~3e-5 m/s for the whole search (0.5 s). The run starts with the belt at rest anywhere
    /// within its backlash.
    fn circulates_freely(&self) -> bool {
        true
    }

    fn reset(&mut self) {
        self.max_penetration_m = 0.0;
    }

    fn recorder(&self, cfg: &ValidConfig) -> Option<Box<dyn Recorder>> {
        Some(Box::new(ToothRecorder {
            record: ToothRecord {
                teeth: self.teeth,
                window_start_s: tooth_load_window_start_s(cfg),
                ..ToothRecord::default()
            },
            sums_n: vec![[0.0; 3]; self.teeth],
        }))
    }
}

/// Records every tooth's loads: their row means, their angles about both shafts at each row's
/// end, and the largest instantaneous load of each region with its time.
struct ToothRecorder {
    record: ToothRecord,
    /// Sums of the loads over the row so far, per tooth.
    sums_n: Vec<[f64; 3]>,
}

fn mesh_of(contact: &dyn BeltContact) -> &ToothMesh {
    contact
        .as_any()
        .downcast_ref::<ToothMesh>()
        .expect("the toothed kind records its own mesh")
}

impl Recorder for ToothRecorder {
    fn step(&mut self, contact: &dyn BeltContact, time_s: f64) {
        let rec = &mut self.record;
        for (a, l) in self.sums_n.iter_mut().zip(&mesh_of(contact).loads_n) {
            for r in 0..3 {
                a[r] += l[r];
                if l[r] > rec.max_n[r] {
                    rec.max_n[r] = l[r];
                    rec.max_time_s[r] = time_s;
                }
            }
        }
    }

    fn row(
        &mut self,
        contact: &dyn BeltContact,
        belt: &Belt,
        pulleys: &[Pulley],
        time_s: f64,
        inv: f64,
    ) {
        let mesh = mesh_of(contact);
        let rec = &mut self.record;
        rec.time_s.push(time_s);
        for (i, a) in self.sums_n.iter_mut().enumerate() {
            rec.loads_n.push([a[0] * inv, a[1] * inv, a[2] * inv]);
            *a = [0.0; 3];
            let angle = |j: usize| {
                let (angle, wrapped) = mesh.tooth_angle_rad(belt, pulleys, i, j);
                if wrapped {
                    angle as f32
                } else {
                    f32::NAN
                }
            };
            rec.angle_rad.push([angle(DRIVER), angle(DRIVEN)]);
        }
    }

    fn finish(self: Box<Self>) -> Arc<dyn KindRecord> {
        Arc::new(self.record)
    }
}
