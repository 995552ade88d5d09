//! `uvms plan SCAN.ply --reference MODEL.ply [--pattern ring|raster|line|FILE.csv]
//! [--ground-truth TRUTH.json] [--up X,Y,Z] [--init auto|identity|FILE.json] [--config F]
//! --out DIR`: segment + check + plan in one go. Writes what `uvms check` writes, plus
//! `trajectory.csv` (the trajectory in the world frame `W`, the simulation's input),
//! `trajectory.ply` (the path with tool axes in the scan frame, over `scan_surface.ply`), `summary.json`
//! and the resolved `config.toml` (`[perception]` and `[plan]` tables).
//!
//! Without `--reference`, only the line pattern can be planned (soil sampling on a patch of
//! sediment): the scan is cleaned, the seabed plane found and its inliers triangulated.

use super::check::{self, check_summary, check_text, init_file, init_mode, write_check_products};
use super::segment::{load_reference, parse_vector3, scan_text, segmentation_summary};
use super::{Ctx, Report, config_origin};
use crate::error::{Error, Result};
use crate::frames::read_pose_file;
use crate::io::ply::read_cloud;
use crate::mesh::TriangleMesh;
use crate::output::OutDir;
use crate::perception::{CheckOptions, PerceptionConfig, check, clean};
use crate::plan::patterns::PatternKind;
use crate::plan::{ObjectAxes, ObjectInput, PlanConfig, PlanInput, PlanReport, plan};
use crate::register::InitMode;
use crate::segment::seabed::find_seabed;
use crate::trajectory::Trajectory;
use crate::triangulate::triangulate_view;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Arguments of `uvms plan`.
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// The scan (PLY, scan frame `S`).
    pub scan: PathBuf,
    /// The reference model (PLY mesh, or PLY point cloud); optional for `--pattern line`.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// The pattern: `ring`, `raster`, `line`, or a CSV polyline file (`x_m,y_m,z_m[,force_n]`,
    /// in the reference model's frame by default). Overrides `plan.pattern` of the configuration.
    #[arg(long)]
    pub pattern: Option<String>,
    /// Ground truth for the alignment check: a JSON file with `"t_scan_reference"`.
    #[arg(long)]
    pub ground_truth: Option<PathBuf>,
    /// Prior on the seabed normal in the scan frame, e.g. `0,-0.7,-0.7`.
    #[arg(long, value_parser = parse_vector3, allow_hyphen_values = true)]
    pub up: Option<Vector3<f64>>,
    /// Initial guess of the alignment: `auto`, `identity`, or a JSON pose file.
    #[arg(long, default_value = "auto")]
    pub init: String,
    /// Configuration (TOML) with `[perception]` and `[plan]` tables.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// The configuration of `uvms plan`: the perception stages and the planner.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanCommandConfig {
    /// Segmentation, registration, triangulation (as `uvms check`).
    pub perception: PerceptionConfig,
    /// The planner.
    pub plan: PlanConfig,
}

/// Applies `--pattern` to the configuration.
fn apply_pattern(cfg: &mut PlanConfig, spec: &str) -> Result<()> {
    cfg.pattern = match spec {
        "ring" => PatternKind::Ring,
        "raster" => PatternKind::Raster,
        "line" => PatternKind::Line,
        file if file.ends_with(".csv") || Path::new(file).is_file() => {
            cfg.polyline.file = Some(crate::config::relative_to(None, Path::new(file)));
            PatternKind::Polyline
        }
        other => {
            return Err(Error::input(
                "--pattern",
                format!("'{other}' is not ring, raster, line or a CSV file"),
            ));
        }
    };
    Ok(())
}

