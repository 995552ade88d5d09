//! The whole floating system: the vehicle (a 6-DOF free body) carrying the six links.
//!
//! Generalised velocity `ζ = [ν; q̇]` (12): `ν = [v; ω]` the vehicle's velocity at the origin
//! of `C` in `C` axes (Fossen's body velocity), `q̇` the joint rates. Configuration: the pose
//! `t_world_body` (NED position, unit quaternion) and the joint angles `q`.
//!
//! ```text
//! H(q) ζ̇ + c(q, ζ, η) = [τ_body; τ_drive − τ_friction(q̇)]
//! ```
//!
//! - `H` by the composite-rigid-body algorithm with every body's `M_RB + M_A` (the added mass is
//!   in the solved mass matrix, never a lagged force: equations.md §2, gz-sim #1923), plus the
//!   rotor inertias `G² Jm` on the joint diagonal. `H` depends on `q` only (everything is in `C`).
//! - `c` by the recursive Newton–Euler algorithm with `ζ̇ = 0`: the vehicle's and the links'
//!   Coriolis terms (`V ×* M V`), drag on the velocity relative to the current, gravity and
//!   buoyancy, a changing current's push on the displaced water and the added mass (see
//!   [`crate::body`]), and the environment's wrench on the tool.
//! - `ζ̇` by Cholesky.
//!
//! The kinematic rates are `ṗ = R ν_1`, `q̇_uat = ½ q_uat ⊗ [0; ν_2]` and `q̇`. Units: SI;
//! frames: world `W` (NED), body `C`, arm base `0`, links `1..6`, tool `G` (DESIGN.md).

use crate::arm::dynamics::{LinkMotion, LinkTransforms};
use crate::arm::{Arm, BaseMotion, JointVector};
use crate::body::Body;
use crate::error::{Error, Result};
use crate::model::{N_JOINTS, UvmsModel};
use crate::spatial_algebra::{Force, Inertia, Motion, Xform, skew};
use crate::vehicle::hydro::vehicle_body;
use nalgebra::{Isometry3, Matrix3, Matrix6, Quaternion, SMatrix, SVector, UnitQuaternion, Vector3, Vector6};

/// Degrees of freedom of the floating system.
pub const NDOF: usize = 6 + N_JOINTS;
/// Generalised vectors `[ν; q̇]` and the like.
pub type GenVector = SVector<f64, NDOF>;
/// Generalised matrices (the mass matrix).
pub type GenMatrix = SMatrix<f64, NDOF, NDOF>;

/// The state of the floating system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Pose of the vehicle frame `C` in the world (NED), m.
    pub t_world_body: Isometry3<f64>,
    /// Vehicle velocity `[v; ω]` at `C`'s origin in `C` axes, m/s and rad/s.
    pub nu: Vector6<f64>,
    /// Joint angles, rad.
    pub q: JointVector,
    /// Joint rates, rad/s.
    pub qd: JointVector,
}

impl State {
    /// At rest at `t_world_body` with the arm at `q`.
    pub fn at_rest(t_world_body: Isometry3<f64>, q: JointVector) -> Self {
        State {
            t_world_body,
            nu: Vector6::zeros(),
            q,
            qd: JointVector::zeros(),
        }
    }

    /// `ζ = [ν; q̇]`.
    pub fn zeta(&self) -> GenVector {
        let mut z = GenVector::zeros();
        z.fixed_rows_mut::<6>(0).copy_from(&self.nu);
        z.fixed_rows_mut::<N_JOINTS>(6).copy_from(&self.qd);
        z
    }

    /// Whether every number is finite.
    pub fn is_finite(&self) -> bool {
        let t = &self.t_world_body;
        t.translation.vector.iter().all(|v| v.is_finite())
            && t.rotation.coords.iter().all(|v| v.is_finite())
            && self
                .nu
                .iter()
                .chain(self.q.iter())
                .chain(self.qd.iter())
                .all(|v| v.is_finite())
    }
}

/// Inputs held over an evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs {
    /// Drive torques on the link side, N·m (before friction and rotor inertia).
    pub tau_drive: JointVector,
    /// Wrench on the vehicle from its actuators (thrusters), `C` axes about `C`'s origin.
    pub body_wrench: Force,
    /// The environment's wrench on the tool: world (NED) axes, moment about the tool point.
    pub f_env_on_tool: Force,
}

