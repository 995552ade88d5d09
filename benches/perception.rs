//! Perception stages with the parameters of the Open3D peer run (`open3d_pipeline.py --voxel 0.005
//! --init pca --icp-dist 0.01`, other options at its defaults): voxel 5 mm, statistical outlier
//! removal k = 20 (Open3D counts the point itself, so 19 neighbours here) and std ratio 2, RANSAC
//! plane at a fixed 10 mm threshold (at most 1000 hypotheses, confidence 0.99999999, scored on every
//! point, no `up` prior), Euclidean clusters at 20 mm of at least 100 points, normals from at most
//! 30 neighbours within 15 mm, ICP with its gate held at 10 mm and at most 50 iterations.
//!
//! Measured, per input: `seabed_ransac` (`find_seabed` on the cleaned scan), `cluster`
//! (`euclidean_clusters` on the object side), `register` (index, and `register` with the global
//! initial guess and the normals estimated alongside it, on the selected object), and the whole
//! `segment` and `check` calls.
//! Inputs: the synthetic bottle scan `data/scans/bottle/scan.ply` with `data/models/bottle.ply`;
//! with `UVMS_REAL_DATA` set, also PCL's `milk_cartoon_all_small_clorox.ply` with `milk.ply`
//! (voxelised like the scene) moved by the peer's perturbation for `--perturb-deg 30
//! --perturb-mm 50 --seed 0`, so the true pose is that motion's inverse.
//!
//! The inputs and parameters live in `common/perception_inputs.rs`, shared with the profiling
//! driver `examples/prof_perception.rs`.
//!
//! Run: `cargo bench --bench perception`, with the real scene
//! `UVMS_REAL_DATA=../shared/data/real cargo bench --bench perception`.

#[path = "common/perception_inputs.rs"]
mod perception_inputs;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Vector3};
use perception_inputs::{Input, bottle, config, milk, register_object};
use std::hint::black_box;
use std::path::PathBuf;
use uvms::perception::{CheckOptions, PerceptionConfig, Timings, check, segment};

use uvms::segment::cluster::euclidean_clusters;
use uvms::segment::seabed::find_seabed;

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
    let mut g = c.benchmark_group(format!("perception_{}", input.name));
    g.sample_size(10);
    g.bench_function("seabed_ransac", |b| {
        b.iter(|| find_seabed(black_box(cleaned), None, &cfg.seabed).unwrap())
    });
    g.bench_function("cluster", |b| {
        b.iter(|| euclidean_clusters(black_box(&side), &cfg.cluster).unwrap())
    });
    g.bench_function("register", |b| {
        b.iter(|| register_object(input, black_box(&object), cfg))
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
