//! `uvms sim --trajectory TRAJ.csv [--surface MESH.ply] [--config F] --out DIR`: the contact
//! operation alone, from a trajectory `uvms plan` wrote. The configuration has a `[sim]` table
//! (see [`crate::sim::SimConfig`]) and a `[frames]` table (where the scan was taken from: maps a
//! surface given in the scan frame into the world). Paths in the configuration are relative to
//! its file.
//!
//! Writes `timeseries.csv`, the figures (`joint_moments`, `force`, `deviations`, `joints`, each
//! as SVG and PNG), `summary.json` and `config.toml`.

use super::{Ctx, Report};
use crate::arm::Arm;
use crate::config::relative_to;
use crate::error::{Error, Result};
use crate::frames::{Pose, ScanFrames, pose_error};
use crate::io::ply::read_mesh;
use crate::mesh::TriangleMesh;
use crate::model::UvmsModel;
use crate::output::OutDir;
use crate::plot::{to_png, to_svg};
use crate::sim::hover::HoverConfig;
use crate::sim::record::{Figures, figures, write_csv};
use crate::sim::{SimConfig, SimSummary, SurfaceFrame, SurfaceSource, check_plant_model, simulate};
use crate::trajectory::{Phase, Trajectory};
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Arguments of `uvms sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// The trajectory (`trajectory.csv` of `uvms plan`, world frame).
    #[arg(long)]
    pub trajectory: PathBuf,
    /// The true surface the tool touches (PLY mesh); overrides `sim.surface`.
    #[arg(long)]
    pub surface: Option<PathBuf>,
    /// Configuration (TOML) with `[sim]` and `[frames]` tables, or a pipeline file (a run's
    /// `config.toml`), whose `[sim]` and `[plan.frames]` are taken.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// The configuration of `uvms sim`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimCommandConfig {
    /// The simulation.
    pub sim: SimConfig,
    /// Where the scan was taken from (to map a scan-frame surface into the world).
    pub frames: ScanFrames,
}

/// Resolves the configuration's paths against the folder of its file.
pub fn resolve_paths(cfg: &mut SimConfig, file: Option<&Path>) {
    cfg.model = cfg.model.as_deref().map(|p| relative_to(file, p));
    cfg.surface = cfg.surface.as_deref().map(|p| relative_to(file, p));
}

/// A joint's least distance from its limits over a run below which the report suggests a
/// station with more room, rad.
const LITTLE_ROOM_RAD: f64 = 0.1;

/// The figures of a run, as readable text.
pub fn sim_text(s: &SimSummary, hover: &HoverConfig) -> String {
    let mut t = String::new();
    let [x, y, z] = s.hover_position_m;
    // A station over a load limit is the least loaded of those searched: none was within both.
    let over: Vec<String> = [
        (s.hover_thrust_utilisation, hover.max_thrust_utilisation, "thrust"),
        (s.hover_drive_utilisation, hover.max_drive_utilisation, "drive"),
    ]
    .iter()
    .filter(|(load, limit, _)| load > limit)
    .map(|(_, limit, what)| format!("sim.hover.max_{what}_utilisation = {limit}"))
    .collect();
    let over = if over.is_empty() {
        String::new()
    } else {
        format!(
            " (over {}: no station searched was within the limits, the least loaded taken)",
            over.join(" and ")
        )
    };
    let _ = writeln!(
        t,
        "hover        [{x:.3}, {y:.3}, {z:.3}] m, heading {:.1}°, worst manipulability {:.4}, contact held with {:.0} % of a thruster's thrust and {:.0} % of a drive's torque{over}",
        s.hover_yaw_deg,
        s.hover_manipulability,
        100.0 * s.hover_thrust_utilisation,
        100.0 * s.hover_drive_utilisation
    );
    let _ = writeln!(
        t,
        "sim          {:.1} s simulated at {:.0}× real time",
        s.simulated_s, s.realtime_factor
    );
    // Under a tenth of a radian the vehicle's drift or a model's error can take a joint to its
    // limit (README, "Model errors"): where to get more room is said.
    let room = if s.joint_limit_margin_rad < LITTLE_ROOM_RAD {
        " (little room: [sim.hover] min_limit_margin_rad chooses a station with more, at a price: README, \"Model errors\")"
    } else {
        ""
    };
    let _ = writeln!(
        t,
        "  arm        closest to a joint limit: joint {} at {:.3} rad{room}",
        s.joint_limit_margin_joint, s.joint_limit_margin_rad
    );
    let fig = &s.figures;
    // No settled force to show (never touched, or not for long): said so, not "NaN N". A path
    // without a force setpoint (soil: the tool pushed by position alone) has no error to it.
    let force = match (fig.force_settled_mean_n.is_finite(), fig.force_setpoint_n > 0.0) {
        (false, _) => "no settled force".to_string(),
        (true, true) if !fig.setpoint_varies() => format!(
            "settled mean {:.2} N (min {:.2}, RMS error {:.2}), overshoot {:.2} N",
            fig.force_settled_mean_n, fig.force_settled_min_n, fig.force_rms_error_n, fig.force_overshoot_n
        ),
        (true, true) => format!(
            "settled mean error {:+.2} N (RMS {:.2}; mean {:.2} N, min {:.2}), largest {:.2} N in the transients",
            fig.force_settled_error_mean_n,
            fig.force_rms_error_n,
            fig.force_settled_mean_n,
            fig.force_settled_min_n,
            fig.force_overshoot_n
        ),
        (true, false) => format!(
            "settled mean {:.2} N (min {:.2})",
            fig.force_settled_mean_n, fig.force_settled_min_n
        ),
    };
    let setpoint = if fig.force_setpoint_n > 0.0 {
        format!("setpoint {} N", setpoint_text(fig))
    } else {
        "no setpoint (the path followed by position)".to_string()
    };
    let _ = writeln!(
        t,
        "  force      {setpoint}, {force}, max {:.2} N",
        fig.force_max_n
    );
    let contact = match fig.first_contact_s {
        Some(first) => format!(
            "first at {first:.2} s, lost for {:.3} s after it",
            fig.contact_lost_s
        ),
        None => "never made".to_string(),
    };
    let _ = writeln!(
        t,
        "  contact    {contact}; largest contact force {:.1} N",
        fig.contact_force_max_n
    );
    let _ = writeln!(
        t,
        "  tool       ‖e‖ max {:.2} mm (off the path across k: {:.2} mm)",
        s.figures.tool_deviation_max_m * 1e3,
        s.figures.tool_path_error_max_m * 1e3
    );
    let _ = writeln!(
        t,
        "  vehicle    ‖r‖ max {:.2} mm, attitude max {:.3}°",
        s.figures.auv_deviation_max_m * 1e3,
        s.figures.attitude_deviation_max_rad.to_degrees()
    );
    if let (Some(median), Some(max)) = (
        s.figures.thrust_utilisation_contact_median,
        s.figures.thrust_utilisation_contact_max,
    ) {
        let _ = writeln!(
            t,
            "  thrusters  in contact the most loaded at a median {:.0} % of its thrust (at most {:.0} %)",
            100.0 * median,
            100.0 * max
        );
    }
    let _ = writeln!(
        t,
        "  identified joint moments within {:.3} N·m, force along k within {:.2} N",
        s.figures.moment_id_error_max_nm, s.figures.force_id_error_max_n
    );
    let f = &s.figures;
    if let (Some(median), Some(p95), Some(max)) = (
        f.moment_id_error_contact_median_nm,
        f.moment_id_error_contact_p95_nm,
        f.moment_id_error_contact_max_nm,
    ) {
        let _ = writeln!(
            t,
            "  in contact: joint moments' error median {median:.3}, p95 {p95:.3}, max {max:.3} N·m"
        );
    }
    t
}

/// What the simulation writes besides a summary and configuration: the time series and the
/// figures of [`figures`] as SVG and PNG.
pub const PRODUCTS: [&str; 9] = [
    "timeseries.csv",
    "joint_moments.svg",
    "joint_moments.png",
    "force.svg",
    "force.png",
    "deviations.svg",
    "deviations.png",
    "joints.svg",
    "joints.png",
];

/// What the simulation reads besides the trajectory: the true surface (world frame) and the
/// plant's model.
#[derive(Debug, Clone)]
pub struct SimInputs {
    /// The true surface and what names it in an error (its file, or the run's surface it
    /// is); `None` until [`SimInputs::with_surface`] gives the run's own (`sim.surface_from`).
    surface: Option<(TriangleMesh, String)>,
    model: UvmsModel,
    t_world_scan: Pose,
}

/// The true surface's file, `sim.surface`.
///
/// # Errors
/// [`Error::Input`] naming `sim.surface` when it is not given.
pub fn surface_file(cfg: &SimConfig) -> Result<&Path> {
    cfg.surface.as_deref().ok_or_else(|| {
        Error::input(
            "sim.surface",
            "the true surface the tool touches is needed (a PLY mesh, e.g. scene_mesh.ply of uvms synth; in uvms run, sim.surface_from = \"scan\" takes the scanned surface)",
        )
    })
}

/// Checks the configuration and reads the simulation's files, before any stage writes: the
/// surface a mesh (with `sim.surface_from = "file"`; the run's own surface comes later, by
/// [`SimInputs::with_surface`]), the model's arm one the analytic IK solves.
///
/// # Errors
/// [`Error::Input`] for bad files or configuration.
pub fn load_sim_inputs(cfg: &SimConfig, frames: &ScanFrames) -> Result<SimInputs> {
    cfg.validate()?;
    frames.validate()?;
    let model = crate::model::load(cfg.model.as_deref())?;
    let origin = crate::model::origin(cfg.model.as_deref());
    check_plant_model(&model).map_err(|e| e.in_table(&origin, ""))?;
    Arm::new(&model.arm, &model.environment)?
        .check_puma_structure()
        .map_err(|e| Error::input(origin, e))?;
    crate::sim::controllers_model(cfg, &model)?;
    let inputs = SimInputs {
        surface: None,
        model,
        t_world_scan: frames.t_world_scan(),
    };
    if cfg.surface_from != SurfaceSource::File {
        return Ok(inputs);
    }
    let file = surface_file(cfg)?;
    let mesh = read_mesh(file)?;
    inputs.with_surface(
        mesh,
        cfg,
        cfg.surface_frame,
        &file.display().to_string(),
        "sim.surface",
    )
}

impl SimInputs {
    /// The inputs with `mesh`, given in `frame`, as the true surface of a run configured by
    /// `cfg`; `origin` names it in an error, `key` the setting that chose it.
    ///
    /// # Errors
    /// [`Error::Input`] if the mesh has no triangles, holds a triangle twice, or the tool's
    /// footprint cannot sample it.
    pub fn with_surface(
        mut self,
        mesh: TriangleMesh,
        cfg: &SimConfig,
        frame: SurfaceFrame,
        origin: &str,
        key: &str,
    ) -> Result<Self> {
        if mesh.triangles.is_empty() {
            return Err(Error::input(
                origin,
                format!("has no triangles: the true surface the tool touches is a triangle mesh ({key})"),
            ));
        }
        let repeated = mesh.repeated_triangles();
        if repeated > 0 {
            return Err(Error::input(
                origin,
                format!(
                    "holds {repeated} triangles twice (a two-sided surface, or faces written twice): the tool's contact needs each surface once, its triangles wound with their normals out of the material ({key})"
                ),
            ));
        }
        crate::sim::contact::check_footprint(&cfg.contact, &mesh).map_err(|e| Error::input(origin, e))?;
        let mesh = match frame {
            SurfaceFrame::Scan => mesh.transformed(&self.t_world_scan),
            SurfaceFrame::World => mesh,
        };
        self.surface = Some((mesh, origin.to_string()));
        Ok(self)
    }
}

/// What [`sim_stage`] gives: the summary (as JSON), the readable account, and why the contact
/// operation failed although the products are written (see `operation_failure`).
pub struct SimStage {
    /// The simulation's summary.
    pub summary: serde_json::Value,
    /// Its readable account.
    pub text: String,
    /// Why the contact operation failed.
    pub failure: Option<Error>,
}

/// Simulates on `inputs` (see [`load_sim_inputs`]) and writes the products into `out`.
///
/// # Errors
/// [`Error::Input`] for a bad trajectory or configuration; [`Error::Failed`] when the hover
/// point or the simulation fails.
pub fn sim_stage(
    trajectory: &Trajectory,
    inputs: &SimInputs,
    cfg: &SimConfig,
    out: &OutDir,
    ctx: &Ctx,
) -> Result<SimStage> {
    let bar = ctx.progress(1000, "sim");
    let (mesh, origin) = inputs.surface.as_ref().ok_or_else(|| {
        Error::input(
            "sim.surface_from",
            format!(
                "\"{}\" takes the run's own surface, which this run did not make",
                cfg.surface_from.as_str()
            ),
        )
    })?;
    let result = simulate(trajectory, mesh, &inputs.model, cfg, &mut |f| {
        bar.set_position((f * 1000.0) as u64)
    })
    .map_err(|e| e.renamed("surface", origin));
    bar.finish_and_clear();
    let run = result?;
    out.write_with("timeseries.csv", |w| write_csv(&run.rows, w))?;
    // The figures are drawn side by side (rasterising the PNGs is most of the stage's time
    // after the loop), and written in order.
    let figures = figures(&run.rows, &cfg.scenario);
    let drawn: Vec<_> = std::thread::scope(|scope| {
        let drawing: Vec<_> = figures
            .iter()
            .map(|(_, fig)| scope.spawn(|| (to_svg(fig, 1200, 900), to_png(fig, 1200, 900))))
            .collect();
        drawing.into_iter().map(|d| d.join()).collect()
    });
    for ((name, _), pictures) in figures.iter().zip(drawn) {
        let (svg, png) = pictures.map_err(|_| Error::failed("plot", format!("drawing {name} failed")))?;
        out.write_bytes(&format!("{name}.svg"), svg.as_bytes())?;
        out.write_bytes(&format!("{name}.png"), &png)?;
    }
    let mut summary = serde_json::to_value(&run.summary).map_err(|e| Error::failed("summary", e))?;
    let failure = operation_failure(trajectory, run.contact_depth_m, &run.summary, cfg)
        .or_else(|| unreachable_failure(&run.summary, cfg))
        .or_else(|| deviation_failure(&run.summary, cfg));
    if let (Some(e), Some(map)) = (&failure, summary.as_object_mut()) {
        // The summary says it too: a script reading it sees the failure, not just figures.
        map.insert("failure".into(), e.to_string().into());
    }
    let mut text = sim_text(&run.summary, &cfg.hover);
    let _ = writeln!(
        text,
        "wrote        timeseries.csv, joint_moments/force/deviations/joints .svg and .png in {}",
        out.path().display()
    );
    Ok(SimStage {
        summary,
        text,
        failure,
    })
}

/// The force asked for in contact: `60.0`, or `40.0–65.0` where it varies along the path.
fn setpoint_text(fig: &Figures) -> String {
    if fig.setpoint_varies() {
        format!("{:.1}–{:.1}", fig.force_setpoint_min_n, fig.force_setpoint_n)
    } else {
        format!("{:.1}", fig.force_setpoint_n)
    }
}

/// A failed run when the trajectory's contact phase asks the tool to touch the surface (a force,
/// or points inside the material, `depth_m` deep at most) and it never did (a surface that is
/// not the one the trajectory was planned on, or in another frame): the figures of such a run
/// describe no contact operation; or when, once touched, the tool lost the surface during the
/// dwell or the contact phase (the vehicle or the drives could not hold the contact, no force
/// loop): the operation was not carried out along the whole path. A phase that asks for no
/// force along or above the surface (or so little inside it that the surface's spring there
/// pushes less than `sim.dwell.tolerance_n`) may skim it untouched, and leave it.
fn operation_failure(
    trajectory: &Trajectory,
    depth_m: Option<f64>,
    summary: &SimSummary,
    cfg: &SimConfig,
) -> Option<Error> {
    let depth = depth_m?;
    let (from, to) = (
        trajectory.phase(Phase::Contact).next()?.t,
        trajectory.phase(Phase::Contact).last()?.t,
    );
    let force = trajectory
        .phase(Phase::Contact)
        .map(|s| s.force)
        .fold(0.0, f64::max);
    // A phase asking for no force whose points lie no deeper than a skim.
    if force <= 0.0 && depth <= cfg.skim_depth_m() {
        return None;
    }
    let asked = crate::config::shown_to(force, 1);
    let asks = if force > 0.0 {
        format!("asks for up to {asked} N")
    } else {
        format!("runs up to {:.1} mm inside the material", depth * 1e3)
    };
    let figures = &summary.figures;
    let Some(first) = figures.first_contact_s else {
        let frame = match cfg.surface_frame {
            SurfaceFrame::Scan => "scan",
            SurfaceFrame::World => "world",
        };
        return Some(Error::failed(
            "sim",
            format!(
                "the tool never touched the surface, though the trajectory's contact phase (from {from:.2} to {to:.2} s) {asks} (the products are written): is sim.surface (in the {frame} frame, sim.surface_frame) the surface the trajectory was planned on?"
            ),
        ));
    };
    if figures.contact_lost_s > 0.0 {
        return Some(Error::failed(
            "sim",
            format!(
                "the tool lost the surface for {:.3} s in all after its first contact at {first:.2} s, though the trajectory's contact phase {asks} (the products are written; the thrusters saturated in {:.1} % of the control periods, {} tool targets out of the arm's reach, ‖e‖ up to {:.1} mm)",
                figures.contact_lost_s,
                100.0 * summary.thrust_saturated_fraction,
                summary.unreachable_steps,
                1e3 * figures.tool_deviation_max_m
            ),
        ));
    }
    // A force asked for and not held: the contact operation did not apply it. The error is
    // each period's against its own set-point, which may vary along the path.
    let off = figures.force_settled_error_mean_n;
    if force <= 0.0 || off.abs() <= cfg.dwell.tolerance_n {
        return None;
    }
    if off.is_nan() {
        return Some(Error::failed(
            "sim",
            format!(
                "the tool first touched at {first:.2} s, too late for the force to settle within the contact phase (to {to:.2} s, sim.settle_time_s = {} s after the touch): the force asked for was never held (the products are written)",
                cfg.settle_time_s
            ),
        ));
    }
    let mut why = Vec::new();
    if figures.force_offset_max_m >= cfg.force.max_offset_m * (1.0 - 1e-9) {
        why.push(format!(
            "the force loop's offset reached its limit, sim.force.max_offset_m = {} m (a surface softer or farther than planned, or too small a limit)",
            cfg.force.max_offset_m
        ));
    }
    if summary.dwell_wait_s >= cfg.dwell.max_wait_s {
        why.push(format!(
            "the dwell waited its {} s (sim.dwell.max_wait_s) without the force settling",
            cfg.dwell.max_wait_s
        ));
    }
    why.push(format!(
        "the thrusters saturated in {:.1} % of the control periods, ‖e‖ up to {:.1} mm",
        100.0 * summary.thrust_saturated_fraction,
        1e3 * figures.tool_deviation_max_m
    ));
    Some(Error::failed(
        "sim",
        format!(
            "the force along k settled at {:.2} N on average against the {} N asked for, {:.2} N off, beyond sim.dwell.tolerance_n = {} N (the products are written; {})",
            figures.force_settled_mean_n,
            setpoint_text(figures),
            off.abs(),
            cfg.dwell.tolerance_n,
            why.join("; ")
        ),
    ))
}

/// A failed run when the arm could not reach some of the tool's targets along the path (the
/// set-points held where they were; the tail after the path does not count): the path was
/// not followed.
fn unreachable_failure(summary: &SimSummary, cfg: &SimConfig) -> Option<Error> {
    let n = summary.unreachable_steps;
    (n > 0).then(|| {
        Error::failed(
            "sim",
            format!(
                "the arm could not reach {n} of the tool's targets ({:.3} s of the run) within its joint limits without changing its posture (its set-points held): the path was not followed (the products are written; ‖e‖ up to {:.1} mm, the thrusters saturated in {:.1} % of the control periods)",
                n as f64 / cfg.control_rate_hz,
                1e3 * summary.figures.tool_deviation_max_m,
                100.0 * summary.thrust_saturated_fraction
            ),
        )
    })
}

/// A failed run when the tool strayed past `sim.max_tool_deviation_m` from where the control
/// system wanted it: wherever it pressed or passed then, it was not on the planned path.
fn deviation_failure(summary: &SimSummary, cfg: &SimConfig) -> Option<Error> {
    let e = summary.figures.tool_deviation_max_m;
    // (Not finite: the run would have stopped as diverged.)
    (e > cfg.max_tool_deviation_m).then(|| {
        Error::failed(
            "sim",
            format!(
                "the tool strayed {:.1} mm from where the control system wanted it, past sim.max_tool_deviation_m = {} m: the path was not followed (the products are written; ‖r‖ up to {:.1} mm, the thrusters saturated in {:.1} % of the control periods)",
                1e3 * e,
                crate::config::shown(cfg.max_tool_deviation_m),
                1e3 * summary.figures.auv_deviation_max_m,
                100.0 * summary.thrust_saturated_fraction
            ),
        )
    })
}

/// A surface in the scan frame is placed in the world by the configuration's `[frames]`: they
/// must be the frames the trajectory was planned with (its note), or the tool runs along a
/// surface that is elsewhere.
fn check_frames(
    trajectory: &Trajectory,
    file: &Path,
    cfg: &SimCommandConfig,
    config: Option<&Path>,
) -> Result<()> {
    if cfg.sim.surface_frame == SurfaceFrame::World {
        return Ok(());
    }
    let origin = file.display().to_string();
    let Some(planned) = trajectory.planned_t_world_scan(&origin)? else {
        return Ok(());
    };
    let (turned_deg, moved) = pose_error(&planned, &cfg.frames.t_world_scan());
    if moved <= 1e-6 && turned_deg <= 1e-6f64.to_degrees() {
        return Ok(());
    }
    let (whose, remedy) = match config {
        Some(c) => (
            format!("{}'s [frames]", c.display()),
            "give [frames] the frames of the plan",
        ),
        None => (
            "the default [frames] (no --config)".to_string(),
            "give --config the plan's configuration (a run's config.toml holds it)",
        ),
    };
    Err(Error::input(
        origin,
        format!(
            "was planned with the scan frame {moved:.3} m and {turned_deg:.2}° from where {whose} put it (camera_in_vehicle, vehicle_in_world): the surface, in the scan frame (sim.surface_frame), would not be where the trajectory runs; {remedy}"
        ),
    ))
}

/// `uvms sim`'s configuration: a file of `[sim]` and `[frames]`, or a pipeline file (the
/// `config.toml` a `uvms run` writes too), whose `[sim]` and `[plan.frames]` are taken; paths
/// relative to the file.
fn load_config(path: Option<&Path>) -> Result<SimCommandConfig> {
    let Some(path) = path else {
        return Ok(SimCommandConfig::default());
    };
    let text = crate::config::read_text(path, "a TOML file")?;
    let pipeline = text
        .parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("input") || t.contains_key("plan"));
    if pipeline {
        let p = super::run::Pipeline::load(path)?;
        return Ok(SimCommandConfig {
            sim: p.sim,
            frames: p.plan.frames,
        });
    }
    let mut cfg: SimCommandConfig = crate::config::from_toml_str(&text, &path.display().to_string())?;
    resolve_paths(&mut cfg.sim, Some(path));
    Ok(cfg)
}

/// Runs `uvms sim`.
///
/// # Errors
/// As [`sim_stage`], and [`Error::Input`] for a bad trajectory file.
pub fn run(args: &SimArgs, ctx: &Ctx) -> Result<Report> {
    let mut cfg = load_config(args.config.as_deref())?;
    if let Some(s) = &args.surface {
        cfg.sim.surface = Some(relative_to(None, s));
        cfg.sim.surface_from = SurfaceSource::File;
    }
    if cfg.sim.surface_from != SurfaceSource::File {
        let from = cfg.sim.surface_from.as_str();
        return Err(Error::input(
            "sim.surface_from",
            format!(
                "\"{from}\" takes the surface uvms run makes on its way; uvms sim takes a mesh file: --surface OUT/{} (the surface uvms run took)",
                super::run::CONTACT_SURFACE
            ),
        ));
    }
    let trajectory = Trajectory::read_csv(&args.trajectory)?;
    check_frames(&trajectory, &args.trajectory, &cfg, args.config.as_deref())?;
    let in_config = |e| super::named_in(e, args.config.as_deref(), &[("", vec!["sim".into()])]);
    // What the trajectory's own length makes too long a run is the file's.
    crate::sim::check_trajectory(&trajectory, &cfg.sim, &args.trajectory.display().to_string())
        .map_err(in_config)?;
    let sim_inputs = load_sim_inputs(&cfg.sim, &cfg.frames).map_err(in_config)?;
    let mut inputs: Vec<&Path> = vec![&args.trajectory];
    inputs.extend(cfg.sim.surface.as_deref());
    inputs.extend(cfg.sim.model.as_deref());
    inputs.extend(args.config.as_deref());
    let out = OutDir::create(&args.out, &inputs, &PRODUCTS)?;
    let stage = sim_stage(&trajectory, &sim_inputs, &cfg.sim, &out, ctx).map_err(in_config)?;
    out.write_toml("config.toml", &cfg)?;
    Ok(Report {
        summary: stage.summary,
        text: stage.text,
        out: Some(out),
        failure: stage.failure,
    })
}
