//! Calibration (model updating) with the shipped surrogate: recovery of known parameters, and
//! the seed paper's Table 2.

use std::path::Path;
use std::sync::OnceLock;

use fom::DesignPoint;
use rom::SurrogateFile;
use twin::calibrate::{calibrate, FreeSet, Target};

fn shipped() -> SurrogateFile {
    beltwin_tests::shipped_surrogate()
}

/// Five conditions at equally spaced distances d0 - i step (m), friction 0.7, installation
/// tension `t` (N), each the surrogate's mean slip plus `offset` (pp), distances unknown.
fn surrogate_made_targets(
    s: &rom::Surrogate,
    cfg: &fom::DriveConfig,
    d0: f64,
    step: f64,
    t: f64,
    offset: f64,
) -> Vec<Target> {
    (0..5)
        .map(|i| {
            let q = DesignPoint::drive(d0 - i as f64 * step, 0.7, t, None);
            Target {
                label: format!("c{i}"),
                mean_slip_pct: s.predict_point(cfg, &q).unwrap().mean_slip_pct + offset,
                mean_se_pct: 0.0,
                known_center_distance_m: None,
                tension_reading: None,
                position: i as f64,
            }
        })
        .collect()
}

#[test]
fn known_parameters_are_recovered_from_surrogate_made_targets() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    // Five equally spaced distances, tension 240 N, friction 0.7, slip offset +1 %.
    let (d0, step, t, offset) = (0.4190, 0.0008, 240.0, 1.0);
    let targets = surrogate_made_targets(s, &cfg, d0, step, t, offset);
    let free: FreeSet = "tension,ratio,spaced-distances".parse().unwrap();
    let c = calibrate(s, &cfg, &targets, free, 5.0, false).unwrap();
    println!("{}", c.to_text());
    // The fit reproduces its own targets closely (they are exactly reachable).
    for r in &c.conditions {
        assert!(r.error_pct < 1.0, "{r:?}");
    }
    // The slip offset is identified by the flat (healthy) conditions: within 0.1 pp.
    assert!(
        (c.slip_offset_pct - offset).abs() < 0.1,
        "{}",
        c.slip_offset_pct
    );
    // Distances and tension trade off along the looseness ridge; the 90 % intervals must hold
    // the truth.
    let truth = [d0, step, t, offset];
    for (p, v) in c.parameters.iter().zip(truth) {
        assert!(
            p.interval90[0] <= v && v <= p.interval90[1],
            "{} = {v} outside {:?}",
            p.name,
            p.interval90
        );
    }
}

/// Leave-one-out on targets the surrogate made at a known point (five equally spaced
/// distances from healthy into the knee, the last two in it like the seed paper's Table 2;
/// slip offset +1 pp): each condition predicted from the other four's posterior. The truth is
/// exactly reachable, so every 90 % predictive interval that has most of its draws inside the
/// box must hold it.
#[test]
fn leave_one_out_predictive_intervals_hold_surrogate_made_truths() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let (d0, step, t, offset) = (0.4185, 0.0008, 170.0, 1.0);
    let targets = surrogate_made_targets(s, &cfg, d0, step, t, offset);
    let free: FreeSet = "friction,tension,ratio,spaced-distances".parse().unwrap();
    let rows = twin::calibrate::leave_one_out(s, &cfg, &targets, free, 5.0, 0).unwrap();
    print!("{}", twin::calibrate::leave_one_out_text(&rows));
    let mut checked = 0;
    for r in &rows {
        let p = r
            .predictive
            .as_ref()
            .expect("equally spaced: every condition predictable");
        assert!(p.draws >= 400, "{p:?}");
        let [lo, hi] = p.interval90_pct;
        assert!(lo <= p.median_pct && p.median_pct <= hi, "{p:?}");
        if p.draws_outside_box * 2 < p.draws {
            assert!(
                (lo..=hi).contains(&r.measured_mean_slip_pct),
                "{}: truth {} outside the predictive interval {:?}",
                r.label,
                r.measured_mean_slip_pct,
                p.interval90_pct
            );
            checked += 1;
        }
    }
    // At most the loosest condition may leave the box with most of its draws.
    assert!(checked >= 4, "{checked} conditions checked");
}

