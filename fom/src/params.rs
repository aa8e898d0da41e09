//! The design point: the parameters a training campaign varies, a surrogate takes as inputs,
//! calibration fits and `rom simulate` overrides. One type, one conversion into a drive
//! configuration ([`DesignPoint::apply`]), and the static quantities the surrogate derives from
//! it without building a model.
//!
//! Adding a design variable: a field here (with its lines in `apply`, `nominal`, `get`, `set`
//! and [`Variable`]), its range in `training/src/settings.rs`, and its flag in
//! `cli/src/args.rs` (`docs/architecture.md`, "Where each piece lives"). Design files, range checks
//! and the surrogate's inputs go through [`Variable`].

use serde::{Deserialize, Serialize};

use crate::config::effects::EffectParameter;
use crate::config::{BeltLengthSpec, DriveConfig, ValidConfig};
use crate::error::{FomError, Result};
use crate::statics::{
    open_belt_length_m, pitch_radii_m as radii, shaft_load_n, static_tension_n,
    unstretched_from_tension_m, unstretched_length_m, wrap_angles_rad,
};

/// A point of the design space.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DesignPoint {
    /// Centre distance d, m: the driven pulley moves along the line of centres.
    pub center_distance_m: f64,
    /// Effective (wedge-included) friction coefficient.
    pub friction: f64,
    /// Installation tension, N: the static span tension at the configuration's reference
    /// centre distance (`belt.reference_center_distance_m`, else its own centre distance).
    pub installation_tension_n: f64,
    /// Effective axial stiffness EA, N; `None` keeps the configuration's.
    pub axial_stiffness_n: Option<f64>,
    /// Effect parameters the design varies (`None`: as the configuration says).
    #[serde(default)]
    pub effects: EffectValues,
    /// Side gap of a toothed belt's teeth in their grooves, m (`contact.tooth.side_gap_m`);
    /// `None` keeps the configuration's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side_gap_m: Option<f64>,
    /// Largest load torque of the driven shaft's torque profile (`driven.load.profile`), N m;
    /// `None` keeps the configuration's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_torque_nm: Option<f64>,
    /// Static shaft load, N: the driven pulley is moved along the line of centres until the
    /// belt (of fixed unstretched length) pulls its shaft with this force; when set it places
    /// the pulley in place of `center_distance_m`. `None` keeps the configuration's distance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shaft_load_n: Option<f64>,
}

/// Values of the effect parameters (`EffectParameter::ALL` order) a design point sets.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct EffectValues(pub [Option<f64>; 5]);

/// The design variables, in design-column order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variable {
    CenterDistance,
    Friction,
    InstallationTension,
    AxialStiffness,
    /// A catalogue effect's magnitude (`effects::EffectParameter`).
    Effect(EffectParameter),
    /// Side gap of a toothed belt (`belt.kind = "toothed"`).
    SideGap,
    /// Largest torque of the driven shaft's load-torque profile.
    LoadTorque,
    /// Static shaft load (places the driven pulley).
    ShaftLoad,
}

impl Variable {
    /// Every variable, in column order.
    pub const ALL: [Variable; 12] = [
        Variable::CenterDistance,
        Variable::Friction,
        Variable::InstallationTension,
        Variable::AxialStiffness,
        Variable::Effect(EffectParameter::Runout),
        Variable::Effect(EffectParameter::BladePassAmplitude),
        Variable::Effect(EffectParameter::StribeckDynamicRatio),
        Variable::Effect(EffectParameter::HysteresisStiffnessRatio),
        Variable::Effect(EffectParameter::BearingCoulomb),
        Variable::SideGap,
        Variable::LoadTorque,
        Variable::ShaftLoad,
    ];

    /// The variable with this key, if any.
    pub fn from_key(key: &str) -> Option<Variable> {
        Self::ALL.into_iter().find(|v| v.key() == key)
    }

