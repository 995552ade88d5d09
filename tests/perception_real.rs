//! Perception on real scans made by others (`UVMS_REAL_DATA`, see `shared/data/real/SOURCES.md`),
//! against the ground truth that comes with them.
//!
//! - `milk.ply` into `milk_cartoon_all_small_clorox.ply`: the model is an exact crop of the scene,
//!   so its true pose is the identity. The model is given in its own frame (origin at its centroid:
//!   truth = the translation to the centroid) and ICP starts from a pose exactly 30° and 50 mm
//!   from the truth (seeded random axis and direction). The scene goes through the whole pipeline:
//!   the table is removed, the objects on it clustered, the carton's cluster chosen by its shape.
//! - `bun045.ply` onto `bun000.ply` from the identity (34° / 53 mm from the truth in
//!   `bunny_gt_poses.json`): both are single objects, so `--whole-scan`. The Stanford range scans
//!   are height fields over x, y seen from +z, so the camera is placed 1 m out along +z.
//! - the uncropped mug scene, whose background is a larger plane than the table once the cloud
//!   is thinned to a uniform 1 cm grid: with a rough `up` the table is found, and the mug is a
//!   cluster of about 0.14 × 0.11 × 0.08 m.

mod common;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use uvms::cloud::PointCloud;
use uvms::frames::{Pose, read_pose_file};
use uvms::io::ply::read_cloud;
use uvms::perception::{CheckOptions, PerceptionConfig, check, segment};
use uvms::register::{InitMode, ReferenceModel};

/// A rigid motion of exactly `deg` degrees about a random axis and `mm` millimetres along a random
/// direction (seeded).
fn perturbation(deg: f64, mm: f64, seed: u64) -> Pose {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
    let mut unit = || loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if (0.1..1.0).contains(&v.norm()) {
            return Unit::new_normalize(v);
        }
    };
    let axis = unit();
    let dir = unit();
    Isometry3::from_parts(
        Translation3::from(dir.into_inner() * mm * 1e-3),
        UnitQuaternion::from_axis_angle(&axis, deg.to_radians()),
    )
}

#[test]
fn milk_carton_from_30_degrees_and_50_mm_off() {
    let (Some(scene_path), Some(model_path)) = (
        common::real_data("milk_cartoon_all_small_clorox.ply"),
        common::real_data("milk.ply"),
    ) else {
        return;
    };
    let (scene, _) = read_cloud(&scene_path).unwrap();
    let (milk, _) = read_cloud(&model_path).unwrap();
    let centre = milk.points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / milk.len() as f64;
    let model_cloud = PointCloud::from_points(milk.points.iter().map(|p| p - centre).collect());
    let cfg = PerceptionConfig::default();
    let model = ReferenceModel::from_cloud(model_cloud, &cfg.normals, "milk").unwrap();
    let truth = Isometry3::translation(centre.x, centre.y, centre.z);
    for seed in [1, 2, 3] {
        let start = truth * perturbation(30.0, 50.0, seed);
        let (deg0, m0) = uvms::frames::pose_error(&start, &truth);
        assert!((deg0 - 30.0).abs() < 1e-9 && (m0 - 0.05).abs() < 1e-12);
        let opts = CheckOptions {
            init: InitMode::Given(start),
            truth: Some(truth),
            ..CheckOptions::default()
        };
        let r = check(&scene, &model, &opts, &cfg).unwrap();
        let e = r.truth.unwrap();
        eprintln!(
            "milk seed {seed}: {:.4}° {:.4} mm, {} iterations",
            e.rotation_error_deg,
            1e3 * e.translation_error_m,
            r.registration.iterations
        );
        assert!(
            e.rotation_error_deg <= 0.1 && e.translation_error_m <= 0.0005,
            "{e:?}"
        );
    }
    // The global initial guess finds it too, with no start at all.
    let r = check(
        &scene,
        &model,
        &CheckOptions {
            truth: Some(truth),
            ..CheckOptions::default()
        },
        &cfg,
    )
    .unwrap();
    let e = r.truth.unwrap();
    assert!(
        e.rotation_error_deg <= 0.1 && e.translation_error_m <= 0.0005,
        "{e:?}"
    );
}

/// Two Stanford scans as `check` takes them: the scan, the model made of `reference` (named
/// `name`), and the configuration with the camera 1 m out along +z (see the module docs).
fn bunny_pair(
    scan: &std::path::Path,
    reference: &std::path::Path,
    name: &str,
) -> (PointCloud, ReferenceModel, PerceptionConfig) {
    let (scan, _) = read_cloud(scan).unwrap();
    let (reference, _) = read_cloud(reference).unwrap();
    let mut cfg = PerceptionConfig::default();
    cfg.view.camera_m = [0.0, 0.0, 1.0];
    let model = ReferenceModel::from_cloud(reference, &cfg.normals, name).unwrap();
    (scan, model, cfg)
}

#[test]
fn bunny_045_onto_000_from_identity() {
    let (Some(b0), Some(b45), Some(gt)) = (
        common::real_data("bun000.ply"),
        common::real_data("bun045.ply"),
        common::real_data("bunny_gt_poses.json"),
    ) else {
        return;
    };
    let truth = read_pose_file(&gt, "T_bun000_from_bun045").unwrap();
    let (deg0, m0) = uvms::frames::pose_error(&Pose::identity(), &truth);
    assert!((deg0 - 34.3).abs() < 0.1 && (m0 - 0.0532).abs() < 1e-3);
    let (scan, model, cfg) = bunny_pair(&b0, &b45, "bun045");
    let opts = CheckOptions {
        init: InitMode::Given(Pose::identity()),
        whole_scan: true,
        truth: Some(truth),
        ..CheckOptions::default()
    };
    let r = check(&scan, &model, &opts, &cfg).unwrap();
    let e = r.truth.unwrap();
    eprintln!(
        "bunny: {:.4}° {:.4} mm, {} iterations, [59] {:.3} mm",
        e.rotation_error_deg,
        1e3 * e.translation_error_m,
        r.registration.iterations,
        1e3 * r.accuracy.rms_m
    );
    assert!(
        e.rotation_error_deg <= 0.15 && e.translation_error_m <= 0.0003,
        "{e:?}"
    );
}

