//! `[belt]` and `[belt.teeth]`: the belt's kind, length, stiffness and teeth. Data and its
//! checks only; what each kind does in the model is `belt_kind`.

use serde::{Deserialize, Serialize};

use super::limits::{non_negative, positive, strain_exceeds, DEFAULT_MAX_STRAIN};

/// The belt's cross-section type.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum BeltKind {
    /// Flat belt: friction acts with the material coefficient.
    Flat,
    /// V-belt: with `contact.groove_angle_deg` the wedge raises the material coefficient.
    VBelt,
    /// Toothed (synchronous) belt: circular-arc teeth (`[belt.teeth]`) in the grooves of the
    /// pulleys (`[contact.tooth]`, `contact::tooth`); the land contact's friction acts too.
    Toothed,
}

impl BeltKind {
    /// The kind as written in a configuration (`belt.kind`).
    pub fn name(self) -> &'static str {
        match self {
            BeltKind::Flat => "flat",
            BeltKind::VBelt => "v-belt",
            BeltKind::Toothed => "toothed",
        }
    }

    /// A configuration error in the groove angle or the tooth tables for this kind, if any.
    pub(crate) fn check_kind_tables(
        self,
        groove_angle_deg: Option<f64>,
        has_teeth: bool,
        has_tooth_contact: bool,
    ) -> Result<(), String> {
        if self != BeltKind::VBelt && groove_angle_deg.is_some() {
            return Err("contact.groove_angle_deg applies to belt.kind = \"v-belt\" only".into());
        }
        match (self == BeltKind::Toothed, has_teeth, has_tooth_contact) {
            (true, true, true) | (false, false, false) => Ok(()),
            (true, _, _) => {
                Err("belt.kind = \"toothed\" needs both [belt.teeth] and [contact.tooth]".into())
            }
            (false, _, _) => {
                Err("[belt.teeth] and [contact.tooth] apply to belt.kind = \"toothed\" only".into())
            }
        }
    }
}

/// How the unstretched belt length is specified: exactly one of the three.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeltLengthSpec {
    /// Unstretched pitch length L0, m.
    UnstretchedLength { length_m: f64 },
    /// Static strain (L(d) - L0) / L0 at the configured centre distance.
    PreStrain { strain: f64 },
    /// Static span tension T0 at a reference centre distance d_ref:
    /// L0 = L(d_ref) / (1 + T0 / EA). Moving the pulleys closer than d_ref lowers the tension.
    InstallationTension {
        tension_n: f64,
        reference_center_distance_m: f64,
    },
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BeltConfig {
    pub kind: BeltKind,
    /// Number of rigid segments N.
    pub segments: usize,
    #[serde(default)]
    pub unstretched_length_m: Option<f64>,
    #[serde(default)]
    pub pre_strain: Option<f64>,
    /// The belt's rated elongation: the largest static strain it may be installed at (a
    /// fraction; the maker's figure). Absent: `DEFAULT_MAX_STRAIN`. Above
    /// `TYPICAL_WORKING_STRAIN` a run warns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_strain: Option<f64>,
    #[serde(default)]
    pub installation_tension_n: Option<f64>,
    /// Centre distance at which `installation_tension_n` holds; absent = the configured one.
    #[serde(default)]
    pub reference_center_distance_m: Option<f64>,
    /// Axial stiffness EA, N.
    pub axial_stiffness_n: f64,
    /// Bending stiffness EI, N m^2.
    pub bending_stiffness_n_m2: f64,
    /// Shear stiffness kappa G A, N (Timoshenko).
    pub shear_stiffness_n: f64,
    /// Mass per unit length rho A, kg/m.
    pub mass_per_length_kg_m: f64,
    /// Belt thickness h, m; the pulley contact surface lies h/2 inside the pitch line.
    pub thickness_m: f64,
    /// Axial strain-rate damping: damping force = axial_damping_s * EA * strain rate, s.
    pub axial_damping_s: f64,
    /// Stiffness-proportional damping time constant of the shear/bending block, s.
    pub bending_damping_s: f64,
    /// The teeth of a `kind = "toothed"` belt.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub teeth: Option<TeethConfig>,
}

impl BeltConfig {
    /// The belt's rated elongation: `max_strain`, or `DEFAULT_MAX_STRAIN`.
    pub fn max_strain(&self) -> f64 {
        self.max_strain.unwrap_or(DEFAULT_MAX_STRAIN)
    }

