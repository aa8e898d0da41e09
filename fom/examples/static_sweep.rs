//! Static span tension versus centre distance and bending stiffness against EA (L(d) - L0) / L0.
use fom::config::DriveConfig;
use fom::simulation::prepare;
use fom::statics::open_belt_length_m;
use fom::DesignPoint;
fn main() {
    for ei in [0.02, 0.005, 0.0005] {
        for d in [0.414, 0.42, 0.43] {
            let mut cfg = DriveConfig::default_hvac();
            cfg.belt.bending_stiffness_n_m2 = ei;
            let cfg = DesignPoint {
                center_distance_m: d,
                ..DesignPoint::nominal(&cfg)
            }
            .apply(&cfg)
            .unwrap();
            let (m, eq) = prepare(&cfg).unwrap();
            let l0 = m.unstretched_length_m;
            let t = 20000.0 * (open_belt_length_m(d, 0.05, 0.1) - l0) / l0;
            println!("EI {ei:6} d {d}: formula {t:7.2} N, slack {:7.2} ({:+.2} %), tight {:7.2} ({:+.2} %)", eq.span_tension_n.0, 100.0 * (eq.span_tension_n.0 / t - 1.0), eq.span_tension_n.1, 100.0 * (eq.span_tension_n.1 / t - 1.0));
        }
    }
}
