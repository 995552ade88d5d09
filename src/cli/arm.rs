//! `uvms arm`: inspect a model's arm — forward and inverse kinematics, inverse dynamics,
//! Jacobian, mass matrix.
//!
//! Angles in radians, rates in rad/s, accelerations in rad/s², torques in N·m; poses and the
//! Jacobian in the arm's base frame 0 (the pose of the tool frame `G`; Jacobian rows
//! `vx vy vz wx wy wz` of the tool point). Inverse dynamics has the base at rest with gravity
//! `--gravity` (m/s², base frame; default: the model's gravity for a level vehicle) and, with
//! the model's water, buoyancy, added mass and drag of the links in the water's velocity
//! `--current` (m/s, base frame; default: the model's current for a level vehicle).

use super::{Ctx, Report};
use crate::arm::{Arm, BaseMotion, JointVector};
use crate::error::{Error, Result};
use crate::frames::{pose_from_rows, pose_to_rows};
use crate::model;
use nalgebra::{Matrix6, UnitQuaternion, Vector3, Vector6};
use serde_json::json;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What `uvms arm` computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ArmQuery {
    /// Pose of the tool in the base frame (`pose`, 4×4 row-major).
    Fk,
    /// All inverse-kinematics solutions within the joint limits, nearest to `--q` first
    /// (`solutions`); the target is `--pose`, or the pose at `--q`.
    Ik,
    /// Drive torques with rotor inertia and friction (`tau`) and of the links alone
    /// (`tau_rigid`).
    Id,
    /// Geometric Jacobian of the tool point, base frame (`jacobian`, rows vx vy vz wx wy wz).
    Jacobian,
    /// Joint-space mass matrix with rotor inertias (`mass_matrix`) and without
    /// (`mass_matrix_rigid`).
    MassMatrix,
}

/// Arguments of `uvms arm`.
#[derive(Debug, clap::Args)]
pub struct ArmArgs {
    /// What to compute.
    #[arg(value_enum)]
    pub query: ArmQuery,
    /// Model file (TOML); the built-in AUV300 + PUMA 560 model when absent.
    #[arg(long, value_name = "F")]
    pub model: Option<PathBuf>,
    /// Joint angles, rad.
    #[arg(long, value_name = "Q1,..,Q6", allow_hyphen_values = true, value_parser = super::parse_numbers::<6>)]
    pub q: [f64; 6],
    /// Joint rates, rad/s (id; default 0).
    #[arg(long, value_name = "QD1,..,QD6", allow_hyphen_values = true, value_parser = super::parse_numbers::<6>)]
    pub qd: Option<[f64; 6]>,
    /// Joint accelerations, rad/s² (id; default 0).
    #[arg(long, value_name = "QDD1,..,QDD6", allow_hyphen_values = true, value_parser = super::parse_numbers::<6>)]
    pub qdd: Option<[f64; 6]>,
    /// Gravity in the base frame, m/s² (id; default: the model's, vehicle level).
    #[arg(long, value_name = "GX,GY,GZ", allow_hyphen_values = true, value_parser = super::parse_numbers::<3>)]
    pub gravity: Option<[f64; 3]>,
    /// Velocity of the water in the base frame, m/s (id; default: the model's current, vehicle
    /// level).
    #[arg(long, value_name = "CX,CY,CZ", allow_hyphen_values = true, value_parser = super::parse_numbers::<3>)]
    pub current: Option<[f64; 3]>,
    /// Target tool pose for ik: 16 numbers, the 4×4 base-from-tool matrix row by row.
    #[arg(long, value_name = "T11,..,T44", allow_hyphen_values = true, value_parser = super::parse_numbers::<16>)]
    pub pose: Option<[f64; 16]>,
}

/// The query as typed on the command line (`mass-matrix`).
fn query_name(query: ArmQuery) -> String {
    use clap::ValueEnum as _;
    query
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string())
}

