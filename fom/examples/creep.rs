use fom::config::DriveConfig;
use fom::simulation::{simulate, RunOptions};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let variants: Vec<&str> = args[1..].iter().map(|s| s.as_str()).collect();
    for v in variants {
        let mut cfg = DriveConfig::default_hvac();
        cfg.simulation.duration_s = 2.5;
        for kv in v.split(',') {
            let (k, val) = kv.split_once('=').unwrap_or((kv, "0"));
            let x: f64 = val.parse().unwrap_or(0.0);
            match k {
                "vth" => cfg.contact.velocity_threshold_m_s = x,
                "ei" => cfg.belt.bending_stiffness_n_m2 = x,
                "ga" => cfg.belt.shear_stiffness_n = x,
                "h" => cfg.belt.thickness_m = x,
                "n" => cfg.belt.segments = x as usize,
                "dt" => cfg.simulation.step_s = x,
                "k" => cfg.contact.stiffness_n_m = x,
                "mu" => cfg.contact.friction = x,
                "t" => cfg.belt.installation_tension_n = Some(x),
                "g" => cfg.simulation.gravity_m_s2 = [0.0, 0.0],
                "eta" => cfg.belt.axial_damping_s = x,
                "etab" => cfg.belt.bending_damping_s = x,
                "d" => cfg.contact.damping_s_m = x,
                "base" => {}
                _ => panic!("{k}"),
            }
        }
        match simulate(&cfg, RunOptions::default()) {
            Ok(r) => {
                let s = &r.summary;
                let ea = cfg.belt.axial_stiffness_n;
                let theory =
                    100.0 * (1.0 - (ea + s.mean_slack_tension_n) / (ea + s.mean_tight_tension_n));
                println!("{v:28} slip {:.4} % theory {:.4} % (ratio {:.3}) Tt {:.1} Ts {:.1} pen {:.2e} rtf {:.2}", s.mean_slip_pct, theory, s.mean_slip_pct / theory, s.mean_tight_tension_n, s.mean_slack_tension_n, s.max_penetration_m, s.real_time_factor);
            }
            Err(e) => println!("{v:28} error {e}"),
        }
    }
}
