//! The `uvms` binary: parses the command line and maps errors to exit codes
//! (0 success, 1 failed run, 2 bad input or usage; a run stopped by SIGINT, SIGTERM or SIGHUP
//! ends as killed by it, after removing the file it was writing).

use clap::Parser;
use std::io::Write;
use std::process::ExitCode;

fn main() -> ExitCode {
    #[cfg(unix)]
    stop_cleanly_on_signals();
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
            let _ = writeln!(
                std::io::stderr(),
                "error: usage: a command is required (see uvms --help)"
            );
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
            let _ = writeln!(std::io::stderr(), "error: usage: {message} (see uvms --help)");
            return ExitCode::from(2);
        }
    };
    match uvms::cli::execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed stderr is no reason to panic: the exit code still tells.
            let _ = writeln!(std::io::stderr(), "error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}

/// A signal that would stop the run (SIGINT, SIGTERM, SIGHUP) stops it where it is: the files
/// being written are removed, those already complete stay, nothing is written after (the lock
/// on their list is held to the end), and the process ends as killed by the signal (a shell
/// reports 128 + its number: 130 for Ctrl-C), so that scripts and loops stop too. A signal the
/// process was started ignoring (`nohup`'s SIGHUP, a background job's SIGINT) stays ignored.
#[cfg(unix)]
fn stop_cleanly_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    use signal_hook::low_level::{emulate_default_handler, signal_name};
    use std::io::IsTerminal;
    let wanted: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
        .into_iter()
        .filter(|s| !uvms::output::signal_ignored_at_start(*s))
        .collect();
    let mut signals = match signal_hook::iterator::Signals::new(&wanted) {
        Ok(s) => s,
        Err(e) => {
            let _ = writeln!(
                std::io::stderr(),
                "warning: cannot handle signals ({e}): an interrupted run may leave a .NAME.PID.tmp in --out"
            );
            return;
        }
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let _writing = uvms::output::remove_unfinished();
            // Off a progress bar's line, on a terminal; a closed stderr is no reason to go on.
            let newline = if std::io::stderr().is_terminal() { "\n" } else { "" };
            let name = signal_name(signal).unwrap_or("a signal");
            let _ = writeln!(
                std::io::stderr(),
                "{newline}error: interrupted by {name}: stopped; no file was left half-written"
            );
            let _ = emulate_default_handler(signal);
            std::process::exit(128 + signal);
        }
    });
}
