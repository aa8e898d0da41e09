//! The POD/GP surrogate against the full-order model at points it was not trained on, and its
//! file format.

use std::sync::OnceLock;

use beltwin_tests::{cheap_settings, light_fan_drive};
use fom::DesignPoint;
use rom::validate::{validate, ValidationReport};
use rom::{predict_distribution, Surrogate, SurrogateFile};
use training::{config_hash, run_campaign, Dataset};

/// Two loose points of the trained box past the knee (traction capacity ~120 and ~130 N
/// against the ~144 N the fan needs), added as a refinement round: the knee is ~1 % of this
/// box, so 30 Latin-hypercube runs seldom reach it.
fn knee_points() -> Vec<DesignPoint> {
    [(0.4160, 0.62, 200.0), (0.4161, 0.65, 203.0)]
        .iter()
        .map(|&(d, mu, t)| DesignPoint {
            center_distance_m: d,
            friction: mu,
            installation_tension_n: t,
            axial_stiffness_n: None,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        })
        .collect()
}

/// A surrogate of the light-fan drive from 30 training runs (seed 11) and the two
/// `knee_points`, fitted once per binary.
fn fitted() -> &'static (tempfile::TempDir, SurrogateFile) {
    static FIT: OnceLock<(tempfile::TempDir, SurrogateFile)> = OnceLock::new();
    FIT.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let cfg = light_fan_drive();
        // Knee runs settle later than creep runs: up to 8 s.
        let settings = training::CampaignSettings {
            duration_s: 8.0,
            ..cheap_settings(30, 11)
        };
        run_campaign(dir.path(), &cfg, &settings, None, &|_| {}).unwrap();
        training::add_points(dir.path(), &knee_points()).unwrap();
        let r = run_campaign(dir.path(), &cfg, &settings, None, &|_| {}).unwrap();
        assert_eq!(
            r.failed + r.unsettled + r.unbalanced,
            0,
            "training runs failed"
        );
        let ds = Dataset::load(dir.path()).unwrap();
        let s = Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY).unwrap();
        (dir, SurrogateFile::new(s, config_hash(&cfg)))
    })
}

fn validation() -> &'static ValidationReport {
    static V: OnceLock<ValidationReport> = OnceLock::new();
    V.get_or_init(|| validate(&fitted().1.surrogate, 10, 12, &|_| {}).unwrap())
}

#[test]
fn mean_slip_matches_full_model_at_fresh_points() {
    let v = validation();
    println!("{}", v.to_text());
    assert!(v.points.iter().all(|p| p.error.is_none()));
    // The accuracy target, max(0.05 pp, 2 %) at >= 90 % of the points, on 10 points.
    assert!(
        v.within_tolerance_share >= 0.9,
        "within tolerance at {:.0} % of points",
        100.0 * v.within_tolerance_share
    );
}

/// Each truth carries its own noise, the standard error of its steady mean (batch means), and
/// in creep it is small against the tolerance it is judged by: a miss there is the
/// surrogate's, not the truth's scatter (in the deep knee it reaches about half the tolerance:
/// `docs/validation/surrogate.md`, "What the two seed-38 misses are").
#[test]
fn each_truth_reports_the_standard_error_of_its_steady_mean() {
    let v = validation();
    for p in &v.points {
        assert!(
            p.fom_mean_se_pct.is_finite() && p.fom_mean_se_pct > 0.0,
            "{p:?}"
        );
        if p.region == Some(rom::validate::Region::Creep) {
            let tol = rom::validate::mean_slip_tolerance_pct(p.fom_mean_slip_pct);
            assert!(p.fom_mean_se_pct < 0.25 * tol, "{p:?}: tolerance {tol}");
        }
    }
}

#[test]
fn predicted_intervals_cover_the_full_model() {
    let v = validation();
    // The calibration target: 90 % intervals cover >= 80 % of the truths.
    assert!(
        v.coverage90_share >= 0.8,
        "coverage {:.0} %",
        100.0 * v.coverage90_share
    );
}

