//! `uvms arm` end to end: JSON keys and values against the reference, exit codes on bad input.

mod common;

use serde_json::Value;
use std::process::Command;

fn rtb_model() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/data/models/puma560_rtb.toml").to_string()
}

fn reference_state(name: &str) -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/puma560_reference.json");
    let r: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    r["states"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .unwrap()
        .clone()
}

fn csv(v: &Value) -> String {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| format!("{}", x.as_f64().unwrap()))
        .collect::<Vec<_>>()
        .join(",")
}

fn arm_json(args: &[&str]) -> Value {
    let out = Command::new(common::uvms_bin())
        .arg("--json")
        .arg("arm")
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn max_diff(a: &Value, b: &Value) -> f64 {
    match (a, b) {
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len());
            x.iter().zip(y).map(|(p, q)| max_diff(p, q)).fold(0.0, f64::max)
        }
        _ => (a.as_f64().unwrap() - b.as_f64().unwrap()).abs(),
    }
}

#[test]
fn every_query_gives_the_reference_values() {
    let s = reference_state("qn_nominal");
    let out = &s["outputs"];
    let (m, q, qd, qdd) = (rtb_model(), csv(&s["q"]), csv(&s["qd"]), csv(&s["qdd"]));
    let base = ["--model", &m, "--q", &q];
    let fk = arm_json(&[&["fk"], &base[..]].concat());
    assert!(max_diff(&fk["pose"], &out["fk_pose_base"]) < 1e-9);
    let j = arm_json(&[&["jacobian"], &base[..]].concat());
    assert!(max_diff(&j["jacobian"], &out["jacobian_base"]) < 1e-9);
    let mm = arm_json(&[&["mass-matrix"], &base[..]].concat());
    assert!(max_diff(&mm["mass_matrix"], &out["mass_matrix_with_armature"]) < 1e-9);
    assert!(max_diff(&mm["mass_matrix_rigid"], &out["mass_matrix_rigid"]) < 1e-9);
    // The summary names the query as it is typed.
    assert_eq!(mm["query"], "mass-matrix");
    assert_eq!(fk["query"], "fk");
    let id = arm_json(&[&["id"], &base[..], &["--qd", &qd, "--qdd", &qdd]].concat());
    assert!(max_diff(&id["tau"], &out["tau_rne_full_rtb"]) < 1e-9);
    assert!(max_diff(&id["tau_rigid"], &out["tau_rne_rigid"]) < 1e-9);
    // Gravity switched off: only the inertial terms remain.
    let id0 = arm_json(&[&["id"], &base[..], &["--qd", &qd, "--gravity", "0,0,0"]].concat());
    assert!(max_diff(&id0["tau_rigid"], &out["coriolis_centrifugal_vector"]) < 1e-9);
    // ik of the fk pose: the configuration itself comes first.
    let pose: Vec<String> = fk["pose"].as_array().unwrap().iter().map(csv).collect();
    let ik = arm_json(&[&["ik"], &base[..], &["--pose", &pose.join(",")]].concat());
    assert!(max_diff(&ik["solutions"][0], &s["q"]) < 1e-9);
}

#[test]
fn bad_input_exits_2_naming_the_flag() {
    for (args, flag) in [
        (vec!["fk", "--q", "1,2,3"], "--q"),
        (vec!["fk", "--q", "0,0,0,0,0,zero"], "--q"),
        (vec!["fk", "--q", "1e300,0,0,0,0,0"], "--q"),
        (vec!["id", "--q", "0,0,0,0,0,0", "--qd", "1,2"], "--qd"),
        (
            vec!["id", "--q", "0,0,0,0,0,0", "--gravity", "0,0,nan"],
            "--gravity",
        ),
        (
            vec![
                "ik",
                "--q",
                "0,0,0,0,0,0",
                "--pose",
                "2,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1",
            ],
            "--pose",
        ),
        (
            vec!["fk", "--q", "0,0,0,0,0,0", "--model", "/no/such/model.toml"],
            "/no/such/model.toml",
        ),
        // Finite but out of range: the torques would not be.
        (
            vec!["id", "--q", "0,0,0,0,0,0", "--qd", "1e200,0,0,0,0,0"],
            "--qd",
        ),
        // Faster than any sea (the simulation's bound).
        (
            vec!["id", "--q", "0,0,0,0,0,0", "--current", "100,0,0"],
            "--current",
        ),
        // A usage error.
        (vec!["fk", "--q"], "--q"),
    ] {
        let out = Command::new(common::uvms_bin())
            .arg("arm")
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?}: {err}");
        assert!(err.lines().count() == 1, "{args:?}: not one line: {err}");
    }
}

#[test]
fn unreachable_pose_is_a_failed_run() {
    let out = Command::new(common::uvms_bin())
        .args([
            "arm",
            "ik",
            "--q",
            "0,0,0,0,0,0",
            "--pose",
            "1,0,0,3,0,1,0,0,0,0,1,0,0,0,0,1",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("ik"));
}

#[test]
fn id_takes_the_models_current_and_its_drag_is_quadratic() {
    let dir = tempfile::tempdir().unwrap();
    let still = concat!(env!("CARGO_MANIFEST_DIR"), "/data/models/auv300_puma560.toml");
    let text = std::fs::read_to_string(still).unwrap();
    let line = "current = [0.0, 0.0, 0.0]";
    assert!(text.contains(line));
    let moving = dir.path().join("current.toml");
    std::fs::write(&moving, text.replacen(line, "current = [0.3, -0.2, 0.1]", 1)).unwrap();
    let moving = moving.to_str().unwrap();
    let q = ["--q", "0.3,0.9,-2.0,0.4,0.5,0.2"];
    let tau = |model: &str, extra: &[&str]| {
        arm_json(&[&["id", "--model", model], &q[..], extra].concat())["tau_rigid"].clone()
    };
    // The model's current, the arm mounted level (the model's mount rotation is the identity).
    let by_model = tau(moving, &[]);
    assert!(max_diff(&by_model, &tau(still, &["--current", "0.3,-0.2,0.1"])) < 1e-12);
    assert!(max_diff(&tau(moving, &["--current", "0,0,0"]), &tau(still, &[])) < 1e-12);
    // Gravity off and the arm at rest, what is left is the water's drag on the links, quadratic in
    // the current (the links have no linear damping): twice the current, four times the torques.
    let zero_g = ["--gravity", "0,0,0"];
    let once = tau(still, &[&zero_g[..], &["--current", "0.3,-0.2,0.1"]].concat());
    let twice = tau(still, &[&zero_g[..], &["--current", "0.6,-0.4,0.2"]].concat());
    let largest = max_diff(&once, &serde_json::json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
    assert!(largest > 0.05, "the current's drag is {largest} N·m at most");
    let four_times: Vec<f64> = once
        .as_array()
        .unwrap()
        .iter()
        .map(|v| 4.0 * v.as_f64().unwrap())
        .collect();
    assert!(max_diff(&twice, &serde_json::json!(four_times)) < 1e-9 * largest.max(1.0));
}
