//! `uvms plan` end to end on the committed synthetic scans (`data/scans`): the files it writes,
//! the summary keys, the trajectory the simulation reads back, and the exit codes of the error
//! cases (1 for a failed run, 2 for bad input).

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;
use uvms::trajectory::{Phase, Trajectory};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(p)
}

fn run(args: &[&str]) -> Output {
    std::process::Command::new(common::uvms_bin())
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn plan_a_ring_on_the_bottle_scan() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scan = data("scans/bottle/scan.ply");
    let model = data("models/bottle.ply");
    let truth = data("scans/bottle/truth.json");
    let o = run(&[
        "--json",
        "plan",
        scan.to_str().unwrap(),
        "--reference",
        model.to_str().unwrap(),
        "--ground-truth",
        truth.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "trajectory.csv",
        "trajectory.ply",
        "summary.json",
        "config.toml",
        "pose.json",
        "scan_surface.ply",
        "reference_surface.ply",
        "aligned_reference.ply",
        "object.ply",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let on_disk: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary, on_disk);
    assert_eq!(summary["pattern"], "ring");
    for key in [
        "points",
        "length_m",
        "duration_s",
        "speed_m_s",
        "t_scan_reference",
        "fitness",
        "add_s_m",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    let traj = Trajectory::read_csv(&out.join("trajectory.csv")).unwrap();
    assert_eq!(traj.samples.len() as u64, summary["points"].as_u64().unwrap());
    assert!((traj.duration() - summary["duration_s"].as_f64().unwrap()).abs() < 1e-5);
    assert!(traj.phase(Phase::Contact).count() > 100);
    // `trajectory.ply` lies over `scan_surface.ply`, in the scan frame: its path's contact
    // vertices (the first of the file's vertices, one a sample) within a few millimetres of the
    // scanned surface, or of the reference's where the scan had a hole (written in the world
    // frame they were a metre off).
    let (path, _) = uvms::io::ply::read_cloud(&out.join("trajectory.ply")).unwrap();
    let surface =
        |f: &str| uvms::surface::Surface::new(&uvms::io::ply::read_mesh(&out.join(f)).unwrap()).unwrap();
    let (scanned, reference) = (surface("scan_surface.ply"), surface("reference_surface.ply"));
    let contact = traj
        .samples
        .iter()
        .enumerate()
        .filter(|(_, s)| s.phase == Phase::Contact);
    for (i, s) in contact {
        let under = if s.fallback { &reference } else { &scanned };
        let d = under.distance_within(&path.points[i], 0.005);
        assert!(d.is_some(), "sample {i} at {} is off the surface", path.points[i]);
    }
    // The resolved configuration runs again as it is, to the same trajectory.
    let again = dir.path().join("again");
    let o2 = run(&[
        "plan",
        scan.to_str().unwrap(),
        "--reference",
        model.to_str().unwrap(),
        "--config",
        out.join("config.toml").to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(o2.status.success(), "{}", stderr(&o2));
    assert_eq!(
        std::fs::read(out.join("trajectory.csv")).unwrap(),
        std::fs::read(again.join("trajectory.csv")).unwrap()
    );
}

#[test]
fn sample_the_sediment_without_a_reference() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scan = data("scans/sediment/scan.ply");
    let o = run(&[
        "plan",
        scan.to_str().unwrap(),
        "--pattern",
        "line",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let traj = Trajectory::read_csv(&out.join("trajectory.csv")).unwrap();
    assert!(traj.phase(Phase::Contact).all(|s| s.force == 0.0));
    // The report tells the seabed it planned on (the summary's), and where the line's scan
    // holes were filled from.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let inliers = summary["seabed_inliers"].as_u64().unwrap();
    let text = stderr(&o);
    assert!(text.starts_with("scan "), "{text}");
    assert!(text.contains(&format!(" = 0, {inliers} inliers")), "{text}");
    assert!(
        text.contains("line pattern: 1 row,") && text.contains("on the seabed's plane (scan holes)"),
        "{text}"
    );
    // Without a reference the other patterns are a usage error.
    let o = run(&[
        "plan",
        scan.to_str().unwrap(),
        "--pattern",
        "ring",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // ...and so is a ground truth or an initial guess, which were ignored.
    let truth = data("scans/bottle/truth.json");
    for option in ["--ground-truth", "--init"] {
        let o = run(&[
            "plan",
            scan.to_str().unwrap(),
            "--pattern",
            "line",
            option,
            truth.to_str().unwrap(),
            "--out",
            dir.path().join("o2").to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("{option}: needs the reference model (--reference")),
            "{}",
            stderr(&o)
        );
        assert!(!dir.path().join("o2").exists());
    }
}

#[test]
fn failed_runs_exit_1_and_bad_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let scan = data("scans/bottle/scan.ply");
    let scan = scan.to_str().unwrap();
    let model = data("models/bottle.ply");
    let model = model.to_str().unwrap();
    let with_config = |cfg: &Path| {
        run(&[
            "plan",
            scan,
            "--reference",
            model,
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            out,
        ])
    };
    // A raster that misses the object.
    let cfg = dir.path().join("far.toml");
    std::fs::write(
        &cfg,
        "[plan]\npattern = \"raster\"\n[plan.raster]\noffset_m = [2.0, 0.0]\n",
    )
    .unwrap();
    let o = with_config(&cfg);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("misses the object"), "{}", stderr(&o));
    // A band wider than the surface.
    std::fs::write(&cfg, "[plan.ring]\narc_deg = 250.0\n").unwrap();
    let o = with_config(&cfg);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("band wider than the surface"),
        "{}",
        stderr(&o)
    );
    // A scan with no object: the sediment patch has nothing standing on the seabed.
    let sediment = data("scans/sediment/scan.ply");
    let o = run(&[
        "plan",
        sediment.to_str().unwrap(),
        "--reference",
        model,
        "--out",
        out,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // Bad files and arguments.
    let bad_csv = dir.path().join("bad.csv");
    // A point repeated (a segment with no direction); a cell that is not a number.
    let with_pattern = |pattern: &str| {
        run(&[
            "plan",
            scan,
            "--reference",
            model,
            "--pattern",
            pattern,
            "--out",
            out,
        ])
    };
    for (text, named) in [
        (
            "x_m,y_m,z_m\n0.1,0,0\n0.1,0,0\n",
            "bad.csv line 3: repeats the previous point",
        ),
        // A force past any tool's (it was planned, then failed the hover point: exit 1).
        (
            "x_m,y_m,z_m,force_n\n0,0,0,60\n0.1,0,0,1e300\n",
            "bad.csv line 3 column 4: 1e300 is beyond",
        ),
        ("x_m,y_m,z_m\n0,0,0\n0,nope,0\n", "bad.csv line 3 column 2"),
    ] {
        std::fs::write(&bad_csv, text).unwrap();
        let o = with_pattern(bad_csv.to_str().unwrap());
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(named), "{}", stderr(&o));
    }
    // Named in a configuration file, the polyline is found beside it (not in the working
    // directory).
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::copy(&bad_csv, sub.join("path.csv")).unwrap();
    let sub_cfg = sub.join("plan.toml");
    std::fs::write(
        &sub_cfg,
        "[plan]\npattern = \"polyline\"\n[plan.polyline]\nfile = \"path.csv\"\n",
    )
    .unwrap();
    let o = with_config(&sub_cfg);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("path.csv") && stderr(&o).contains("line 3 column 2"),
        "{}",
        stderr(&o)
    );
    let o = run(&[
        "plan",
        "/nonexistent/scan.ply",
        "--reference",
        model,
        "--out",
        out,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = with_pattern("spiral");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    std::fs::write(&cfg, "[plan.ring]\narc_degrees = 90.0\n").unwrap();
    let o = with_config(&cfg);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("arc_degrees"), "{}", stderr(&o));
    // Nothing was written by the failed runs.
    assert!(!Path::new(out).join("trajectory.csv").exists());
}