/// Accelerations and the torques that go with them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accelerations {
    /// `ν̇`, m/s² and rad/s² (time derivative of `ν`'s components).
    pub nu_dot: Vector6<f64>,
    /// `q̈`, rad/s².
    pub qdd: JointVector,
    /// The torque at each joint's output shaft (what a one-axis joint-torque sensor reads, the
    /// paper's `M_dz`): `τ_drive − G² Jm q̈ − τ_friction`, N·m.
    pub shaft_torque: JointVector,
    /// The environment's wrench on the tool that goes with the accelerations (world axes,
    /// about the tool point): the input's, or in a linearly implicit step with [`ToolDamping`]
    /// the one at the step's end velocity to first order, `F − D h J ζ̇`.
    pub tool_force: Force,
}

/// The slope of a velocity-dependent force on the tool point, for a linearly implicit step
/// ([`Multibody::step_accelerations`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolDamping {
    /// `D ≈ −∂F/∂v`: the force's (world axes) slope against the tool point's velocity (world),
    /// N·s/m; symmetric (the contact's, [`crate::sim::contact::ContactState::damping`]).
    pub damping: Matrix3<f64>,
    /// `J = ∂v/∂ζ`: the tool point's velocity (world) per generalised velocity
    /// ([`Multibody::tool_point_jacobian`]).
    pub jacobian: SMatrix<f64, 3, NDOF>,
}

/// The floating vehicle–manipulator system built from a model.
#[derive(Debug, Clone)]
pub struct Multibody {
    /// The arm.
    pub arm: Arm,
    /// The vehicle as a body (at `C`'s origin).
    pub vehicle: Body,
    /// Gravity, m/s² along +z of the world.
    pub gravity: f64,
    /// Water velocity in the world, m/s.
    pub current: Vector3<f64>,
    /// The water's acceleration in the world (the rate of a changing current), m/s².
    pub current_rate: Vector3<f64>,
}

/// Everything one evaluation needs, computed once from the configuration.
struct Kinematics {
    xs: LinkTransforms,
    /// Gravity, the current and its rate in `C`.
    g_body: Vector3<f64>,
    c_body: Vector3<f64>,
    c_rate_body: Vector3<f64>,
}

impl Multibody {
    /// Builds the system of `model`.
    ///
    /// # Errors
    /// [`Error::Input`] if the model does not validate.
    pub fn new(model: &UvmsModel) -> Result<Self> {
        model.validate("model")?;
        let arm = Arm::new(&model.arm, &model.environment)?;
        Ok(Multibody {
            arm,
            vehicle: vehicle_body(&model.vehicle, &model.environment),
            gravity: model.environment.gravity,
            current: crate::model::vector3(&model.environment.current),
            current_rate: Vector3::zeros(),
        })
    }

    fn kinematics(&self, s: &State) -> Kinematics {
        let r_inv = s.t_world_body.rotation.inverse();
        Kinematics {
            xs: self.arm.transforms(&s.q),
            g_body: r_inv * Vector3::new(0.0, 0.0, self.gravity),
            c_body: r_inv * self.current,
            c_rate_body: r_inv * self.current_rate,
        }
    }

    /// The environment's tool wrench (world axes, about the tool point) in frame 6 about `o_6`.
    fn tool_wrench(&self, s: &State, xs: &LinkTransforms, f: &Force) -> Force {
        if f.lin == Vector3::zeros() && f.ang == Vector3::zeros() {
            return Force::ZERO;
        }
        let r_body_world = s
            .t_world_body
            .rotation
            .inverse()
            .to_rotation_matrix()
            .into_inner();
        let r_6_world =
            xs.x.iter()
                .fold(self.arm.mount().rot * r_body_world, |acc, x| x.rot * acc);
        self.arm
            .tool_wrench_in_flange(&(r_6_world * f.lin), &(r_6_world * f.ang))
    }

    /// Generalised forces `[wrench on the vehicle in C; joint torques of the links]` that give
    /// the accelerations `zeta_dot` at state `s` (no drive terms: no rotor inertia, no
    /// friction), with the environment pushing on the tool with `f_env_on_tool` (world axes,
    /// about the tool point). This is the RNEA of the whole system; with `zeta_dot = 0` it is
    /// the bias `c`.
    pub fn inverse_dynamics(&self, s: &State, zeta_dot: &GenVector, f_env_on_tool: &Force) -> GenVector {
        let k = self.kinematics(s);
        self.rnea(s, &k, zeta_dot, f_env_on_tool, None)
    }

