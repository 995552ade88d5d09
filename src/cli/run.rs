//! `uvms run PIPELINE.toml [--out DIR]`: scan to contact operation, end to end.
//!
//! A pipeline file holds every stage's configuration: `[input]` (the scan, the reference
//! model, optionally the ground truth, the `up` prior and the initial guess), `[perception]`
//! (as `uvms check`), `[plan]` (as `uvms plan`; its `[plan.frames]` also place the scan's
//! surface in the world for the simulation) and `[sim]` (as `uvms sim`, with the true surface
//! the tool touches: a mesh file, or the run's own scanned or aligned reference surface,
//! `sim.surface_from`). Paths are relative to the pipeline file. Stages: segment → check → plan
//! (one stage, as `uvms plan`) → hover point → simulation. Writes what `uvms plan` and
//! `uvms sim` write into one folder (default `out/NAME` for `pipelines/NAME.toml`); the summary
//! nests each stage's summary under its name (`check`, `plan`, `sim`) with the stage timings.

use super::check::init_file;
use super::plan::{PlanCommandConfig, PlanInputs, plan_stage};
use super::sim::{load_sim_inputs, resolve_paths, sim_stage, surface_file};
use super::{Ctx, Report, named_in, pipeline_tables};
use crate::config::relative_to;
use crate::error::{Error, Result};
use crate::io::ply::write_mesh;
use crate::output::OutDir;
use crate::perception::PerceptionConfig;
use crate::plan::PlanConfig;
use crate::plan::patterns::PatternKind;
use crate::sim::{SimConfig, SurfaceFrame, SurfaceSource, check_trajectory};
use crate::trajectory::{Phase, Trajectory};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The surface the simulation's tool touched (scan frame), written with `sim.surface_from`
/// `"scan"` or `"reference"`.
pub const CONTACT_SURFACE: &str = "contact_surface.ply";

/// Arguments of `uvms run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The pipeline file (TOML).
    pub pipeline: PathBuf,
    /// Output folder (default: `out/` and the pipeline's name).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A pipeline file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pipeline {
    /// Input files.
    pub input: PlanInputs,
    /// Segmentation, registration, triangulation, accuracy.
    pub perception: PerceptionConfig,
    /// The planner.
    pub plan: PlanConfig,
    /// The simulation.
    pub sim: SimConfig,
}

impl Pipeline {
    /// Reads a pipeline file and resolves its paths against its folder.
    ///
    /// # Errors
    /// [`Error::Input`] for an unreadable file, a bad key or value, or a missing scan.
    pub fn load(path: &Path) -> Result<Self> {
        let mut p: Pipeline = crate::config::load(Some(path))?;
        if p.input.scan.as_os_str().is_empty() {
            return Err(Error::input(
                format!("{}: input.scan", path.display()),
                "the scan to process is missing",
            ));
        }
        let file = Some(path);
        p.input.scan = relative_to(file, &p.input.scan);
        p.input.reference = p.input.reference.as_deref().map(|r| relative_to(file, r));
        p.input.ground_truth = p.input.ground_truth.as_deref().map(|r| relative_to(file, r));
        if let Some(init) = init_file(&p.input.init) {
            p.input.init = relative_to(file, init).display().to_string();
        }
        p.plan.polyline.file = p.plan.polyline.file.as_deref().map(|r| relative_to(file, r));
        resolve_paths(&mut p.sim, file);
        // Every stage's values before the first stage runs: a bad value of a late stage must
        // not fail the run after the early stages have written their products.
        let origin = path.display();
        if let Some(up) = p.input.up {
            crate::segment::seabed::unit_up(&up.into())
                .map_err(|e| Error::input(format!("{origin}: input.up"), e))?;
        }
        p.perception
            .validate()
            .map_err(|e| e.in_table(&origin, "perception."))?;
        p.plan.validate().map_err(|e| e.in_table(&origin, "plan."))?;
        p.sim.validate().map_err(|e| e.in_table(&origin, "sim."))?;
        match p.sim.surface_from {
            SurfaceSource::File => {
                surface_file(&p.sim).map_err(|e| e.in_table(&origin, "sim."))?;
            }
            SurfaceSource::Reference if p.input.reference.is_none() => {
                return Err(Error::input(
                    format!("{origin}: sim.surface_from"),
                    "\"reference\" takes the aligned reference model: input.reference is not given",
                ));
            }
            SurfaceSource::Reference if p.plan.pattern == PatternKind::Line => {
                return Err(Error::input(
                    format!("{origin}: sim.surface_from"),
                    "\"reference\" takes the aligned reference model, and the line pattern runs on the seabed beside it: take \"scan\" (the scanned seabed) or a mesh file",
                ));
            }
            _ => {}
        }
        Ok(p)
    }
}

/// With `sim.surface_from = "scan"` the tool touches only what the camera saw: a point of the
/// dwell or the contact phase the plan had to put on the aligned reference (or, for a line, on
/// the seabed's plane) lies over a hole of the scanned surface, where the tool would fall in.
///
/// # Errors
/// [`Error::Failed`] (stage `sim`) counting those points and saying what to take instead.
fn scan_covers_path(trajectory: &Trajectory, reference: bool) -> Result<()> {
    let touching: Vec<_> = [Phase::Dwell, Phase::Contact]
        .into_iter()
        .flat_map(|p| trajectory.phase(p))
        .collect();
    let holes: Vec<_> = touching.iter().filter(|s| s.fallback).collect();
    let Some(first) = holes.first() else {
        return Ok(());
    };
    let instead = if reference {
        "sim.surface_from = \"reference\" or a mesh file"
    } else {
        "a mesh file (sim.surface)"
    };
    Err(Error::failed(
        "sim",
        format!(
            "sim.surface_from = \"scan\": {} of the {} points of the dwell and contact phases lie over holes of the scanned surface (the first at t = {:.2} s; the plan took them from the aligned reference or the seabed's plane), where the tool would fall in: take {instead}",
            holes.len(),
            touching.len(),
            first.t
        ),
    ))
}

