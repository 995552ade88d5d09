//! `uvms synth` against its ground truth: the depth-noise model, the truth file's poses, what
//! the camera can and cannot see, determinism, and bad configurations.

mod common;

use nalgebra::{Point3, Vector3};
use std::path::Path;
use std::process::Command;
use uvms::frames::read_pose_file;
use uvms::mesh::TriangleMesh;
use uvms::surface::Surface;
use uvms::synth::{Artefact, SceneKind, SurfaceKind, SynthConfig, synthesize};

/// A fast configuration: every 4th pixel, a coarser seabed grid and bottle mesh.
fn small(seed: u64) -> SynthConfig {
    let mut c = SynthConfig {
        seed,
        ..Default::default()
    };
    c.camera.pixel_stride = 4;
    c.seabed.cell_m = 0.02;
    c.object.bottle.segments = 64;
    c.object.bottle.profile_step_m = 0.012;
    c
}

/// A flat, level sediment patch seen straight down from `distance` metres, with no dropouts or
/// artefacts: every measured point differs from the truth by the depth noise only.
fn flat_target(distance: f64) -> SynthConfig {
    let mut c = small(11);
    c.scene = SceneKind::Sediment;
    c.camera.tilt_deg = 0.0;
    c.camera.distance_m = distance;
    c.seabed.slope_deg = 0.0;
    c.seabed.ripple_amplitude_m = 0.0;
    c.seabed.roughness_m = 0.0;
    c.sensor.textureless_seabed = 0.0;
    c.sensor.speckle_fraction = 0.0;
    c.sensor.flying_fraction = 0.0;
    c.sensor.max_incidence_deg = 90.0;
    c
}