    fn rnea(
        &self,
        s: &State,
        k: &Kinematics,
        zeta_dot: &GenVector,
        f_env_on_tool: &Force,
        motion: Option<&mut LinkMotion>,
    ) -> GenVector {
        let nu = Motion::from_vector6(&s.nu);
        let nu_dot = Motion::from_vector6(&zeta_dot.fixed_rows::<6>(0).into_owned());
        let base = BaseMotion {
            velocity: self.arm.mount().motion(&nu),
            acceleration: self.arm.mount().motion(&nu_dot),
            gravity: self.arm.mount().rot * k.g_body,
            current: self.arm.mount().rot * k.c_body,
            current_rate: self.arm.mount().rot * k.c_rate_body,
        };
        let f6 = self.tool_wrench(s, &k.xs, f_env_on_tool);
        let mut tau = JointVector::zeros();
        let qdd = zeta_dot.fixed_rows::<N_JOINTS>(6).into_owned();
        let f1 = self.arm.rnea(&k.xs, &s.qd, &qdd, &base, &f6, &mut tau, motion);
        let on_vehicle = self
            .vehicle
            .wrench(&nu, &nu_dot, &k.g_body, &k.c_body, &k.c_rate_body)
            + self.arm.mount().force_inv(&k.xs.x[0].force_inv(&f1));
        let mut out = GenVector::zeros();
        out.fixed_rows_mut::<6>(0).copy_from(&on_vehicle.to_vector6());
        out.fixed_rows_mut::<N_JOINTS>(6).copy_from(&tau);
        out
    }

    /// The mass matrix `H(q)` (12 × 12, symmetric positive definite), including added mass and
    /// the rotor inertias.
    pub fn mass_matrix(&self, q: &JointVector) -> GenMatrix {
        self.mass_matrix_from(&self.arm.transforms(q))
    }

    fn mass_matrix_from(&self, xs: &LinkTransforms) -> GenMatrix {
        let mut hqq = Matrix6::zeros();
        let mut cols = Matrix6::zeros();
        // The links' coupling and composite straight in `C`: the mount composed with `x[0]`.
        let root = self.arm.mount().then(&xs.x[0]);
        let arm_in_body = self.arm.crba(xs, &root, &mut hqq, &mut cols);
        let hvv: Inertia = self.vehicle.total + arm_in_body;
        let mut h = GenMatrix::zeros();
        h.fixed_view_mut::<6, 6>(0, 0).copy_from(&hvv.to_matrix6());
        h.fixed_view_mut::<6, 6>(0, 6).copy_from(&cols);
        h.fixed_view_mut::<6, 6>(6, 0).copy_from(&cols.transpose());
        for j in 0..N_JOINTS {
            hqq[(j, j)] += self.arm.links[j].armature;
        }
        h.fixed_view_mut::<6, 6>(6, 6).copy_from(&hqq);
        h
    }

    /// Forward dynamics: the accelerations at state `s` under `u`, with the plant's smoothed
    /// joint friction.
    ///
    /// # Errors
    /// [`Error::Failed`] (stage `dynamics`) if the mass matrix is not positive definite.
    pub fn accelerations(&self, s: &State, u: &Inputs) -> Result<Accelerations> {
        Ok(self.step_accelerations(s, u, 0.0, None)?.0)
    }