#[test]
fn predicted_distribution_is_close_to_the_simulated_one() {
    let v = validation();
    for p in &v.points {
        // Distribution shape: W1 within 10 % of the mean slip (the spread in the steady window
        // is 1-10 % of the mean on this drive).
        assert!(
            p.wasserstein1_pct <= 0.1 * p.fom_mean_slip_pct.abs().max(0.5),
            "W1 {} at {p:?}",
            p.wasserstein1_pct
        );
        // Start-up: the run-up transient is reproduced to within a few slip points (slip
        // swings over tens of percent in the first 0.2 s).
        assert!(
            p.startup_rmse_pct < 5.0,
            "start-up RMSE {} at {p:?}",
            p.startup_rmse_pct
        );
    }
}

#[test]
fn slip_rises_as_the_belt_is_loosened() {
    let (dir, file) = fitted();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    // The loosest training run (largest simulated slip) against the tightest corner.
    let ds = Dataset::load(dir.path()).unwrap();
    let loosest = ds
        .points
        .iter()
        .max_by(|a, b| {
            a.status
                .mean_slip_pct
                .unwrap()
                .total_cmp(&b.status.mean_slip_pct.unwrap())
        })
        .unwrap();
    let at = |q: DesignPoint| predict_distribution(s, &cfg, &q, 50, false).unwrap();
    let loose = at(DesignPoint {
        center_distance_m: loosest.point.center_distance_m,
        friction: loosest.point.friction,
        installation_tension_n: loosest.point.installation_tension_n,
        axial_stiffness_n: None,
        effects: Default::default(),
        side_gap_m: None,
        load_torque_nm: None,
        shaft_load_n: None,
    });
    let tight = at(DesignPoint {
        center_distance_m: 0.424,
        friction: 0.7,
        installation_tension_n: 300.0,
        axial_stiffness_n: None,
        effects: Default::default(),
        side_gap_m: None,
        load_torque_nm: None,
        shaft_load_n: None,
    });
    // The loosest run (a knee point) slips visibly more than a tight belt's creep (0.68 %),
    // and the surrogate, which saw that run, says so. (Within creep, slip hardly depends on
    // the tension: Grashof's creep goes with the tension difference, not the installation.)
    let simulated = loosest.status.mean_slip_pct.unwrap();
    assert!(
        simulated > tight.mean_slip_pct + 0.1,
        "training set has no loose run"
    );
    assert!(
        loose.mean_slip_pct > tight.mean_slip_pct + 0.1,
        "tight {} loose {}",
        tight.mean_slip_pct,
        loose.mean_slip_pct
    );
    let q = loose.quantiles_pct;
    assert!(q.p05 <= q.p25 && q.p25 <= q.p50 && q.p50 <= q.p75 && q.p75 <= q.p95);
}

#[test]
fn predictions_outside_the_trained_ranges_are_refused_unless_allowed() {
    let (_, file) = fitted();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let q = DesignPoint {
        center_distance_m: 0.43,
        friction: 0.7,
        installation_tension_n: 250.0,
        axial_stiffness_n: None,
        effects: Default::default(),
        side_gap_m: None,
        load_torque_nm: None,
        shaft_load_n: None,
    };
    let err = predict_distribution(s, &cfg, &q, 10, false)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("0.43") && err.contains("[0.416, 0.424]"),
        "{err}"
    );
    let d = predict_distribution(s, &cfg, &q, 10, true).unwrap();
    assert!(d.extrapolated);
}

