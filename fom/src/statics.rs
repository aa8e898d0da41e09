//! Static formulas of an open two-pulley belt drive, in one place: belt length, wrap angles,
//! static tension and strain, the unstretched length a configuration specifies, the static
//! shaft load, the wedge's effective friction and the transmission ratio. No model is built:
//! the surrogate, the design point and model building all use these.

use std::f64::consts::PI;

use crate::config::{BeltKind, BeltLengthSpec, DriveConfig};
use crate::error::FomError;

/// Exact pitch length of an open belt on two pulleys (e.g. Shigley, Mechanical Engineering
/// Design, 10th ed., eq. 17-1 with the exact wrap angles):
/// L = 2 d cos(beta) + r1 (pi - 2 beta) + r2 (pi + 2 beta), beta = asin((r2 - r1) / d).
pub fn open_belt_length_m(d_m: f64, r1_m: f64, r2_m: f64) -> f64 {
    let beta = ((r2_m - r1_m) / d_m).asin();
    2.0 * d_m * beta.cos() + r1_m * (PI - 2.0 * beta) + r2_m * (PI + 2.0 * beta)
}

/// Wrap angles (driver, driven) of an open belt, rad: pi -/+ 2 asin((r2 - r1) / d).
pub fn wrap_angles_rad(d_m: f64, r1_m: f64, r2_m: f64) -> (f64, f64) {
    let beta = ((r2_m - r1_m) / d_m).asin();
    (PI - 2.0 * beta, PI + 2.0 * beta)
}

/// Static strain of a belt of unstretched length `l0_m` laid on a path of length `path_m`,
/// (L - L0) / L0 (docs/fom-numerics.md, "Initial state").
pub fn static_strain(path_m: f64, l0_m: f64) -> f64 {
    (path_m - l0_m) / l0_m
}

/// Unstretched belt length L0 from the configuration's length specification, m.
pub fn unstretched_length_m(cfg: &DriveConfig) -> Result<f64, FomError> {
    let (r1, r2) = pitch_radii_m(cfg);
    let ea = cfg.static_axial_stiffness_n();
    Ok(match cfg.length_spec() {
        BeltLengthSpec::UnstretchedLength { length_m } => length_m,
        BeltLengthSpec::PreStrain { strain } => {
            open_belt_length_m(cfg.center_distance_m(), r1, r2) / (1.0 + strain)
        }
        BeltLengthSpec::InstallationTension {
            tension_n,
            reference_center_distance_m,
        } => {
            if reference_center_distance_m <= r1 + r2 {
                return Err(FomError::Geometry(format!(
                    "reference centre distance {reference_center_distance_m} m is smaller \
                     than the sum of the pitch radii"
                )));
            }
            unstretched_from_tension_m(
                open_belt_length_m(reference_center_distance_m, r1, r2),
                tension_n,
                ea,
            )
        }
    })
}

/// The static strain of the configuration's belt laid on its open-belt path at its centre
/// distance, (L - L0) / L0 (docs/fom-numerics.md, "Initial state"), or why the belt cannot be
/// installed there: the pulleys overlap, the belt is slack (L0 not shorter than the path), or
/// it would have to stretch beyond its rated elongation `belt.max_strain`. The one definition
/// model building and the surrogates' physical domain (`docs/decisions/physical-domain.md`)
/// share.
pub fn installed_strain(cfg: &DriveConfig) -> Result<f64, FomError> {
    let d = cfg.center_distance_m();
    let (r1, r2) = pitch_radii_m(cfg);
    if d.is_nan() || d <= r1 + r2 {
        return Err(FomError::Geometry(format!(
            "the pulleys overlap at centre distance {} m: it must exceed the sum of the pitch \
             radii, {} m",
            crate::readable::readable(d),
            crate::readable::readable(r1 + r2)
        )));
    }
    let l_d = open_belt_length_m(d, r1, r2);
    let ea = cfg.static_axial_stiffness_n();
    let l0 = unstretched_length_m(cfg)?;
    let strain = static_strain(l_d, l0);
    // Four decimals for a drive's lengths; a typed-in 1e308 m stays short.
    let four = |x: f64| {
        if x.abs() < 1e6 {
            format!("{x:.4}")
        } else {
            crate::readable::readable(x)
        }
    };
    let (d4, l04, ld4) = (four(d), four(l0), four(l_d));
    if strain.is_nan() || strain <= 0.0 {
        return Err(FomError::Geometry(format!(
            "belt is slack at centre distance {d4} m: unstretched length {l04} m is not \
             shorter than the open-belt path {ld4} m (static tension would be {} N; \
             the belt's length comes from belt.unstretched_length_m, belt.pre_strain or \
             belt.installation_tension_n over the axial stiffness EA = {} N)",
            crate::readable::readable(ea * strain),
            crate::readable::readable(ea)
        )));
    }
    let max_strain = cfg.belt.max_strain();
    if crate::config::strain_exceeds(strain, max_strain) {
        return Err(FomError::Geometry(format!(
            "belt too short to wrap at centre distance {d4} m: it would have to stretch {} % \
             (unstretched {l04} m, path {ld4} m), beyond its rated elongation \
             belt.max_strain = {:.2} %",
            if strain < 1e6 {
                format!("{:.2}", 100.0 * strain)
            } else {
                crate::readable::readable(100.0 * strain)
            },
            100.0 * max_strain
        )));
    }
    Ok(strain)
}

