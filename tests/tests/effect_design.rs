//! An effect's magnitude as a design variable: a campaign varies it, the data set records it,
//! the surrogate takes it as an input, through the one design-point type.

use beltwin_tests::{cheap_drive, cheap_settings};
use fom::effects::{BearingDrag, EffectParameter};
use fom::params::Variable;
use fom::DesignPoint;
use rom::Surrogate;
use training::{run_campaign, Dataset};

const KEY: &str = "bearing-drag.coulomb_nm";

#[test]
fn a_campaign_over_bearing_drag_gives_a_surrogate_that_reads_the_drag() {
    let mut cfg = cheap_drive();
    cfg.effects.bearing_drag = Some(BearingDrag {
        coulomb_nm: 0.0,
        viscous_nm_s: 0.0,
    });
    let mut settings = cheap_settings(12, 5);
    // A tight belt (creep only) so the drag shows as creep slip, not as the knee.
    settings.center_distance_m = [0.421, 0.424];
    settings.effect_parameters.insert(KEY.into(), [0.0, 4.0]);
    assert_eq!(
        settings.ranges().last().unwrap().0,
        Variable::Effect(EffectParameter::BearingCoulomb)
    );
    let dir = tempfile::tempdir().unwrap();
    run_campaign(dir.path(), &cfg, &settings, None, &|_| {}).unwrap();
    let design = std::fs::read_to_string(dir.path().join("design.csv")).unwrap();
    assert!(design.lines().next().unwrap().ends_with(KEY), "{design}");
    let ds = Dataset::load(dir.path()).unwrap();
    let not_ok: Vec<_> = ds.points.iter().filter(|p| !p.status.is_ok()).collect();
    assert!(not_ok.is_empty(), "{not_ok:?}");
    let s = Surrogate::fit(&ds, rom::surrogate::DEFAULT_ENERGY).unwrap();
    let at = |drag: f64| {
        let mut p = DesignPoint {
            center_distance_m: 0.4225,
            friction: 0.7,
            installation_tension_n: 250.0,
            axial_stiffness_n: None,
            effects: Default::default(),
            side_gap_m: None,
            load_torque_nm: None,
            shaft_load_n: None,
        };
        p.set(Variable::Effect(EffectParameter::BearingCoulomb), drag);
        s.predict_point(&ds.config, &p).unwrap().mean_slip_pct
    };
    let (low, high) = (at(0.3), at(3.7));
    // 3.4 N m more drag on a ~14 N m load: creep slip rises by roughly a quarter.
    assert!(high > 1.1 * low, "slip {low} at 0.3 N m, {high} at 3.7 N m");
    // Outside the trained drag range the surrogate refuses, naming the variable.
    let mut p = DesignPoint::nominal(&ds.config);
    p.center_distance_m = 0.4225;
    p.set(Variable::Effect(EffectParameter::BearingCoulomb), 6.0);
    let why = s.outside_ranges(&p).unwrap();
    assert!(why.contains(KEY), "{why}");
}