    /// The accelerations of one semi-implicit step of `h` seconds from `s`, and the explicit
    /// ones at `s` ([`Multibody::accelerations`]: what the state and the inputs give at that
    /// instant, what an instrument sampling the system there reads, not the step's average).
    ///
    /// In the step the joint friction is linearly implicit: the friction over the step is
    /// taken as `F(q̇) + φ D h q̈` (`D = ∂F/∂q̇`, the slope of the smoothed Coulomb and viscous
    /// friction), i.e. `(H + φ h D) ζ̇ = rhs`, exponentially fitted:
    /// `φ = (x / (1 − e^(−x)) − 1) / x` with `x = h D (H⁻¹)_jj`, so that a joint's rate decays
    /// over the step as the continuous system's does (`φ = 1`, plain implicit Euler, damps it
    /// 10 % too much on the PUMA's joints held near rest). The smoothed Coulomb friction is
    /// steep (`Tc/ε` N·m·s/rad); explicitly, a joint at rest under a load below the Coulomb
    /// level overshoots zero every step and its acceleration alternates in sign, implicitly it
    /// settles. `shaft_torque` holds the friction of the step, `F + φ D h q̈`.
    ///
    /// With `tool` the environment's force on the tool point is linearly implicit too: the
    /// force over the step taken as `F − D Δv` with `Δv = J h ζ̇`, i.e. `h Jᵀ D J` added to the
    /// system matrix (`D ≈ −∂F/∂v`, `J` the tool point's Jacobian, see [`ToolDamping`]). A stiff
    /// damper at the tool (the soil's resistance at low speed, tens of thousands of N·s/m) held
    /// over the step overshoots and makes the force alternate in sign every step; implicitly it
    /// settles. `tool_force` holds the force of the step, `F − D h J ζ̇`. `D` must be symmetric
    /// (Cholesky reads one triangle). `h = 0` gives the explicit accelerations twice.
    ///
    /// # Errors
    /// [`Error::Failed`] (stage `dynamics`) if `H` or the step's matrix is not positive
    /// definite.
    pub fn step_accelerations(
        &self,
        s: &State,
        u: &Inputs,
        h: f64,
        tool: Option<&ToolDamping>,
    ) -> Result<(Accelerations, Accelerations)> {
        let k = self.kinematics(s);
        let bias = self.rnea(s, &k, &GenVector::zeros(), &u.f_env_on_tool, None);
        let mut mass = self.mass_matrix_from(&k.xs);
        let eps = Some(self.arm.coulomb_smoothing);
        let (mut friction, mut slope) = (JointVector::zeros(), JointVector::zeros());
        for (j, link) in self.arm.links.iter().enumerate() {
            let (f, d) = link.friction(s.qd[j], eps);
            (friction[j], slope[j]) = (f, d * h);
        }
        let not_definite = || Error::failed("dynamics", "the mass matrix is not positive definite");
        // The explicit matrix's factor: the instant's accelerations, and each joint's effective
        // inertia on the floating system, `1 / (H⁻¹)_jj`.
        let explicit = if h != 0.0 {
            Some(Cholesky12::new(&mass).ok_or_else(not_definite)?)
        } else {
            None
        };
        if let Some(f) = &explicit {
            // Exponentially fitted: a joint's own friction slope decays its rate as `e^(−x)`
            // over the step, `x = h D (H⁻¹)_jj`; `H + φ h D` with
            // `φ = (x / (1 − e^(−x)) − 1) / x` (½ for a flat slope, → 1 for a steep one) moves
            // the rate by that decay's mean, where the plain implicit step (`φ = 1`) damps a
            // torque step on a joint held by the steep friction too much.
            for j in 0..N_JOINTS {
                let x = slope[j] * f.inverse_diagonal(6 + j);
                let phi = if x > 1e-6 {
                    (x / -(-x).exp_m1() - 1.0) / x
                } else {
                    0.5
                };
                slope[j] *= phi;
                mass[(6 + j, 6 + j)] += slope[j];
            }
        }
        let mut rhs = -bias;
        let body = u.body_wrench.to_vector6();
        for i in 0..6 {
            rhs[i] += body[i];
        }
        for j in 0..N_JOINTS {
            rhs[6 + j] += u.tau_drive[j] - friction[j];
        }
        // The tool's damper over the step: `D h J` (3 × 12) and `Jᵀ (D h J)` in the matrix, the
        // triangle `solve_spd` reads (row ≤ column) only: the rank-3 update of a symmetric matrix.
        let tool = tool
            .filter(|_| h != 0.0)
            .map(|t| (t, (t.damping * h) * t.jacobian));
        if let Some((t, dj)) = &tool {
            // Over the column-major storage (no index checks): `J`'s column `r` and `D h J`'s
            // column `c` give element `(r, c)`, `r ≤ c`.
            let j = &t.jacobian.data.0;
            for (c, (col, dj_c)) in mass.data.0.iter_mut().zip(&dj.data.0).enumerate() {
                for (m, j_r) in col[..=c].iter_mut().zip(j) {
                    *m += j_r[0] * dj_c[0] + j_r[1] * dj_c[1] + j_r[2] * dj_c[2];
                }
            }
        }
        // Without the tool's damper the step's matrix is the explicit one but for the joints'
        // diagonal: the vehicle's rows of the explicit factor are the step's.
        let zd = match (&explicit, &tool) {
            (Some(f), None) => f.with_diagonal_from(&mass, 6).map(|f| f.solve(&rhs)),
            _ => solve_spd(&mass, &rhs),
        }
        .ok_or_else(not_definite)?;
        let qdd: JointVector = zd.fixed_rows::<N_JOINTS>(6).into_owned();
        let tool_force = match &tool {
            Some((_, dj)) => u.f_env_on_tool - Force::new(dj * zd, Vector3::zeros()),
            None => u.f_env_on_tool,
        };
        let accelerations = |zd: &GenVector, friction: JointVector, tool_force: Force| {
            let qdd: JointVector = zd.fixed_rows::<N_JOINTS>(6).into_owned();
            Accelerations {
                nu_dot: zd.fixed_rows::<6>(0).into_owned(),
                qdd,
                shaft_torque: u.tau_drive - self.arm.armature().component_mul(&qdd) - friction,
                tool_force,
            }
        };
        let step = accelerations(&zd, friction + slope.component_mul(&qdd), tool_force);
        let at_instant = match &explicit {
            Some(f) => accelerations(&f.solve(&rhs), friction, u.f_env_on_tool),
            None => step,
        };
        Ok((step, at_instant))
    }