#[test]
fn surrogate_file_round_trips_and_refuses_damage() {
    let (dir, file) = fitted();
    let path = dir.path().join("model.json");
    file.save(&path).unwrap();
    let back = SurrogateFile::load(&path).unwrap();
    let s = &back.surrogate;
    let cfg = s.config().unwrap();
    let q = DesignPoint {
        center_distance_m: 0.42,
        friction: 0.7,
        installation_tension_n: 250.0,
        axial_stiffness_n: None,
        effects: Default::default(),
        side_gap_m: None,
        load_torque_nm: None,
        shaft_load_n: None,
    };
    let a = predict_distribution(&file.surrogate, &cfg, &q, 20, false).unwrap();
    let b = predict_distribution(s, &cfg, &q, 20, false).unwrap();
    assert_eq!(a, b, "a saved and reloaded surrogate predicts the same");
    assert_eq!(back.header.samples, 30);
    assert_eq!(back.header.seed, 11);

    let bytes = std::fs::read(&path).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    let bad = dir.path().join("bad.json");
    let load_err = |content: &[u8]| {
        std::fs::write(&bad, content).unwrap();
        SurrogateFile::load(&bad).unwrap_err().to_string()
    };
    let e = load_err(&bytes[..bytes.len() - 100]);
    assert!(e.contains("truncated"), "{e}");
    assert!(text.contains("\"ratio\":2.0"));
    let e = load_err(
        text.replacen("\"ratio\":2.0", "\"ratio\":2.5", 1)
            .as_bytes(),
    );
    assert!(e.contains("edited"), "{e}");
    // The checksum covers the header too: an edited seed is refused.
    assert!(text.contains("\"seed\":11"));
    let e = load_err(text.replacen("\"seed\":11", "\"seed\":12", 1).as_bytes());
    assert!(e.contains("edited"), "{e}");
    let e = load_err(
        text.replacen("beltwin-surrogate/3", "beltwin-surrogate/0", 1)
            .as_bytes(),
    );
    assert!(
        e.contains("beltwin-surrogate/0") && e.contains("version"),
        "{e}"
    );
    let e = load_err(b"hello");
    assert!(e.contains("not a beltwin surrogate file"), "{e}");

    let mut other = light_fan_drive();
    other.contact.friction = 0.5;
    let e = back
        .check_config(&config_hash(&other), "other.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("another drive configuration than other.toml"),
        "{e}"
    );
    back.check_config(&config_hash(&light_fan_drive()), "cheap")
        .unwrap();
}

#[test]
fn refinement_puts_its_first_run_where_the_knee_is_least_certain() {
    let (dir, file) = fitted();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let ds = Dataset::load(dir.path()).unwrap();
    let existing: Vec<DesignPoint> = ds.points.iter().map(|p| p.point).collect();
    let seed = 99;
    let new = rom::refine::refinement_points(s, &cfg, &existing, 4, seed).unwrap();
    assert_eq!(new.len(), 4);
    for q in &new {
        assert!(s.outside_ranges(q).is_none(), "{q:?}");
        assert!(!existing.contains(q), "{q:?} is already in the design");
    }
    // U = |mean - 1 %| / std (AK-MCS) at the first pick against every candidate of the round:
    // the pick is among the 10 % least certain about the knee threshold.
    let u = |q: &DesignPoint| {
        let p = s.predict_point(&cfg, q).unwrap();
        (p.mean_slip_pct - rom::validate::KNEE_SLIP_PCT).abs() / p.surrogate_std_pct
    };
    let candidates = training::latin_hypercube(
        &s.settings.ranges(),
        rom::refine::CANDIDATES_PER_POINT * 4,
        seed,
    );
    let mut all: Vec<f64> = candidates.iter().map(u).collect();
    all.sort_by(f64::total_cmp);
    let first = u(&new[0]);
    assert!(
        first <= fom::stats::quantile(&all, 0.1),
        "first pick U {first}, candidates' 10 % quantile {}",
        fom::stats::quantile(&all, 0.1)
    );
}

/// The third pick of a round fills the region predicted past the knee threshold (the shipped
/// surrogate, whose box holds the knee; this file's light-fan box predicts none).
#[test]
fn refinement_fills_the_region_predicted_at_the_knee() {
    let file = beltwin_tests::shipped_surrogate();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let seed = 7;
    let new = rom::refine::refinement_points(s, &cfg, &[], 3, seed).unwrap();
    let mean = |q: &DesignPoint| s.predict_point(&cfg, q).unwrap().mean_slip_pct;
    let candidates = training::latin_hypercube(
        &s.settings.ranges(),
        rom::refine::CANDIDATES_PER_POINT * 3,
        seed,
    );
    let at_knee = candidates
        .iter()
        .filter(|q| mean(q) >= rom::validate::KNEE_SLIP_PCT)
        .count();
    println!("{at_knee} of {} candidates at the knee", candidates.len());
    assert!(at_knee >= 2, "the test needs candidates at the knee");
    assert!(
        mean(&new[2]) >= rom::validate::KNEE_SLIP_PCT,
        "third pick {:?} predicted at {} %",
        new[2],
        mean(&new[2])
    );
}

