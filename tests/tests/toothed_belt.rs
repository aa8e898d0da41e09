//! The toothed (synchronous) belt: the tooth-groove contact against its law (a single tooth
//! pressed statically into a groove), the load sharing over the wrap against the quasi-static
//! tooth-spring distribution, and the shipped drive of seed paper
//! "arc-tooth-synchronous-belt-recurdyn" (`fom/configs/synchronous-arc.toml`).

use fom::belt_kind::tooth_record::ToothRecord;
use fom::config::{SpeedProfileConfig, TorqueProfileConfig};
use fom::contact::tooth::ToothMesh;
use fom::model::DRIVER;
use fom::{DriveConfig, Model, RunOptions};
use std::f64::consts::PI;

fn synchronous() -> DriveConfig {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fom/configs/synchronous-arc.toml");
    DriveConfig::from_file(&p).unwrap().into_inner()
}

fn with_gap(mut cfg: DriveConfig, gap_m: f64) -> DriveConfig {
    cfg.contact.tooth.as_mut().unwrap().side_gap_m = gap_m;
    cfg
}

/// The tooth nearest the middle of the driver's wrap (its groove is aligned with it when the
/// model is built) and its angle about the driver, rad.
fn middle_tooth(model: &Model) -> (usize, f64) {
    let mesh = model.belt_contact_as::<ToothMesh>().unwrap();
    // The driver sits left of the driven pulley: the middle of its wrap faces -x.
    (0..mesh.teeth)
        .filter_map(|i| {
            let (a, wrapped) = mesh.tooth_angle_rad(&model.belt, &model.pulleys, i, DRIVER);
            wrapped.then_some((i, a))
        })
        .min_by(|x, y| (x.1.cos()).total_cmp(&y.1.cos()))
        .unwrap()
}

/// Presses the middle tooth of the driver's wrap to the offset (tangential, radial outward) from
/// its groove's centre, at rest, and returns the force the groove puts on its segment in the
/// groove's frame (tangential, radial) with the tooth's loads.
fn pressed(gap_m: f64, tangential_m: f64, radial_m: f64) -> ([f64; 2], [f64; 3], Model) {
    pressed_in(&with_gap(synchronous(), gap_m), tangential_m, radial_m)
}

/// `pressed` on the drive `cfg`.
fn pressed_in(cfg: &DriveConfig, tangential_m: f64, radial_m: f64) -> ([f64; 2], [f64; 3], Model) {
    let mut model = Model::from_config(&cfg.check().unwrap()).unwrap();
    let (i, angle) = middle_tooth(&model);
    let mut mesh = model.belt_contact_as::<ToothMesh>().unwrap().clone();
    let (st, sr) = mesh.groove_offset_m(&model.belt, &model.pulleys, i, DRIVER);
    let e_t = [-angle.sin(), angle.cos()];
    let e_r = [angle.cos(), angle.sin()];
    let b = &mut model.belt;
    let s = i * mesh.stride;
    b.x[s] += (tangential_m - st) * e_t[0] + (radial_m - sr) * e_r[0];
    b.y[s] += (tangential_m - st) * e_t[1] + (radial_m - sr) * e_r[1];
    b.vx.fill(0.0);
    b.vy.fill(0.0);
    b.w.fill(0.0);
    b.fx.fill(0.0);
    b.fy.fill(0.0);
    b.tq.fill(0.0);
    mesh.normal_forces(b, &model.pulleys);
    let f = [
        b.fx[s] * e_t[0] + b.fy[s] * e_t[1],
        b.fx[s] * e_r[0] + b.fy[s] * e_r[1],
    ];
    let loads = mesh.loads_n[i];
    *model.belt_contact_as_mut::<ToothMesh>().unwrap() = mesh;
    (f, loads, model)
}

