//! Belt kinds and what each changes in the model. A new kind (e.g. a toothed belt) is a
//! variant here with its contact law; the step loop does not name kinds.

use serde::{Deserialize, Serialize};

use crate::contact::FrictionLaw;

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

    /// Friction coefficient acting in the plane of the drive, from the material coefficient
    /// `mu` and the groove angle (V-belts only).
    pub fn effective_friction(self, mu: f64, groove_angle_deg: Option<f64>) -> f64 {
        match (self, groove_angle_deg) {
            // Wedge action of a V-groove: mu' = mu / sin(beta/2) (e.g. Shigley, Mechanical
            // Engineering Design, 10th ed., eq. 17-17 context; Johnson, Contact Mechanics ch. 8).
            (BeltKind::VBelt, Some(angle)) => mu / (0.5 * angle.to_radians()).sin(),
            _ => mu,
        }
    }

    /// The friction law of this kind of belt, from the material coefficient `mu`, the groove
    /// angle and the regularisation velocity of paper eq. 5.
    pub fn friction_law(
        self,
        mu: f64,
        groove_angle_deg: Option<f64>,
        velocity_threshold_m_s: f64,
    ) -> FrictionLaw {
        FrictionLaw::RegularisedCoulomb {
            mu: self.effective_friction(mu, groove_angle_deg),
            velocity_threshold_m_s,
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
