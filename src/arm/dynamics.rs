//! Arm dynamics in spatial-vector form (Featherstone, *RBDA* 2008, ch. 5–6), with the water.
//!
//! - [`Arm::inverse_dynamics`]: the recursive Newton–Euler algorithm (RNEA). Forward pass for
//!   `i = 1..6`: `V_i = X_i V_{i−1} + S_i q̇_i`, `A_i = X_i A_{i−1} + S_i q̈_i + V_i × S_i q̇_i`;
//!   each link's wrench from [`crate::body::Body::wrench`] (rigid inertia, added mass, drag on
//!   the velocity relative to the current, gravity, buoyancy); backward pass
//!   `F_{i−1} += X_iᵀ F_i`, `τ_i = S_iᵀ F_i`. The base may move (`V_0, A_0` of the vehicle), and
//!   the wrench the arm exerts on its base comes out (`−X_1ᵀ F_1`).
//! - [`Arm::velocity_terms`] and [`Arm::inverse_dynamics_split`]: the same RNEA in two parts, the
//!   wrenches being affine in the accelerations. The first pass takes the links' velocities,
//!   their velocity-product accelerations `C_i = X_i C_{i−1} + V_i × S_i q̇_i` (`C_0 = 0`) and each
//!   link's wrench for them (with drag, gravity, buoyancy); each call of the second adds
//!   `I_i A'_i`, `A'_i = X_i A'_{i−1} + S_i q̈_i` (`A'_0 = A_0`; `I_i` rigid + added), and runs the
//!   backward pass. The ICU and the joint controllers take their inverse dynamics at the same
//!   measured state with different accelerations: they share the first pass.
//! - [`Arm::mass_matrix`]: the composite-rigid-body algorithm (CRBA) with each link's
//!   `M_RB + M_A`; the rotor inertias `G² Jm` are added on the diagonal.
//! - [`Arm::forward_dynamics`]: `H q̈ = τ − c(q, q̇)` solved by Cholesky.
//!
//! The joint axis is constant in the link's own frame (see [`super::Link::axis`]), so the
//! velocity-product term is `V_i × S_i q̇_i`. Drive model on the link side (Robotics Toolbox):
//! `τ = τ_rigid + G² Jm q̈ + |G|(|G| B q̇ + Tc_sel)`. Units: SI, frames: link frames, base 0.

use super::kinematics::Chain;
use super::{Arm, JointVector};
use crate::model::N_JOINTS;
use crate::spatial_algebra::{Force, Inertia, Motion, Xform};
use nalgebra::{Cholesky, Matrix3, Matrix6, UnitQuaternion, Vector3, Vector6};

/// Motion of the arm's base frame 0 and of the water around it, in base-frame coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BaseMotion {
    /// Spatial velocity of frame 0 (`[v; ω]` at its origin), m/s and rad/s.
    pub velocity: Motion,
    /// Spatial acceleration of frame 0 (the time derivative of `velocity`'s components), m/s²
    /// and rad/s².
    pub acceleration: Motion,
    /// Gravity vector, m/s².
    pub gravity: Vector3<f64>,
    /// Water velocity, m/s.
    pub current: Vector3<f64>,
    /// The water's acceleration (the world's rate of the current), m/s².
    pub current_rate: Vector3<f64>,
}

impl BaseMotion {
    /// A base at rest in still water with gravity `gravity` (m/s², base frame).
    pub fn fixed(gravity: Vector3<f64>) -> Self {
        BaseMotion {
            gravity,
            ..Default::default()
        }
    }

