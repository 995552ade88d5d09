//! Profiling driver for the perception stages on the benchmark's inputs (the parameters of
//! `benches/perception.rs`), for instruction counts under callgrind:
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/prof_perception MODE N
//! SCENE` (add `--toggle-collect='uvms::register::register'` for one function's share), with MODE
//! `register` (index, registration of the selected object with its normals), `check`, `clean` or
//! `normals`; N repetitions; SCENE `milk` (needs `UVMS_REAL_DATA`) or `bottle`.

#[path = "../benches/common/perception_inputs.rs"]
mod inputs;

use uvms::cloud::normals::estimate_normals;
use uvms::perception::{CheckOptions, check, clean};

fn main() {
    // The main thread is one of rayon's workers, so that callgrind's `--toggle-collect` on a
    // function follows its parallel work too (with `RAYON_NUM_THREADS=1`, all of it).
    rayon::ThreadPoolBuilder::new()
        .use_current_thread()
        .build_global()
        .expect("rayon pool");
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("register", String::as_str);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let scene = args.get(3).map_or("milk", String::as_str);
    let cfg = inputs::config();
    let input = inputs::load(scene, &cfg);
    let opts = CheckOptions {
        truth: Some(input.truth),
        ..CheckOptions::default()
    };
    let r = check(&input.scan, &input.model, &opts, &cfg).expect("check");
    let truth = r.truth.as_ref().expect("truth");
    eprintln!(
        "{}: object {} points, error {:.4}° {:.4} mm, ADD-S {:.4} mm, {} ICP iterations",
        input.name,
        r.object.len(),
        truth.rotation_error_deg,
        1e3 * truth.translation_error_m,
        1e3 * truth.add_s_m,
        r.registration.iterations
    );
    let object = r.object.points.clone();
    let camera = cfg.view.camera();
    for _ in 0..n {
        match mode {
            "register" => {
                std::hint::black_box(inputs::register_object(&input, &object, &cfg));
            }
            "normals" => {
                std::hint::black_box(estimate_normals(&object, &cfg.normals, &camera).unwrap());
            }
            "clean" => {
                std::hint::black_box(clean(&input.scan, &cfg.clean, &camera).unwrap());
            }
            _ => {
                std::hint::black_box(
                    check(&input.scan, &input.model, &CheckOptions::default(), &cfg).unwrap(),
                );
            }
        }
    }
}