/// The oracle: eq. 3 at rest (F = K delta) summed over the tooth's contact points, each point's
/// penetration from the two arcs in the groove's frame (tooth centre at the offset, tooth axes
/// along the groove's), written here independently of `contact::tooth`: the force on the tooth
/// (tangential, radial) and the sum of the points' normal forces (the tooth's loads).
fn oracle(model: &Model, tangential_m: f64, radial_m: f64) -> [f64; 3] {
    let cfg = synchronous();
    let teeth = cfg.belt.teeth.as_ref().unwrap();
    let gap = model.belt_contact_as::<ToothMesh>().unwrap().law.side_gap_m;
    let mesh = model.belt_contact_as::<ToothMesh>().unwrap();
    let (r_t, r_g) = (teeth.profile_radius_m, teeth.profile_radius_m + 0.5 * gap);
    let mut f = [0.0; 3];
    for k in 0..15 {
        let phi = (k as f64 + 0.5) * PI / 15.0;
        // Point relative to the groove centre: tangential along the rotation, radial outward.
        let (pt, pr) = (tangential_m + r_t * phi.cos(), radial_m - r_t * phi.sin());
        let dist = pt.hypot(pr);
        let delta = dist - r_g;
        // Only below the land (pr < 0, the land circle's curvature is second order here).
        if delta <= 0.0 || pr >= 0.0 {
            continue;
        }
        let k_pt = if (5..10).contains(&k) {
            mesh.tip_point_stiffness
        } else {
            mesh.flank_point_stiffness
        };
        f[0] -= k_pt * delta * pt / dist;
        f[1] -= k_pt * delta * pr / dist;
        f[2] += k_pt * delta;
    }
    f
}

#[test]
fn single_tooth_pressed_into_its_groove_follows_the_contact_law() {
    let cfg = synchronous();
    let teeth = cfg.belt.teeth.clone().unwrap();
    // No side gap: a tangential press of s engages every point facing it by s cos(phi), and
    // the tooth's tangential stiffness is the one its rubber gives (belt::teeth, cantilever
    // in shear and bending), to second order in s / R (0.4 % at s = 10 um).
    let s = 1e-5;
    let (f, loads, model) = pressed(0.0, s, 0.0);
    let k = teeth.flank_stiffness_n_m();
    assert!(
        (-f[0] / (k * s) - 1.0).abs() < 0.01,
        "tangential force {} N against k s = {} N",
        -f[0],
        k * s
    );
    // Pressed forwards: the leading flank (a) carries most of it, the tip's leading half the
    // rest, the trailing flank nothing.
    assert!(
        loads[0] > 2.0 * loads[2] && loads[2] > 0.0 && loads[1] == 0.0,
        "{loads:?}"
    );
    let o = oracle(&model, s, 0.0);
    assert!((f[0] / o[0] - 1.0).abs() < 1e-6 && (f[1] - o[1]).abs() < 1e-6 * o[0].abs());

    // Backwards: flank b, same stiffness.
    let (f, loads, _) = pressed(0.0, -s, 0.0);
    assert!((f[0] / (k * s) - 1.0).abs() < 0.01);
    assert!(loads[1] > 0.0 && loads[0] == 0.0, "{loads:?}");

    // Pressed radially into the groove: every point engages by s sin(phi), and the tooth
    // pushes back with its radial (column) stiffness.
    let (f, loads, model) = pressed(0.0, 0.0, -s);
    let o = oracle(&model, 0.0, -s);
    assert!(
        f[1] > 0.0 && (f[1] / o[1] - 1.0).abs() < 1e-6,
        "{f:?} against {o:?}"
    );
    assert!((f[1] / (teeth.tip_stiffness_n_m() * s) - 1.0).abs() < 0.01);
    assert!(loads[2] > 0.0 && (loads[0] - loads[1]).abs() < 1e-9 * loads[0]);

    // With a side gap of 0.2 mm: nothing within the clearance of 0.1 mm per flank, the law
    // beyond it.
    let (f, loads, _) = pressed(2e-4, 0.9e-4, 0.0);
    assert_eq!((f, loads), ([0.0, 0.0], [0.0; 3]));
    let (f, _, model) = pressed(2e-4, 1.2e-4, 0.0);
    let o = oracle(&model, 1.2e-4, 0.0);
    assert!(
        f[0] < 0.0 && (f[0] / o[0] - 1.0).abs() < 1e-6,
        "{f:?} against {o:?}"
    );
}