    /// The base of `arm` mounted on a vehicle with attitude `r_world_body`, velocity `nu` and
    /// acceleration `nu_dot` (`[v; ω]` at `C`'s origin, `C` axes), in a world with gravity `g`
    /// (m/s², along +z of NED) and water velocity `current_world` (m/s, NED).
    pub fn on_vehicle(
        arm: &Arm,
        r_world_body: &UnitQuaternion<f64>,
        nu: &Vector6<f64>,
        nu_dot: &Vector6<f64>,
        g: f64,
        current_world: &Vector3<f64>,
    ) -> Self {
        BaseMotion {
            velocity: arm.mount().motion(&Motion::from_vector6(nu)),
            acceleration: arm.mount().motion(&Motion::from_vector6(nu_dot)),
            gravity: world_to_base(arm, r_world_body, &Vector3::new(0.0, 0.0, g)),
            current: world_to_base(arm, r_world_body, current_world),
            current_rate: Vector3::zeros(),
        }
    }

    /// This base in water accelerating at `rate_world` (m/s², NED), the vehicle at attitude
    /// `r_world_body`.
    pub fn with_current_rate(
        self,
        arm: &Arm,
        r_world_body: &UnitQuaternion<f64>,
        rate_world: &Vector3<f64>,
    ) -> Self {
        BaseMotion {
            current_rate: world_to_base(arm, r_world_body, rate_world),
            ..self
        }
    }
}

/// A world vector in the base frame of `arm` on a vehicle at attitude `r_world_body`.
fn world_to_base(arm: &Arm, r_world_body: &UnitQuaternion<f64>, w: &Vector3<f64>) -> Vector3<f64> {
    arm.mount().rot * (r_world_body.inverse() * w)
}

/// The result of the inverse dynamics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InverseDynamics {
    /// Drive torques on the link side including rotor inertia and friction, N·m.
    pub tau: JointVector,
    /// Torques of the links' dynamics alone (bodies and water; no drives), N·m.
    pub tau_rigid: JointVector,
    /// The wrench the arm exerts on its base (the vehicle), base frame, about the base origin.
    pub wrench_on_base: Force,
}

/// The link transforms of a configuration: `x[i]` maps frame `i` (0-based: base = frame 0 for
/// `x[0]`) into frame `i + 1`.
#[derive(Debug, Clone, Copy)]
pub struct LinkTransforms {
    /// `ⁱ⁺¹X_i`.
    pub x: [Xform; N_JOINTS],
}

/// The acceleration-free part of the inverse dynamics at one state ([`Arm::velocity_terms`]).
#[derive(Debug, Clone, Copy)]
pub struct VelocityTerms {
    /// The joint angles, rad.
    pub q: JointVector,
    /// The joint rates, rad/s.
    pub qd: JointVector,
    xs: LinkTransforms,
    /// The link frames in the base frame.
    chain: Chain,
    /// Each link's wrench at zero joint and base accelerations (link frames).
    forces: [Force; N_JOINTS],
    /// The drives' friction at `qd` (exact sign rule), N·m.
    friction: JointVector,
}

impl VelocityTerms {
    /// The link frames at `q` in the base frame.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }
}

/// Velocities and accelerations of the links from a forward pass (link frames).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinkMotion {
    pub v: [Motion; N_JOINTS],
    pub a: [Motion; N_JOINTS],
}

impl Arm {
    /// The link transforms at `q`.
    #[inline]
    pub fn transforms(&self, q: &JointVector) -> LinkTransforms {
        LinkTransforms {
            x: std::array::from_fn(|i| self.links[i].xform(q[i])),
        }
    }

    /// Inverse dynamics: the torques that give `q̈` at `(q, q̇)` with the base moving as `base`
    /// and the environment pushing on the tool with `f_env_on_tool` (base-frame axes, moment
    /// about the tool point; `None` for free motion). Coulomb friction by the exact sign rule.
    pub fn inverse_dynamics(
        &self,
        q: &JointVector,
        qd: &JointVector,
        qdd: &JointVector,
        base: &BaseMotion,
        f_env_on_tool: Option<&Force>,
    ) -> InverseDynamics {
        let xs = self.transforms(q);
        let mut forces = [Force::ZERO; N_JOINTS];
        self.forward(&xs, qd, qdd, base, &mut forces, None);
        let f6 = self.flange_wrench(&xs, f_env_on_tool);
        self.finish(&xs, forces, f6, qdd, self.friction(qd, None))
    }