#[test]
fn bad_free_parameter_lists_are_refused() {
    for bad in ["friction,spaced-distances,distances", "mass"] {
        let e = bad.parse::<FreeSet>().unwrap_err();
        assert!(!e.is_empty());
    }
    let e = "mass".parse::<FreeSet>().unwrap_err();
    assert!(e.contains("unknown free parameter `mass`"), "{e}");
}

#[test]
fn stiffness_needs_a_surrogate_trained_over_stiffness() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let targets = vec![Target {
        label: "a".into(),
        mean_slip_pct: 0.7,
        mean_se_pct: 0.0,
        known_center_distance_m: Some(0.42),
        tension_reading: None,
        position: 0.0,
    }];
    let free: FreeSet = "stiffness".parse().unwrap();
    let e = calibrate(s, &cfg, &targets, free, 5.0, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("trained at one belt stiffness"), "{e}");
}

/// A condition at a known distance outside the surrogate's trained range is named, with the
/// range, instead of "no parameter set reproduces these conditions" (another simulator's data
/// set at 0.425 m got only that).
#[test]
fn a_known_distance_outside_the_trained_range_is_named() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let [_, dhi] = s.settings.center_distance_m;
    let target = |label: &str, d: f64| Target {
        label: label.into(),
        mean_slip_pct: 0.7,
        mean_se_pct: 0.0,
        known_center_distance_m: Some(d),
        tension_reading: None,
        position: 0.0,
    };
    let targets = vec![target("in", dhi - 0.002), target("past", dhi + 0.001)];
    let free: FreeSet = "friction,tension".parse().unwrap();
    let e = calibrate(s, &cfg, &targets, free, 5.0, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("condition past") && e.contains("outside the surrogate's trained range"),
        "{e}"
    );
}

#[test]
fn stiffness_is_recovered_with_a_surrogate_trained_over_stiffness() {
    // A small campaign of the light-fan drive over EA 10-30 kN.
    let dir = tempfile::tempdir().unwrap();
    let cfg = beltwin_tests::light_fan_drive();
    let mut settings = beltwin_tests::cheap_settings(30, 21);
    settings.center_distance_m = [0.417, 0.424];
    settings.axial_stiffness_n = Some([10_000.0, 30_000.0]);
    training::run_campaign(dir.path(), &cfg, &settings, None, &|_| {}).unwrap();
    let ds = training::Dataset::load(dir.path()).unwrap();
    let s = rom::Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY).unwrap();
    // Creep slip goes as 1/EA: targets made by the surrogate at EA = 15 kN, known distances.
    let ea = 15_000.0;
    let targets: Vec<Target> = [0.423, 0.421, 0.419]
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            let q = DesignPoint {
                center_distance_m: d,
                friction: 0.7,
                installation_tension_n: 250.0,
                axial_stiffness_n: Some(ea),
                effects: Default::default(),
                side_gap_m: None,
                load_torque_nm: None,
                shaft_load_n: None,
            };
            Target {
                label: format!("c{i}"),
                mean_slip_pct: s.predict_point(&cfg, &q).unwrap().mean_slip_pct,
                mean_se_pct: 0.0,
                known_center_distance_m: Some(d),
                tension_reading: None,
                position: i as f64,
            }
        })
        .collect();
    let free: FreeSet = "stiffness".parse().unwrap();
    let c = calibrate(&s, &cfg, &targets, free, 5.0, false).unwrap();
    println!("{}", c.to_text());
    let fitted = c.axial_stiffness_n.unwrap();
    // The creep level pins EA: within 5 % (slip ~0.9 % at 15 kN against ~0.7 % at 20 kN).
    assert!((fitted / ea - 1.0).abs() < 0.05, "fitted EA {fitted}");
    let p = &c.parameters[0];
    assert!(p.interval90[0] <= ea && ea <= p.interval90[1], "{p:?}");
}

