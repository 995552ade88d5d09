//! The library's one error type.
//!
//! Two kinds of failure, as the command-line contract needs them:
//! - [`Error::Input`]: the user's input is wrong (a malformed file, a missing file, a typo in a
//!   configuration key, an impossible argument). The command exits with code 2.
//! - [`Error::Failed`]: the input was valid but the run did not succeed (no object found, ICP did
//!   not converge, the simulation diverged, an output could not be written). Exit code 1.
//!
//! Every message is one line that names the file, field or stage and says why.

use std::fmt::Display;

/// Errors returned by every fallible function of the library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Bad input: `what` names the file, field or argument, `reason` says what is wrong with it.
    #[error("{what}: {reason}")]
    Input {
        /// The file, field or argument at fault.
        what: String,
        /// Why it is rejected.
        reason: String,
    },
    /// A run that failed on valid input: `stage` names the stage, `reason` says what it reached.
    #[error("{stage}: {reason}")]
    Failed {
        /// The stage that failed (`seabed`, `icp`, `sim`, `write out/summary.json`, ...).
        stage: String,
        /// What went wrong and what was reached.
        reason: String,
    },
}

impl Error {
    /// A bad-input error (exit code 2).
    pub fn input(what: impl Display, reason: impl Display) -> Self {
        Error::Input {
            what: what.to_string(),
            reason: one_line(reason),
        }
    }

    /// A failed-run error (exit code 1).
    pub fn failed(stage: impl Display, reason: impl Display) -> Self {
        Error::Failed {
            stage: stage.to_string(),
            reason: one_line(reason),
        }
    }

    /// A bad value of a configuration read from `origin` (a file), its key in the file's table
    /// `table` (`"plan."`, or `""` for the top level): the error names the file and the whole
    /// key. Other errors are unchanged.
    #[must_use]
    pub fn in_table(self, origin: impl Display, table: &str) -> Self {
        match self {
            Error::Input { what, reason } => {
                let table = if what.starts_with(table) { "" } else { table };
                Error::Input {
                    what: format!("{origin}: {table}{what}"),
                    reason,
                }
            }
            other => other,
        }
    }

    /// A bad-input error about `what` (as named by code that cannot name it better) said of
    /// `name` instead. Other errors are unchanged.
    #[must_use]
    pub fn renamed(self, what: &str, name: impl Display) -> Self {
        match self {
            Error::Input { what: w, reason } if w == what => Error::Input {
                what: name.to_string(),
                reason,
            },
            other => other,
        }
    }

    /// The process exit code the command line uses for this error: 2 for bad input, 1 for a
    /// failed run.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } => 2,
            Error::Failed { .. } => 1,
        }
    }
}

/// Folds a possibly multi-line message into one line.
fn one_line(reason: impl Display) -> String {
    let s = reason.to_string();
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_table_names_the_file_and_the_whole_key() {
        let e = Error::input("seabed.threshold_m", "must be ≥ 0").in_table("p.toml", "perception.");
        assert_eq!(
            e.to_string(),
            "p.toml: perception.seabed.threshold_m: must be ≥ 0"
        );
        // A key already in the table's terms keeps them; a failed run is left alone.
        let e = Error::input("sim.tail_s", "must be ≥ 0").in_table("p.toml", "sim.");
        assert_eq!(e.to_string(), "p.toml: sim.tail_s: must be ≥ 0");
        let e = Error::failed("icp", "did not converge").in_table("p.toml", "perception.");
        assert_eq!(
            (e.to_string().as_str(), e.exit_code()),
            ("icp: did not converge", 1)
        );
    }
}