/// A settled run on the gross-slip branch (mean slip above `GROSS_SLIP_PCT`) is left out of
/// the fit and counted apart from the failed runs; a held-out truth there is no truth either.
#[test]
fn runs_on_the_gross_slip_branch_are_left_out_of_the_fit_and_of_the_truths() {
    use rom::surrogate::GROSS_SLIP_PCT;
    let s0 = &fitted().1.surrogate;
    let mut ds = Dataset::load(fitted().0.path()).unwrap();
    let k = ds.points.iter().position(|p| p.status.is_ok()).unwrap();
    // At the bound: kept; above it (32 %, where the gross-slip runs settled): left out.
    ds.points[k].status.mean_slip_pct = Some(GROSS_SLIP_PCT);
    let kept = Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY).unwrap();
    assert_eq!(kept.gross_slip_runs, 0);
    assert_eq!(kept.training_runs, s0.training_runs);
    ds.points[k].status.mean_slip_pct = Some(32.0);
    let s = Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY).unwrap();
    assert_eq!(s.gross_slip_runs, 1);
    assert_eq!(s.training_runs, s0.training_runs - 1);
    assert_eq!(s.failed_runs, s0.failed_runs);
    let max = s.max_trained_slip_pct.unwrap();
    assert!(max < GROSS_SLIP_PCT, "largest trained slip {max} %");

    // A stored validation file with one truth moved onto the gross-slip branch.
    let file = beltwin_tests::shipped_surrogate();
    let sha = &file.header.config_sha256;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/validation/validation-seed20261137.json");
    let (_, runs, _) = rom::validate::read_held_out(&path, sha).unwrap();
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let point = json["points"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|p| p["error"].is_null())
        .unwrap();
    point["fom_mean_slip_pct"] = serde_json::json!(32.0);
    let dir = tempfile::tempdir().unwrap();
    let moved = dir.path().join("v.json");
    std::fs::write(&moved, json.to_string()).unwrap();
    let (_, left, _) = rom::validate::read_held_out(&moved, sha).unwrap();
    assert_eq!(left.len(), runs.len() - 1);
}

/// The knee-aligned input's exponent is the one of largest likelihood among those tried, and
/// each tried exponent is recorded.
#[test]
fn knee_aligned_input_takes_the_most_likely_exponent() {
    let ds = Dataset::load(fitted().0.path()).unwrap();
    let s = &Surrogate::fit_with_exponents(
        &ds,
        rom::surrogate::DEFAULT_ENERGY,
        &rom::surrogate::FRICTION_EXPONENTS,
    )
    .unwrap();
    let ll = &s.friction_exponent_likelihoods;
    let tried: Vec<f64> = ll.iter().map(|(c, _)| *c).collect();
    assert_eq!(tried, rom::surrogate::FRICTION_EXPONENTS.to_vec());
    let best = ll.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    println!("log likelihoods {ll:?}");
    let chosen = s.aligned_capacity.map_or(0.0, |a| a.friction_exponent);
    assert_eq!(chosen, best.0);
    if let Some(a) = s.aligned_capacity {
        // The input's range spans the training points' u mu^c.
        assert!(a.range[0] > 0.0 && a.range[0] < a.range[1], "{a:?}");
    }
}

/// The friction samples' quantile functions through mode coefficients interpolated in mu
/// (`Surrogate::friction_quantile_functions`) agree with evaluating every sample directly, at
/// points spread over the shipped surrogate's box (knee and creep region alike).
#[test]
fn mixture_interpolation_matches_direct_evaluation() {
    let file = beltwin_tests::shipped_surrogate();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let mut worst = 0.0f64;
    for (i, d) in [0.4156, 0.4165, 0.418, 0.42, 0.4235]
        .into_iter()
        .enumerate()
    {
        for (mu, t) in [(0.62, 290.0), (0.7, 250.0), (0.78, 200.0)] {
            let q = fom::DesignPoint {
                center_distance_m: d,
                friction: mu,
                installation_tension_n: t - 10.0 * i as f64,
                axial_stiffness_n: None,
                effects: Default::default(),
                side_gap_m: None,
                load_torque_nm: None,
                shaft_load_n: None,
            };
            let mus = rom::predict::friction_samples(mu, 100);
            let fast = s.friction_quantile_functions(&cfg, &q, &mus).unwrap();
            let qs: Vec<_> = mus
                .iter()
                .map(|&m| fom::DesignPoint { friction: m, ..q })
                .collect();
            let direct = s.quantile_functions(&cfg, &qs).unwrap();
            let sd = s.predict_point(&cfg, &q).unwrap().surrogate_std_pct;
            for (a, b) in fast.iter().flatten().zip(direct.iter().flatten()) {
                worst = worst.max((a - b).abs() / sd);
            }
        }
    }
    println!("largest difference {worst:.3e} of the point's own sd");
    // Negligible against what the prediction can resolve: 1/1000 of the surrogate's own
    // uncertainty of the mean slip at the point (1 sd).
    assert!(worst < 1e-3, "{worst:.3e} of the sd");
}