    /// The part of the inverse dynamics that does not depend on the accelerations, at `(q, q̇)`
    /// with the base moving at `base.velocity` in gravity `base.gravity` and the current
    /// `base.current` (`base.acceleration` is not used): the link transforms, the links'
    /// velocities, and each link's wrench for its velocity-product acceleration with its
    /// velocity-dependent terms, gravity and buoyancy, and the push of the water's acceleration
    /// `base.current_rate`. [`Arm::inverse_dynamics_split`] adds the
    /// accelerations' part; several of them at one state share this.
    pub fn velocity_terms(&self, q: &JointVector, qd: &JointVector, base: &BaseMotion) -> VelocityTerms {
        let xs = self.transforms(q);
        let mut forces = [Force::ZERO; N_JOINTS];
        let unaccelerated = BaseMotion {
            acceleration: Motion::ZERO,
            ..*base
        };
        self.forward(&xs, qd, &JointVector::zeros(), &unaccelerated, &mut forces, None);
        VelocityTerms {
            q: *q,
            qd: *qd,
            chain: Self::chain_of(&xs),
            xs,
            forces,
            friction: self.friction(qd, None),
        }
    }

    /// [`Arm::inverse_dynamics`] at the state of `vt` for the joint accelerations `qdd` and the
    /// base's acceleration `base_acceleration`: the accelerations' part added to `vt`'s (equal up
    /// to round-off; the wrench is affine in the accelerations).
    pub fn inverse_dynamics_split(
        &self,
        vt: &VelocityTerms,
        qdd: &JointVector,
        base_acceleration: &Motion,
        f_env_on_tool: Option<&Force>,
    ) -> InverseDynamics {
        let mut forces = vt.forces;
        let mut a = *base_acceleration;
        for i in 0..N_JOINTS {
            let link = &self.links[i];
            a = vt.xs.x[i].motion(&a) + link.axis() * qdd[i];
            forces[i] += link.body.total.mul(&a);
        }
        let f6 = self.flange_wrench(&vt.xs, f_env_on_tool);
        self.finish(&vt.xs, forces, f6, qdd, vt.friction)
    }

    /// [`Arm::inverse_dynamics_split`] of free motion, and the wrench on the base that the same
    /// motion gives with the environment's wrench `f_env_on_tool` on the tool (base-frame axes,
    /// moment about the tool point): what `inverse_dynamics_split` with it returns as
    /// `wrench_on_base`. The tool wrench enters the base wrench linearly, carried through the
    /// static arm to the base origin: its moment there is `n + p × f`, `p` the tool point in the
    /// base frame (equal up to round-off).
    pub fn inverse_dynamics_loaded(
        &self,
        vt: &VelocityTerms,
        qdd: &JointVector,
        base_acceleration: &Motion,
        f_env_on_tool: &Force,
    ) -> (InverseDynamics, Force) {
        let free = self.inverse_dynamics_split(vt, qdd, base_acceleration, None);
        let p = self.tool_point(&vt.chain);
        let f = f_env_on_tool;
        (
            free,
            free.wrench_on_base + Force::new(f.lin, f.ang + p.cross(&f.lin)),
        )
    }

    /// The inverse dynamics from the links' wrenches `forces` of the forward pass, with the
    /// environment's wrench `f6` on link 6 (frame 6, about its origin), the joint accelerations
    /// `qdd` and the drives' friction `friction`: the backward pass and the drive torques.
    fn finish(
        &self,
        xs: &LinkTransforms,
        forces: [Force; N_JOINTS],
        f6: Force,
        qdd: &JointVector,
        friction: JointVector,
    ) -> InverseDynamics {
        let mut tau_rigid = JointVector::zeros();
        let f1 = self.backward(xs, forces, f6, &mut tau_rigid);
        InverseDynamics {
            tau: tau_rigid + self.armature().component_mul(qdd) + friction,
            tau_rigid,
            wrench_on_base: -xs.x[0].force_inv(&f1),
        }
    }