/// Static span tension of a flexible belt, T0 = EA (L - L0) / L0 (docs/fom-numerics.md), N,
/// for a path of length `path_m` and an unstretched length `l0_m`; negative when slack.
pub fn static_tension_n(ea_n: f64, path_m: f64, l0_m: f64) -> f64 {
    ea_n * (path_m - l0_m) / l0_m
}

/// The same relation solved for L0: the unstretched length whose static span tension is
/// `tension_n` on a path of length `path_m`, L0 = L / (1 + T0 / EA), m.
pub fn unstretched_from_tension_m(path_m: f64, tension_n: f64, ea_n: f64) -> f64 {
    path_m / (1.0 + tension_n / ea_n)
}

/// Static shaft load of the belt on the driven shaft at centre distance `d_m`, N: the two
/// spans' static tension T0 = EA (L(d) - L0) / L0 (docs/fom-numerics.md, "Initial state"),
/// each at the angle beta = asin((r2 - r1) / d) to the line of centres, so F = 2 T0 cos(beta)
/// (the resultant of two equal forces; Shigley's Mechanical Engineering Design, 10th ed.,
/// sec. 17-2). Negative when the belt is slack there.
pub fn shaft_load_n(cfg: &DriveConfig, d_m: f64) -> f64 {
    let (r1, r2) = pitch_radii_m(cfg);
    let l0 = unstretched_length_m(cfg).unwrap_or(f64::NAN);
    let t0 = static_tension_n(
        cfg.static_axial_stiffness_n(),
        open_belt_length_m(d_m, r1, r2),
        l0,
    );
    let beta = ((r2 - r1) / d_m).asin();
    2.0 * t0 * beta.cos()
}

/// Pitch radii of driver and driven pulley, m.
pub fn pitch_radii_m(cfg: &DriveConfig) -> (f64, f64) {
    (
        0.5 * cfg.driver.pitch_diameter_m,
        0.5 * cfg.driven.pitch_diameter_m,
    )
}

/// Friction coefficient acting in the plane of the drive, from the material coefficient `mu`
/// and, for a V-belt, the groove angle: the wedge action of a V-groove gives
/// mu' = mu / sin(beta/2) (e.g. Shigley, Mechanical Engineering Design, 10th ed., eq. 17-17
/// context; Johnson, Contact Mechanics ch. 8); other kinds act with `mu`.
pub fn effective_friction(kind: BeltKind, mu: f64, groove_angle_deg: Option<f64>) -> f64 {
    match (kind, groove_angle_deg) {
        (BeltKind::VBelt, Some(angle)) => mu / (0.5 * angle.to_radians()).sin(),
        _ => mu,
    }
}

impl DriveConfig {
    /// Effective friction coefficient acting in the plane of the drive ([`effective_friction`]).
    pub fn effective_friction(&self) -> f64 {
        effective_friction(
            self.belt.kind,
            self.contact.friction,
            self.contact.groove_angle_deg,
        )
    }

    /// Transmission ratio R_t = driven / driver pitch diameter (seed paper eq. 1).
    pub fn transmission_ratio(&self) -> f64 {
        crate::slip::transmission_ratio(self.driver.pitch_diameter_m, self.driven.pitch_diameter_m)
    }
}