    /// Key in settings files, CSV headers and reports.
    pub const fn key(self) -> &'static str {
        match self {
            Variable::CenterDistance => "center_distance_m",
            Variable::Friction => "friction",
            Variable::InstallationTension => "installation_tension_n",
            Variable::AxialStiffness => "axial_stiffness_n",
            Variable::Effect(p) => p.key(),
            Variable::SideGap => "side_gap_m",
            Variable::LoadTorque => "load_torque_nm",
            Variable::ShaftLoad => "shaft_load_n",
        }
    }

    /// Words for messages, with the unit.
    pub const fn describe(self) -> &'static str {
        match self {
            Variable::CenterDistance => "centre distance (m)",
            Variable::Friction => "friction",
            Variable::InstallationTension => "installation tension (N)",
            Variable::AxialStiffness => "axial stiffness EA (N)",
            Variable::Effect(p) => p.key(),
            Variable::SideGap => "side gap of a toothed belt (m)",
            Variable::LoadTorque => "load torque (N m)",
            Variable::ShaftLoad => "static shaft load (N)",
        }
    }
}

impl DesignPoint {
    /// A point of the drive's own variables: centre distance (m), effective friction,
    /// installation tension (N) and, if set, EA (N); no effects, no tooth inputs.
    pub fn drive(
        center_distance_m: f64,
        friction: f64,
        installation_tension_n: f64,
        axial_stiffness_n: Option<f64>,
    ) -> Self {
        Self {
            center_distance_m,
            friction,
            installation_tension_n,
            axial_stiffness_n,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        }
    }

    /// The configuration's own point with any of d, mu and the installation tension replaced
    /// (what `rom simulate --d --mu --tension` and Python's `beltwin.simulate` run).
    pub fn nominal_with(
        cfg: &DriveConfig,
        center_distance_m: Option<f64>,
        friction: Option<f64>,
        installation_tension_n: Option<f64>,
    ) -> Self {
        let n = Self::nominal(cfg);
        Self::drive(
            center_distance_m.unwrap_or(n.center_distance_m),
            friction.unwrap_or(n.friction),
            installation_tension_n.unwrap_or(n.installation_tension_n),
            None,
        )
    }

    /// This point with a toothed belt's side gap (m), load torque (N m) and shaft load (N)
    /// where given (what `rom simulate` and `rom predict --side-gap ...` and Python's
    /// `ToothSurrogate.predict` ask for).
    pub fn with_tooth_inputs(
        self,
        side_gap_m: Option<f64>,
        load_torque_nm: Option<f64>,
        shaft_load_n: Option<f64>,
    ) -> Self {
        Self {
            side_gap_m,
            load_torque_nm,
            shaft_load_n,
            ..self
        }
    }

    /// The configuration's own point: its centre distance, effective friction, installation
    /// tension (the static span tension at its reference distance) and EA.
    pub fn nominal(cfg: &DriveConfig) -> Self {
        let installation_tension_n = match cfg.length_spec() {
            BeltLengthSpec::InstallationTension { tension_n, .. } => tension_n,
            _ => {
                let (r1, r2) = radii(cfg);
                static_tension_n(
                    cfg.belt.axial_stiffness_n,
                    open_belt_length_m(reference_distance_m(cfg), r1, r2),
                    unstretched_length_m(cfg).unwrap_or(f64::NAN),
                )
            }
        };
        Self {
            center_distance_m: cfg.center_distance_m(),
            friction: cfg.effective_friction(),
            installation_tension_n,
            axial_stiffness_n: None,
            effects: EffectValues::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        }
    }

    /// The coordinates of the variables it sets, in design-column order.
    pub fn columns(&self) -> Vec<f64> {
        Variable::ALL.iter().filter_map(|v| self.get(*v)).collect()
    }

    /// The point with `values[i]` for `vars[i]` (a design row); variables not named keep
    /// zero, and an optional one (stiffness) stays absent.
    pub fn from_columns(vars: &[Variable], values: &[f64]) -> Self {
        Self {
            center_distance_m: 0.0,
            friction: 0.0,
            installation_tension_n: 0.0,
            axial_stiffness_n: None,
            effects: EffectValues::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        }
        .with_columns(vars, values)
    }

    /// This point with `values[i]` for `vars[i]` (a design row over `self`: the variables not
    /// named keep its values).
    pub fn with_columns(mut self, vars: &[Variable], values: &[f64]) -> Self {
        for (v, x) in vars.iter().zip(values) {
            self.set(*v, *x);
        }
        self
    }

