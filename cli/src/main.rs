//! `rom`: the beltwin command line. Parses the flags (`args`) and dispatches to one module per
//! command (`commands/`); all real work is in the library crates.

mod args;
mod commands;
mod kinds;
mod progress;
mod values;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches};

use args::{Cli, Command};

/// The command line as parsed: the derive's, with what is known only at run time (the shipped
/// models' trained ranges in `rom predict --help`) and negative numbers taken as values
/// everywhere (`--mu -1` reaches its value parser).
pub fn command() -> clap::Command {
    let mut cmd = Cli::command();
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    for name in names {
        cmd = cmd.mut_subcommand(&name, |s| s.allow_negative_numbers(true));
    }
    cmd.mut_subcommand("predict", |s| {
        s.after_help(commands::info::trained_ranges_help())
    })
}

fn main() -> ExitCode {
    let matches = command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let (name, result) = match cli.command {
        Command::Simulate(a) => ("simulate", commands::simulate::run(a)),
        Command::Train(a) => ("train", commands::train::run(a)),
        Command::Predict(a) => ("predict", commands::predict::run(a)),
        Command::Info(a) => ("info", commands::info::run(a)),
        Command::Validate(a) => ("validate", commands::validate::run(a)),
        Command::Diagnose(a) => ("diagnose", commands::diagnose::run(a)),
        Command::Gap(a) => ("gap", commands::gap::run(a)),
        Command::Calibrate(a) => ("calibrate", commands::calibrate::run(a)),
        Command::Serve(a) => ("serve", commands::serve::run(a)),
        Command::ExportFmu(a) => ("export-fmu", commands::export_fmu::run(a)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(u) = e.downcast_ref::<commands::UsageError>() {
                // A usage error found after parsing: clap's message and exit code (2).
                let mut cmd = command();
                cmd.build();
                let sub = cmd.find_subcommand_mut(name).expect("a subcommand of rom");
                sub.error(u.kind, &u.message).exit();
            }
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
        rom::RomError::Impossible { input, reason } => Some(format!(
            "{}: {reason}; no model answers outside physics (--allow-extrapolation widens only \
             the trained ranges)",
            kinds::flag_of(*input)
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
