//! `rom calibrate`: model updating to measured slip.

use twin::calibrate::{self, Distances, FreeSet, Target};

use super::{load_model, CommandResult};
use crate::args::CalibrateArgs;

pub fn run(a: CalibrateArgs) -> CommandResult {
    let (file, cfg) = load_model(a.model.as_deref(), a.config.as_deref())?;
    if !(a.tolerance.is_finite() && a.tolerance > 0.0) {
        return Err(format!("--tolerance must be positive, got {}", a.tolerance).into());
    }
    let targets: Vec<Target> = match (&a.measured, &a.table) {
        (_, Some(t)) => calibrate::read_slip_table(t)?,
        (Some(dir), None) => {
            let set = twin::measured::read_dataset(dir, twin::signal::MIN_STEADY_SAMPLES)?;
            calibrate::targets_from_dataset(&set, &cfg)?
        }
        (None, None) => unreachable!("clap requires one"),
    };
    let free = a.free.unwrap_or(FreeSet {
        friction: true,
        tension: true,
        ratio: false,
        stiffness: false,
        distances: if targets.iter().all(|t| t.known_center_distance_m.is_some()) {
            Distances::Known
        } else {
            Distances::Free
        },
    });
    let s = &file.surrogate;
    let c = calibrate::calibrate(s, &cfg, &targets, free, a.tolerance, !a.no_confirm)?;
    let mut text = c.to_text() + "\n";
    if a.leave_one_out {
        let rows = calibrate::leave_one_out(s, &cfg, &targets, free, a.tolerance)?;
        text += &calibrate::leave_one_out_text(&rows);
    }
    if let Some(out) = &a.out {
        let labels: Vec<String> = targets.iter().map(|t| t.label.clone()).collect();
        let toml = calibrate::calibrated_config_toml(&cfg, &c, &labels)?;
        fom::output::write_atomic(out, |w| w.write_all(toml.as_bytes()))?;
        text += &format!("wrote {}\n", out.display());
    }
    print!("{text}");
    Ok(())
}