    /// Sets one variable.
    pub fn set(&mut self, v: Variable, x: f64) {
        match v {
            Variable::CenterDistance => self.center_distance_m = x,
            Variable::Friction => self.friction = x,
            Variable::InstallationTension => self.installation_tension_n = x,
            Variable::AxialStiffness => self.axial_stiffness_n = Some(x),
            Variable::Effect(p) => self.effects.0[p.index()] = Some(x),
            Variable::SideGap => self.side_gap_m = Some(x),
            Variable::LoadTorque => self.load_torque_nm = Some(x),
            Variable::ShaftLoad => self.shaft_load_n = Some(x),
        }
    }

    /// Value of one variable, or the configuration's where the point leaves it open.
    pub fn value_or_config(&self, v: Variable, cfg: &DriveConfig) -> f64 {
        self.get(v).unwrap_or_else(|| match v {
            Variable::AxialStiffness => cfg.belt.axial_stiffness_n,
            Variable::Effect(p) => p.read(&cfg.effects),
            Variable::SideGap => cfg
                .contact
                .tooth
                .as_ref()
                .map_or(f64::NAN, |t| t.side_gap_m),
            Variable::LoadTorque => cfg
                .driven
                .load
                .as_ref()
                .and_then(|l| l.profile.as_ref())
                .map_or(f64::NAN, |p| p.peak_torque_nm()),
            Variable::ShaftLoad => shaft_load_n(cfg, cfg.center_distance_m()),
            _ => Self::nominal(cfg).get(v).unwrap_or(f64::NAN),
        })
    }

    /// Value of one variable (`None` for an absent stiffness).
    pub fn get(&self, v: Variable) -> Option<f64> {
        match v {
            Variable::CenterDistance => Some(self.center_distance_m),
            Variable::Friction => Some(self.friction),
            Variable::InstallationTension => Some(self.installation_tension_n),
            Variable::AxialStiffness => self.axial_stiffness_n,
            Variable::Effect(p) => self.effects.0[p.index()],
            Variable::SideGap => self.side_gap_m,
            Variable::LoadTorque => self.load_torque_nm,
            Variable::ShaftLoad => self.shaft_load_n,
        }
    }

    /// The configuration moved to this point and checked (the one check of the moved
    /// configuration). A variable already at the configuration's value leaves its keys as
    /// written, so `nominal(cfg).apply(cfg) == cfg`.
    pub fn apply(&self, cfg: &DriveConfig) -> Result<ValidConfig> {
        self.moved(cfg)?.check_as("design point")
    }

    /// The configuration moved to this point, not yet checked: for a caller that edits it
    /// further (a run's resolution, an effect) and then checks it once.
    pub fn moved(&self, cfg: &DriveConfig) -> Result<DriveConfig> {
        let mut c = cfg.clone();
        let here = Self::nominal(cfg);
        let d = match self.shaft_load_n {
            Some(f) => center_distance_for_shaft_load_m(cfg, f)?,
            None => self.center_distance_m,
        };
        if !(d.is_finite() && d > 0.0) {
            return Err(FomError::Config {
                origin: "design point".into(),
                message: format!("centre distance must be a positive number of metres, got {d}"),
            });
        }
        if d != here.center_distance_m {
            // The reference distance of the installation tension stays where it was.
            if c.belt.installation_tension_n.is_some()
                && c.belt.reference_center_distance_m.is_none()
            {
                c.belt.reference_center_distance_m = Some(here.center_distance_m);
            }
            let (ax, ay) = (
                (c.driven.center_m[0] - c.driver.center_m[0]) / here.center_distance_m,
                (c.driven.center_m[1] - c.driver.center_m[1]) / here.center_distance_m,
            );
            c.driven.center_m = [c.driver.center_m[0] + d * ax, c.driver.center_m[1] + d * ay];
        }
        if self.friction != here.friction {
            // The point holds the effective coefficient, whatever the file's wedge setting.
            c.contact.friction = self.friction;
            c.contact.groove_angle_deg = None;
        }
        if self.installation_tension_n != here.installation_tension_n {
            if c.belt.reference_center_distance_m.is_none() {
                c.belt.reference_center_distance_m = Some(here.center_distance_m);
            }
            c.belt.installation_tension_n = Some(self.installation_tension_n);
            c.belt.unstretched_length_m = None;
            c.belt.pre_strain = None;
        }
        if let Some(ea) = self.axial_stiffness_n {
            c.belt.axial_stiffness_n = ea;
        }
        if let Some(gap) = self.side_gap_m {
            let Some(tooth) = c.contact.tooth.as_mut() else {
                return Err(FomError::Config {
                    origin: "design point".into(),
                    message: format!(
                        "side gap = {gap} m applies to a toothed belt (belt.kind = \"toothed\"); \
                         this belt is \"{}\"",
                        c.belt.kind.name()
                    ),
                });
            };
            tooth.side_gap_m = gap;
        }
        if let Some(torque_nm) = self.load_torque_nm {
            set_peak_load_torque(&mut c, torque_nm)?;
        }
        for p in EffectParameter::ALL {
            if let Some(x) = self.effects.0[p.index()] {
                p.write(&mut c.effects, x)
                    .map_err(|message| FomError::Config {
                        origin: "design point".into(),
                        message,
                    })?;
            }
        }
        Ok(c)
    }

