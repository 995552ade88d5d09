//! The inputs and parameters of `benches/perception.rs`, shared with the profiling driver
//! `examples/prof_perception.rs` (so that instruction counts measure what the benchmark times).
//! See the benchmark's module doc for what they are.

use nalgebra::{Isometry3, Vector3};
use std::path::{Path, PathBuf};
use uvms::cloud::filter::{OutlierConfig, VoxelConfig, voxel_downsample};
use uvms::frames::{Pose, read_pose_file};
use uvms::io::ply::read_cloud;
use uvms::perception::PerceptionConfig;
use uvms::register::{InitMode, ReferenceModel, Registration, ScanNormals, register};
use uvms::spatial::KdIndex;

/// The peer's parameters; options Open3D does not have keep their defaults.
pub fn config() -> PerceptionConfig {
    let mut cfg = PerceptionConfig::default();
    cfg.clean.voxel_m = 0.005;
    cfg.clean.outliers = OutlierConfig {
        neighbours: 19,
        std_ratio: 2.0,
    };
    cfg.seabed.threshold_m = 0.01;
    cfg.seabed.max_iterations = 1000;
    cfg.seabed.confidence = 0.999_999_99;
    cfg.seabed.score_points = 0;
    cfg.cluster.tolerance_m = 0.02;
    cfg.cluster.min_points = 100;
    cfg.normals.neighbours = 30;
    cfg.normals.radius_m = 0.015;
    cfg.register.icp.initial_gate_m = 0.01;
    cfg.register.icp.min_gate_m = 0.01;
    cfg.register.icp.max_iterations = 50;
    cfg.register.evaluation_distance_m = 0.01;
    // As many model points as the peer's voxelised bottle mesh vertices.
    cfg.register.mesh_samples = 14_538;
    cfg
}

pub struct Input {
    pub name: &'static str,
    pub scan: uvms::cloud::PointCloud,
    pub model: ReferenceModel,
    pub truth: Pose,
}

pub fn bottle(cfg: &PerceptionConfig) -> Input {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let scans = data.join("scans/bottle");
    Input {
        name: "bottle",
        scan: read_cloud(&scans.join("scan.ply")).unwrap().0,
        model: uvms::cli::segment::load_reference(&data.join("models/bottle.ply"), cfg).unwrap(),
        truth: read_pose_file(&scans.join("truth.json"), "t_scan_reference").unwrap(),
    }
}

pub fn milk(cfg: &PerceptionConfig, dir: &Path) -> Input {
    // open3d_pipeline.py's perturbation of the reference (30°, 50 mm, seed 0).
    let moved = Isometry3::new(
        Vector3::new(0.00801071, -0.04090645, 0.02761324),
        Vector3::new(0.09886441, -0.10387693, 0.50357828),
    );
    let (reference, _) = read_cloud(&dir.join("milk.ply")).unwrap();
    let mut reference = voxel_downsample(&reference, &VoxelConfig { voxel_m: 0.005 })
        .unwrap()
        .cloud;
    reference.points.iter_mut().for_each(|p| *p = moved * *p);
    Input {
        name: "milk",
        scan: read_cloud(&dir.join("milk_cartoon_all_small_clorox.ply"))
            .unwrap()
            .0,
        model: ReferenceModel::from_cloud(reference, &cfg.normals, "milk.ply").unwrap(),
        truth: moved.inverse(),
    }
}

/// The input named `scene` (`bottle`, or `milk` from the directory in `UVMS_REAL_DATA`).
///
/// # Panics
/// On an unknown scene, a missing `UVMS_REAL_DATA` for milk, or an unreadable file.
#[allow(dead_code)]
pub fn load(scene: &str, cfg: &PerceptionConfig) -> Input {
    match scene {
        "bottle" => bottle(cfg),
        "milk" => {
            let dir = std::env::var_os("UVMS_REAL_DATA").map(PathBuf::from);
            milk(
                cfg,
                &dir.expect("UVMS_REAL_DATA must name the real scenes' directory"),
            )
        }
        other => panic!("unknown scene {other}"),
    }
}

/// What the benchmark's `register` times: the selected object's index, and the registration of
/// the reference onto it with the object's normals estimated on the way.
#[allow(dead_code)]
pub fn register_object(
    input: &Input,
    object: &[nalgebra::Point3<f64>],
    cfg: &PerceptionConfig,
) -> Registration {
    let index = KdIndex::new(object).unwrap();
    register(
        &input.model,
        object,
        ScanNormals::Estimate(&cfg.normals),
        &index,
        &cfg.view.camera(),
        &InitMode::Auto,
        &cfg.register,
    )
    .unwrap()
}
