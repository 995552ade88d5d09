//! The main job end to end: `uvms run pipelines/bottle_cleaning.toml` (the scan in `data/` →
//! segment → check → plan a ring → hover point → 36 s of the contact operation at a 1 kHz
//! control rate), on one core. Criterion times the whole run; each run's simulated seconds per
//! wall-clock second of the simulation alone (`realtime_factor` of the summary) is printed.
//!
//! Run: `cargo bench --bench sim`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::path::Path;
use uvms::cli::Ctx;
use uvms::cli::run::{RunArgs, run};

fn bench(c: &mut Criterion) {
    let pipeline = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/bottle_cleaning.toml");
    let dir = tempfile::tempdir().expect("temporary directory");
    let ctx = Ctx {
        json: true,
        quiet: true,
    };
    let mut n = 0;
    let mut group = c.benchmark_group("sim");
    group.sample_size(10);
    group.bench_function("bottle_cleaning_run", |b| {
        b.iter(|| {
            n += 1;
            let args = RunArgs {
                pipeline: pipeline.clone(),
                out: Some(dir.path().join(n.to_string())),
            };
            let report = run(&args, &ctx).expect("uvms run");
            let sim = &report.summary["sim"];
            eprintln!(
                "simulated {:.1} s at {:.1}× real time",
                sim["simulated_s"].as_f64().unwrap_or(f64::NAN),
                sim["realtime_factor"].as_f64().unwrap_or(f64::NAN)
            );
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
