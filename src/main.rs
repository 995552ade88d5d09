//! The `uvms` binary: parses the command line and maps errors to exit codes
//! (0 success, 1 failed run, 2 bad input or usage, 130 interrupted by a signal).

use clap::Parser;
use std::io::IsTerminal;
use std::process::ExitCode;

/// The exit code of a run stopped by a signal (SIGINT, SIGTERM or SIGHUP): 128 + SIGINT's
/// number, as shells report it.
const INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
    // A signal stops the run where it is: the files being written are removed, those already
    // complete stay, and nothing is written after (the lock is held until the exit).
    let handler = ctrlc::set_handler(|| {
        let _writing = uvms::output::remove_unfinished();
        // Off a progress bar's line, on a terminal.
        let newline = if std::io::stderr().is_terminal() { "\n" } else { "" };
        eprintln!("{newline}error: interrupted: stopped by a signal; no file was left half-written");
        std::process::exit(INTERRUPTED);
    });
    if let Err(e) = handler {
        eprintln!("warning: cannot handle interruptions ({e}): one may leave a .NAME.PID.tmp in --out");
    }
    let cli = match uvms::cli::Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version go to stdout as clap prints them.
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // A usage error in one line, as every other error: clap's message up to its usage
        // lines, and where to look.
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            eprintln!("error: usage: a command is required (see uvms --help)");
            return ExitCode::from(2);
        }
        Err(e) => {
            let rendered = e.render().to_string();
            let message: Vec<&str> = rendered
                .lines()
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            let message = message.join(" ");
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            eprintln!("error: usage: {message} (see uvms --help)");
            return ExitCode::from(2);
        }
    };
    match uvms::cli::execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
