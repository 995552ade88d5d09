//! Per-call cost of the dynamics: RNEA, CRBA and forward dynamics of the 6-DOF arm (the
//! rigid PUMA 560 of the reference, as Pinocchio's figures: RNEA 1.05 µs, CRBA 0.55 µs, ABA
//! 2.3 µs on this machine class), the same underwater (added mass, strip drag, buoyancy), one
//! forward-dynamics evaluation of the whole floating system, and one RK4 plant step.
//!
//! `cargo bench --bench dynamics`

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use std::hint::black_box;
use std::path::Path;
use uvms::arm::{Arm, BaseMotion, JointVector};
use uvms::integrate::Integrator;
use uvms::model::{self, UvmsModel};
use uvms::multibody::{Inputs, Multibody, State};
use uvms::plant::{Plant, PlantInput};
use uvms::spatial_algebra::Force;

fn state() -> (JointVector, JointVector, JointVector) {
    (
        JointVector::new(0.3, 0.8, -2.2, 0.4, 0.9, -0.6),
        JointVector::new(0.5, -0.4, 0.6, 0.8, -0.7, 0.9),
        JointVector::new(1.0, -0.5, 0.8, -1.2, 0.9, 2.0),
    )
}

fn arm_benches(c: &mut Criterion) {
    let rtb = model::load(Some(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/models/puma560_rtb.toml"
    ))))
    .unwrap();
    let def = UvmsModel::default();
    let (q, qd, qdd) = state();
    for (name, m) in [("rigid", &rtb), ("underwater", &def)] {
        let arm = Arm::new(&m.arm, &m.environment).unwrap();
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        c.bench_function(&format!("arm_{name}/rnea"), |b| {
            b.iter(|| {
                black_box(&arm).inverse_dynamics(black_box(&q), black_box(&qd), black_box(&qdd), &base, None)
            })
        });
        c.bench_function(&format!("arm_{name}/crba"), |b| {
            b.iter(|| black_box(&arm).mass_matrix_rigid(black_box(&q)))
        });
        let tau = arm.inverse_dynamics(&q, &qd, &qdd, &base, None).tau;
        c.bench_function(&format!("arm_{name}/forward_dynamics"), |b| {
            b.iter(|| black_box(&arm).forward_dynamics(black_box(&q), black_box(&qd), black_box(&tau), &base))
        });
    }
    let fk_arm = Arm::new(&def.arm, &def.environment).unwrap();
    let target = fk_arm.t_base_tool(&q);
    c.bench_function("arm/fk", |b| {
        b.iter(|| black_box(&fk_arm).t_base_tool(black_box(&q)))
    });
    c.bench_function("arm/jacobian", |b| {
        b.iter(|| black_box(&fk_arm).jacobian(black_box(&q)))
    });
    c.bench_function("arm/ik_all_solutions", |b| {
        b.iter(|| black_box(&fk_arm).ik(black_box(&target), black_box(&q)))
    });
}

fn floating_benches(c: &mut Criterion) {
    let m = UvmsModel::default();
    let sys = Multibody::new(&m).unwrap();
    let (q, qd, _) = state();
    let s = State {
        t_world_body: Isometry3::from_parts(
            Vector3::new(1.0, -2.0, 5.0).into(),
            UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7),
        ),
        nu: Vector6::new(0.2, -0.1, 0.15, 0.1, -0.05, 0.2),
        q,
        qd,
    };
    let u = Inputs {
        tau_drive: JointVector::new(5.0, 60.0, 20.0, 1.0, 1.0, 0.5),
        body_wrench: Force::new(Vector3::new(10.0, 0.0, -20.0), Vector3::new(0.0, 5.0, 0.0)),
        f_env_on_tool: Force::new(Vector3::new(0.0, 0.0, 60.0), Vector3::zeros()),
    };
    c.bench_function("floating/forward_dynamics", |b| {
        b.iter(|| black_box(&sys).accelerations(black_box(&s), black_box(&u)))
    });
    c.bench_function("floating/mass_matrix", |b| {
        b.iter(|| black_box(&sys).mass_matrix(black_box(&s.q)))
    });
    let mut plant = Plant::new(&m, s, Integrator::Rk4).unwrap();
    let cmd = [0.0; 6];
    let input = PlantInput {
        tau_drive: u.tau_drive,
        thrust_cmd: &cmd,
        f_env_on_tool: u.f_env_on_tool,
    };
    c.bench_function("floating/plant_step_rk4", |b| {
        b.iter(|| {
            plant.state = s;
            black_box(plant.step(1e-3, black_box(&input)).unwrap())
        })
    });
}

criterion_group!(benches, arm_benches, floating_benches);
criterion_main!(benches);