fn std_dev(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn depth_noise_follows_the_stereo_formula() {
    let mut sigmas = Vec::new();
    for z in [1.0, 2.0] {
        let cfg = flat_target(z);
        let s = synthesize(&cfg).unwrap();
        assert!(s.scan.len() > 20_000, "{}", s.scan.len());
        let mut errors = Vec::new();
        for (p, t) in s.scan.points.iter().zip(&s.points) {
            // The flat target lies at depth z, and the error is along the pixel's ray.
            assert!((t.true_point.z - z).abs() < 1e-9);
            assert!(
                p.coords
                    .normalize()
                    .cross(&t.true_point.coords.normalize())
                    .norm()
                    < 1e-9
            );
            errors.push(p.z - t.true_point.z);
        }
        let formula = z * z * cfg.sensor.disparity_sigma_px / (cfg.camera.focal_px * cfg.camera.baseline_m);
        let measured = std_dev(&errors);
        eprintln!(
            "depth noise at {z} m: measured {:.3} mm, formula {:.3} mm",
            measured * 1e3,
            formula * 1e3
        );
        assert!((measured / formula - 1.0).abs() < 0.2, "{measured} vs {formula}");
        sigmas.push(measured);
    }
    // Quadratic in depth: twice as far, four times the noise.
    assert!((sigmas[1] / sigmas[0] / 4.0 - 1.0).abs() < 0.2, "{sigmas:?}");
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(common::uvms_bin()).args(args).output().unwrap()
}

fn write_config(dir: &Path, cfg: &SynthConfig) -> String {
    let path = dir.join("in.toml");
    std::fs::write(&path, toml::to_string(cfg).unwrap()).unwrap();
    path.display().to_string()
}

/// The object's triangles of the true scene.
fn object_mesh(mesh: &TriangleMesh, kinds: &[SurfaceKind], kind: SurfaceKind) -> TriangleMesh {
    TriangleMesh {
        vertices: mesh.vertices.clone(),
        triangles: mesh
            .triangles
            .iter()
            .zip(kinds)
            .filter(|(_, k)| **k == kind)
            .map(|(t, _)| *t)
            .collect(),
    }
}

#[test]
fn truth_file_puts_the_reference_on_the_noise_free_points() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = small(7);
    let out = dir.path().join("out");
    let o = run(&[
        "synth",
        "--config",
        &write_config(dir.path(), &cfg),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t_scan_reference = read_pose_file(&out.join("truth.json"), "t_scan_reference").unwrap();

    // The same scene from the written (resolved) configuration, through the library.
    let resolved: SynthConfig = uvms::config::load(Some(&out.join("config.toml"))).unwrap();
    let s = synthesize(&resolved).unwrap();
    let reference = Surface::new(&s.reference.clone().unwrap().transformed(&t_scan_reference)).unwrap();
    let (mut clean, mut fouled) = (Vec::new(), Vec::new());
    for t in s
        .points
        .iter()
        .filter(|t| t.surface == SurfaceKind::Object && t.artefact == Artefact::None)
    {
        let d = reference.project(&t.true_point).distance;
        if t.fouling_m == 0.0 {
            clean.push(d)
        } else {
            fouled.push(d)
        }
    }
    assert!(clean.len() > 1000, "{} clean object points", clean.len());
    let mean = clean.iter().sum::<f64>() / clean.len() as f64;
    eprintln!(
        "mean distance of {} clean object points to the reference: {mean:.3e} m",
        clean.len()
    );
    assert!(mean < 0.5e-3, "{mean}");
    // The fouled points are off the reference: the true surface differs from the model there.
    assert!(
        fouled.iter().cloned().fold(0.0, f64::max) > 2e-3,
        "fouling not visible"
    );

    // A wrong pose would not pass: 2 mm of translation moves the mean distance well past 0.5 mm.
    let shifted = uvms::frames::Pose::translation(0.0, 0.0, 0.002) * t_scan_reference;
    let off = Surface::new(&s.reference.clone().unwrap().transformed(&shifted)).unwrap();
    let object = s.noise_free(SurfaceKind::Object);
    let mean_off = object.iter().map(|p| off.project(p).distance).sum::<f64>() / object.len() as f64;
    assert!(mean_off > 0.5e-3, "{mean_off}");

    // The seabed plane: unit normal towards the camera, through the noise-free seabed points on
    // average (ripples and roughness average out; the silt only raises it).
    let text = std::fs::read_to_string(out.join("truth.json")).unwrap();
    let truth: serde_json::Value = serde_json::from_str(&text).unwrap();
    let plane: Vec<f64> = serde_json::from_value(truth["seabed_plane"].clone()).unwrap();
    let n = Vector3::new(plane[0], plane[1], plane[2]);
    assert!((n.norm() - 1.0).abs() < 1e-12 && plane[3] > 0.0);
    let seabed = s.noise_free(SurfaceKind::Seabed);
    let heights: Vec<f64> = seabed.iter().map(|p| n.dot(&p.coords) + plane[3]).collect();
    let mean_h = heights.iter().sum::<f64>() / heights.len() as f64;
    assert!(mean_h.abs() < 3e-3, "{mean_h}");
    // Gravity's up is the seabed normal tilted by the slope.
    let up: Vec<f64> = serde_json::from_value(truth["up_in_scan"].clone()).unwrap();
    let up = Vector3::new(up[0], up[1], up[2]);
    let slope = up.angle(&n).to_degrees();
    assert!((slope - resolved.seabed.slope_deg).abs() < 1e-9, "{slope}");
    // The reference's +z is the seabed's up (the bottle lies in the plane), and its origin is
    // body-radius minus burial above the plane.
    let z_ref = t_scan_reference.rotation * Vector3::z();
    assert!((z_ref - n).norm() < 1e-9);
    let origin = t_scan_reference.translation.vector;
    assert!((n.dot(&origin) + plane[3] - (0.175 - resolved.object.burial_m)).abs() < 1e-6);
}

#[test]
fn the_camera_sees_only_what_it_can_see() {
    let s = synthesize(&small(3)).unwrap();
    let scene = Surface::new(&s.scene_mesh).unwrap();
    let object = Surface::new(&object_mesh(
        &s.scene_mesh,
        &s.triangle_kinds,
        SurfaceKind::Object,
    ))
    .unwrap();
    let right = Point3::new(s.config.camera.baseline_m, 0.0, 0.0);
    assert!(s.counts.stereo_shadow > 0, "{:?}", s.counts);
    for t in &s.points {
        let p = t.true_point;
        // From the left camera, nothing lies between it and a seabed point: no point behind the
        // object (checked against the object's surfaces alone).
        if t.surface != SurfaceKind::Object {
            assert!(
                object
                    .cast_ray(&Point3::origin(), &p.coords, p.coords.norm() - 1e-6)
                    .is_none(),
                "{p:?}"
            );
        }
        // The right camera sees every measured point (no point in the stereo shadow).
        let d = p - right;
        assert!(scene.cast_ray(&right, &d, d.norm() - 1e-4).is_none(), "{p:?}");
    }
    // The seabed behind the object's centre, on the same ray, is not in the scan.
    let seabed = Surface::new(&object_mesh(
        &s.scene_mesh,
        &s.triangle_kinds,
        SurfaceKind::Seabed,
    ))
    .unwrap();
    let behind = seabed
        .cast_ray(&Point3::origin(), &s.truth.target_in_scan.coords, 10.0)
        .unwrap()
        .point;
    let nearest = s
        .points
        .iter()
        .map(|t| (t.true_point - behind).norm())
        .fold(f64::MAX, f64::min);
    assert!(
        nearest > 0.1,
        "a scan point {nearest} m from the seabed behind the bottle"
    );
    // The object is in view and occludes: object points exist, and the seabed under it is hidden.
    assert!(
        s.points
            .iter()
            .filter(|t| t.surface == SurfaceKind::Object)
            .count()
            > 1000
    );
}

#[test]
fn sediment_scene_has_no_object() {
    let mut cfg = small(5);
    cfg.scene = SceneKind::Sediment;
    let s = synthesize(&cfg).unwrap();
    assert!(s.reference.is_none() && s.truth.t_scan_reference.is_none());
    assert!(s.points.iter().all(|t| t.surface == SurfaceKind::Seabed));
    assert!(s.truth.stones.is_empty());
    let json = serde_json::to_value(&s.truth).unwrap();
    assert!(json.get("t_scan_reference").is_none() && json.get("object").is_none());
    // The target is on the mean plane, on the optical axis at the distance.
    let [a, b, c, d] = s.truth.seabed_plane;
    let target = s.truth.target_in_scan;
    assert!((a * target.x + b * target.y + c * target.z + d).abs() < 1e-9);
    assert!((target - Point3::new(0.0, 0.0, cfg.camera.distance_m)).norm() < 1e-9);
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(dir.path(), &small(0));
    let outs: Vec<_> = ["a", "b", "c"].iter().map(|n| dir.path().join(n)).collect();
    for (out, seed) in outs.iter().zip(["21", "21", "22"]) {
        let o = run(&[
            "synth",
            "--config",
            &cfg,
            "--seed",
            seed,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (a, b, c) = (files(&outs[0]), files(&outs[1]), files(&outs[2]));
    let names: Vec<&str> = a.iter().map(|f| f.0.as_str()).collect();
    assert_eq!(
        names,
        [
            "config.toml",
            "reference.ply",
            "scan.ply",
            "scene_mesh.ply",
            "summary.json",
            "truth.json"
        ]
    );
    for (fa, fb) in a.iter().zip(&b) {
        assert!(fa == fb, "{} differs between two runs with the same seed", fa.0);
    }
    for name in ["scan.ply", "scene_mesh.ply", "truth.json", "config.toml"] {
        let get = |v: &[(String, Vec<u8>)]| v.iter().find(|f| f.0 == name).unwrap().1.clone();
        assert_ne!(get(&a), get(&c), "{name} does not depend on the seed");
    }
}

#[test]
fn bad_configurations_exit_2_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // The file and the key (the synthesis's own checks name the file too).
    let cases = [
        ("[camera]\nfocal_px = -700.0\n", "bad.toml: camera.focal_px"),
        // Valid, but the camera sees nothing: no empty scan is written.
        (
            "[camera]\nfocal_px = 1e8\n",
            "bad.toml: camera: the stereo pair matched no point",
        ),
        // Past any camera.
        (
            "[camera]\nfocal_px = 1e300\n",
            "bad.toml: camera.focal_px: 1e300 is beyond",
        ),
        ("[sensor]\ndisparity_sigma = 0.1\n", "disparity_sigma"),
        (
            "[fouling]\nbump_height_m = [0.01, 0.001]\n",
            "fouling.bump_height_m",
        ),
        (
            "[object.bottle]\nneck_diameter_m = 0.4\n",
            "object.bottle.neck_diameter_m",
        ),
        ("[camera]\ntilt_deg = 80.0\n", "bad.toml: camera.tilt_deg"),
    ];
    for (text, key) in cases {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, text).unwrap();
        let o = run(&[
            "synth",
            "--config",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{text}: {err}");
        assert!(err.contains(key) && err.lines().count() == 1, "{text}: {err}");
        assert!(!out.join("scan.ply").exists(), "{text}: a scan written");
    }
    let o = run(&["synth", "--scene", "reef", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&[
        "synth",
        "--seed",
        "18446744073709551615",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("seed"));
    assert!(!out.join("scan.ply").exists());
}

#[test]
fn a_reference_file_replaces_the_generated_bottle() {
    let dir = tempfile::tempdir().unwrap();
    let generated = small(4);
    let a = synthesize(&generated).unwrap();
    // The same bottle, through a PLY file: the same scene, point for point.
    let path = dir.path().join("bottle.ply");
    let out = uvms::output::OutDir::create(dir.path(), &[], &["bottle.ply"]).unwrap();
    out.write_with("bottle.ply", |w| {
        uvms::io::ply::write_mesh(w, a.reference.as_ref().unwrap())
    })
    .unwrap();
    let mut from_file = generated.clone();
    from_file.object.reference = Some(path.clone());
    let b = synthesize(&from_file).unwrap();
    assert!(a.scan == b.scan, "the scan through the PLY file differs");
    assert_eq!(a.truth.t_scan_reference, b.truth.t_scan_reference);
    assert_eq!(b.truth.object.as_ref().unwrap().model, path.display().to_string());
    // A reference file that `uvms synth` would write over (a product's name in its --out) is
    // refused, and left as it was.
    let before = std::fs::read(&path).unwrap();
    for name in ["reference.ply", "scan.ply"] {
        let product = dir.path().join(name);
        std::fs::copy(&path, &product).unwrap();
        let mut into_out = generated.clone();
        into_out.object.reference = Some(product.clone());
        let cfg = write_config(dir.path(), &into_out);
        let out = dir.path().display().to_string();
        let o = run(&["synth", "--quiet", "--config", &cfg, "--out", &out]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("is an input"), "{stderr}");
        assert_eq!(std::fs::read(&product).unwrap(), before, "{name} overwritten");
    }
    // A missing file is bad input naming the key.
    from_file.object.reference = Some(dir.path().join("missing.ply"));
    let e = synthesize(&from_file).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("object.reference"), "{e}");
    // A mesh without area (every point on a line) is named as such, not as too shallow a model
    // for the burial.
    let flat = uvms::mesh::TriangleMesh {
        vertices: (0..4)
            .map(|i| nalgebra::Point3::new(0.1 * i as f64, 0.0, 0.0))
            .collect(),
        triangles: vec![[0, 1, 2], [1, 2, 3]],
    };
    let out = uvms::output::OutDir::create(dir.path(), &[], &["flat.ply"]).unwrap();
    out.write_with("flat.ply", |w| uvms::io::ply::write_mesh(w, &flat))
        .unwrap();
    from_file.object.reference = Some(dir.path().join("flat.ply"));
    let e = synthesize(&from_file).unwrap_err().to_string();
    assert!(e.ends_with("flat.ply: the mesh has no surface area"), "{e}");
}

/// The files under `data/` are what the commands in `data/README.md` make, byte for byte.
#[test]
fn committed_data_is_reproducible() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let dir = tempfile::tempdir().unwrap();
    let sediment_cfg = data.join("configs/sediment.toml");
    let runs: [(&str, Vec<&str>); 2] = [
        ("bottle", vec!["--scene", "bottle", "--seed", "1"]),
        (
            "sediment",
            vec!["--config", sediment_cfg.to_str().unwrap(), "--seed", "1"],
        ),
    ];
    for (name, args) in runs {
        let out = dir.path().join(name);
        let mut all = vec!["synth", "--quiet"];
        all.extend(args);
        all.extend(["--out", out.to_str().unwrap()]);
        let o = run(&all);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let made = files(&out);
        let committed = files(&data.join("scans").join(name));
        let names = |v: &[(String, Vec<u8>)]| v.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
        assert_eq!(names(&made), names(&committed), "{name}");
        for (m, c) in made.iter().zip(&committed) {
            assert!(
                m.1 == c.1,
                "data/scans/{name}/{} differs from what the command makes now",
                c.0
            );
        }
    }
    let model = std::fs::read(data.join("models/bottle.ply")).unwrap();
    assert!(
        model == std::fs::read(dir.path().join("bottle/reference.ply")).unwrap(),
        "data/models/bottle.ply"
    );
}

#[test]
fn impossible_camera_placements_are_bad_input() {
    // 0.15 m above the bottle's axis is inside its 0.175 m radius body.
    let mut c = small(1);
    c.camera.min_depth_m = 0.1;
    c.camera.distance_m = 0.15;
    c.camera.tilt_deg = 0.0;
    let Err(e) = synthesize(&c) else {
        panic!("a camera inside the bottle must be rejected")
    };
    assert_eq!(e.exit_code(), 2, "{e}");
    assert!(
        e.to_string().contains("camera.distance_m") && e.to_string().contains("inside"),
        "{e}"
    );
    let mut c = small(1);
    c.camera.pixel_stride = 1;
    c.camera.width_px = 20_000;
    c.camera.height_px = 20_000;
    let Err(e) = synthesize(&c) else {
        panic!("20000 x 20000 pixels must be rejected")
    };
    assert!(e.to_string().contains("camera.pixel_stride"), "{e}");
}