/// The readable account of a plan.
pub fn plan_text(r: &PlanReport) -> String {
    let mut t = String::new();
    let [approach, dwell, contact, retreat] = r.phase_durations_s;
    let _ = writeln!(
        t,
        "plan         {} pattern: {} row{}, {:.3} m in contact at {:.3} m/s, {} samples every {:.2} mm",
        r.pattern,
        r.rows,
        if r.rows == 1 { "" } else { "s" },
        r.length_m,
        r.speed_m_s,
        r.contact_points,
        r.spacing_m * 1e3
    );
    if let Some(arc) = r.arc_deg {
        let _ = writeln!(t, "  arc                            {arc:.1}°");
    }
    let _ = writeln!(
        t,
        "  duration                       {:.1} s (approach {approach:.1}, dwell {dwell:.1}, contact {contact:.1}, retreat {retreat:.1})",
        r.duration_s
    );
    // A line's holes are filled from the seabed's plane, the others' from the reference.
    let filled_from = if r.pattern == "line" {
        "on the seabed's plane (scan holes)"
    } else {
        "on the reference (scan holes)"
    };
    let _ = writeln!(
        t,
        "  {filled_from:<30} {} of {} samples",
        r.fallback_points, r.contact_points
    );
    let _ = writeln!(
        t,
        "  fastest turn of the tool       {:.1}°/s ({} steps slowed to the limit)",
        r.max_rate_deg_s, r.rate_limited_steps
    );
    if r.clipped {
        let _ = writeln!(t, "  clipped to the scanned surface");
    }
    t
}

/// The seabed plane and its triangulated inliers, from a cleaned cloud.
fn seabed_surface(points: &[Point3<f64>], inliers: &[usize], cfg: &PerceptionConfig) -> Result<TriangleMesh> {
    let pts: Vec<Point3<f64>> = inliers.iter().filter_map(|&i| points.get(i).copied()).collect();
    triangulate_view(&pts, &[], &cfg.view.camera(), &cfg.surface)
}

/// Runs `uvms plan`.
///
/// # Errors
/// [`Error::Input`] for bad files, arguments or configuration (exit 2); [`Error::Failed`] when a
/// stage fails: no seabed or object found, ICP not converged, a pattern that misses the object
/// or is wider than the scanned surface (exit 1).
pub fn run(args: &PlanArgs, _ctx: &Ctx) -> Result<Report> {
    let mut cfg: PlanCommandConfig = crate::config::load(args.config.as_deref())?;
    let origin = config_origin(args.config.as_deref());
    cfg.perception
        .validate()
        .map_err(|e| e.in_table(&origin, "perception."))?;
    cfg.plan.validate().map_err(|e| e.in_table(&origin, "plan."))?;
    // A polyline file named in the configuration is relative to it (as in `uvms sim` and
    // `uvms run`); one given with `--pattern` is relative to the working directory.
    cfg.plan.polyline.file = cfg
        .plan
        .polyline
        .file
        .as_deref()
        .map(|f| crate::config::relative_to(args.config.as_deref(), f));
    if let Some(p) = &args.pattern {
        apply_pattern(&mut cfg.plan, p)?;
    }
    let inputs = PlanInputs {
        scan: args.scan.clone(),
        reference: args.reference.clone(),
        ground_truth: args.ground_truth.clone(),
        up: args.up.map(|v| [v.x, v.y, v.z]),
        init: args.init.clone(),
    };
    let mut files: Vec<&Path> = inputs.files().into_iter().map(|(_, f)| f).collect();
    files.extend(args.config.as_deref());
    files.extend(cfg.plan.polyline.file.as_deref());
    let out = OutDir::create(&args.out, &files, &products())?;
    let mut stage = plan_stage(&inputs, &cfg, &out, &|_| Ok(()))
        .map_err(|e| super::named_in(e, args.config.as_deref(), &super::pipeline_tables()))?;
    out.write_toml("config.toml", &cfg)?;
    let _ = writeln!(
        stage.text,
        "wrote        trajectory.csv, trajectory.ply, summary.json, config.toml in {}",
        out.path().display()
    );
    let mut summary = stage.check;
    if let (Some(s), Some(p)) = (summary.as_object_mut(), stage.plan.as_object()) {
        s.extend(p.clone());
    }
    Ok(Report {
        summary,
        text: stage.text,
        out: Some(out),
        failure: None,
    })
}