/// Runs `uvms run`.
///
/// # Errors
/// As the stages: [`Error::Input`] (exit 2) for bad files or configuration,
/// [`Error::Failed`] (exit 1) naming the stage that failed.
pub fn run(args: &RunArgs, ctx: &Ctx) -> Result<Report> {
    let p = Pipeline::load(&args.pipeline)?;
    let out_dir = args.out.clone().unwrap_or_else(|| {
        let name = args
            .pipeline
            .file_stem()
            .map_or("run".into(), |s| s.to_os_string());
        Path::new("out").join(name)
    });
    let mut keyed: Vec<(String, &Path)> = p
        .input
        .files()
        .into_iter()
        .map(|(key, f)| (format!("input.{key}"), f))
        .collect();
    keyed.extend(p.sim.surface.as_deref().map(|f| ("sim.surface".into(), f)));
    keyed.extend(p.sim.model.as_deref().map(|f| ("sim.model".into(), f)));
    keyed.extend(
        p.plan
            .polyline
            .file
            .as_deref()
            .map(|f| ("plan.polyline.file".into(), f)),
    );
    // A missing or bad input of a late stage is found before the first stage writes anything.
    if let Some((key, missing)) = keyed.iter().find(|(_, f)| !f.exists()) {
        return Err(Error::input(
            format!("{}: {key}", args.pipeline.display()),
            format!("{}: no such file", missing.display()),
        ));
    }
    let mut inputs: Vec<&Path> = keyed.iter().map(|(_, f)| *f).collect();
    inputs.push(&args.pipeline);
    let in_pipeline = |e| named_in(e, Some(&args.pipeline), &[("", vec!["sim".into()])]);
    let sim_inputs = load_sim_inputs(&p.sim, &p.plan.frames).map_err(in_pipeline)?;
    let mut products = super::plan::products();
    products.extend(super::sim::PRODUCTS);
    products.push(CONTACT_SURFACE);
    let out = OutDir::create(&out_dir, &inputs, &products)?;
    let stages = ctx.progress(2, "pipeline");
    let mut text = format!("pipeline     {}\n", args.pipeline.display());
    let started = Instant::now();
    let plan_cfg = PlanCommandConfig {
        perception: p.perception.clone(),
        plan: p.plan.clone(),
    };
    // What only the plan tells (the run's length, the settling time against the contact) is
    // checked before the plan's stage writes.
    let planned_trajectory = format!("{}: the planned trajectory", args.pipeline.display());
    let accept = |t: &Trajectory| {
        check_trajectory(t, &p.sim, &planned_trajectory)
            .map(|_| ())
            .map_err(in_pipeline)
    };
    // The stage names `uvms plan`'s options; here they are the pipeline's `[input]` keys.
    let as_input_key = |e| match e {
        Error::Input { what, reason } if what.starts_with("--") && !what.contains(' ') => {
            Error::input(what[2..].replace('-', "_"), reason).in_table(args.pipeline.display(), "input.")
        }
        other => named_in(other, Some(&args.pipeline), &pipeline_tables()),
    };
    let planned = plan_stage(&p.input, &plan_cfg, &out, &accept).map_err(as_input_key)?;
    let plan_s = started.elapsed().as_secs_f64();
    stages.inc(1);
    text += &planned.text;
    let sim_started = Instant::now();
    let sim_inputs = match p.sim.surface_from {
        SurfaceSource::File => sim_inputs,
        from => {
            let (mesh, name) = match from {
                SurfaceSource::Reference => (planned.reference, "aligned reference"),
                _ => (planned.scanned, "scanned surface"),
            };
            let mesh = mesh.ok_or_else(|| {
                Error::failed(
                    "sim",
                    "sim.surface_from = \"scan\": the segmentation found no seabed plane to take the line's surface from",
                )
            })?;
            if from == SurfaceSource::Scan {
                scan_covers_path(&planned.trajectory, p.input.reference.is_some())?;
            }
            // What the tool touches, for `uvms sim --surface` and a viewer.
            out.write_with(CONTACT_SURFACE, |w| write_mesh(w, &mesh))?;
            let _ = writeln!(
                text,
                "wrote        {CONTACT_SURFACE} (the {name}, the surface the tool touches)"
            );
            let origin = format!("the run's {name}");
            sim_inputs.with_surface(mesh, &p.sim, SurfaceFrame::Scan, &origin, "sim.surface_from")?
        }
    };
    let stage = sim_stage(&planned.trajectory, &sim_inputs, &p.sim, &out, ctx).map_err(in_pipeline)?;
    let sim_s = sim_started.elapsed().as_secs_f64();
    stages.finish_and_clear();
    text += &stage.text;
    out.write_toml("config.toml", &p)?;
    let _ = writeln!(
        text,
        "stages       segment + check + plan {plan_s:.2} s, hover + sim {sim_s:.2} s; wrote everything in {}",
        out.path().display()
    );
    let summary = json!({
        "pipeline": args.pipeline.display().to_string(),
        "check": planned.check,
        "plan": planned.plan,
        "sim": stage.summary,
        "timings_s": {"segment_check_plan": plan_s, "hover_sim": sim_s, "total": plan_s + sim_s},
    });
    Ok(Report {
        summary,
        text,
        out: Some(out),
        failure: stage.failure,
    })
}
