//! Filters on a real RGB-D scene, `milk_cartoon_all_small_clorox.ply` (241 407 points), with the
//! parameters of the Open3D peer run: voxel 5 mm on the full cloud, then statistical outlier
//! removal (k = 20, std ratio 2.0) on the voxelised cloud (as `open3d_pipeline.py` chains them),
//! plus SOR on the full cloud and a range crop.
//!
//! Data from `UVMS_REAL_DATA`, else `../shared/data/real` relative to the crate; skipped with a
//! note when missing. `UVMS_REAL_DATA=/work/shared/data/real cargo bench --bench cloud_filters`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::PathBuf;
use uvms::cloud::filter::{
    OutlierConfig, RangeCropConfig, VoxelConfig, crop_range, remove_statistical_outliers, voxel_downsample,
};
use uvms::io::ply::read_cloud;

const FILE: &str = "milk_cartoon_all_small_clorox.ply";

fn scene() -> Option<PathBuf> {
    let dir = std::env::var_os("UVMS_REAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real"));
    let path = dir.join(FILE);
    path.is_file().then_some(path)
}

fn bench(c: &mut Criterion) {
    let Some(path) = scene() else {
        eprintln!("note: {FILE} not found (set UVMS_REAL_DATA); skipping the filter benchmarks");
        return;
    };
    let (cloud, _) = read_cloud(&path).unwrap();
    let voxel = VoxelConfig { voxel_m: 0.005 };
    let sor = OutlierConfig {
        neighbours: 20,
        std_ratio: 2.0,
    };
    let down = voxel_downsample(&cloud, &voxel).unwrap().cloud;
    let kept = remove_statistical_outliers(&down, &sor).unwrap().kept.len();
    eprintln!(
        "{FILE}: {} points -> voxel 5 mm: {} -> SOR k=20 std 2: {kept}",
        cloud.len(),
        down.len()
    );
    let mut g = c.benchmark_group("filters_milk_scene");
    g.sample_size(20);
    g.bench_function("read", |b| b.iter(|| read_cloud(black_box(&path)).unwrap()));
    g.bench_function("voxel_5mm", |b| {
        b.iter(|| voxel_downsample(black_box(&cloud), &voxel).unwrap())
    });
    g.bench_function("sor_k20_std2_on_voxelised", |b| {
        b.iter(|| remove_statistical_outliers(black_box(&down), &sor).unwrap())
    });
    g.bench_function("sor_k20_std2_on_full", |b| {
        b.iter(|| remove_statistical_outliers(black_box(&cloud), &sor).unwrap())
    });
    let range = RangeCropConfig {
        max_m: 1.5,
        ..Default::default()
    };
    g.bench_function("range_crop_1.5m", |b| {
        b.iter(|| crop_range(black_box(&cloud), &range).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