/// The seed paper's Table 2 (measured mean slip for d0..d4;
/// `tests/data/paper-table2-mean-slip.csv`, with its source in the header).
fn table2() -> Vec<Target> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/paper-table2-mean-slip.csv");
    twin::calibrate::read_slip_table(&p).unwrap()
}

/// The Table 2 fit with the twin's free parameters: the five distances equally spaced (first
/// and spacing), friction, installation tension and the slip offset (a V-belt's effective
/// pitch diameter against its datum diameter), each condition confirmed by the full-order model.
/// One fit shared by the tests that read it.
fn table2_fit() -> &'static twin::calibrate::Calibration {
    static FIT: OnceLock<twin::calibrate::Calibration> = OnceLock::new();
    FIT.get_or_init(|| {
        let file = shipped();
        let s = &file.surrogate;
        let cfg = s.config().unwrap();
        let free: FreeSet = "friction,tension,ratio,spaced-distances".parse().unwrap();
        // The target is 2 % per condition at the confirmed fit: the calibration is
        // asked for it, and confirms again (at most three times) while the full-order model
        // misses it (the seed paper's Figure 1 loop).
        let c = calibrate(s, &cfg, &table2(), free, 2.0, true).unwrap();
        println!("{}", c.to_text());
        c
    })
}

fn confirmed_slips(c: &twin::calibrate::Calibration) -> Vec<f64> {
    c.conditions
        .iter()
        .map(|r| r.fom_mean_slip_pct.unwrap())
        .collect()
}

#[test]
fn paper_table2_d0_to_d3_are_reproduced_and_the_curve_is_flat_then_steep() {
    let c = table2_fit();
    // The target's bound on the first four conditions after the full-order confirmation.
    for r in &c.conditions[..4] {
        assert!(r.fom_error_pct.unwrap() < 5.0, "{r:?}");
    }
    // Equally spaced and decreasing from d0 to d4.
    let d = &c.distances_m;
    assert!(d.windows(2).all(|w| w[1] < w[0]), "{d:?}");
    // The paper's shape: d0..d2 on one plateau (within 2.9 % of each other in the
    // experiment), then a steep end: d4 well above d0.
    let slip = confirmed_slips(c);
    assert!(slip[2] / slip[0] < 1.05, "{slip:?}");
    assert!(slip[4] > 1.5 * slip[0], "{slip:?}");
}

/// The target's bound (`docs/validation/calibration.md`, "Table 2 on the shipped model"):
/// every condition, d4 included, within 2 % after the full-order confirmation (the shipped
/// box reaches installation tensions down to 150 N; on the 200-300 N box d4 missed by 9.4 %).
#[test]
fn paper_table2_is_reproduced_within_two_percent() {
    let c = table2_fit();
    for r in &c.conditions {
        assert!(r.fom_error_pct.unwrap() < 2.0, "{r:?}");
    }
}

/// The leave-one-out on the seed paper's Table 2 (calibrate on four conditions through
/// the surrogate, predict the fifth), read from the posterior predictive: the knee condition
/// d3 within the target's 15 %, and the 90 % intervals of the conditions whose draws all stay
/// inside the surrogate's box hold the measured slip at least three times in four (for
/// calibrated intervals that fails with probability 1 - 0.9^4 - 4 0.9^3 0.1 = 5 %; asking all
/// four to hold would fail 34 % of the time, and passed only while the intervals were too
/// wide). A condition with draws past the box is left out of that count: its interval is of
/// the draws left inside, the tighter half, biased low. d4 lies past the box's smallest
/// distance for many draws of the others' fit; the check is that the prediction says so.
#[test]
fn paper_table2_leave_one_out_from_the_posterior_predictive() {
    let rows = table2_leave_one_out(0);
    let inside: Vec<bool> = rows
        .iter()
        .filter(|r| r.predictive.as_ref().unwrap().draws_outside_box == 0)
        .map(|r| {
            r.predictive
                .as_ref()
                .unwrap()
                .holds(r.measured_mean_slip_pct)
        })
        .collect();
    assert!(inside.len() >= 4, "{rows:?}");
    let held = inside.iter().filter(|&&h| h).count();
    assert!(
        4 * held >= 3 * inside.len(),
        "{held} of {} held: {rows:?}",
        inside.len()
    );
    assert!(
        rows[3].predictive_error_pct.unwrap() < 15.0,
        "{:?}",
        rows[3]
    );
    assert!(rows[4].predictive.as_ref().unwrap().draws_outside_box > 0);
}