    /// A wrench on the tool (base-frame axes, moment about the tool point; `None`: none) in
    /// frame 6 about its origin, at the link transforms `xs`.
    fn flange_wrench(&self, xs: &LinkTransforms, f: Option<&Force>) -> Force {
        let Some(f) = f else {
            return Force::ZERO;
        };
        let r60 = xs.x.iter().fold(Matrix3::identity(), |acc, x| x.rot * acc);
        self.tool_wrench_in_flange(&(r60 * f.lin), &(r60 * f.ang))
    }

    /// A wrench on the tool (frame-6 axes, moment about the tool point) as a wrench about the
    /// origin of frame 6.
    #[inline]
    pub(crate) fn tool_wrench_in_flange(&self, f: &Vector3<f64>, n: &Vector3<f64>) -> Force {
        Force::new(*f, n + self.t_flange_tool.translation.vector.cross(f))
    }

    /// The RNEA core: joint torques of the links' dynamics into `tau`, returns `F_1` (the wrench
    /// transmitted from the base to link 1, link-1 frame). `f6` is the environment's wrench on
    /// link 6 (frame 6, about its origin). With `motion` the forward pass's link motions are kept.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn rnea(
        &self,
        xs: &LinkTransforms,
        qd: &JointVector,
        qdd: &JointVector,
        base: &BaseMotion,
        f6: &Force,
        tau: &mut JointVector,
        motion: Option<&mut LinkMotion>,
    ) -> Force {
        let mut forces = [Force::ZERO; N_JOINTS];
        self.forward(xs, qd, qdd, base, &mut forces, motion);
        self.backward(xs, forces, *f6, tau)
    }

    /// The RNEA's forward pass: each link's wrench (link frame) into `forces`. With `motion` the
    /// link motions are kept.
    #[inline]
    fn forward(
        &self,
        xs: &LinkTransforms,
        qd: &JointVector,
        qdd: &JointVector,
        base: &BaseMotion,
        forces: &mut [Force; N_JOINTS],
        mut motion: Option<&mut LinkMotion>,
    ) {
        let (mut v, mut a) = (base.velocity, base.acceleration);
        let (mut g, mut c, mut c_rate) = (base.gravity, base.current, base.current_rate);
        let changing = c_rate != Vector3::zeros();
        for i in 0..N_JOINTS {
            let link = &self.links[i];
            let x = &xs.x[i];
            let vj = link.axis() * qd[i];
            v = x.motion(&v) + vj;
            a = x.motion(&a) + link.axis() * qdd[i] + v.cross(&vj);
            g = x.rot * g;
            c = x.rot * c;
            if changing {
                c_rate = x.rot * c_rate;
            }
            forces[i] = link.body.wrench(&v, &a, &g, &c, &c_rate);
            if let Some(m) = motion.as_deref_mut() {
                m.v[i] = v;
                m.a[i] = a;
            }
        }
    }

    /// The RNEA's backward pass: the links' wrenches `forces` (link frames) with the
    /// environment's wrench `f6` on link 6 taken off, carried down the chain; the joint torques
    /// into `tau`, returns `F_1`.
    #[inline]
    fn backward(
        &self,
        xs: &LinkTransforms,
        mut forces: [Force; N_JOINTS],
        f6: Force,
        tau: &mut JointVector,
    ) -> Force {
        forces[N_JOINTS - 1] -= f6;
        for i in (0..N_JOINTS).rev() {
            tau[i] = self.links[i].axis().dot(&forces[i]);
            if i > 0 {
                let up = xs.x[i].force_inv(&forces[i]);
                forces[i - 1] += up;
            }
        }
        forces[0]
    }

    /// The composite-rigid-body algorithm: the joint-space mass matrix of the links (rigid +
    /// added mass, no rotor inertia) into `h`, and their coupling with the base in the frame
    /// `root` maps into frame 1 (`xs.x[0]` for the base frame 0 itself, or the vehicle's mount
    /// composed with it): `base_cols` column `j` is the wrench that a unit `q̈_j` needs there,
    /// and the returned inertia is the composite of all links there.
    ///
    /// Everything in that one frame: each link's inertia and joint axis are carried there once
    /// (six inertia transforms, as many as the recursion in the link frames needs), the
    /// composites are then plain sums, and a column's wrench `Ic_j S_j` is already the base's,
    /// where the link-frame form carries it down the chain joint by joint
    /// (`H_ij = S_iᵀ Ic_j S_j` for `i ≤ j`, Featherstone *RBDA* §6.2, in any one frame).
    #[inline]
    pub(crate) fn crba(
        &self,
        xs: &LinkTransforms,
        root: &Xform,
        h: &mut Matrix6<f64>,
        base_cols: &mut Matrix6<f64>,
    ) -> Inertia {
        let mut axes = [Motion::ZERO; N_JOINTS];
        let mut ic = [Inertia::ZERO; N_JOINTS];
        let mut x = *root;
        for i in 0..N_JOINTS {
            if i > 0 {
                x = x.then(&xs.x[i]);
            }
            axes[i] = x.motion_inv(&self.links[i].axis());
            ic[i] = x.inertia_inv(&self.links[i].body.total);
        }
        for i in (1..N_JOINTS).rev() {
            let outer = ic[i];
            ic[i - 1] += outer;
        }
        for j in 0..N_JOINTS {
            let f = ic[j].mul(&axes[j]);
            for i in 0..j {
                let hij = axes[i].dot(&f);
                h[(i, j)] = hij;
                h[(j, i)] = hij;
            }
            h[(j, j)] = axes[j].dot(&f);
            base_cols.fixed_view_mut::<6, 1>(0, j).copy_from(&f.to_vector6());
        }
        ic[0]
    }

    /// Joint-space mass matrix of the links alone (rigid bodies + added mass), kg·m².
    pub fn mass_matrix_rigid(&self, q: &JointVector) -> Matrix6<f64> {
        let mut h = Matrix6::zeros();
        let mut unused = Matrix6::zeros();
        let xs = self.transforms(q);
        self.crba(&xs, &xs.x[0], &mut h, &mut unused);
        h
    }

    /// Joint-space mass matrix with the rotor inertias `G² Jm` on the diagonal, kg·m².
    pub fn mass_matrix(&self, q: &JointVector) -> Matrix6<f64> {
        let mut h = self.mass_matrix_rigid(q);
        for i in 0..N_JOINTS {
            h[(i, i)] += self.links[i].armature;
        }
        h
    }

    /// Forward dynamics on a base moving as `base`: `q̈` for drive torques `tau` (link side) at
    /// `(q, q̇)`, with rotor inertia and the smoothed friction of the plant. `None` if the mass
    /// matrix is not positive definite (a model with massless, inertia-free links).
    pub fn forward_dynamics(
        &self,
        q: &JointVector,
        qd: &JointVector,
        tau: &JointVector,
        base: &BaseMotion,
    ) -> Option<JointVector> {
        let xs = self.transforms(q);
        let mut bias = JointVector::zeros();
        self.rnea(
            &xs,
            qd,
            &JointVector::zeros(),
            base,
            &Force::ZERO,
            &mut bias,
            None,
        );
        let rhs = tau - bias - self.friction(qd, Some(self.coulomb_smoothing));
        Cholesky::new(self.mass_matrix(q)).map(|c| c.solve(&rhs))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;

    use crate::arm::test_arm as arm;

    #[test]
    fn the_loaded_base_wrench_is_the_inverse_dynamics_with_the_tool_wrench() {
        let arm = arm();
        let q = JointVector::new(0.2, 1.0, -2.0, 0.3, 0.9, -0.4);
        let qd = JointVector::new(0.5, -0.7, 0.6, -0.9, 0.8, 1.1);
        let qdd = JointVector::new(1.0, -0.5, 0.8, -1.2, 0.9, 2.0);
        let base = BaseMotion::on_vehicle(
            &arm,
            &UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3),
            &Vector6::new(0.1, -0.2, 0.05, 0.2, -0.1, 0.3),
            &Vector6::new(0.3, 0.1, -0.2, 0.4, 0.2, -0.1),
            9.81,
            &Vector3::new(0.2, 0.0, 0.1),
        );
        let f = Force::new(Vector3::new(30.0, -45.0, 60.0), Vector3::new(1.0, 2.0, -3.0));
        let vt = arm.velocity_terms(&q, &qd, &base);
        let (free, loaded) = arm.inverse_dynamics_loaded(&vt, &qdd, &base.acceleration, &f);
        assert_eq!(
            free,
            arm.inverse_dynamics_split(&vt, &qdd, &base.acceleration, None)
        );
        let want = arm
            .inverse_dynamics(&q, &qd, &qdd, &base, Some(&f))
            .wrench_on_base;
        let err = (loaded.to_vector6() - want.to_vector6()).norm();
        assert!(err < 1e-12 * want.to_vector6().norm(), "{loaded:?} vs {want:?}");
    }

    #[test]
    fn the_split_inverse_dynamics_is_the_rnea() {
        // Random states, accelerations, base motions, currents and tool wrenches: the velocity
        // terms plus the accelerations' part equal the one-pass RNEA up to round-off.
        let arm = arm();
        let mut rng = crate::synth::random::stream(7, 0, 0);
        let mut u = |s: f64| crate::synth::random::uniform(&mut rng, [-s, s]);
        for _ in 0..200 {
            let q = JointVector::from_fn(|_, _| u(3.0));
            let qd = JointVector::from_fn(|_, _| u(2.0));
            let qdd = JointVector::from_fn(|_, _| u(5.0));
            let mut v6 = |s: f64| Vector6::from_fn(|_, _| u(s));
            let (nu, nu_dot) = (v6(0.5), v6(2.0));
            let rpy = (u(0.5), u(0.5), u(3.0));
            let current = Vector3::new(u(0.3), u(0.3), u(0.1));
            let base = BaseMotion::on_vehicle(
                &arm,
                &UnitQuaternion::from_euler_angles(rpy.0, rpy.1, rpy.2),
                &nu,
                &nu_dot,
                9.81,
                &current,
            );
            let f = Force::new(
                Vector3::new(u(80.0), u(80.0), u(80.0)),
                Vector3::new(u(5.0), u(5.0), u(5.0)),
            );
            let vt = arm.velocity_terms(&q, &qd, &base);
            for tool in [None, Some(&f)] {
                let want = arm.inverse_dynamics(&q, &qd, &qdd, &base, tool);
                let got = arm.inverse_dynamics_split(&vt, &qdd, &base.acceleration, tool);
                let close = |a: &[f64], b: &[f64]| {
                    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
                    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-12 * scale)
                };
                assert!(
                    close(got.tau.as_slice(), want.tau.as_slice()),
                    "{got:?} vs {want:?}"
                );
                assert!(close(got.tau_rigid.as_slice(), want.tau_rigid.as_slice()));
                let (g, w) = (got.wrench_on_base.to_vector6(), want.wrench_on_base.to_vector6());
                assert!(close(g.as_slice(), w.as_slice()), "{g} vs {w}");
            }
        }
    }

    #[test]
    fn forward_dynamics_inverts_inverse_dynamics_underwater() {
        // With added mass, drag and buoyancy: FD(q, q̇, ID(q, q̇, q̈)) = q̈. Friction differs
        // (exact vs smoothed) unless q̇ is far from 0 compared with the smoothing: take |q̇| ≥ 0.5.
        let arm = arm();
        let q = JointVector::new(0.2, 1.0, -2.0, 0.3, 0.9, -0.4);
        let qd = JointVector::new(0.5, -0.7, 0.6, -0.9, 0.8, 1.1);
        let qdd = JointVector::new(1.0, -0.5, 0.8, -1.2, 0.9, 2.0);
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        let id = arm.inverse_dynamics(&q, &qd, &qdd, &base, None);
        let back = arm.forward_dynamics(&q, &qd, &id.tau, &base).unwrap();
        let smooth_gap = arm.friction(&qd, None) - arm.friction(&qd, Some(arm.coulomb_smoothing));
        let corr = arm.mass_matrix(&q).cholesky().unwrap().solve(&smooth_gap);
        assert!((back - corr - qdd).norm() < 1e-9, "{back} vs {qdd}");
    }

    #[test]
    fn mass_matrix_columns_are_rnea_with_unit_accelerations() {
        // H e_j = RNEA(q, 0, e_j) with no gravity, no current: an independent route to H.
        let arm = arm();
        let q = JointVector::new(-0.4, 0.3, -1.0, 1.2, -0.6, 0.2);
        let h = arm.mass_matrix_rigid(&q);
        for j in 0..6 {
            let mut e = JointVector::zeros();
            e[j] = 1.0;
            let id = arm.inverse_dynamics(&q, &JointVector::zeros(), &e, &BaseMotion::default(), None);
            assert!((h.column(j) - id.tau_rigid).norm() < 1e-12, "column {j}");
        }
        assert!((h - h.transpose()).norm() < 1e-12);
    }

    #[test]
    fn buoyant_arm_weighs_less() {
        // Links 2..6 displace water: the gravity torque underwater is that of the dry arm with
        // each link's weight reduced by rho*V*g at its centre of buoyancy.
        let m = UvmsModel::default();
        let wet = Arm::new(&m.arm, &m.environment).unwrap();
        let mut dry_env = m.environment.clone();
        dry_env.water_density = 0.0;
        let dry = Arm::new(&m.arm, &dry_env).unwrap();
        let q = JointVector::new(0.0, 0.5, -1.0, 0.0, 0.3, 0.0);
        let g = wet.level_gravity(9.81);
        let z = JointVector::zeros();
        let t_wet = wet
            .inverse_dynamics(&q, &z, &z, &BaseMotion::fixed(g), None)
            .tau_rigid;
        let t_dry = dry
            .inverse_dynamics(&q, &z, &z, &BaseMotion::fixed(g), None)
            .tau_rigid;
        // Buoyancy alone: a fictitious arm whose link masses are the displaced masses at the
        // cylinder centres; its gravity torque is the difference.
        let mut b_model = m.arm.clone();
        for l in &mut b_model.links {
            let (mass, com) = match &l.hydro {
                Some(c) if !c.volume_in_hull => (
                    1025.0 * std::f64::consts::PI * c.radius * c.radius * c.length,
                    c.center,
                ),
                _ => (0.0, [0.0; 3]),
            };
            l.mass = mass;
            l.center_of_mass = com;
            l.inertia = [[0.0; 3]; 3];
            l.hydro = None;
        }
        let b_arm = Arm::new(&b_model, &dry_env).unwrap();
        let t_b = b_arm
            .inverse_dynamics(&q, &z, &z, &BaseMotion::fixed(g), None)
            .tau_rigid;
        assert!((t_dry - t_b - t_wet).norm() < 1e-9, "{t_dry} {t_b} {t_wet}");
        assert!(t_b.norm() > 1.0);
    }
}
