//! The `uvms` binary: parses the command line and maps errors to exit codes
//! (0 success, 1 failed run, 2 bad input or usage).

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = uvms::cli::Cli::parse();
    match uvms::cli::execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
