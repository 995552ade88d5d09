//! PLY read throughput on a 1 M-point binary little-endian file (generated at start into
//! `$TMPDIR/uvms-bench/`, seeded): `float x y z` + `uchar red green blue` (the layout of the real
//! scans, 15 MB) and `double x y z` (uvms's own output, 24 MB). Reported in bytes per second.
//! For comparison, the same float file read with ply-rs-bw's generic parser (`DefaultElement`).
//!
//! `cargo bench --bench ply_read`; the Open3D figure on the same files:
//! `python3 benches/open3d_read.py` (after the bench has written them).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Point3;
use rand::{RngExt, SeedableRng};
use std::hint::black_box;
use std::io::Write;
use std::path::PathBuf;
use uvms::cloud::PointCloud;
use uvms::io::ply::{read_cloud, write_cloud};

const N: usize = 1_000_000;

fn files() -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join("uvms-bench");
    std::fs::create_dir_all(&dir).unwrap();
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(1);
    let pts: Vec<[f32; 3]> = (0..N)
        .map(|_| {
            [
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(0.5..2.5),
            ]
        })
        .collect();
    let rgb: Vec<[u8; 3]> = (0..N).map(|_| rng.random()).collect();
    let float_path = dir.join("points_1m_float_rgb.ply");
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {N}\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    )
    .into_bytes();
    for (p, c) in pts.iter().zip(&rgb) {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend_from_slice(c);
    }
    std::fs::write(&float_path, bytes).unwrap();
    let double_path = dir.join("points_1m_double.ply");
    let cloud = PointCloud::from_points(
        pts.iter()
            .map(|p| Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .collect(),
    );
    let mut f = std::io::BufWriter::new(std::fs::File::create(&double_path).unwrap());
    write_cloud(&mut f, &cloud).unwrap();
    f.flush().unwrap();
    (float_path, double_path)
}

fn bench(c: &mut Criterion) {
    let (float_path, double_path) = files();
    eprintln!(
        "bench files: {} and {}",
        float_path.display(),
        double_path.display()
    );
    let mut g = c.benchmark_group("ply_read_1M");
    g.sample_size(20);
    for (name, path) in [("float_xyz_rgb", &float_path), ("double_xyz", &double_path)] {
        let size = std::fs::metadata(path).unwrap().len();
        g.throughput(Throughput::Bytes(size));
        g.bench_function(format!("uvms/{name}"), |b| {
            b.iter(|| {
                let (cloud, _) = read_cloud(black_box(path)).unwrap();
                assert_eq!(cloud.len(), N);
                cloud
            })
        });
    }
    let size = std::fs::metadata(&float_path).unwrap().len();
    g.throughput(Throughput::Bytes(size));
    g.sample_size(10);
    g.bench_function("ply-rs-bw_generic/float_xyz_rgb", |b| {
        b.iter(|| {
            let mut f = std::fs::File::open(&float_path).unwrap();
            let p = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
            let ply = p.read_ply(&mut f).unwrap();
            assert_eq!(ply.payload["vertex"].len(), N);
            ply
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
