//! The contact query the simulation makes every control period: a tool tip 6 mm deep carried
//! along a scanned-like surface (a 20 cm plane meshed every 2 mm with 1 mm of noise across it,
//! as the stereo's), as a point and with footprints of 10, 15 and 20 mm
//! (`[sim.contact] footprint_radius_m`). Each iteration is 1000 queries 20 µm apart (a control
//! period each at 20 mm/s).
//!
//! Run: `cargo bench --bench contact`.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Vector3};
use std::hint::black_box;
use uvms::mesh::TriangleMesh;
use uvms::sim::contact::{Contact, ContactConfig};
use uvms::synth::random::{gaussian, stream};

fn rough_plane() -> TriangleMesh {
    let mut rng = stream(7, 0, 0);
    TriangleMesh::grid(101, 0.002, |_, _| 0.001 * gaussian(&mut rng))
}

fn bench(c: &mut Criterion) {
    let mesh = rough_plane();
    let mut group = c.benchmark_group("contact");
    for radius in [0.0, 0.01, 0.015, 0.02] {
        let cfg = ContactConfig {
            footprint_radius_m: radius,
            ..ContactConfig::default()
        };
        let mut contact = Contact::new(&mesh, &cfg).expect("contact");
        let v = Vector3::new(0.02, 0.0, 0.0);
        group.bench_function(format!("1000_queries_footprint_{}_mm", radius * 1e3), |b| {
            b.iter(|| {
                for k in 0..1000 {
                    let tip = Point3::new(-0.01 + 2e-5 * f64::from(k), 0.003, 0.006);
                    black_box(contact.evaluate(&tip, &v));
                }
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