    /// Kinetic energy `½ ζᵀ H ζ` of the bodies, the water they carry (added mass) and the
    /// rotors, J.
    pub fn kinetic_energy(&self, s: &State) -> f64 {
        let z = s.zeta();
        0.5 * z.dot(&(self.mass_matrix(&s.q) * z))
    }

    /// Potential energy of gravity and buoyancy, J (zero at depth 0): `−g Σ (m z_g − ρ∇ z_b)`
    /// over the bodies, `z` the depth (NED) of each centre of gravity and of buoyancy.
    pub fn potential_energy(&self, s: &State) -> f64 {
        let mut e = 0.0;
        self.for_each_body_pose(s, |body, t_world_i| {
            let first_moment = t_world_i.rotation * body.net_first_moment;
            e -= self.gravity * (body.net_mass * t_world_i.translation.vector.z + first_moment.z);
        });
        e
    }

    /// Total spatial momentum of the bodies and their added water in the world frame: linear
    /// momentum (kg·m/s) and angular momentum about the world origin (kg·m²/s), summed body by
    /// body from the link velocities (not from `H`).
    pub fn momentum_world(&self, s: &State) -> Force {
        let k = self.kinematics(s);
        let mut lm = LinkMotion {
            v: [Motion::ZERO; N_JOINTS],
            a: [Motion::ZERO; N_JOINTS],
        };
        let nu = Motion::from_vector6(&s.nu);
        let base = BaseMotion {
            velocity: self.arm.mount().motion(&nu),
            ..Default::default()
        };
        let mut unused = JointVector::zeros();
        self.arm.rnea(
            &k.xs,
            &s.qd,
            &JointVector::zeros(),
            &base,
            &Force::ZERO,
            &mut unused,
            Some(&mut lm),
        );
        let x_world_body = Xform::from_pose(&s.t_world_body);
        let mut total = x_world_body.force_inv(&self.vehicle.total.mul(&nu));
        let mut x = x_world_body.then(self.arm.mount());
        for i in 0..N_JOINTS {
            x = x.then(&k.xs.x[i]);
            total += x.force_inv(&self.arm.links[i].body.total.mul(&lm.v[i]));
        }
        total
    }

    /// Calls `f` with each body (vehicle first, then links 1..6) and its pose in the world.
    fn for_each_body_pose(&self, s: &State, mut f: impl FnMut(&Body, &Isometry3<f64>)) {
        f(&self.vehicle, &s.t_world_body);
        let chain = self.arm.chain(&s.q);
        let t_world_base = s.t_world_body * self.arm.t_body_base();
        for i in 0..N_JOINTS {
            let t = t_world_base * crate::arm::kinematics::isometry(&chain.rot[i], &chain.pos[i]);
            f(&self.arm.links[i].body, &t);
        }
    }

    /// Pose of the tool frame `G` in the world.
    pub fn t_world_tool(&self, s: &State) -> Isometry3<f64> {
        s.t_world_body * self.arm.t_body_base() * self.arm.t_base_tool(&s.q)
    }

    /// Velocity of the tool point and angular velocity of the tool, world axes: `[v; ω]`.
    pub fn tool_velocity_world(&self, s: &State) -> Vector6<f64> {
        self.tool_kinematics(s).1
    }

    /// [`Multibody::t_world_tool`], [`Multibody::tool_velocity_world`] and the arm's Jacobian of
    /// the tool point at `s.q` (base frame, [`Arm::jacobian`]), from one forward kinematics.
    pub fn tool_kinematics(&self, s: &State) -> (Isometry3<f64>, Vector6<f64>, Matrix6<f64>) {
        let chain = self.arm.chain(&s.q);
        let t_base_tool = chain.t_base_flange() * self.arm.t_flange_tool;
        let t_body_tool = self.arm.t_body_base() * t_base_tool;
        // In C: the vehicle's motion carried to the tool point plus the arm's Jacobian.
        let p = t_body_tool.translation.vector;
        let w = Vector3::new(s.nu[3], s.nu[4], s.nu[5]);
        let v_vehicle = Vector3::new(s.nu[0], s.nu[1], s.nu[2]) + w.cross(&p);
        let jacobian = chain.jacobian_at(&self.arm.t_flange_tool.translation.vector);
        let j = jacobian * s.qd;
        let r_b0 = self.arm.t_body_base().rotation;
        let v = v_vehicle + r_b0 * Vector3::new(j[0], j[1], j[2]);
        let om = w + r_b0 * Vector3::new(j[3], j[4], j[5]);
        let r = s.t_world_body.rotation;
        let (v, om) = (r * v, r * om);
        (
            s.t_world_body * self.arm.t_body_base() * t_base_tool,
            Vector6::new(v.x, v.y, v.z, om.x, om.y, om.z),
            jacobian,
        )
    }

