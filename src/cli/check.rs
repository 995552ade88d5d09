//! `uvms check SCAN.ply --reference MODEL.ply [--ground-truth TRUTH.json] [--up X,Y,Z]
//! [--init auto|identity|FILE.json] [--whole-scan] [--config F] [--out DIR]`: aligns the
//! reference model to the scanned object and says how good the alignment is — the seed's \[59\]
//! estimate always, pose errors and ADD-S when the truth is known.

use super::segment::{load_reference, parse_vector3, segmentation_summary, segmentation_text};
use super::{Ctx, Report, config_origin};
use crate::error::{Error, Result};
use crate::frames::{Pose, pose_to_rows, read_pose_file};
use crate::io::ply::{read_cloud, write_cloud, write_mesh};
use crate::output::OutDir;
use crate::perception::{CheckOptions, CheckResult, PerceptionConfig, check};
use crate::register::InitMode;
use nalgebra::Vector3;
use serde_json::json;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Arguments of `uvms check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The scan (PLY, scan frame `S`).
    pub scan: PathBuf,
    /// The reference model (PLY mesh, or PLY point cloud).
    #[arg(long)]
    pub reference: PathBuf,
    /// Ground truth: a JSON file with `"t_scan_reference"` (4×4, row-major).
    #[arg(long)]
    pub ground_truth: Option<PathBuf>,
    /// Prior on the seabed normal in the scan frame, e.g. `0,-0.7,-0.7`.
    #[arg(long, value_parser = parse_vector3, allow_hyphen_values = true)]
    pub up: Option<Vector3<f64>>,
    /// Initial guess: `auto` (global search), `identity`, or a JSON pose file with
    /// `"t_scan_reference"`.
    #[arg(long, default_value = "auto")]
    pub init: String,
    /// The scan is the object already: no seabed removal, no clustering (its spans must
    /// still fit the reference's, as a cluster's must).
    #[arg(long)]
    pub whole_scan: bool,
    /// Perception configuration (TOML).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder (aligned model, scan surface, pose, summary, configuration).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The `--init` argument: `auto`, `identity` or a pose file.
///
/// # Errors
/// [`Error::Input`] for anything else, or a bad pose file.
pub fn init_mode(spec: &str) -> Result<InitMode> {
    match spec {
        // Empty: a configuration written before the default was spelled out.
        "auto" | "" => Ok(InitMode::Auto),
        "identity" => Ok(InitMode::Given(Pose::identity())),
        file => {
            let path = Path::new(file);
            if !path.is_file() {
                return Err(Error::input(
                    "--init",
                    format!("'{file}' is not auto, identity or an existing pose file"),
                ));
            }
            Ok(InitMode::Given(read_pose_file(path, "t_scan_reference")?))
        }
    }
}

/// The pose file an `--init` names (`None` for `auto`, `identity` and none given): one of the
/// run's inputs.
pub fn init_file(spec: &str) -> Option<&Path> {
    (!matches!(spec, "" | "auto" | "identity")).then(|| Path::new(spec))
}

/// The check part of a summary (DESIGN.md keys plus diagnostics).
pub fn check_summary(r: &CheckResult) -> serde_json::Value {
    let reg = &r.registration;
    let mut v = json!({
        "t_scan_reference": pose_to_rows(&reg.t_scan_reference),
        "fitness": reg.fitness,
        "scan_fitness": reg.scan_fitness,
        "inlier_rmse_m": reg.inlier_rmse_m,
        "evaluation_distance_m": reg.evaluation_distance_m,
        "scan_noise_m": reg.scan_noise_m,
        "accuracy_rms_m": r.accuracy.rms_m,
        "accuracy_max_m": r.accuracy.max_m,
        "accuracy_mean_signed_m": r.accuracy.mean_signed_m,
        "accuracy_samples": r.accuracy.samples,
        "coverage": r.accuracy.coverage,
        "free_space_fraction": r.free_space.fraction(),
        "free_space_max_m": r.free_space.max_m,
        "iterations": reg.iterations,
        "converged": reg.converged,
        "visible_reference_points": reg.visible.len(),
        "t_scan_reference_initial": pose_to_rows(&reg.initial),
        "object_points": r.object.len(),
        "object_centroid": r.object_shape.centroid.coords.as_slice(),
        "object_extent": r.object_shape.spans.as_slice(),
        "reference_centroid_in_scan": r.reference_axes.centroid.coords.as_slice(),
        "reference_axis_in_scan": r.reference_axes.axes.column(0).as_slice(),
        "reference_extent": r.reference_axes.spans.as_slice(),
        "scan_surface_triangles": r.scan_surface.triangles.len(),
        "timings_s": r.timings,
        "register_timings_s": reg.timings,
        "total_time_s": r.timings.total(),
    });
    if let Some(i) = &reg.init {
        v["init_candidates"] = json!(i.candidates);
        v["init_score_m"] = json!(i.score_m);
        v["init_runner_up_score_m"] = json!(i.runner_up_score_m);
    }
    if let Some(t) = &r.truth {
        v["rotation_error_deg"] = json!(t.rotation_error_deg);
        v["axis_error_deg"] = json!(t.axis_error_deg);
        v["translation_error_m"] = json!(t.translation_error_m);
        v["add_s_m"] = json!(t.add_s_m);
        v["add_m"] = json!(t.add_m);
    }
    v
}

/// The readable table of a check.
pub fn check_text(r: &CheckResult) -> String {
    let mut t = String::new();
    if let Some(seg) = &r.segmentation {
        segmentation_text(seg, &mut t);
    }
    let reg = &r.registration;
    let p = reg.t_scan_reference;
    let (axis, angle) = p
        .rotation
        .axis_angle()
        .map_or((Vector3::z(), 0.0), |(a, g)| (a.into_inner(), g));
    let _ = writeln!(t, "object       {} points", r.object.len());
    let _ = writeln!(
        t,
        "pose         t = [{:.4}, {:.4}, {:.4}] m, rotation {:.2}° about [{:.3}, {:.3}, {:.3}]",
        p.translation.x,
        p.translation.y,
        p.translation.z,
        angle.to_degrees(),
        axis.x,
        axis.y,
        axis.z
    );
    let mut row = |name: &str, value: String| {
        let _ = writeln!(t, "  {name:<30} {value}");
    };
    row(
        "ICP",
        format!("{} iterations, converged {}", reg.iterations, reg.converged),
    );
    row(
        "fitness",
        format!(
            "{:.3} of the scanned object, {:.3} of the model's visible points (within {:.2} mm)",
            reg.scan_fitness,
            reg.fitness,
            1e3 * reg.evaluation_distance_m
        ),
    );
    row("inlier RMSE", format!("{:.3} mm", 1e3 * reg.inlier_rmse_m));
    row("scan noise", format!("{:.3} mm", 1e3 * reg.scan_noise_m));
    row(
        "[59] trajectories RMS",
        format!("{:.3} mm", 1e3 * r.accuracy.rms_m),
    );
    row(
        "[59] trajectories max",
        format!("{:.3} mm", 1e3 * r.accuracy.max_m),
    );
    row(
        "[59] coverage",
        format!(
            "{:.1} % of {} samples",
            100.0 * r.accuracy.coverage,
            r.accuracy.first_hits
        ),
    );
    row(
        "free space",
        format!(
            "{:.1} % of the reference's {} points seen face-on lie in front of all the camera saw around them{}",
            100.0 * r.free_space.fraction(),
            r.free_space.judged,
            if r.free_space.violating > 0 {
                format!(" (by up to {:.1} mm)", 1e3 * r.free_space.max_m)
            } else {
                String::new()
            }
        ),
    );
    if let Some(e) = &r.truth {
        row("rotation error", format!("{:.4}°", e.rotation_error_deg));
        row(
            "axis error",
            match e.axis_error_deg {
                Some(a) => format!(
                    "{a:.4}° (the model's most distinct principal axis, as a body of revolution's own axis: the rotation error without the turn about it)"
                ),
                None => "none (no principal axis of the model stands apart from the other two)".into(),
            },
        );
        row(
            "translation error",
            format!("{:.3} mm", 1e3 * e.translation_error_m),
        );
        row("ADD", format!("{:.3} mm", 1e3 * e.add_m));
        row("ADD-S", format!("{:.3} mm", 1e3 * e.add_s_m));
    }
    row("time", format!("{:.3} s", r.timings.total()));
    t
}

/// What `uvms check --out` writes besides its summary and configuration.
pub const PRODUCTS: [&str; 5] = [
    "pose.json",
    "scan_surface.ply",
    "reference_surface.ply",
    "object.ply",
    "aligned_reference.ply",
];

/// Writes what `uvms check` produces besides its summary and configuration: `pose.json`,
/// `scan_surface.ply`, `reference_surface.ply`, `object.ply` and `aligned_reference.ply` (the
/// model file `reference` moved by `t_scan_reference`). Returns a line for the report's text.
///
/// # Errors
/// [`Error::Input`] if the model cannot be read again; [`Error::Failed`] if a write fails.
pub fn write_check_products(out: &OutDir, result: &CheckResult, reference: &Path) -> Result<String> {
    let pose = result.registration.t_scan_reference;
    out.write_json("pose.json", &json!({ "t_scan_reference": pose_to_rows(&pose) }))?;
    out.write_with("scan_surface.ply", |w| write_mesh(w, &result.scan_surface))?;
    out.write_with("reference_surface.ply", |w| {
        write_mesh(w, &result.reference_surface)
    })?;
    let mut object = result.object.clone();
    object.normals = None;
    out.write_with("object.ply", |w| write_cloud(w, &object))?;
    let aligned = crate::io::ply::read_ply(reference)?;
    let mut cloud = aligned.cloud;
    cloud.points.iter_mut().for_each(|p| *p = pose * *p);
    if let Some(n) = cloud.normals.as_mut() {
        n.iter_mut().for_each(|v| *v = pose * *v);
    }
    out.write_with("aligned_reference.ply", |w| {
        crate::io::ply::write_ply(w, &cloud, &aligned.triangles)
    })?;
    Ok(format!(
        "wrote        aligned_reference.ply, reference_surface.ply, scan_surface.ply, object.ply, pose.json in {}\n",
        out.path().display()
    ))
}

/// Runs `uvms check`.
///
/// # Errors
/// [`Error::Input`] for bad files, poses or configuration (exit 2); [`Error::Failed`] when a
/// stage fails — no plane, no cluster fitting the reference, ICP not converged (exit 1).
pub fn run(args: &CheckArgs, _ctx: &Ctx) -> Result<Report> {
    let cfg: PerceptionConfig = crate::config::load(args.config.as_deref())?;
    cfg.validate()
        .map_err(|e| e.in_table(config_origin(args.config.as_deref()), ""))?;
    let init = init_mode(&args.init)?;
    let truth = match &args.ground_truth {
        Some(p) => Some(read_pose_file(p, "t_scan_reference")?),
        None => None,
    };
    let out = match &args.out {
        Some(dir) => {
            let mut inputs: Vec<&Path> = vec![&args.scan, &args.reference];
            inputs.extend(args.ground_truth.as_deref());
            inputs.extend(args.config.as_deref());
            inputs.extend(init_file(&args.init));
            Some(OutDir::create(dir, &inputs, &PRODUCTS)?)
        }
        None => None,
    };
    let (scan, _) = read_cloud(&args.scan)?;
    if scan.is_empty() {
        return Err(Error::input(args.scan.display(), "the scan has no points"));
    }
    let model = load_reference(&args.reference, &cfg)?;
    let opts = CheckOptions {
        up: args.up,
        init,
        whole_scan: args.whole_scan,
        truth,
    };
    let result = check(&scan, &model, &opts, &cfg)
        .map_err(|e| super::named_in(e, args.config.as_deref(), &super::perception_tables()))?;
    let mut summary = check_summary(&result);
    summary["scan"] = json!(args.scan.display().to_string());
    summary["reference"] = json!(args.reference.display().to_string());
    if let Some(seg) = &result.segmentation {
        summary["segmentation"] = segmentation_summary(seg);
    }
    let mut text = check_text(&result);
    if let Some(out) = &out {
        text += &write_check_products(out, &result, &args.reference)?;
        // The configuration last: a run whose products failed leaves none.
        out.write_toml("config.toml", &cfg)?;
    }
    Ok(Report {
        summary,
        text,
        out,
        failure: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `config.toml` of a run made before `[input] init` spelled out its default holds
    /// `init = ""`: it still reruns, as `auto`.
    #[test]
    fn an_empty_initial_guess_is_auto() {
        assert_eq!(init_mode("").unwrap(), InitMode::Auto);
        assert_eq!(init_mode("identity").unwrap(), InitMode::Given(Pose::identity()));
        assert_eq!(init_mode("no/such.json").unwrap_err().exit_code(), 2);
    }
}
