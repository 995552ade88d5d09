//! Per-call cost of the dynamics: RNEA, CRBA and forward dynamics of the 6-DOF arm (the
//! rigid PUMA 560 of the reference, as Pinocchio's figures: RNEA 1.05 µs, CRBA 0.55 µs, ABA
//! 2.3 µs on this machine class), the same underwater (added mass, strip drag, buoyancy), one
//! forward-dynamics evaluation of the whole floating system, FK/Jacobian/IK (all solutions, and
//! the nearest alone) and one plant step (RK4 and semi-implicit Euler). After criterion's report,
//! a table of the *minimum* time per call over 200 batches, which stays stable on a shared,
//! loaded machine where criterion's means do not.
//!
//! `cargo bench --bench dynamics`

use criterion::Criterion;
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;
use uvms::arm::{Arm, BaseMotion, JointVector};
use uvms::integrate::Integrator;
use uvms::model::{self, UvmsModel};
use uvms::multibody::{Inputs, State};
use uvms::plant::{Plant, PlantInput};
use uvms::spatial_algebra::Force;

/// One timed call: its name and the closure.
type Case<'a> = (String, Box<dyn FnMut() + 'a>);

fn joint_state() -> (JointVector, JointVector, JointVector) {
    (
        JointVector::new(0.3, 0.8, -2.2, 0.4, 0.9, -0.6),
        JointVector::new(0.5, -0.4, 0.6, 0.8, -0.7, 0.9),
        JointVector::new(1.0, -0.5, 0.8, -1.2, 0.9, 2.0),
    )
}

/// Every timed call, built on the models it needs.
fn cases<'a>(rtb: &'a UvmsModel, def: &'a UvmsModel, plants: &'a mut [Plant]) -> Vec<Case<'a>> {
    let (q, qd, qdd) = joint_state();
    let mut out: Vec<Case> = Vec::new();
    for (name, m) in [("arm_rigid", rtb), ("arm_underwater", def)] {
        let arm = Arm::new(&m.arm, &m.environment).unwrap();
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        let tau = arm.inverse_dynamics(&q, &qd, &qdd, &base, None).tau;
        let a = arm.clone();
        out.push((
            format!("{name}/rnea"),
            Box::new(move || {
                black_box(black_box(&a).inverse_dynamics(black_box(&q), &qd, &qdd, &base, None));
            }),
        ));
        let a = arm.clone();
        out.push((
            format!("{name}/crba"),
            Box::new(move || {
                black_box(black_box(&a).mass_matrix_rigid(black_box(&q)));
            }),
        ));
        out.push((
            format!("{name}/forward_dynamics"),
            Box::new(move || {
                black_box(black_box(&arm).forward_dynamics(black_box(&q), &qd, &tau, &base));
            }),
        ));
    }
    let arm = Arm::new(&def.arm, &def.environment).unwrap();
    let target = arm.t_base_tool(&q);
    let (a1, a2) = (arm.clone(), arm.clone());
    out.push((
        "arm/fk".into(),
        Box::new(move || {
            black_box(black_box(&a1).t_base_tool(black_box(&q)));
        }),
    ));
    out.push((
        "arm/jacobian".into(),
        Box::new(move || {
            black_box(black_box(&a2).jacobian(black_box(&q)));
        }),
    ));
    let a3 = arm.clone();
    out.push((
        "arm/ik_all_solutions".into(),
        Box::new(move || {
            black_box(black_box(&arm).ik(black_box(&target), black_box(&q)).ok());
        }),
    ));
    out.push((
        "arm/ik_nearest".into(),
        Box::new(move || {
            black_box(black_box(&a3).ik_nearest(black_box(&target), black_box(&q)).ok());
        }),
    ));
    let sys = plants[0].system.clone();
    let s = plants[0].state;
    let u = Inputs {
        tau_drive: JointVector::new(5.0, 60.0, 20.0, 1.0, 1.0, 0.5),
        body_wrench: Force::new(Vector3::new(10.0, 0.0, -20.0), Vector3::new(0.0, 5.0, 0.0)),
        f_env_on_tool: Force::new(Vector3::new(0.0, 0.0, 60.0), Vector3::zeros()),
    };
    out.push((
        "floating/forward_dynamics".into(),
        Box::new(move || {
            black_box(black_box(&sys).accelerations(black_box(&s), black_box(&u)).ok());
        }),
    ));
    for plant in plants {
        let name = match plant.integrator {
            Integrator::Rk4 => "floating/plant_step_rk4",
            Integrator::SemiImplicitEuler => "floating/plant_step_semi_implicit",
        };
        out.push((
            name.into(),
            Box::new(move || {
                plant.state = s;
                let input = PlantInput {
                    tau_drive: u.tau_drive,
                    thrust_cmd: &[0.0; 6],
                    f_env_on_tool: u.f_env_on_tool,
                };
                black_box(plant.step(1e-3, black_box(&input)).ok());
            }),
        ));
    }
    out
}

/// The fastest of 200 batches of 2000 calls, ns per call.
fn min_ns(f: &mut dyn FnMut()) -> f64 {
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

fn main() {
    let rtb = model::load(Some(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/models/puma560_rtb.toml"
    ))))
    .unwrap();
    let def = UvmsModel::default();
    let (q, qd, _) = joint_state();
    let s = State {
        t_world_body: Isometry3::from_parts(
            Vector3::new(1.0, -2.0, 5.0).into(),
            UnitQuaternion::from_euler_angles(0.1, -0.05, 0.7),
        ),
        nu: Vector6::new(0.2, -0.1, 0.15, 0.1, -0.05, 0.2),
        q,
        qd,
    };
    let mut plants =
        [Integrator::Rk4, Integrator::SemiImplicitEuler].map(|i| Plant::new(&def, s, i).unwrap());
    let mut criterion = Criterion::default().configure_from_args();
    let mut all = cases(&rtb, &def, &mut plants);
    for (name, f) in &mut all {
        criterion.bench_function(name, |b| b.iter(&mut *f));
    }
    criterion.final_summary();
    println!("\nminimum time per call (200 batches of 2000 calls)");
    for (name, f) in &mut all {
        println!("{name:<34} {:>9.0} ns", min_ns(f.as_mut()));
    }
}