/// Runs `uvms arm`.
///
/// # Errors
/// [`Error::Input`] for an unreadable model, a non-PUMA arm for ik, or a bad pose; [`Error::Failed`]
/// (stage `ik`) when the pose is out of reach within the joint limits.
pub fn run(args: &ArmArgs, _ctx: &Ctx) -> Result<Report> {
    let m = model::load(args.model.as_deref())?;
    let arm = Arm::new(&m.arm, &m.environment)?;
    let q = JointVector::from_column_slice(&args.q);
    let model_name = args.model.as_ref().map_or_else(
        || "built-in auv300_puma560".to_string(),
        |p| p.display().to_string(),
    );
    let mut summary = json!({ "model": model_name, "query": query_name(args.query), "q": args.q });
    let mut text = String::new();
    match args.query {
        ArmQuery::Fk => {
            let rows = pose_to_rows(&arm.t_base_tool(&q));
            summary["pose"] = json!(rows);
            text += &format!(
                "pose (base <- tool):\n{}",
                matrix_text(rows.iter().map(|r| r.as_slice()))
            );
        }
        ArmQuery::Ik => {
            let target = match &args.pose {
                Some(p) => {
                    let rows: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| p[4 * r + c]));
                    pose_from_rows(&rows, "--pose")?
                }
                None => arm.t_base_tool(&q),
            };
            let sols = arm.ik(&target, &q)?;
            if sols.is_empty() {
                return Err(Error::failed(
                    "ik",
                    format!(
                        "the pose is out of reach within the joint limits ({} analytic solutions, none within the limits)",
                        sols.analytic
                    ),
                ));
            }
            let list: Vec<[f64; 6]> = sols
                .as_slice()
                .iter()
                .map(|s| std::array::from_fn(|i| s[i]))
                .collect();
            summary["target_pose"] = json!(pose_to_rows(&target));
            summary["solutions"] = json!(list);
            summary["analytic_solutions"] = json!(sols.analytic);
            let _ = writeln!(
                text,
                "{} solutions within the limits ({} analytic), nearest to --q first (rad):",
                list.len(),
                sols.analytic
            );
            text += &matrix_text(list.iter().map(|r| r.as_slice()));
        }
        ArmQuery::Id => {
            let qd = JointVector::from_column_slice(&args.qd.unwrap_or([0.0; 6]));
            let qdd = JointVector::from_column_slice(&args.qdd.unwrap_or([0.0; 6]));
            // The base at rest on a level vehicle in the model's water, then the flags.
            let mut base = BaseMotion::on_vehicle(
                &arm,
                &UnitQuaternion::identity(),
                &Vector6::zeros(),
                &Vector6::zeros(),
                m.environment.gravity,
                &Vector3::from(m.environment.current),
            );
            if let Some(g) = args.gravity {
                base.gravity = Vector3::from(g);
            }
            if let Some(c) = args.current {
                crate::sim::check_current("--current", c)?;
                base.current = Vector3::from(c);
            }
            let id = arm.inverse_dynamics(&q, &qd, &qdd, &base, None);
            let (g, c) = (base.gravity, base.current);
            summary["gravity"] = json!([g.x, g.y, g.z]);
            summary["current"] = json!([c.x, c.y, c.z]);
            summary["tau"] = json!(id.tau.as_slice());
            summary["tau_rigid"] = json!(id.tau_rigid.as_slice());
            summary["wrench_on_base"] = json!(id.wrench_on_base.to_vector6().as_slice());
            text += &format!(
                "tau (N m, with rotor inertia and friction):\n{}tau_rigid (N m, links and water):\n{}",
                matrix_text([id.tau.as_slice()].into_iter()),
                matrix_text([id.tau_rigid.as_slice()].into_iter())
            );
        }
        ArmQuery::Jacobian => {
            let rows = matrix_rows(&arm.jacobian(&q));
            summary["jacobian"] = json!(rows);
            text += &format!(
                "jacobian (rows vx vy vz wx wy wz):\n{}",
                matrix_text(rows.iter().map(|r| r.as_slice()))
            );
        }
        ArmQuery::MassMatrix => {
            let rows = matrix_rows(&arm.mass_matrix(&q));
            summary["mass_matrix"] = json!(rows);
            summary["mass_matrix_rigid"] = json!(matrix_rows(&arm.mass_matrix_rigid(&q)));
            text += &format!(
                "mass_matrix (kg m^2, with rotor inertia):\n{}",
                matrix_text(rows.iter().map(|r| r.as_slice()))
            );
        }
    }
    // A number out of range serialises as `null`.
    if has_null(&summary) {
        return Err(Error::input(
            format!("{model_name} at --q/--qd/--qdd/--current"),
            "the model gives values that are not finite there (joint rates, accelerations, current or model values too large)",
        ));
    }
    Ok(Report {
        summary,
        text,
        out: None,
        failure: None,
    })
}

fn has_null(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Null => true,
        serde_json::Value::Array(a) => a.iter().any(has_null),
        serde_json::Value::Object(o) => o.values().any(has_null),
        _ => false,
    }
}

fn matrix_rows(m: &Matrix6<f64>) -> [[f64; 6]; 6] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

fn matrix_text<'a>(rows: impl Iterator<Item = &'a [f64]>) -> String {
    let mut s = String::new();
    for r in rows {
        for v in r {
            // Fixed columns (round-off near zero shows as 0), exponent form for huge values.
            let _ = if v.abs() < 1e7 {
                write!(s, " {v:>12.6}")
            } else {
                write!(s, " {v:>12.3e}")
            };
        }
        s.push('\n');
    }
    s
}