    /// Static span tension of a flexible belt at this point on `cfg`'s geometry,
    /// T0 = EA (L(d) - L0) / L0 with L0 = L(d_ref) / (1 + T_inst / EA) (docs/fom-numerics.md,
    /// "Initial state"), N; negative when the belt would be slack. No model is built.
    pub fn static_tension_n(&self, cfg: &DriveConfig) -> f64 {
        let (r1, r2) = radii(cfg);
        let ea = self.axial_stiffness_n.unwrap_or(cfg.belt.axial_stiffness_n)
            * cfg.relaxed_stiffness_share();
        let l0 = unstretched_from_tension_m(
            open_belt_length_m(reference_distance_m(cfg), r1, r2),
            self.installation_tension_n,
            ea,
        );
        static_tension_n(ea, open_belt_length_m(self.center_distance_m, r1, r2), l0)
    }

    /// The smaller of the two wrap angles at this point's centre distance, rad.
    pub fn smaller_wrap_angle_rad(&self, cfg: &DriveConfig) -> f64 {
        let (r1, r2) = radii(cfg);
        let (a1, a2) = wrap_angles_rad(self.center_distance_m, r1, r2);
        a1.min(a2)
    }
}

/// An error of the design point.
fn point_error(message: String) -> FomError {
    FomError::Config {
        origin: "design point".into(),
        message,
    }
}

/// Sets the largest torque of the driven load's torque profile to `torque_nm`: a cosine ramp's
/// end torque, or a table scaled so its largest |torque| is `torque_nm`.
fn set_peak_load_torque(c: &mut DriveConfig, torque_nm: f64) -> Result<()> {
    if !(torque_nm.is_finite() && torque_nm >= 0.0) {
        return Err(point_error(format!(
            "load torque = {torque_nm} N m must be a non-negative number"
        )));
    }
    let Some(profile) = c.driven.load.as_mut().and_then(|l| l.profile.as_mut()) else {
        return Err(point_error(format!(
            "load torque = {torque_nm} N m applies to a driven load with a torque profile \
             (driven.load.profile); this configuration has none"
        )));
    };
    let peak = profile.peak_torque_nm();
    match profile {
        crate::config::TorqueProfileConfig::CosineRamp { torque_nm: t, .. } => *t = torque_nm,
        crate::config::TorqueProfileConfig::Table { torque_nm: t, .. } => {
            if peak == 0.0 {
                return Err(point_error(
                    "load torque: driven.load.profile's table is zero throughout, so it has no \
                     shape to scale"
                        .into(),
                ));
            }
            t.iter_mut().for_each(|v| *v *= torque_nm / peak);
        }
    }
    Ok(())
}