/// The shipped drive slowed down to near-static running: driver at 60 r/min, the load torque
/// ramped in over 0.1 s, 0.5 s in all (a tooth takes 0.25 s through a wrap); two segments per
/// tooth (the distribution over the wrap is the same as at six; the largest transient load
/// is not, see `paper_set_up_short`).
fn quasi_static_run(gap_m: f64) -> fom::RunResult {
    let mut cfg = with_gap(synchronous(), gap_m);
    cfg.belt.segments = 120;
    // Ten times the shipped belt damping, so that the span and torsional vibration the ramp
    // starts has died out and the end state is the quasi-static one the theory describes.
    cfg.belt.axial_damping_s = 1e-6;
    cfg.belt.bending_damping_s = 1e-6;
    cfg.driver.speed_profile = Some(SpeedProfileConfig {
        time_s: vec![0.0, 0.1],
        rpm: vec![0.0, 60.0],
    });
    cfg.driven.load.as_mut().unwrap().profile = Some(TorqueProfileConfig::CosineRamp {
        start_s: 0.0,
        end_s: 0.1,
        torque_nm: 4.5,
    });
    cfg.simulation.duration_s = 0.5;
    cfg.simulation.output_interval_s = 1e-3;
    fom::simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap()
}

#[test]
fn load_sharing_over_the_wrap_follows_the_tooth_spring_distribution() {
    let run = quasi_static_run(2e-4);
    let model = &run.model;
    let mesh = model.belt_contact_as::<ToothMesh>().unwrap();
    let cfg = synchronous();
    let ea = cfg.belt.axial_stiffness_n;
    // Teeth wrapped on the driver, in the order they entered (the entry is at the top, the
    // belt turns counter-clockwise): angle turned since the entry.
    let mut wrap: Vec<(f64, usize)> = (0..mesh.teeth)
        .filter_map(|i| {
            let (a, w) = mesh.tooth_angle_rad(&model.belt, &model.pulleys, i, DRIVER);
            let turned = (a - PI / 2.0).rem_euclid(2.0 * PI);
            (w && turned < PI).then_some((turned, i))
        })
        .collect();
    wrap.sort_by(|a, b| a.0.total_cmp(&b.0));
    let loads: Vec<f64> = wrap.iter().map(|&(_, i)| mesh.loads_n[i][1]).collect();
    let tight = run.rows.last().unwrap().tight_span_tension_n;
    let slack = run.rows.last().unwrap().slack_span_tension_n;
    let r = model.pulleys[DRIVER].pitch_radius_m;
    let torque = run.rows.last().unwrap().driver_torque_nm;

    // The cord's equilibrium on the driver: span tension difference times radius is the
    // driver's torque (the teeth carry it all: the land is frictionless).
    assert!(
        ((tight - slack) * r / torque - 1.0).abs() < 0.03,
        "span tensions {tight:.1} - {slack:.1} N, torque {torque:.3} N m"
    );

    // The quasi-static tooth-spring distribution (shear lag between cord and teeth; Gerbert,
    // Traction Belt Mechanics, 1999, ch. 17): tooth i carries q_i = F(w_i) for its flank
    // compression w_i, the cord beyond it carries T_i = T_(i-1) - q_i, and the next tooth,
    // one pitch further on, sits further forward in its groove by the cord's stretch:
    // w_(i+1) = w_i - p T_i / EA. F is the tooth's static
    // characteristic (the law checked above, at the land seating); w_1 is shot so that the
    // tension after the last tooth is the slack span's. The grooves' pitch is the belt's
    // unstretched pitch p, so under tension T the belt's teeth are p T / EA further apart
    // than the grooves (the pitch difference that loads the entering teeth most).
    let p = mesh.pitch_m;
    let seat = model.pulleys[DRIVER].node_radius_m - model.pulleys[DRIVER].pitch_radius_m;
    let probe = Model::from_config(&(with_gap(synchronous(), 2e-4)).check().unwrap()).unwrap();
    // Tangential force (for the cord's equilibrium) and normal load (what the FOM reports).
    let tooth_force = |w: f64| {
        let o = oracle(&probe, -(1e-4 + w), seat);
        (o[0], o[2])
    };
    let distribute = |w1: f64| {
        let mut q = Vec::with_capacity(loads.len());
        let (mut w, mut t) = (w1, tight);
        for _ in 0..loads.len() {
            let (f, normal) = tooth_force(w.max(-1e-4));
            q.push(normal);
            t -= f;
            w -= p * t / ea;
        }
        (q, t)
    };
    let (mut lo, mut hi) = (-1e-4, 1e-3);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if distribute(mid).1 > slack {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (theory, _) = distribute(0.5 * (lo + hi));
    println!("entry -> exit, FOM vs tooth-spring theory (N):");
    for (q, th) in loads.iter().zip(&theory) {
        println!("  {q:7.2} {th:7.2}");
    }
    // Interior teeth (the first and last are half in their grooves, tilted with the belt's
    // turn, which the theory leaves out): within 15 % of the largest load (measured: 9 %), the
    // centre of load within half a tooth, and their total within 10 % (measured: 5.7 %).
    let peak = theory.iter().cloned().fold(0.0, f64::max);
    let n = loads.len();
    for k in 1..n - 1 {
        assert!(
            (loads[k] - theory[k]).abs() < 0.15 * peak,
            "tooth {k} of {n}: FOM {:.2} N, theory {:.2} N",
            loads[k],
            theory[k]
        );
    }
    let centre = |q: &[f64]| {
        q.iter().enumerate().map(|(k, v)| k as f64 * v).sum::<f64>() / q.iter().sum::<f64>()
    };
    assert!((centre(&loads) - centre(&theory)).abs() < 0.5);
    let (sum, sum_theory) = (
        loads[1..n - 1].iter().sum::<f64>(),
        theory[1..n - 1].iter().sum::<f64>(),
    );
    assert!(
        (sum / sum_theory - 1.0).abs() < 0.1,
        "{sum:.1} N against {sum_theory:.1} N"
    );
    // The first tooth meshes in against the groove's edge, tilted with the belt's turn, and
    // carries more than the theory's share (the interference at the first engaged tooth of the
    // seed paper's Figure 7).
    assert!(
        loads[0] > theory[0],
        "first tooth {:.2} N, theory {:.2} N",
        loads[0],
        theory[0]
    );
}

fn synchronous_text() -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fom/configs/synchronous-arc.toml");
    std::fs::read_to_string(p).unwrap()
}

