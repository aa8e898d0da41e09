//! The command line's tests, one test binary (one link against every dependency instead of one
//! per file; `docs/testing.md`, "One test binary per crate"). Each file of this folder is a
//! module: run one with a filter, e.g. `cargo test --release --workspace --test cli golden::`.

mod cli;
mod cli_conventions;
mod cli_intervals;
mod cli_predict;
mod docs;
mod golden;
mod reliability;
mod serve;
mod serve_dashboard;
mod serve_gap;
mod serve_mqtt;
mod slurm;
mod support;
