//! `rom`: the beltwin command line. Parses the flags (`args`) and dispatches to one module per
//! command (`commands/`); all real work is in the library crates.

mod args;
mod commands;
mod kinds;
mod progress;

use std::process::ExitCode;

use clap::Parser;

use args::{Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => commands::simulate::run(a),
        Command::Train(a) => commands::train::run(a),
        Command::Predict(a) => commands::predict::run(a),
        Command::Validate(a) => commands::validate::run(a),
        Command::Diagnose(a) => commands::diagnose::run(a),
        Command::Gap(a) => commands::gap::run(a),
        Command::Calibrate(a) => commands::calibrate::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(e.as_ref()));
            ExitCode::FAILURE
        }
    }
}

/// The message of a failed command, in the user's terms: a library parameter out of its domain
/// is named by its flag, and an extrapolation says how to allow it.
fn describe(e: &(dyn std::error::Error + 'static)) -> String {
    let invalid = |input: &rom::Input, message: &str| {
        args::flag_for(*input).map(|flag| format!("{flag} {message}"))
    };
    let rom_message = |r: &rom::RomError| match r {
        rom::RomError::InvalidArgument { input, message } => invalid(input, message),
        rom::RomError::Extrapolation { reason } => Some(format!(
            "{reason}; pass --allow-extrapolation to predict anyway"
        )),
        _ => None,
    };
    let specific = if let Some(r) = e.downcast_ref::<rom::RomError>() {
        rom_message(r)
    } else if let Some(t) = e.downcast_ref::<twin::TwinError>() {
        match t {
            twin::TwinError::InvalidArgument { input, message } => invalid(input, message),
            twin::TwinError::Rom(r) => rom_message(r),
            _ => None,
        }
    } else {
        None
    };
    specific.unwrap_or_else(|| e.to_string())
}
