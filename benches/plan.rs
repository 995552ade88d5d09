//! Planning time: the default ring and a 0.3 × 0.3 m raster at 5 mm row spacing, on a noisy
//! single-view scan of a bottle-sized cylinder (0.35 m diameter, 0.6 m long, 1 m from the camera,
//! 4 mm grid, 0.5 mm depth noise; about 24 000 scan triangles) with its closed reference mesh.
//! Each pattern's measurement is a whole `plan::plan` call: surface sampling and indexing,
//! projection, resampling, tool frames, timing; `prepare_scan_and_reference` is the first part
//! alone.
//!
//! Run: `cargo bench --bench plan`.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Point3;
use std::hint::black_box;
use uvms::frames::Pose;
use uvms::plan::fixtures::{Cylinder, ScanSpec};
use uvms::plan::patterns::PatternKind;
use uvms::plan::project::{Facing, SmoothSurface};
use uvms::plan::{ObjectAxes, ObjectInput, PlanConfig, PlanInput, plan};

fn bench(c: &mut Criterion) {
    let cylinder = Cylinder::bottle();
    let scan = cylinder.scan(&ScanSpec::default());
    let reference = cylinder.mesh(128, 8);
    let input = PlanInput {
        object: Some(ObjectInput {
            scan_surface: &scan,
            reference: &reference,
            t_scan_reference: Pose::identity(),
            axes: ObjectAxes::from_mesh(&reference).expect("reference"),
        }),
        viewpoint: Point3::origin(),
        seabed_plane: None,
        seabed_surface: None,
    };
    let ring = PlanConfig::default();
    let mut raster = PlanConfig {
        pattern: PatternKind::Raster,
        ..PlanConfig::default()
    };
    raster.raster.width_m = 0.3;
    raster.raster.height_m = 0.3;
    raster.raster.spacing_m = 0.005;
    for (name, cfg) in [("ring_default", &ring), ("raster_0.3x0.3m_5mm", &raster)] {
        let p = plan(&input, cfg).expect("plan");
        eprintln!(
            "{name}: {} scan triangles, {} samples ({} in contact), {:.3} m, {:.0} s",
            scan.triangles.len(),
            p.report.points,
            p.report.contact_points,
            p.report.length_m,
            p.report.duration_s
        );
    }
    let mut g = c.benchmark_group("plan");
    g.sample_size(10);
    g.bench_function("prepare_scan_and_reference", |b| {
        b.iter(|| {
            let r = 0.015;
            let s = SmoothSurface::new(black_box(&scan), Facing::Toward(Point3::origin()), r);
            let m = SmoothSurface::new(black_box(&reference), Facing::Winding, r);
            (s.is_ok(), m.is_ok())
        })
    });
    g.bench_function("ring_default", |b| b.iter(|| plan(black_box(&input), &ring)));
    g.bench_function("raster_0.3x0.3m_5mm", |b| {
        b.iter(|| plan(black_box(&input), &raster))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