    /// `J = ∂v/∂ζ`: the velocity of the tool point (world axes) per generalised velocity, from
    /// the tool's pose `t_world_tool` at `s` and the arm's Jacobian of the tool point
    /// `arm_jacobian` (base frame), both as [`Multibody::tool_kinematics`] gives them:
    /// `v = R (ν_1 + ν_2 × p) + R_0 J_v q̇`.
    pub fn tool_point_jacobian(
        &self,
        s: &State,
        t_world_tool: &Isometry3<f64>,
        arm_jacobian: &Matrix6<f64>,
    ) -> SMatrix<f64, 3, NDOF> {
        let r = s.t_world_body.rotation.to_rotation_matrix().into_inner();
        let r_w0 = (s.t_world_body.rotation * self.arm.t_body_base().rotation)
            .to_rotation_matrix()
            .into_inner();
        // ω × p in world axes: −[p_w]× R ω_C, p_w the tool point from C's origin.
        let p_w = t_world_tool.translation.vector - s.t_world_body.translation.vector;
        let mut j = SMatrix::<f64, 3, NDOF>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&p_w) * r));
        j.fixed_view_mut::<3, N_JOINTS>(0, 6)
            .copy_from(&(r_w0 * arm_jacobian.fixed_rows::<3>(0)));
        j
    }

    /// The kinematic rates of the configuration: `ṗ = R ν_1` (world, `R` from the normalised
    /// `q`) and the quaternion rate `½ q ⊗ [0; ν_2]` (of `q` as given, normalised or not).
    pub fn pose_rate(q: &Quaternion<f64>, nu: &Vector6<f64>) -> (Vector3<f64>, Quaternion<f64>) {
        let v = Vector3::new(nu[0], nu[1], nu[2]);
        let w = Quaternion::new(0.0, nu[3], nu[4], nu[5]);
        (UnitQuaternion::from_quaternion(*q) * v, q * w * 0.5)
    }
}

/// Solves `H x = b` for a symmetric positive definite `H` by its Cholesky factor `H = L Lᵀ`
/// (computed in place from the lower triangle); `None` if `H` is not positive definite.
fn solve_spd(h: &GenMatrix, b: &GenVector) -> Option<GenVector> {
    Some(Cholesky12::new(h)?.solve(b))
}

/// The Cholesky factor `L` of a symmetric positive definite 12 × 12 matrix (read from its upper
/// triangle), with the reciprocals of its diagonal.
struct Cholesky12 {
    /// Row `r` of `L` in `l[r]` (below the diagonal and on it).
    l: [[f64; NDOF]; NDOF],
    inv: [f64; NDOF],
}

impl Cholesky12 {
    /// `None` if the matrix is not positive definite (or holds a NaN).
    fn new(h: &GenMatrix) -> Option<Self> {
        Self::factor(h, None)
    }

    /// The factor of `h`, which differs from `known`'s matrix only on the diagonal from row
    /// `from` on: the factor's rows before `from`, and the others' columns before `from`, read
    /// nothing that differs and are `known`'s; the rest is computed as [`Cholesky12::new`]
    /// computes it (the same numbers, for the work of the columns from `from` on).
    fn with_diagonal_from(&self, h: &GenMatrix, from: usize) -> Option<Self> {
        Self::factor(h, Some((self, from)))
    }

    /// The factor of `h`, row by row; with `known = (k, from)` the rows and columns before
    /// `from` are `k`'s ([`Cholesky12::with_diagonal_from`]).
    fn factor(h: &GenMatrix, known: Option<(&Cholesky12, usize)>) -> Option<Self> {
        const N: usize = NDOF;
        // Column-major storage of a symmetric matrix: `l[r]` is row `r` (and column `r`). With
        // the reciprocals of L's diagonal: one division per row instead of one per element.
        let mut f = Cholesky12 {
            l: h.data.0,
            inv: [0.0; N],
        };
        let from = match known {
            Some((k, from)) => {
                for (row, known_row) in f.l.iter_mut().zip(&k.l) {
                    row[..from].copy_from_slice(&known_row[..from]);
                }
                f.inv[..from].copy_from_slice(&k.inv[..from]);
                from
            }
            None => 0,
        };
        let Cholesky12 { l, inv } = &mut f;
        for j in from..N {
            let (done, rest) = l.split_at_mut(j);
            let row_j = &mut rest[0];
            for (k, row_k) in done.iter().enumerate().skip(from) {
                let mut s = row_j[k];
                for m in 0..k {
                    s -= row_j[m] * row_k[m];
                }
                row_j[k] = s * inv[k];
            }
            let d = row_j[j] - row_j[..j].iter().map(|v| v * v).sum::<f64>();
            // Not positive (or NaN): not positive definite.
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            row_j[j] = d.sqrt();
            inv[j] = 1.0 / row_j[j];
        }
        Some(f)
    }