/// The input files and options of the planning stage (`uvms plan`'s arguments, or a
/// pipeline's `[input]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanInputs {
    /// The scan (PLY, scan frame `S`).
    pub scan: PathBuf,
    /// The reference model; optional for the line pattern.
    pub reference: Option<PathBuf>,
    /// Ground truth for the alignment check (`t_scan_reference`).
    pub ground_truth: Option<PathBuf>,
    /// Prior on the seabed normal in the scan frame.
    pub up: Option<[f64; 3]>,
    /// Initial guess of the alignment: `auto` (the default), `identity` or a JSON pose file.
    pub init: String,
}

impl Default for PlanInputs {
    fn default() -> Self {
        PlanInputs {
            scan: PathBuf::new(),
            reference: None,
            ground_truth: None,
            up: None,
            init: "auto".into(),
        }
    }
}

impl PlanInputs {
    /// The files read, each with its key.
    pub fn files(&self) -> Vec<(&'static str, &Path)> {
        let mut v: Vec<(&'static str, &Path)> = vec![("scan", &self.scan)];
        v.extend(self.reference.as_deref().map(|f| ("reference", f)));
        v.extend(self.ground_truth.as_deref().map(|f| ("ground_truth", f)));
        v.extend(init_file(&self.init).map(|f| ("init", f)));
        v
    }
}

/// What the planning stage may write besides a summary and configuration: the check's
/// products and the trajectory.
pub fn products() -> Vec<&'static str> {
    let mut v = check::PRODUCTS.to_vec();
    v.extend(["trajectory.csv", "trajectory.ply"]);
    v
}

/// What the planning stage produced.
#[derive(Debug, Clone)]
pub struct PlanStage {
    /// The alignment check's summary (with the segmentation), or the seabed's for the line
    /// pattern without a reference.
    pub check: serde_json::Value,
    /// The plan's summary.
    pub plan: serde_json::Value,
    /// The readable account.
    pub text: String,
    /// The trajectory (world frame).
    pub trajectory: Trajectory,
    /// The surface the trajectory was planned on as triangulated from the scan (scan frame): the
    /// object's, or the seabed's for the line pattern; `None` for a line on a seabed the
    /// segmentation found no plane of.
    pub scanned: Option<TriangleMesh>,
    /// The reference model aligned to the scan (scan frame); `None` without a reference.
    pub reference: Option<TriangleMesh>,
}

