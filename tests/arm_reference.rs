//! The arm's kinematics and dynamics against independent reference values: the Robotics
//! Toolbox for Python 1.5.0, cross-checked with Pinocchio 4.1.0 (tests/data/README.md), for
//! every state of `tests/data/puma560_reference.json`, each to 1e-9.

use nalgebra::{Matrix4, Matrix6, Vector3};
use serde_json::Value;
use std::path::Path;
use uvms::arm::{Arm, BaseMotion, JointVector};
use uvms::model;
use uvms::spatial_algebra::Force;

const TOL: f64 = 1e-9;

fn reference() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/puma560_reference.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn rtb_arm() -> Arm {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/models/puma560_rtb.toml");
    let m = model::load(Some(Path::new(path))).unwrap();
    Arm::new(&m.arm, &m.environment).unwrap()
}

fn vec6(v: &Value) -> JointVector {
    JointVector::from_iterator(v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
}

fn mat6(v: &Value) -> Matrix6<f64> {
    let rows = v.as_array().unwrap();
    Matrix6::from_fn(|r, c| rows[r][c].as_f64().unwrap())
}

fn mat4(v: &Value) -> Matrix4<f64> {
    let rows = v.as_array().unwrap();
    Matrix4::from_fn(|r, c| rows[r][c].as_f64().unwrap())
}

fn assert_close<const R: usize, const C: usize>(
    got: &nalgebra::SMatrix<f64, R, C>,
    want: &nalgebra::SMatrix<f64, R, C>,
    what: &str,
    state: &str,
) {
    let err = (got - want).abs().max();
    assert!(
        err < TOL,
        "{state}: {what} differs by {err:e}\n got {got}\nwant {want}"
    );
}

/// Runs `check` on every state with its name, q, qd, qdd and outputs.
fn for_each_state(mut check: impl FnMut(&str, &JointVector, &JointVector, &JointVector, &Value)) {
    let r = reference();
    let states = r["states"].as_array().unwrap();
    assert_eq!(states.len(), 5);
    for s in states {
        check(
            s["name"].as_str().unwrap(),
            &vec6(&s["q"]),
            &vec6(&s["qd"]),
            &vec6(&s["qdd"]),
            &s["outputs"],
        );
    }
}

#[test]
fn gravity_of_the_upright_mount_is_the_reference_gravity() {
    let r = reference();
    let g = &r["parameters"]["gravity_base"];
    let want = Vector3::new(
        g[0].as_f64().unwrap(),
        g[1].as_f64().unwrap(),
        g[2].as_f64().unwrap(),
    );
    let got = rtb_arm().level_gravity(9.81);
    assert!((got - want).norm() < 1e-12, "{got} vs {want}");
}

#[test]
fn forward_kinematics() {
    let arm = rtb_arm();
    for_each_state(|name, q, _, _, out| {
        assert_close(
            &arm.t_base_tool(q).to_homogeneous(),
            &mat4(&out["fk_pose_base"]),
            "fk",
            name,
        );
    });
}

#[test]
fn jacobian() {
    let arm = rtb_arm();
    for_each_state(|name, q, _, _, out| {
        assert_close(&arm.jacobian(q), &mat6(&out["jacobian_base"]), "jacobian", name);
    });
}

#[test]
fn rnea_torques_rigid_and_with_drives() {
    let arm = rtb_arm();
    let base = BaseMotion::fixed(arm.level_gravity(9.81));
    for_each_state(|name, q, qd, qdd, out| {
        let id = arm.inverse_dynamics(q, qd, qdd, &base, None);
        assert_close(&id.tau_rigid, &vec6(&out["tau_rne_rigid"]), "tau_rne_rigid", name);
        assert_close(&id.tau, &vec6(&out["tau_rne_full_rtb"]), "tau_rne_full_rtb", name);
        assert_close(
            &arm.armature().component_mul(qdd),
            &vec6(&out["tau_armature"]),
            "tau_armature",
            name,
        );
        assert_close(
            &arm.friction(qd, None),
            &vec6(&out["tau_friction"]),
            "tau_friction",
            name,
        );
    });
}

#[test]
fn mass_matrices() {
    let arm = rtb_arm();
    for_each_state(|name, q, _, _, out| {
        assert_close(
            &arm.mass_matrix_rigid(q),
            &mat6(&out["mass_matrix_rigid"]),
            "mass_matrix_rigid",
            name,
        );
        assert_close(
            &arm.mass_matrix(q),
            &mat6(&out["mass_matrix_with_armature"]),
            "mass_matrix_with_armature",
            name,
        );
    });
}

#[test]
fn gravity_and_coriolis_torques() {
    let arm = rtb_arm();
    let z = JointVector::zeros();
    for_each_state(|name, q, qd, _, out| {
        let g = arm.inverse_dynamics(q, &z, &z, &BaseMotion::fixed(arm.level_gravity(9.81)), None);
        assert_close(
            &g.tau_rigid,
            &vec6(&out["gravity_torque"]),
            "gravity_torque",
            name,
        );
        let c = arm.inverse_dynamics(q, qd, &z, &BaseMotion::default(), None);
        assert_close(
            &c.tau_rigid,
            &vec6(&out["coriolis_centrifugal_vector"]),
            "coriolis",
            name,
        );
    });
}

#[test]
fn jacobian_transpose_times_tool_wrench() {
    // The reference's wrench is exerted BY the tool ON the environment, so the environment pushes
    // on the tool with its negative; the RNEA must then need J0ᵀ w of extra drive torque.
    let arm = rtb_arm();
    let z = JointVector::zeros();
    for_each_state(|name, q, _, _, out| {
        let w = vec6(&out["tool_wrench_base"]);
        let want = vec6(&out["tau_ext_JT_F"]);
        assert_close(&(arm.jacobian(q).transpose() * w), &want, "J^T F", name);
        let on_tool = -Force::from_vector6(&w);
        let id = arm.inverse_dynamics(q, &z, &z, &BaseMotion::default(), Some(&on_tool));
        assert_close(&id.tau_rigid, &want, "RNEA with tool wrench", name);
        // The base then carries the tool's wrench: the arm pushes on its base with −w moved to
        // the base origin (static, no gravity): force −f, moment −(n + p × f).
        let p = arm.t_base_tool(q).translation.vector;
        let f = Vector3::new(w[0], w[1], w[2]);
        let n = Vector3::new(w[3], w[4], w[5]) + p.cross(&f);
        let want_base = -Force::new(f, n);
        assert!(
            (id.wrench_on_base.to_vector6() - want_base.to_vector6())
                .abs()
                .max()
                < TOL,
            "{name}: base wrench"
        );
    });
}