    /// The table's first error (`[belt.teeth]` apart), naming the key and the offending value.
    pub(crate) fn check(&self) -> Result<(), String> {
        let b = self;
        super::limits::check_model_size(b.segments, b.teeth.as_ref().map(|t| t.count))?;
        if b.segments < 16 {
            return Err(format!(
                "belt.segments = {} is too few (at least 16)",
                b.segments
            ));
        }
        let n_specs = [
            b.unstretched_length_m.is_some(),
            b.pre_strain.is_some(),
            b.installation_tension_n.is_some(),
        ]
        .iter()
        .filter(|x| **x)
        .count();
        if n_specs != 1 {
            return Err(format!(
                "belt: give exactly one of unstretched_length_m, pre_strain, installation_tension_n \
                 (found {n_specs})"
            ));
        }
        if let Some(l) = b.unstretched_length_m {
            positive("belt.unstretched_length_m", l)?;
        }
        if let Some(m) = b.max_strain {
            if !(m.is_finite() && m > 0.0 && m <= 0.5) {
                return Err(format!(
                    "belt.max_strain = {m} must lie in (0, 0.5] (a fraction: 0.05 is 5 %)"
                ));
            }
        }
        if let Some(e) = b.pre_strain {
            let limit = b.max_strain();
            if !(e.is_finite() && e > 0.0) || strain_exceeds(e, limit) {
                return Err(format!(
                    "belt.pre_strain = {e} must lie in (0, belt.max_strain = {limit}] (the \
                     belt's rated elongation{})",
                    if b.max_strain.is_none() {
                        "; absent, the default; set it from the maker's data"
                    } else {
                        ""
                    }
                ));
            }
        }
        if let Some(t) = b.installation_tension_n {
            positive("belt.installation_tension_n", t)?;
        }
        if let Some(d) = b.reference_center_distance_m {
            positive("belt.reference_center_distance_m", d)?;
        }
        positive("belt.axial_stiffness_n", b.axial_stiffness_n)?;
        positive("belt.bending_stiffness_n_m2", b.bending_stiffness_n_m2)?;
        positive("belt.shear_stiffness_n", b.shear_stiffness_n)?;
        positive("belt.mass_per_length_kg_m", b.mass_per_length_kg_m)?;
        positive("belt.thickness_m", b.thickness_m)?;
        non_negative("belt.axial_damping_s", b.axial_damping_s)?;
        non_negative("belt.bending_damping_s", b.bending_damping_s)?;
        Ok(())
    }
}

/// `[belt.teeth]`: the teeth of a `kind = "toothed"` belt.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TeethConfig {
    /// Number of teeth on the belt; the unstretched length is count x pitch.
    pub count: usize,
    /// Tooth pitch p along the cord (pitch line), m.
    pub pitch_m: f64,
    /// Radius of the tooth's circular arc (tooth height and half its base width), m.
    pub profile_radius_m: f64,
    /// Distance from the cord (pitch line) to the land line (the pulley's outside diameter),
    /// the pitch line differential, m.
    pub pitch_line_offset_m: f64,
    /// Belt width b, m.
    pub width_m: f64,
    /// Young's modulus of the tooth rubber, Pa.
    pub rubber_modulus_pa: f64,
    /// Poisson's ratio of the tooth rubber.
    pub rubber_poisson: f64,
}

impl TeethConfig {
    pub(crate) fn check(&self) -> Result<(), String> {
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("belt.teeth.{key} = {v} must be a positive number"))
            }
        };
        if self.count < 8 {
            return Err(format!(
                "belt.teeth.count = {} is too few (at least 8)",
                self.count
            ));
        }
        positive("pitch_m", self.pitch_m)?;
        positive("profile_radius_m", self.profile_radius_m)?;
        positive("pitch_line_offset_m", self.pitch_line_offset_m)?;
        positive("width_m", self.width_m)?;
        positive("rubber_modulus_pa", self.rubber_modulus_pa)?;
        if !(self.rubber_poisson.is_finite() && (0.0..0.5).contains(&self.rubber_poisson)) {
            return Err(format!(
                "belt.teeth.rubber_poisson = {} must lie in [0, 0.5)",
                self.rubber_poisson
            ));
        }
        if 2.0 * self.profile_radius_m >= self.pitch_m {
            return Err(format!(
                "belt.teeth.profile_radius_m = {} leaves no land: the tooth base (2 R) must be \
                 narrower than the pitch {} m",
                self.profile_radius_m, self.pitch_m
            ));
        }
        Ok(())
    }
}
