//! The `uvms` command line (DESIGN.md, "Command line and files").
//!
//! Every command returns a [`Report`]: a JSON summary and a human-readable text. With `--json`
//! the summary is printed on stdout; the text always goes to stderr (unless `--quiet`). A command
//! that writes files writes them under `--out DIR`, including `summary.json` and the resolved
//! `config.toml`.

use crate::error::{Error, Result};
use crate::output::OutDir;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

pub mod arm;
pub mod check;
pub mod info;
pub mod plan;
pub mod run;
pub mod segment;
pub mod sim;
pub mod synth;

/// Command-line arguments.
#[derive(Debug, Parser)]
#[command(
    name = "uvms",
    version,
    about = "Underwater stereo scan to force-controlled contact operation"
)]
pub struct Cli {
    /// Print the run's summary as one JSON object on stdout.
    #[arg(long, global = true)]
    pub json: bool,
    /// No progress bars and no human-readable text on stderr (errors are still printed).
    #[arg(long, global = true)]
    pub quiet: bool,
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Inspect the arm of a model: fk, ik, id, jacobian, mass-matrix.
    Arm(arm::ArmArgs),
    /// What a PLY file holds: points, faces, properties, encoding, bounding box.
    Info(info::InfoArgs),
    /// Seabed and clusters of a scan, as coloured PLYs (seabed red, object green).
    Segment(segment::SegmentArgs),
    /// Align a reference model to the scanned object and report the alignment's accuracy.
    Check(check::CheckArgs),
    /// A synthetic underwater stereo scan with its ground truth.
    Synth(synth::SynthArgs),
    /// Segment, check and plan: a tool trajectory on the scanned surface (CSV, PLY).
    Plan(plan::PlanArgs),
    /// Simulate the contact operation along a trajectory under the seed's force control.
    Sim(sim::SimArgs),
    /// Run a pipeline file end to end: scan, alignment, trajectory, simulation.
    Run(run::RunArgs),
}

/// What a command produced.
#[derive(Debug)]
pub struct Report {
    /// The run's summary (`summary.json`, and stdout under `--json`).
    pub summary: serde_json::Value,
    /// A human-readable account, printed on stderr.
    pub text: String,
    /// Where the command wrote its products, if anywhere; `summary.json` is added there.
    pub out: Option<OutDir>,
    /// Why the run failed although its products are whole (written, then exit 1): a contact
    /// operation that never touched the surface.
    pub failure: Option<Error>,
}

/// Flags every command sees.
#[derive(Debug, Clone, Copy)]
pub struct Ctx {
    /// `--json` was given.
    pub json: bool,
    /// `--quiet` was given.
    pub quiet: bool,
}

impl Ctx {
    /// A progress bar of `len` steps, drawn only on an interactive terminal and never under
    /// `--quiet`.
    pub fn progress(&self, len: u64, message: &str) -> ProgressBar {
        if self.quiet || !std::io::stderr().is_terminal() {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed_precise}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(message.to_string());
        bar
    }
}