    /// `x` with `H x = b`.
    fn solve(&self, b: &GenVector) -> GenVector {
        const N: usize = NDOF;
        let (l, inv) = (&self.l, &self.inv);
        let mut x = *b;
        for i in 0..N {
            let s = x[i] - (0..i).map(|k| l[i][k] * x[k]).sum::<f64>();
            x[i] = s * inv[i];
        }
        for i in (0..N).rev() {
            let s = x[i] - (i + 1..N).map(|k| l[k][i] * x[k]).sum::<f64>();
            x[i] = s * inv[i];
        }
        x
    }

    /// The diagonal element `(H⁻¹)_jj = ‖L⁻¹ e_j‖²` (forward substitution from row `j`).
    fn inverse_diagonal(&self, j: usize) -> f64 {
        let mut y = [0.0; NDOF];
        y[j] = self.inv[j];
        let mut sum = y[j] * y[j];
        for i in j + 1..NDOF {
            let s: f64 = (j..i).map(|k| self.l[i][k] * y[k]).sum();
            y[i] = -s * self.inv[i];
            sum += y[i] * y[i];
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::exp_twist;

    fn moving() -> State {
        State {
            t_world_body: Isometry3::from_parts(
                Vector3::new(0.5, 1.0, 3.0).into(),
                UnitQuaternion::from_euler_angles(0.2, -0.1, 1.0),
            ),
            nu: Vector6::new(0.3, -0.2, 0.1, 0.2, -0.1, 0.3),
            q: JointVector::new(0.2, 0.9, -2.0, 0.3, 0.8, -0.2),
            qd: JointVector::new(0.4, -0.3, 0.5, -0.6, 0.7, 0.8),
        }
    }

    #[test]
    fn tool_velocity_is_the_rate_of_the_tool_pose() {
        let m = UvmsModel::default();
        let sys = Multibody::new(&m).unwrap();
        let s = moving();
        let h = 1e-6;
        let moved = State {
            t_world_body: exp_twist(&s.t_world_body, &s.nu, h),
            q: s.q + s.qd * h,
            ..s
        };
        let (t0, t1) = (sys.t_world_tool(&s), sys.t_world_tool(&moved));
        let v = (t1.translation.vector - t0.translation.vector) / h;
        let w = (t1.rotation * t0.rotation.inverse()).scaled_axis() / h;
        let got = sys.tool_velocity_world(&s);
        assert!((got.fixed_rows::<3>(0) - v).norm() < 1e-5, "{got} vs {v}");
        assert!((got.fixed_rows::<3>(3) - w).norm() < 1e-5, "{got} vs {w}");
    }

    #[test]
    fn solve_spd_agrees_with_nalgebra_and_refuses_indefinite() {
        let sys = Multibody::new(&UvmsModel::default()).unwrap();
        let h = sys.mass_matrix(&JointVector::new(0.2, 0.9, -2.0, 0.3, 0.8, -0.2));
        let b = GenVector::from_fn(|i, _| (i as f64 * 0.7).sin() * 10.0);
        let x = solve_spd(&h, &b).unwrap();
        let want = h.cholesky().unwrap().solve(&b);
        assert!((x - want).norm() < 1e-12 * want.norm(), "{x} vs {want}");
        let mut bad = h;
        bad[(7, 7)] = -1.0;
        assert!(solve_spd(&bad, &b).is_none());
        // Refactorised with another joint diagonal: the same factor as afresh.
        let mut stiffer = h;
        for j in 6..NDOF {
            stiffer[(j, j)] += 0.3 * j as f64;
        }
        let (afresh, reused) = (
            Cholesky12::new(&stiffer).unwrap(),
            Cholesky12::new(&h)
                .unwrap()
                .with_diagonal_from(&stiffer, 6)
                .unwrap(),
        );
        assert_eq!((afresh.l, afresh.inv), (reused.l, reused.inv));
        assert!(Cholesky12::new(&h).unwrap().with_diagonal_from(&bad, 6).is_none());
    }

    #[test]
    fn tool_point_jacobian_gives_the_tool_velocity() {
        let sys = Multibody::new(&UvmsModel::default()).unwrap();
        let s = moving();
        let (t, v, arm_jacobian) = sys.tool_kinematics(&s);
        let j = sys.tool_point_jacobian(&s, &t, &arm_jacobian);
        assert!((j * s.zeta() - v.fixed_rows::<3>(0)).norm() < 1e-12);
    }

    #[test]
    fn implicit_tool_force_is_the_force_the_accelerations_answer() {
        // With a stiff damper at the tool (the soil's at rest) the accelerations of the linearly
        // implicit step are those of the dynamics with the tool force held at the step's
        // `F − D h J ζ̇` (which differs from `F`).
        let sys = Multibody::new(&UvmsModel::default()).unwrap();
        let s = moving();
        let (t, _, arm_jacobian) = sys.tool_kinematics(&s);
        let u = Inputs {
            tau_drive: JointVector::new(10.0, -40.0, 20.0, 3.0, -2.0, 1.0),
            body_wrench: Force::new(Vector3::new(30.0, 0.0, -10.0), Vector3::new(0.0, 5.0, 0.0)),
            f_env_on_tool: Force::new(Vector3::new(-60.0, 10.0, -40.0), Vector3::zeros()),
        };
        let n = Vector3::new(0.0, 0.0, -1.0);
        let d = (Matrix3::identity() - n * n.transpose()) * 35_000.0 + n * n.transpose() * 50.0;
        let tool = ToolDamping {
            damping: d,
            jacobian: sys.tool_point_jacobian(&s, &t, &arm_jacobian),
        };
        let a = sys.step_accelerations(&s, &u, 1e-3, Some(&tool)).unwrap().0;
        let dv =
            tool.jacobian * GenVector::from_fn(|i, _| if i < 6 { a.nu_dot[i] } else { a.qdd[i - 6] }) * 1e-3;
        assert!((a.tool_force.lin - (u.f_env_on_tool.lin - d * dv)).norm() < 1e-9);
        assert!((a.tool_force.lin - u.f_env_on_tool.lin).norm() > 1.0);
        let explicit = Inputs {
            f_env_on_tool: a.tool_force,
            ..u
        };
        let b = sys.step_accelerations(&s, &explicit, 1e-3, None).unwrap().0;
        assert!(
            (a.nu_dot - b.nu_dot).norm() < 1e-8 && (a.qdd - b.qdd).norm() < 1e-8,
            "{} {}",
            a.qdd,
            b.qdd
        );
        assert!((a.shaft_torque - b.shaft_torque).norm() < 1e-8);
    }

    #[test]
    fn mass_matrix_columns_are_the_whole_systems_rnea_with_unit_accelerations() {
        // The CRBA (in `C`) against the RNEA (body by body, in the link frames): at rest the
        // generalised force of a unit `ζ̇_k` less the bias is `H e_k` without the rotors.
        let sys = Multibody::new(&UvmsModel::default()).unwrap();
        for q in [
            JointVector::new(0.2, 0.9, -2.0, 0.3, 0.8, -0.2),
            JointVector::new(-1.1, 0.1, 0.7, -2.5, -1.3, 2.0),
        ] {
            let s = State::at_rest(moving().t_world_body, q);
            let h = sys.mass_matrix(&q);
            let bias = sys.inverse_dynamics(&s, &GenVector::zeros(), &Force::ZERO);
            for k in 0..NDOF {
                let col =
                    sys.inverse_dynamics(&s, &GenVector::from_fn(|i, _| f64::from(i == k)), &Force::ZERO)
                        - bias;
                let mut want = h.column(k).into_owned();
                if k >= 6 {
                    want[k] -= sys.arm.links[k - 6].armature;
                }
                assert!(
                    (col - want).norm() < 1e-12 * h.norm(),
                    "column {k}: {col} vs {want}"
                );
            }
        }
    }

    #[test]
    fn mass_matrix_is_symmetric_positive_definite_and_holds_the_added_mass() {
        let m = UvmsModel::default();
        let sys = Multibody::new(&m).unwrap();
        let q = JointVector::new(0.2, 0.9, -2.0, 0.3, 0.8, -0.2);
        let h = sys.mass_matrix(&q);
        assert!((h - h.transpose()).abs().max() < 1e-12);
        assert!(h.symmetric_eigenvalues().min() > 0.0);
        // Heave: vehicle + links + the vehicle's heave added mass (≈ 2 m) and the links'.
        let mut dry = m.clone();
        dry.environment.water_density = 0.0; // no link added mass
        dry.vehicle.added_mass = [[0.0; 6]; 6];
        let h_dry = Multibody::new(&dry).unwrap().mass_matrix(&q);
        let extra = h[(2, 2)] - h_dry[(2, 2)];
        assert!(
            extra > m.vehicle.added_mass[2][2] && extra < m.vehicle.added_mass[2][2] + 30.0,
            "{extra}"
        );
        assert!(
            (h_dry[(0, 0)] - (m.vehicle.mass + m.arm.links.iter().map(|l| l.mass).sum::<f64>())).abs() < 1e-9
        );
    }
}