/// The healthy conditions' posterior predictive is the surrogate's alone, with full-order
/// stand-ins on: their draws lie on the creep plateau, where the surrogate is trusted, so no
/// full-order run is made and the median and interval are the surrogate-only ones (the
/// stand-ins are for the knee and past the box: `Calibration::predictive`).
#[test]
fn healthy_conditions_predictive_needs_no_full_order_run() {
    let c = table2_fit();
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    for position in [0.0, 1.0] {
        let at =
            |draw: &twin::calibrate::Draw| draw.spacing_m.map(|[d0, step]| d0 - position * step);
        let alone = c.predictive(s, &cfg, at, 0).unwrap().unwrap();
        let with = c
            .predictive(s, &cfg, at, twin::calibrate::PREDICTIVE_FOM_RUNS)
            .unwrap()
            .unwrap();
        println!("position {position}: {with:?}");
        assert_eq!((with.draws_stood_in, with.fom_runs), (0, 0), "{with:?}");
        assert_eq!(with.median_pct, alone.median_pct);
        assert_eq!(with.interval90_pct, alone.interval90_pct);
    }
}

/// Table 2's d4 predicted from the other four through the posterior predictive, with
/// full-order runs standing in for the draws past the surrogate's box (d4 lies at the box's
/// smallest distance) and for those inside it at the knee: the knee draws inside the box are
/// stood in for too, and the 90 % interval holds the measurement. Long (96 full-order runs,
/// d3 and d4): `cargo test --release -p beltwin-tests --test system calibration:: -- --ignored`.
#[test]
#[ignore = "long (96 full-order runs): run with --ignored"]
fn paper_table2_d4_from_the_posterior_predictive_with_full_order_runs_at_the_knee() {
    let rows = table2_leave_one_out(twin::calibrate::PREDICTIVE_FOM_RUNS);
    let d4 = &rows[4];
    let p = d4.predictive.as_ref().unwrap();
    assert!(p.fom_runs > 0, "{p:?}");
    assert!(p.draws_stood_in > p.draws_outside_box, "{p:?}");
    assert!(p.holds(d4.measured_mean_slip_pct), "{d4:?}");
}

/// The target for Table 2's d4 left out: the posterior predictive's median within 15 %,
/// with the full-order model standing in wherever the surrogate is not trusted. Not met on
/// the shipped model: 17.59 % with the default 48 runs (15.26 % with 12, 17.98 % with 96:
/// `docs/validation/calibration.md`, "Table 2 on the shipped model"). Long, and failing today.
#[test]
#[ignore = "long (96 full-order runs), and the d4 target (15 %) is not met: run with --ignored"]
fn paper_table2_d4_left_out_is_within_15_percent() {
    let rows = table2_leave_one_out(twin::calibrate::PREDICTIVE_FOM_RUNS);
    let d4 = &rows[4];
    assert!(d4.predictive_error_pct.unwrap() < 15.0, "{d4:?}");
}