/// The shipped surrogate against the full-order runs that `rom validate --json` stored at fresh
/// seeds, none used to train it or to calibrate its intervals (uniform, knee-band and onset
/// designs; `docs/validation/surrogate.md`, "The shipped model"). The mean-slip targets per
/// region of the settled full-order slip, pooled over the files: creep (below 1 %) within
/// max(0.05 pp, 2 %) at 95 % or more, the knee (from 1 %) within max(0.1 pp, 5 %) at 90 % or more.
/// No full-order run: the truths are the stored ones, so a retrained or refitted model is checked
/// on them too. The five-round model shipped before the gross-slip rule failed it (creep 91 %, knee
/// 86 % on these files); the knee-aligned model fitted without the two gross-slip runs passes
/// (`docs/validation/surrogate.md`, "The shipped model").
#[test]
fn shipped_surrogate_meets_the_region_targets_on_stored_fresh_runs() {
    let file = beltwin_tests::shipped_surrogate();
    let s = &file.surrogate;
    let cfg = s.config().unwrap();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/validation");
    let seeds = s
        .interval_calibration
        .as_ref()
        .map(|c| c.seeds.clone())
        .unwrap_or_default();
    let (mut n, mut within) = ([0usize; 2], [0usize; 2]);
    for name in FRESH_VALIDATION_FILES {
        let (seed, runs, _) =
            rom::validate::read_held_out(&dir.join(name), &file.header.config_sha256).unwrap();
        assert!(
            !seeds.contains(&seed),
            "{name}: its seed calibrated the intervals"
        );
        assert_ne!(seed, s.settings.seed, "{name}: the training seed");
        for r in runs {
            let p = s.predict_point(&cfg, &r.point).unwrap();
            let region = (r.mean_slip_pct >= rom::validate::KNEE_SLIP_PCT) as usize;
            let tol = rom::validate::mean_slip_tolerance_pct(r.mean_slip_pct);
            n[region] += 1;
            within[region] += ((p.mean_slip_pct - r.mean_slip_pct).abs() <= tol) as usize;
        }
    }
    println!(
        "creep {} of {}, knee {} of {}",
        within[0], n[0], within[1], n[1]
    );
    assert!(n[0] >= 50 && n[1] >= 50, "too few stored runs: {n:?}");
    assert!(
        within[0] as f64 >= 0.95 * n[0] as f64,
        "creep {} of {}",
        within[0],
        n[0]
    );
    assert!(
        within[1] as f64 >= 0.90 * n[1] as f64,
        "knee {} of {}",
        within[1],
        n[1]
    );
}

/// `rom validate --json` files in `tests/fixtures/validation/` at seeds fresh to the shipped surrogate.
const FRESH_VALIDATION_FILES: [&str; 15] = [
    "validation-seed20261127.json",
    "validation-seed20261128.json",
    "validation-knee-seed20261127.json",
    "validation-knee-seed20261128.json",
    "validation-onset-seed20261133.json",
    "validation-onset-seed20261134.json",
    "validation-seed20261135.json",
    "validation-knee-seed20261135.json",
    "validation-onset-seed20261136.json",
    "validation-seed20261137.json",
    "validation-knee-seed20261137.json",
    "validation-onset-seed20261137.json",
    "validation-seed20261138.json",
    "validation-knee-seed20261138.json",
    "validation-onset-seed20261138.json",
];