/// Segment + check + plan: writes what `uvms check` writes, `trajectory.csv` and
/// `trajectory.ply` into `out`, once `accept` has taken the planned trajectory (a later
/// stage's check of it, before anything is written).
///
/// # Errors
/// As [`run`], and `accept`'s.
pub fn plan_stage(
    args: &PlanInputs,
    cfg: &PlanCommandConfig,
    out: &OutDir,
    accept: &dyn Fn(&Trajectory) -> Result<()>,
) -> Result<PlanStage> {
    cfg.plan.validate()?;
    let line = cfg.plan.pattern == PatternKind::Line;
    if args.reference.is_none() && !line {
        return Err(Error::input(
            "--reference",
            format!(
                "the {} pattern needs the reference model",
                cfg.plan.pattern.as_str()
            ),
        ));
    }
    let init = init_mode(&args.init)?;
    // Without a reference there is no alignment to start or to check: the options would be
    // silently ignored.
    if args.reference.is_none() {
        let given = if args.ground_truth.is_some() {
            Some("--ground-truth")
        } else {
            (init != InitMode::Auto).then_some("--init")
        };
        if let Some(option) = given {
            return Err(Error::input(
                option,
                "needs the reference model (--reference, [input] reference): without one there is no alignment to start or check",
            ));
        }
    }
    let truth = match &args.ground_truth {
        Some(p) => Some(read_pose_file(p, "t_scan_reference")?),
        None => None,
    };
    let (scan, _) = read_cloud(&args.scan)?;
    if scan.is_empty() {
        return Err(Error::input(args.scan.display(), "the scan has no points"));
    }
    let pc = &cfg.perception;
    let camera = pc.view.camera();
    let mut summary = json!({});
    let mut text = String::new();
    let (report, trajectory, scanned, reference_surface) = match &args.reference {
        Some(reference) => {
            let model = load_reference(reference, pc)?;
            let opts = CheckOptions {
                up: args.up.map(Vector3::from),
                init,
                whole_scan: false,
                truth,
            };
            let result = check(&scan, &model, &opts, pc)?;
            summary = check_summary(&result);
            summary["reference"] = json!(reference.display().to_string());
            text += &check_text(&result);
            let seg = result.segmentation.as_ref();
            if let Some(seg) = seg {
                summary["segmentation"] = segmentation_summary(seg);
            }
            let fit = seg.and_then(|s| s.seabed.as_ref().map(|f| (s, f)));
            let seabed = match fit {
                Some((s, f)) if line => Some(seabed_surface(&s.cloud.points, &f.inliers, pc)?),
                _ => None,
            };
            let axes = ObjectAxes::with_axis(
                &result.reference_surface,
                result.reference_axes.centroid,
                result.reference_axes.axes.column(0).into_owned(),
            );
            let input = PlanInput {
                object: Some(ObjectInput {
                    scan_surface: &result.scan_surface,
                    reference: &result.reference_surface,
                    t_scan_reference: result.registration.t_scan_reference,
                    axes,
                }),
                viewpoint: camera,
                seabed_plane: fit.map(|(_, f)| f.plane.coefficients()),
                seabed_surface: seabed.as_ref(),
            };
            let p = plan(&input, &cfg.plan)?;
            accept(&p.trajectory)?;
            text += &write_check_products(out, &result, reference)?;
            let scanned = if line { seabed } else { Some(result.scan_surface) };
            (p.report, p.trajectory, scanned, Some(result.reference_surface))
        }
        None => {
            // Soil sampling on a sediment patch: the seabed is all there is.
            let (cloud, cleaning) = clean(&scan, &pc.clean, &camera)?;
            let fit = find_seabed(&cloud.points, args.up.map(Vector3::from).as_ref(), &pc.seabed)?;
            scan_text(cleaning.input, cloud.len(), Some(&fit), &mut text);
            let seabed = seabed_surface(&cloud.points, &fit.inliers, pc)?;
            summary["seabed_plane"] = json!(fit.plane.coefficients());
            summary["seabed_inliers"] = json!(fit.inliers.len());
            let input = PlanInput {
                object: None,
                viewpoint: camera,
                seabed_plane: Some(fit.plane.coefficients()),
                seabed_surface: Some(&seabed),
            };
            let p = plan(&input, &cfg.plan)?;
            accept(&p.trajectory)?;
            (p.report, p.trajectory, Some(seabed), None)
        }
    };
    let mut trajectory = trajectory;
    trajectory.notes.push(format!("scan: {}", args.scan.display()));
    if let Some(r) = &args.reference {
        trajectory.notes.push(format!("reference: {}", r.display()));
    }
    out.write_with("trajectory.csv", |w| trajectory.write_csv(w))?;
    let t_scan_world = cfg.plan.frames.t_world_scan().inverse();
    out.write_with("trajectory.ply", |w| {
        trajectory.write_ply(w, &t_scan_world, 0.02, 25)
    })?;
    let plan_summary = serde_json::to_value(&report).map_err(|e| Error::failed("summary", e))?;
    summary["scan"] = json!(args.scan.display().to_string());
    text += &plan_text(&report);
    Ok(PlanStage {
        check: summary,
        plan: plan_summary,
        text,
        trajectory,
        scanned,
        reference: reference_surface,
    })
}
