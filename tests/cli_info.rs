//! `uvms info`: the JSON summary of a small mesh (values known by construction) and of a real
//! scan (counts from SOURCES.md).

mod common;

use std::process::Command;

fn info_json(path: &std::path::Path) -> serde_json::Value {
    let out = Command::new(common::uvms_bin())
        .args(["info", "--json"])
        .arg(path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 1, "one JSON object on one line");
    serde_json::from_str(&text).unwrap()
}

#[test]
fn json_of_a_quad_mesh() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/valid_quad.ply");
    let j = info_json(&path);
    assert_eq!(j["points"], 4);
    assert_eq!(j["faces"], 1);
    assert_eq!(j["triangles"], 2);
    assert_eq!(j["encoding"], "ascii");
    assert_eq!(j["bbox_min"], serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(j["bbox_max"], serde_json::json!([1.0, 1.0, 0.0]));
    assert_eq!(j["elements"][1]["properties"][0], "list uchar int vertex_indices");
}

#[test]
fn human_text_goes_to_stderr_and_quiet_silences_it() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/valid_quad.ply");
    let out = Command::new(common::uvms_bin())
        .arg("info")
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("points       4") && err.contains("faces        1 (2 triangles"),
        "{err}"
    );
    let out = Command::new(common::uvms_bin())
        .args(["info", "--quiet"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success() && out.stderr.is_empty() && out.stdout.is_empty());
}

#[test]
fn json_of_a_real_scan() {
    let Some(path) = common::real_data("milk.ply") else {
        return;
    };
    let j = info_json(&path);
    assert_eq!(j["points"], 13704);
    assert_eq!(j["faces"], 0);
    assert_eq!(j["has_colors"], true);
    let lo = j["bbox_min"].as_array().unwrap();
    let hi = j["bbox_max"].as_array().unwrap();
    for (k, (l, h)) in [(-0.140, 0.014), (-0.264, -0.012), (0.714, 0.891)]
        .iter()
        .enumerate()
    {
        assert!((lo[k].as_f64().unwrap() - l).abs() < 5e-4);
        assert!((hi[k].as_f64().unwrap() - h).abs() < 5e-4);
    }
}

/// A reader that has gone (a pipe into `head`) ends the command quietly, without a panic: the
/// report and the JSON are written into a closed pipe.
#[test]
fn a_closed_pipe_is_no_panic() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/valid_quad.ply");
    // The JSON into a closed stdout, then the report into a closed stderr.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(common::uvms_bin())
        .args(["info", "--json"])
        .arg(&path)
        .stdout(writer)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let status = Command::new(common::uvms_bin())
        .arg("info")
        .arg(&path)
        .stderr(writer)
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(0));
}