/// The shipped toothed drive with one line replaced (the line must exist), built as a model.
fn build_edited(old: &str, new: &str) -> Result<Model, String> {
    let text = synchronous_text();
    assert!(text.contains(old), "test edits a line that exists: {old}");
    DriveConfig::from_toml_str(&text.replacen(old, new, 1), "sync.toml")
        .and_then(|c| Model::from_config(&c))
        .map_err(|e| e.to_string())
}

#[test]
fn bad_toothed_drives_are_refused_with_the_cause() {
    let err = build_edited("segments = 360", "segments = 370").unwrap_err();
    assert!(err.contains("multiple of belt.teeth.count"), "{err}");
    let err = build_edited(
        "pitch_diameter_m = 0.066701836 # 22",
        "pitch_diameter_m = 0.0683 # 22",
    )
    .unwrap_err();
    assert!(
        err.contains("whole number") && err.contains("pulley 0"),
        "{err}"
    );
    let err = build_edited(
        "unstretched_length_m = 0.5715",
        "unstretched_length_m = 0.57",
    )
    .unwrap_err();
    assert!(err.contains("tooth count times its pitch"), "{err}");
    let err = build_edited("kind = \"toothed\"", "kind = \"v-belt\"").unwrap_err();
    assert!(
        err.contains("apply to belt.kind = \"toothed\" only"),
        "{err}"
    );
    let err = build_edited("[contact.tooth]", "[contact.toothx]").unwrap_err();
    assert!(err.contains("toothx"), "{err}");
    let err = build_edited("side_gap_m = 2.0e-4", "side_gap_m = -1.0e-4").unwrap_err();
    assert!(err.contains("contact.tooth.side_gap_m"), "{err}");
    let err = build_edited("profile_radius_m = 2.8e-3", "profile_radius_m = 5.0e-3").unwrap_err();
    assert!(err.contains("belt.teeth.profile_radius_m"), "{err}");
    // A V-belt drive with a tooth table is refused, not silently run without teeth.
    let text = fom::config::DEFAULT_HVAC_TOML.replacen(
        "[driver]",
        "[belt.teeth]\ncount = 60\npitch_m = 0.01\nprofile_radius_m = 0.003\n\
         pitch_line_offset_m = 0.0007\nwidth_m = 0.02\nrubber_modulus_pa = 4.5e7\n\
         rubber_poisson = 0.46\n\n[driver]",
        1,
    );
    let err = DriveConfig::from_toml_str(&text, "hvac.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("apply to belt.kind = \"toothed\" only"),
        "{err}"
    );
}