/// The centre distance at which the static shaft load is `load_n` (bisection on the monotone
/// [`shaft_load_n`]), m.
fn center_distance_for_shaft_load_m(cfg: &DriveConfig, load_n: f64) -> Result<f64> {
    if !(load_n.is_finite() && load_n > 0.0) {
        return Err(point_error(format!(
            "shaft load = {load_n} N must be a positive number of newtons"
        )));
    }
    let (r1, r2) = radii(cfg);
    // Below (r2 - r1) the pulleys overlap; from the slack distance up the load grows.
    let mut lo = (r2 - r1).abs() * (1.0 + 1e-9) + 1e-9;
    let mut hi = cfg.center_distance_m().max(lo) * 1.01;
    let mut grow = 0;
    while shaft_load_n(cfg, hi) < load_n {
        hi *= 1.5;
        grow += 1;
        if grow > 60 || !hi.is_finite() {
            return Err(point_error(format!(
                "shaft load = {load_n} N cannot be reached by moving the driven pulley"
            )));
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if shaft_load_n(cfg, mid) < load_n {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * hi {
            break;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Centre distance at which the installation tension holds, m.
fn reference_distance_m(cfg: &DriveConfig) -> f64 {
    cfg.belt
        .reference_center_distance_m
        .unwrap_or_else(|| cfg.center_distance_m())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_point_applied_leaves_the_configuration_unchanged() {
        let cfg = DriveConfig::default_hvac();
        assert_eq!(*DesignPoint::nominal(&cfg).apply(&cfg).unwrap(), cfg);
    }

    #[test]
    fn static_tension_matches_the_model_estimate() {
        let cfg = DriveConfig::default_hvac();
        let p = DesignPoint {
            center_distance_m: 0.417,
            friction: 0.65,
            installation_tension_n: 230.0,
            axial_stiffness_n: Some(15_000.0),
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        };
        let moved = p.apply(&cfg).unwrap();
        let want = crate::model::Model::from_config(&moved)
            .unwrap()
            .nominal_static_tension_n();
        // Same formula, same operations: equal to rounding.
        assert!((p.static_tension_n(&cfg) - want).abs() < 1e-9 * want.abs());
    }

    #[test]
    fn a_non_positive_distance_is_refused_with_its_value() {
        let cfg = DriveConfig::default_hvac();
        let p = DesignPoint {
            center_distance_m: -0.42,
            ..DesignPoint::nominal(&cfg)
        };
        let e = p.apply(&cfg).unwrap_err().to_string();
        assert!(e.contains("centre distance") && e.contains("-0.42"), "{e}");
    }

    #[test]
    fn a_side_gap_sets_the_tooth_contact_and_only_a_toothed_belt_takes_it() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/synchronous-arc.toml");
        let cfg = DriveConfig::from_file(&path).unwrap();
        let p = DesignPoint {
            side_gap_m: Some(2.5e-4),
            ..DesignPoint::nominal(&cfg)
        };
        let moved = p.apply(&cfg).unwrap();
        assert_eq!(moved.contact.tooth.as_ref().unwrap().side_gap_m, 2.5e-4);
        assert_eq!(p.value_or_config(Variable::SideGap, &cfg), 2.5e-4);
        assert_eq!(
            DesignPoint::nominal(&cfg).value_or_config(Variable::SideGap, &cfg),
            2.0e-4
        );
        let hvac = DriveConfig::default_hvac();
        let e = DesignPoint {
            side_gap_m: Some(2.5e-4),
            ..DesignPoint::nominal(&hvac)
        }
        .apply(&hvac)
        .unwrap_err()
        .to_string();
        assert!(e.contains("side gap") && e.contains("\"v-belt\""), "{e}");
        let e = DesignPoint {
            side_gap_m: Some(-1e-4),
            ..DesignPoint::nominal(&cfg)
        }
        .apply(&cfg)
        .unwrap_err()
        .to_string();
        assert!(e.contains("contact.tooth.side_gap_m"), "{e}");
    }

    #[test]
    fn columns_round_trip() {
        let p = DesignPoint {
            center_distance_m: 0.42,
            friction: 0.7,
            installation_tension_n: 250.0,
            axial_stiffness_n: Some(2e4),
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        };
        assert_eq!(DesignPoint::from_columns(&Variable::ALL, &p.columns()), p);
        let q = DesignPoint {
            axial_stiffness_n: None,
            ..p
        };
        assert_eq!(DesignPoint::from_columns(&Variable::ALL, &q.columns()), q);
        assert_eq!(
            Variable::ALL.map(|v| q.get(v).is_some())[..4],
            [true, true, true, false]
        );
    }
}
