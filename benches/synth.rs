//! `uvms synth` timings: the full 1280 × 720 bottle scene (every pixel) and the default scene
//! (every 3rd pixel), end to end (scene composition + rendering).
//!
//! Run: `cargo bench --bench synth`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use uvms::synth::{SynthConfig, synthesize};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("synth");
    g.sample_size(10);
    for stride in [1, 3] {
        let mut cfg = SynthConfig {
            seed: 1,
            ..Default::default()
        };
        cfg.camera.pixel_stride = stride;
        g.bench_function(format!("bottle_1280x720_stride{stride}"), |b| {
            b.iter(|| black_box(synthesize(&cfg).unwrap().scan.len()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