/// Max flank load over the run, and the loaded flank's mean over the first and the last third of
/// the latest complete pass of any tooth through each pulley's wrap (driver flank b, driven
/// flank a), N.
fn paper_run(cfg: &DriveConfig) -> (f64, [[f64; 2]; 2]) {
    let run = fom::simulate(&cfg.check().unwrap(), RunOptions::default()).unwrap();
    // The energy ledger closes (input = load + dissipated + stored, within the summary's 2 %).
    assert_eq!(
        run.summary.energy_warning(),
        None,
        "{}",
        run.summary.to_text()
    );
    let rec = run.record::<ToothRecord>().unwrap();
    let mut thirds = [[0.0; 2]; 2];
    for (j, tangent, flank) in [(DRIVER, 3, 1), (fom::model::DRIVEN, 1, 0)] {
        let e = run.model.path.tangent_points()[tangent];
        let c = run.model.pulleys[j].center_m;
        let entry = (e[1] - c[1]).atan2(e[0] - c[0]);
        let pass = (0..rec.teeth)
            .map(|i| rec.last_pass(i, j, entry))
            .filter(|p| !p.is_empty())
            .max_by(|a, b| a.last().unwrap().0.total_cmp(&b.last().unwrap().0))
            .unwrap();
        assert!(pass[0].0 > 0.1, "the pass starts after the ramp");
        let mean = |lo: f64, hi: f64| {
            let v: Vec<f64> = pass
                .iter()
                .filter(|(_, a, _)| *a >= lo && *a < hi)
                .map(|(_, _, l)| l[flank])
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        thirds[j] = [mean(0.0, 60.0), mean(120.0, 180.0)];
    }
    (rec.max_flank_load_n(), thirds)
}

/// The seed paper's set-up (section IV) in its coarse, always-run form: two segments per tooth
/// and 0.2 s (the ramp to 1000 r/min and 4.5 N m takes 0.1 s). The qualitative pattern of the
/// paper's Figure 7: on the driver a tooth's load falls as it moves through the wrap from the
/// tight side; on the driven pulley it rises towards the tight side, where the tooth leaves.
/// The maximum load at this resolution is ~35 % above the converged one, so its value is
/// checked in `paper_side_gap_study` only.
#[test]
fn paper_set_up_short() {
    let mut cfg = synchronous();
    cfg.belt.segments = 120;
    cfg.simulation.duration_s = 0.2;
    let (max_n, [driver, driven]) = paper_run(&cfg);
    println!("max {max_n:.1} N; driver thirds {driver:?}, driven thirds {driven:?}");
    assert!(max_n.is_finite() && max_n > 0.0);
    assert!(
        driver[0] > 2.0 * driver[1],
        "driver: entry third {driver:?}"
    );
    assert!(driven[1] > 2.0 * driven[0], "driven: exit third {driven:?}");
}

/// The seed paper's side-gap study at the shipped resolution, as the acceptance target states it:
/// the maximum tooth load rises with the side gap, the ratios 0.2 / 0.1 mm and 0.3 / 0.1 mm within
/// 5 points of the paper's (1.14, 1.30), absolute values within 25 %. Measured
/// (`docs/validation/toothed-belt.md`; `studies/tooth-load/tooth-load-vs-side-gap.csv`):
/// 53.1 / 60.9 / 57.8 N, ratios 1.15 / 1.09 against 38.2 / 43.5 / 49.8 N: the largest load does not
/// rise steadily with the gap and is 11-39 % above the paper's, so the test fails
/// (`docs/validation/toothed-belt.md`, "What is not met"). About 2 min on two cores.
#[test]
#[ignore]
fn paper_side_gap_study() {
    let maxima: Vec<f64> = [1e-4, 2e-4, 3e-4]
        .iter()
        .map(|g| paper_run(&with_gap(synchronous(), *g)).0)
        .collect();
    println!("max flank loads {maxima:?} N");
    let paper = [38.2, 43.5, 49.8];
    for k in 0..3 {
        assert!(
            (maxima[k] / paper[k] - 1.0).abs() < 0.25,
            "{maxima:?} against {paper:?}"
        );
    }
    for k in 1..3 {
        let (ours, theirs) = (maxima[k] / maxima[0], paper[k] / paper[0]);
        assert!(
            (ours - theirs).abs() < 0.05,
            "ratio {ours:.3} against {theirs:.3}"
        );
    }
}

/// The shipped drive installed as the paper's: the driven pulley moved until the shaft load is
/// 400 N, i.e. 200 N in each span over 180 degrees of wrap.
#[test]
fn shipped_drive_carries_the_paper_shaft_load() {
    let (model, eq) = fom::simulation::prepare(&synchronous().check().unwrap()).unwrap();
    println!("span tensions {:?} N", eq.span_tension_n);
    let cfg = synchronous();
    let wrap = fom::statics::wrap_angles_rad(
        cfg.center_distance_m(),
        model.pulleys[DRIVER].pitch_radius_m,
        model.pulleys[fom::model::DRIVEN].pitch_radius_m,
    )
    .0;
    // Shaft load of two equal span tensions T over a wrap beta: 2 T sin(beta / 2).
    let shaft_n = (eq.span_tension_n.0 + eq.span_tension_n.1) * (0.5 * wrap).sin();
    assert!(
        (shaft_n / 400.0 - 1.0).abs() < 0.01,
        "shaft load {shaft_n:.1} N"
    );
}

/// The shaft-load design variable places the driven pulley where the static shaft load
/// 2 T0 cos(beta) is the one asked for (checked against the analytic static tension of the
/// moved drive), and the load-torque variable sets the ramp's end torque.
#[test]
fn shaft_load_and_load_torque_design_variables_move_the_drive() {
    let base = synchronous();
    for load_n in [250.0, 400.0, 600.0] {
        let p = fom::DesignPoint {
            shaft_load_n: Some(load_n),
            load_torque_nm: Some(3.25),
            ..fom::DesignPoint::nominal(&base)
        };
        let cfg = p.apply(&base).unwrap();
        let d = cfg.center_distance_m();
        // Equal pulleys: F = 2 T0 with T0 = EA (2 d + pi D - L0) / L0.
        let t0 = cfg.belt.axial_stiffness_n * (2.0 * d + PI * cfg.driver.pitch_diameter_m - 0.5715)
            / 0.5715;
        assert!(
            (2.0 * t0 / load_n - 1.0).abs() < 1e-9,
            "{load_n} N: {t0} N at {d} m"
        );
        assert!(
            (fom::statics::shaft_load_n(&cfg, d) / load_n - 1.0).abs() < 1e-9,
            "round trip"
        );
        match &cfg.driven.load.as_ref().unwrap().profile {
            Some(TorqueProfileConfig::CosineRamp { torque_nm, .. }) => {
                assert_eq!(*torque_nm, 3.25)
            }
            other => panic!("{other:?}"),
        }
    }
    let too_much = fom::DesignPoint {
        shaft_load_n: Some(-5.0),
        ..fom::DesignPoint::nominal(&base)
    };
    let e = too_much.apply(&base).unwrap_err().to_string();
    assert!(e.contains("shaft load = -5 N must be a positive"), "{e}");
}

/// The tooth-load surrogate in its coarse, always-run form: a 10-point campaign over side gap,
/// load torque and shaft load on the paper's drive at two segments per tooth (~1.7 s a run),
/// the tooth-load surrogate fitted, saved and read back, then checked against 3 fresh
/// full-order runs. Bound: the mean pass peak within 10 % and the largest load within 15 %
/// (the spread of the pass peaks at a point is ~10 % of their mean,
/// `docs/validation/toothed-belt.md`); the shipped 360-segment surrogate is measured in
/// `docs/validation/toothed-belt.md`, "The tooth-load surrogate".
#[test]
fn tooth_surrogate_trains_saves_and_predicts_fresh_full_order_runs() {
    let mut base = synchronous();
    base.belt.segments = 120;
    let settings = training::CampaignSettings {
        samples: 10,
        seed: 5,
        tooth: Some(training::ToothRanges {
            side_gap_m: [0.1e-3, 0.3e-3],
            load_torque_nm: [3.0, 6.0],
            shaft_load_n: [350.0, 450.0],
        }),
        ..training::CampaignSettings::toothed_default()
    };
    let dir = tempfile::tempdir().unwrap();
    let report = training::run_campaign(dir.path(), &base, &settings, None, &|_| {}).unwrap();
    assert!(report.complete && report.failed == 0, "{report:?}");
    let ds = training::Dataset::load(dir.path()).unwrap();
    // Every run kept the configuration's centre distance field and moved by its shaft load.
    assert!(ds
        .points
        .iter()
        .all(|p| p.status.max_tooth_load_n.is_some()));
    let s = rom::tooth::ToothSurrogate::fit(&ds).unwrap();
    let path = dir.path().join("tooth.json");
    rom::tooth::ToothSurrogateFile::new(s, training::config_hash(&ds.config))
        .save(&path)
        .unwrap();
    assert!(rom::tooth::ToothSurrogateFile::is_tooth_file(&path));
    let file = rom::tooth::ToothSurrogateFile::load(&path).unwrap();
    // The training seed would give the training points back: refused before any run.
    let e = rom::tooth::validate_tooth(&file.surrogate, 3, 5, &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("is the training seed"), "{e}");
    let checks = rom::tooth::validate_tooth(&file.surrogate, 3, 99, &|_| {}).unwrap();
    println!("{}", rom::tooth::validation_text(&checks));
    for c in &checks {
        let e_mean = (c.rom_mean_peak_n / c.fom_mean_peak_n - 1.0).abs();
        let e_max = (c.rom_max_n / c.fom_max_n - 1.0).abs();
        assert!(
            e_mean < 0.10,
            "mean pass peak off by {:.1} %",
            100.0 * e_mean
        );
        assert!(e_max < 0.15, "largest load off by {:.1} %", 100.0 * e_max);
        assert!(c.rom_mean_peak_interval_n[0] < c.rom_mean_peak_n);
        assert!(c.rom_mean_peak_n < c.rom_mean_peak_interval_n[1]);
    }
    // Outside the trained box: refused, and allowed on request with a flag in the output.
    let cfg = file.surrogate.config().unwrap();
    let far = fom::DesignPoint {
        side_gap_m: Some(0.5e-3),
        ..fom::DesignPoint::nominal(&cfg)
    };
    let e = file
        .surrogate
        .predict(&cfg, &far, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("side_gap_m = 0.0005 is outside the trained range"),
        "{e}"
    );
    assert!(
        file.surrogate
            .predict(&cfg, &far, true)
            .unwrap()
            .extrapolated
    );
    // An edited file is refused.
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n - 10] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    let e = rom::tooth::ToothSurrogateFile::load(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("checksum does not match"), "{e}");
}