/// `N` comma-separated finite numbers within ±1e9.
pub(crate) fn parse_numbers<const N: usize>(s: &str) -> std::result::Result<[f64; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "expected {N} comma-separated numbers, got {}",
            parts.len()
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p.parse::<f64>().map_err(|_| format!("'{p}' is not a number"))?;
        if !o.is_finite() {
            return Err(format!("'{p}' is not a finite number"));
        }
        crate::config::within_max(*o, || format!("'{p}'")).map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// How errors name a command's configuration: its file, or `configuration` (the defaults).
pub(crate) fn config_origin(config: Option<&std::path::Path>) -> String {
    config.map_or_else(|| "configuration".into(), |p| p.display().to_string())
}

/// The sub-tables of a configuration `T` (`clean.`, `cluster.`, …, the keys whose values are
/// tables), by which a stage's error names a key it finds wrong only as it runs.
fn tables_of<T: serde::Serialize + Default>() -> Vec<String> {
    match toml::Value::try_from(T::default()) {
        Ok(toml::Value::Table(t)) => t
            .iter()
            .filter(|(_, v)| v.is_table())
            .map(|(k, _)| format!("{k}."))
            .collect(),
        _ => Vec::new(),
    }
}

/// The tables of a perception configuration (`segment --config`, `check --config`), for
/// [`named_in`].
pub(crate) fn perception_tables() -> [(&'static str, Vec<String>); 1] {
    [("", tables_of::<crate::perception::PerceptionConfig>())]
}

/// The tables of a pipeline file, or of `uvms plan --config`'s file, for [`named_in`].
pub(crate) fn pipeline_tables() -> [(&'static str, Vec<String>); 2] {
    [
        ("perception.", tables_of::<crate::perception::PerceptionConfig>()),
        ("plan.", tables_of::<crate::plan::PlanConfig>()),
    ]
}

/// A stage's error about a value of the configuration file `file` (found only once the stage
/// ran) named as the file's other errors are, by the file and the whole key: the first of
/// `tables` (a table of the file, and the keys it holds, by their start) holding the key the
/// error names. A key is a bare one (`cluster.tolerance_m`), not a file the commands read
/// (`line.csv`, `seabed.ply`) nor an error named already (`ring.toml: …`). Other errors, and
/// any without a file, are unchanged.
pub(crate) fn named_in(e: Error, file: Option<&std::path::Path>, tables: &[(&str, Vec<String>)]) -> Error {
    let is_key = |what: &str| {
        what.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._[]".contains(c))
            && !what
                .rsplit_once('.')
                .is_some_and(|(_, ext)| ["ply", "csv", "toml", "json"].contains(&ext))
    };
    let table = match (&e, file) {
        (Error::Input { what, .. }, Some(_)) if is_key(what) => tables
            .iter()
            .find(|(_, keys)| keys.iter().any(|k| what.starts_with(k)))
            .map(|(table, _)| *table),
        _ => None,
    };
    match (table, file) {
        (Some(table), Some(file)) => e.in_table(file.display(), table),
        _ => e,
    }
}

/// Runs a parsed command line: the command, then its summary and text.
///
/// # Errors
/// Whatever the command returns; the caller maps it to the exit code.
pub fn execute(cli: Cli) -> Result<()> {
    let ctx = Ctx {
        json: cli.json,
        quiet: cli.quiet,
    };
    let report: Report = match &cli.command {
        Command::Arm(a) => arm::run(a, &ctx)?,
        Command::Info(args) => info::run(args, &ctx)?,
        Command::Segment(args) => segment::run(args, &ctx)?,
        Command::Check(args) => check::run(args, &ctx)?,
        Command::Synth(args) => synth::run(args, &ctx)?,
        Command::Plan(args) => plan::run(args, &ctx)?,
        Command::Sim(args) => sim::run(args, &ctx)?,
        Command::Run(args) => run::run(args, &ctx)?,
    };
    if let Some(out) = &report.out {
        out.write_json("summary.json", &report.summary)?;
    }
    let text =
        (!ctx.quiet && !report.text.is_empty()).then(|| emit(&mut std::io::stderr(), &report.text, "stderr"));
    let json = ctx
        .json
        .then(|| emit(&mut std::io::stdout(), &format!("{}\n", report.summary), "stdout"));
    // The run's own failure before a failure to tell of it.
    report.failure.map_or(Ok(()), Err)?;
    text.into_iter().chain(json).collect()
}

/// Writes `text` to `stream`: a reader that has gone (a pipe into `head`) is no error, the
/// products being written; any other failure is.
fn emit(stream: &mut dyn std::io::Write, text: &str, name: &str) -> Result<()> {
    match stream.write_all(text.as_bytes()).and_then(|()| stream.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Error::failed(
            "output",
            format!("cannot write the report to {name}: {e}"),
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stage's error about a key is named by the file and the key's table; one about a file
    /// whose name looks like a key (`seabed.ply`, `line.csv line 3`), or one already named, is
    /// not (they read `c.toml: perception.seabed.ply`).
    #[test]
    fn named_in_names_keys_not_files() {
        let file = Some(std::path::Path::new("c.toml"));
        let named = |what: &str| named_in(Error::input(what, "why"), file, &pipeline_tables()).to_string();
        assert_eq!(
            named("cluster.tolerance_m"),
            "c.toml: perception.cluster.tolerance_m: why"
        );
        assert_eq!(named("ring.offset_m[2]"), "c.toml: plan.ring.offset_m[2]: why");
        for what in [
            "seabed.ply",
            "line.csv line 3",
            "ring.toml: the planned trajectory",
            "sim.x",
        ] {
            assert_eq!(named(what), format!("{what}: why"));
        }
    }
}
