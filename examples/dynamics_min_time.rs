//! Minimum per-call time of the dynamics over many repetitions: a figure that stays stable on
//! a shared, loaded machine (criterion's means do not). Complements `benches/dynamics.rs`.
//!
//! `cargo run --release --example dynamics_min_time`

use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;
use uvms::arm::{Arm, BaseMotion, JointVector};
use uvms::model::{self, UvmsModel};
use uvms::multibody::{Inputs, Multibody, State};

/// The fastest of 200 batches of 2000 calls, ns per call.
fn min_ns(mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..200 {
        let t = Instant::now();
        for _ in 0..2000 {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / 2000.0);
    }
    best * 1e9
}

fn main() -> uvms::Result<()> {
    let rtb = model::load(Some(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/models/puma560_rtb.toml"
    ))))?;
    let def = UvmsModel::default();
    let q = JointVector::new(0.3, 0.8, -2.2, 0.4, 0.9, -0.6);
    let qd = JointVector::new(0.5, -0.4, 0.6, 0.8, -0.7, 0.9);
    let qdd = JointVector::new(1.0, -0.5, 0.8, -1.2, 0.9, 2.0);
    println!("{:<36} {:>8}", "call", "min ns");
    for (name, m) in [("rigid PUMA 560", &rtb), ("underwater PUMA 560", &def)] {
        let arm = Arm::new(&m.arm, &m.environment)?;
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        let tau = arm.inverse_dynamics(&q, &qd, &qdd, &base, None).tau;
        let rnea = min_ns(|| {
            black_box(black_box(&arm).inverse_dynamics(black_box(&q), &qd, &qdd, &base, None));
        });
        let crba = min_ns(|| {
            black_box(black_box(&arm).mass_matrix_rigid(black_box(&q)));
        });
        let fd = min_ns(|| {
            black_box(black_box(&arm).forward_dynamics(black_box(&q), &qd, &tau, &base));
        });
        println!(
            "{:<36} {rnea:>8.0}\n{:<36} {crba:>8.0}\n{:<36} {fd:>8.0}",
            format!("{name}: RNEA"),
            format!("{name}: CRBA"),
            format!("{name}: forward dynamics")
        );
    }
    let sys = Multibody::new(&def)?;
    let s = State {
        t_world_body: Isometry3::from_parts(
            Vector3::new(1.0, -2.0, 5.0).into(),
            UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7),
        ),
        nu: Vector6::new(0.2, -0.1, 0.15, 0.1, -0.05, 0.2),
        q,
        qd,
    };
    let u = Inputs::default();
    let fd = min_ns(|| {
        black_box(black_box(&sys).accelerations(black_box(&s), &u).ok());
    });
    println!("{:<36} {fd:>8.0}", "floating system: forward dynamics");
    Ok(())
}
