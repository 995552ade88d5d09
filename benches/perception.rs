//! Perception stages with the parameters of the Open3D peer run (`open3d_pipeline.py --voxel 0.005
//! --init pca --icp-dist 0.01`, other options at its defaults): voxel 5 mm, statistical outlier
//! removal k = 20 (Open3D counts the point itself, so 19 neighbours here) and std ratio 2, RANSAC
//! plane at a fixed 10 mm threshold (at most 1000 hypotheses, confidence 0.99999999, scored on every
//! point, no `up` prior), Euclidean clusters at 20 mm of at least 100 points, normals from at most
//! 30 neighbours within 15 mm, ICP with its gate held at 10 mm and at most 50 iterations.
//!
//! Measured, per input: `seabed_ransac` (`find_seabed` on the cleaned scan), `cluster`
//! (`euclidean_clusters` on the object side), `register` (index, normals and `register` with the
//! global initial guess on the selected object), and the whole `segment` and `check` calls.
//! Inputs: the synthetic bottle scan `data/scans/bottle/scan.ply` with `data/models/bottle.ply`;
//! with `UVMS_REAL_DATA` set, also PCL's `milk_cartoon_all_small_clorox.ply` with `milk.ply`
//! (voxelised like the scene) moved by the peer's perturbation for `--perturb-deg 30
//! --perturb-mm 50 --seed 0`, so the true pose is that motion's inverse.
//!
//! Run: `cargo bench --bench perception`, with the real scene
//! `UVMS_REAL_DATA=../shared/data/real cargo bench --bench perception`.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Point3, Vector3};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use uvms::cloud::filter::{OutlierConfig, VoxelConfig, voxel_downsample};
use uvms::cloud::normals::estimate_normals;
use uvms::frames::{Pose, read_pose_file};
use uvms::io::ply::read_cloud;
use uvms::perception::{CheckOptions, PerceptionConfig, Timings, check, segment};
use uvms::register::{InitMode, ReferenceModel, register};
use uvms::segment::cluster::euclidean_clusters;
use uvms::segment::seabed::find_seabed;
use uvms::spatial::KdIndex;

/// The peer's parameters; options Open3D does not have keep their defaults.
fn config() -> PerceptionConfig {
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

struct Input {
    name: &'static str,
    scan: uvms::cloud::PointCloud,
    model: ReferenceModel,
    truth: Pose,
}

fn bottle(cfg: &PerceptionConfig) -> Input {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let scans = data.join("scans/bottle");
    Input {
        name: "bottle",
        scan: read_cloud(&scans.join("scan.ply")).unwrap().0,
        model: uvms::cli::segment::load_reference(&data.join("models/bottle.ply"), cfg).unwrap(),
        truth: read_pose_file(&scans.join("truth.json"), "t_scan_reference").unwrap(),
    }
}

fn milk(cfg: &PerceptionConfig, dir: &Path) -> Input {
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

fn stages(t: &Timings) -> String {
    let each = t.0.iter().map(|s| format!("{} {:.4}", s.stage, s.seconds));
    each.collect::<Vec<_>>().join(", ")
}

fn bench_input(c: &mut Criterion, cfg: &PerceptionConfig, input: &Input) {
    let opts = CheckOptions {
        truth: Some(input.truth),
        ..CheckOptions::default()
    };
    let r = check(&input.scan, &input.model, &opts, cfg).expect("check");
    let seg = r.segmentation.as_ref().expect("segmentation");
    let fit = seg.seabed.as_ref().expect("seabed");
    let reg = &r.registration;
    let truth = r.truth.as_ref().expect("truth");
    // The bottle turns freely about its x axis: the full rotation error includes that turn.
    let axis_deg = (reg.t_scan_reference * Vector3::x()).angle(&(input.truth * Vector3::x()));
    eprintln!(
        "{}: {} points, {} cleaned; plane {:.4?}, {} inliers; {} clusters, object {} points; \
         fitness {:.3}, inlier RMSE {:.2} mm, {} ICP iterations; error {:.3}° (x axis {:.3}°), \
         {:.2} mm, ADD-S {:.2} mm; stages (s): {}; in register: {}",
        input.name,
        input.scan.len(),
        seg.cloud.len(),
        fit.plane.coefficients(),
        fit.inliers.len(),
        seg.clusters.len(),
        r.object.len(),
        reg.fitness,
        1e3 * reg.inlier_rmse_m,
        reg.iterations,
        truth.rotation_error_deg,
        axis_deg.to_degrees(),
        1e3 * truth.translation_error_m,
        1e3 * truth.add_s_m,
        stages(&r.timings),
        stages(&reg.timings)
    );
    let cleaned = &seg.cloud.points;
    let side: Vec<Point3<f64>> = seg.object_side.iter().map(|&i| cleaned[i]).collect();
    let object = seg.object_cloud().points;
    let camera = cfg.view.camera();
    let mut g = c.benchmark_group(format!("perception_{}", input.name));
    g.sample_size(10);
    g.bench_function("seabed_ransac", |b| {
        b.iter(|| find_seabed(black_box(cleaned), None, &cfg.seabed).unwrap())
    });
    g.bench_function("cluster", |b| {
        b.iter(|| euclidean_clusters(black_box(&side), &cfg.cluster).unwrap())
    });
    g.bench_function("register", |b| {
        b.iter(|| {
            let index = KdIndex::new(black_box(&object)).unwrap();
            let normals = estimate_normals(&object, &cfg.normals, &camera).unwrap();
            register(
                &input.model,
                &object,
                &normals,
                &index,
                &InitMode::Auto,
                &cfg.register,
            )
            .unwrap()
        })
    });
    let spans = input.model.shape.spans;
    g.bench_function("segment", |b| {
        b.iter(|| segment(black_box(&input.scan), None, Some(&spans), cfg).unwrap())
    });
    g.bench_function("check", |b| {
        b.iter(|| {
            check(
                black_box(&input.scan),
                &input.model,
                &CheckOptions::default(),
                cfg,
            )
            .unwrap()
        })
    });
    g.finish();
}

fn bench(c: &mut Criterion) {
    let cfg = config();
    bench_input(c, &cfg, &bottle(&cfg));
    match std::env::var_os("UVMS_REAL_DATA").map(PathBuf::from) {
        Some(dir) => bench_input(c, &cfg, &milk(&cfg, &dir)),
        None => eprintln!("note: UVMS_REAL_DATA is not set; skipping the real milk scene"),
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