/// Table 2's leave-one-out on the shipped surrogate (the free set of
/// `docs/validation/calibration.md`, "Table 2 on the shipped model", 2 % tolerance), printed;
/// `fom_runs`: at most this many full-order runs stand in for the draws past the box and at the
/// knee (0: none).
fn table2_leave_one_out(fom_runs: usize) -> Vec<twin::calibrate::LeftOut> {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let free: FreeSet = "friction,tension,ratio,spaced-distances".parse().unwrap();
    let rows = twin::calibrate::leave_one_out(s, &cfg, &table2(), free, 2.0, fom_runs).unwrap();
    print!("{}", twin::calibrate::leave_one_out_text(&rows));
    rows
}

/// A belt setting's tension read by a meter (`Target::tension_reading`) checks the calibrated
/// installation tension: four labels made by the surrogate at 250 N, the static tension the
/// twin's belt settles at there read at each (sd 5 %). Where the loosest label slides at 5.3 %
/// (an effect the twin lacks), the slips read a looser belt and the misfit says the meter reads
/// a tighter one,
/// and the readings are not taken in; where it does not, the speeds agree with the readings,
/// which become the tension's prior and pin it nearer 250 N than the speeds alone; where no
/// tension was read, nothing is said of the tension.
#[test]
fn a_tension_reading_flags_a_calibrated_tension_the_meter_contradicts() {
    let file = shipped();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let t_true = 250.0;
    let targets = |read: bool, slide: bool| -> Vec<Target> {
        [0.424, 0.421, 0.418, 0.416]
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                let q = DesignPoint::drive(d, 0.7, t_true, None);
                let slip = s.predict_point(&cfg, &q).unwrap().mean_slip_pct;
                let static_n =
                    fom::simulation::settled_static_tension_n(&q.apply(&cfg).unwrap()).unwrap();
                Target {
                    label: format!("d{i}"),
                    mean_slip_pct: if slide && i == 3 { 5.3 } else { slip },
                    mean_se_pct: 0.005,
                    known_center_distance_m: Some(d),
                    tension_reading: read.then_some(twin::measured::TensionReading {
                        tension_n: static_n,
                        sd_n: 0.05 * static_n,
                    }),
                    position: i as f64,
                }
            })
            .collect()
    };
    let free: FreeSet = "friction,tension".parse().unwrap();
    let flag = |read, slide| {
        let c = calibrate(s, &cfg, &targets(read, slide), free, 5.0, false).unwrap();
        let f = c
            .misfit
            .iter()
            .find(|f| f.contains("tension readings"))
            .cloned();
        let width = c
            .parameter("installation_tension_n")
            .map(|p| p.interval90[1] - p.interval90[0]);
        (
            c.installation_tension_n,
            f,
            c.tension_prior.map(|tp| (tp, width)),
        )
    };
    let (t, f, taken) = flag(true, true);
    assert!(t < 215.0, "the sliding label pulls the fit looser: {t} N");
    let f = f.expect("the meter contradicts the fit");
    assert!(f.contains("looser belt than the meter reads"), "{f}");
    assert!(
        taken.is_none(),
        "contradicting readings stay a check: {taken:?}"
    );
    let (_, f, taken) = flag(false, true);
    assert_eq!(
        (f, taken.is_none()),
        (None, true),
        "no reading, no tension flag"
    );
    let (t, f, taken) = flag(true, false);
    assert_eq!(f, None, "a fit at {t} N agrees with the readings");
    let (taken, width) = taken.expect("agreeing readings are taken in as the tension's prior");
    let width = width.unwrap();
    println!("{taken:?}, calibrated {t} N, 90 % interval {width} N wide");
    assert!((taken.read_n - t_true).abs() < 0.05 * t_true, "{taken:?}");
    assert!(
        (t - taken.read_n).abs() < 3.0 * taken.read_sd_n,
        "{t} N, {taken:?}"
    );
    let [lo, hi] = taken.speeds_only_interval90;
    assert!(
        width < 0.5 * (hi - lo),
        "the readings narrow the tension's interval: {width} N against {} N",
        hi - lo
    );
}