/// The pose of a Stanford scan in the bunny's frame: its `T_world_from_scan` in
/// `bunny_gt_poses.json`'s `poses`.
fn bunny_pose(gt: &std::path::Path, scan: &str) -> Pose {
    let text = std::fs::read_to_string(gt).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let m = |r: usize, c: usize| json["poses"][scan]["T_world_from_scan"][r][c].as_f64().unwrap();
    let rotation = nalgebra::Matrix3::from_fn(m);
    Isometry3::from_parts(
        Translation3::new(m(0, 3), m(1, 3), m(2, 3)),
        UnitQuaternion::from_matrix(&rotation),
    )
}

/// ICP that converges on a wrong pose is refused, exit 1, not passed with a good-looking
/// fitness: `bun270` onto `bun180` (the truth a turn of about 90°) from the truth turned a further
/// 90° about the model's y axis settles with its residuals spread 165 times the scan's noise.
/// From the identity it converges to the truth, since the hidden-point removal culls the model
/// from the camera, 1 m out along +z (culled from the scan frame's origin, it settled 126° off
/// with a scan fitness of 0.95 at a 39 mm gate, and was refused). Started at the truth, the same
/// check is accepted and stays there.
#[test]
fn a_wrong_bunny_alignment_is_refused_and_the_true_one_accepted() {
    let (Some(b180), Some(b270), Some(gt)) = (
        common::real_data("bun180.ply"),
        common::real_data("bun270.ply"),
        common::real_data("bunny_gt_poses.json"),
    ) else {
        return;
    };
    let truth = bunny_pose(&gt, "bun180.ply").inverse() * bunny_pose(&gt, "bun270.ply");
    let (deg0, _) = uvms::frames::pose_error(&Pose::identity(), &truth);
    assert!((80.0..100.0).contains(&deg0), "{deg0}");
    let (scan, model, cfg) = bunny_pair(&b180, &b270, "bun270");
    let from = |init: Pose| CheckOptions {
        init: InitMode::Given(init),
        whole_scan: true,
        truth: Some(truth),
        ..CheckOptions::default()
    };
    let turned = truth * Isometry3::rotation(Vector3::y() * std::f64::consts::FRAC_PI_2);
    let err = check(&scan, &model, &from(turned), &cfg).unwrap_err();
    assert_eq!(err.exit_code(), 1);
    assert!(err.to_string().contains("times the scan's own noise"), "{err}");
    for init in [truth, Pose::identity()] {
        let r = check(&scan, &model, &from(init), &cfg).unwrap();
        let e = r.truth.unwrap();
        assert!(
            e.rotation_error_deg < 0.5 && e.translation_error_m < 0.001,
            "{e:?}"
        );
    }
}

#[test]
fn mug_scene_table_not_background() {
    let Some(path) = common::real_data("table_scene_mug_stereo_textured.ply") else {
        return;
    };
    let (scan, _) = read_cloud(&path).unwrap();
    // A rough prior: the camera held level would see `up` as −y; the table is 33° from it.
    let up = Vector3::new(0.0, -1.0, 0.0);
    // The table: every inlier on the near table top (0.69–1.1 m), none on the background (≥ 1.8 m).
    let on_table = |seg: &uvms::perception::Segmentation| {
        let inl = &seg.seabed.as_ref().unwrap().inliers;
        inl.iter().all(|&i| seg.cloud.points[i].z < 1.1)
    };
    // Thinned to a uniform 1 cm grid, the background holds more points than the table.
    let mut thin = PerceptionConfig::default();
    thin.clean.voxel_m = 0.01;
    let largest = segment(&scan, None, None, &thin).unwrap();
    assert!(
        !on_table(&largest),
        "without a prior the largest plane should be the background"
    );
    let prior = segment(&scan, Some(&up), None, &thin).unwrap();
    assert!(on_table(&prior));
    // At full resolution, with the prior: the table, and the mug standing on it.
    let seg = segment(&scan, Some(&up), None, &PerceptionConfig::default()).unwrap();
    assert!(on_table(&seg));
    let fit = seg.seabed.as_ref().unwrap();
    assert!(fit.inliers.len() > 100_000, "{}", fit.inliers.len());
    let mut spans: Vec<f64> = seg.object().shape.spans.iter().copied().collect();
    spans.sort_by(|a, b| b.total_cmp(a));
    eprintln!("mug: {spans:.3?}, {} points", seg.object().indices.len());
    for (s, want) in spans.iter().zip([0.14, 0.11, 0.08]) {
        assert!((s - want).abs() <= 0.02, "mug spans {spans:?}");
    }
    // It stands on the table: its lowest points touch the plane, its top is a mug's height above.
    let heights: Vec<f64> = seg
        .object()
        .indices
        .iter()
        .map(|&i| fit.plane.signed_distance(&seg.cloud.points[i]))
        .collect();
    let top = heights.iter().copied().fold(0.0, f64::max);
    let bottom = heights.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(bottom < 0.01 && (0.08..0.13).contains(&top), "{bottom} {top}");
}