/// `contact.tooth.tip_clearance_m = 0`: the groove arc's centre moves out by g / 2, so a tooth on
/// the land has its tip at the groove bottom, and a tangential shift s inside the side gap
/// wedges it: penetration sqrt(s^2 + g^2 / 4) - g / 2, along the line of the two arc centres
/// (tangent of its angle to the radial s / (g / 2)). The concentric groove (the default) leaves
/// the same shift free. Out-of-range clearances are refused.
#[test]
fn a_groove_without_tip_clearance_wedges_a_shifted_tooth() {
    let gap = 2e-4;
    let s = 0.25 * gap;
    let concentric = with_gap(synchronous(), gap);
    let (f, loads, _) = pressed_in(&concentric, s, 0.0);
    assert_eq!(f, [0.0, 0.0], "free inside the clearance: {loads:?}");
    let mut tip0 = concentric.clone();
    tip0.contact.tooth.as_mut().unwrap().tip_clearance_m = Some(0.0);
    // The tooth on the land sits g / 2 inside the moved groove centre.
    let (f, loads, model) = pressed_in(&tip0, s, -0.5 * gap);
    println!("force {f:?} N, loads {loads:?} N");
    assert!(f[0] < 0.0 && f[1] > 0.0, "pushed back and out: {f:?}");
    let angle_tan = -f[0] / f[1];
    assert!(
        (angle_tan / (s / (0.5 * gap)) - 1.0).abs() < 0.2,
        "tan {angle_tan}"
    );
    let delta = (s * s + 0.25 * gap * gap).sqrt() - 0.5 * gap;
    assert!(
        delta > 0.0
            && model
                .belt_contact_as::<ToothMesh>()
                .unwrap()
                .max_penetration_m
                > 0.5 * delta
    );
    let mut bad = concentric;
    bad.contact.tooth.as_mut().unwrap().tip_clearance_m = Some(0.6 * gap);
    let e = bad
        .check()
        .and_then(|c| Model::from_config(&c))
        .unwrap_err()
        .to_string();
    assert!(e.contains("tip_clearance_m"), "{e}");
}
