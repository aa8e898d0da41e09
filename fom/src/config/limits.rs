//! Limits a configuration is checked against, and the value checks every table uses. Data
//! only: no model type is named here.

/// Most output rows one run keeps (64 bytes each: 6.4 GB of the machine's memory).
pub const MAX_OUTPUT_ROWS: f64 = 1e8;

/// Most integrator steps one run may take, static-equilibrium search included: about 16 days
/// on one core for the default 240-segment belt (~14 us per step, measured). A step count
/// beyond this is a typo, not a study (`step_s = 1e-12` would run for days with no word).
pub const MAX_STEPS: f64 = 1e11;

/// Rated elongation assumed when `belt.max_strain` is absent: 10 %, the upper end of the
/// installation elongation of elastomer flat and round belts; cord-reinforced V-belts and
/// flat belts are rated far lower, so set `belt.max_strain` from the maker's data.
pub const DEFAULT_MAX_STRAIN: f64 = 0.10;

/// Static strain above which a run warns: 3 %, beyond the working strain of cord-reinforced
/// belts (the default V-belt runs at 1.25 %: 250 N on EA 20 kN).
pub const TYPICAL_WORKING_STRAIN: f64 = 0.03;

/// Relative tolerance of the strain limits: a belt installed at exactly its limit passes.
const STRAIN_TOLERANCE: f64 = 1e-9;

/// Whether `strain` exceeds `limit` by more than rounding.
pub(crate) fn strain_exceeds(strain: f64, limit: f64) -> bool {
    strain > limit * (1.0 + STRAIN_TOLERANCE)
}

/// Longest static-equilibrium search beyond its frictionless phase, simulated s
/// (`simulation::relax_to_equilibrium`); counted in the step limit `MAX_STEPS`.
pub const RELAXATION_MAX_S: f64 = 0.5;

/// The most belt segments a model may have: over 400 times the default drive's 240
/// (`fom/configs/`, docs/fom-numerics.md), far past any useful resolution; the state, the
/// contact buffers and the element forces of 100 000 segments take some tens of MB.
pub const MAX_SEGMENTS: usize = 100_000;

/// The most teeth a toothed belt may have (one contact body per tooth and pulley groove).
pub const MAX_TEETH: usize = 100_000;

/// Refuses a model larger than [`MAX_SEGMENTS`] segments or [`MAX_TEETH`] teeth, naming the
/// key.
pub fn check_model_size(segments: usize, teeth: Option<usize>) -> Result<(), String> {
    if segments > MAX_SEGMENTS {
        return Err(format!(
            "belt.segments = {segments} is too many (at most {MAX_SEGMENTS}; the default drive \
             has 240)"
        ));
    }
    if let Some(count) = teeth.filter(|&c| c > MAX_TEETH) {
        return Err(format!(
            "belt.teeth.count = {count} is too many (at most {MAX_TEETH})"
        ));
    }
    Ok(())
}

/// Bytes one output row (`output::OutputRow`, eight `f64`) takes in memory; `output.rs`
/// asserts it at compile time.
pub const OUTPUT_ROW_BYTES: usize = 64;

pub(crate) fn positive(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{key} = {} must be a positive finite number",
            crate::readable::readable(v)
        ))
    }
}

pub(crate) fn non_negative(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{key} = {} must be a non-negative finite number",
            crate::readable::readable(v)
        ))
    }
}

pub(crate) fn finite_all(key: &str, v: &[f64]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{key} = {v:?} must be finite"))
    }
}

pub(crate) fn table(key: &str, t: &[f64], y: &[f64]) -> Result<(), String> {
    if t.is_empty() || t.len() != y.len() {
        return Err(format!(
            "{key}: time_s and values must be non-empty and of equal length ({} vs {})",
            t.len(),
            y.len()
        ));
    }
    finite_all(&format!("{key}.time_s"), t)?;
    finite_all(&format!("{key} values"), y)?;
    if t.windows(2).any(|w| w[1] <= w[0]) {
        return Err(format!("{key}.time_s must be strictly increasing"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_model_too_large_is_refused_by_its_key() {
        assert!(super::check_model_size(240, Some(100)).is_ok());
        let e = super::check_model_size(100_000_000_000, None).unwrap_err();
        assert!(e.contains("belt.segments = 100000000000"), "{e}");
        let e = super::check_model_size(240, Some(usize::MAX)).unwrap_err();
        assert!(e.contains("belt.teeth.count"), "{e}");
    }
}
