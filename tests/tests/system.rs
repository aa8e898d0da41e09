//! The system tests, one test binary (one link against every dependency instead of one per
//! file; `docs/testing.md`, "One test binary per crate"). Each file of this folder is a module:
//! run one with a filter, e.g. `cargo test --release --workspace --test system gap::`.

mod artifacts_layout;
mod bad_input;
mod calibration;
mod code_shape;
mod convergence;
mod creep_simulator;
mod diagnosis;
mod domain;
mod effect_design;
mod effect_hooks;
mod effects;
mod gap;
mod gap_load_levels;
mod gross_slip_and_vibration;
mod measured_data;
mod noise_shape;
mod readers_prop;
mod static_tension;
mod steady_running;
mod surrogate;
mod toothed_belt;
mod training_campaign;
mod until_settled;
