//! The manipulator: a serial chain of six revolute joints in standard Denavit–Hartenberg form,
//! with its drives (gears, rotor inertia, friction) and the hydrodynamics of its links.
//!
//! - [`kinematics`]: forward kinematics and the geometric Jacobian.
//! - [`ik`]: analytic inverse kinematics of the PUMA class (all eight solutions, no Jacobian
//!   inverse anywhere).
//! - [`dynamics`]: recursive Newton–Euler (fixed base or a moving base such as the vehicle),
//!   composite-rigid-body mass matrix and forward dynamics by Cholesky.
//!
//! Frames: base `0` (the mount), link frames `1..6` (DH frame `i` is attached to link `i`, joint
//! `i` turns about `z_{i−1}`), tool `G` in frame 6. Angles in radians, SI units.

pub mod dynamics;
pub mod ik;
pub mod kinematics;

use crate::body::{Body, CylinderDrag, Drag, MassMoment};
use crate::error::Result;
use crate::model::{self, ArmModel, Dh, Environment, N_JOINTS};
use crate::spatial_algebra::{Inertia, Motion, Xform};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};

pub use dynamics::{BaseMotion, InverseDynamics};
pub use ik::IkSolutions;

/// Joint-space vector of the arm (angles rad, rates rad/s, torques N·m).
pub type JointVector = Vector6<f64>;

/// One link with its joint and drive, ready for the algorithms.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// DH parameters of the joint ([`Link::dh`]; set with [`Link::set_dh`], which keeps what is
    /// derived from them in step).
    dh: Dh,
    /// `sin α`, `cos α`.
    sin_alpha: f64,
    cos_alpha: f64,
    /// The joint's motion subspace ([`Link::axis`]).
    axis: Motion,
    /// The link as a body of the multibody (in its DH frame).
    pub body: Body,
    /// Rotor inertia on the link side `G² Jm`, kg·m².
    pub armature: f64,
    /// Viscous friction on the link side `G² B`, N·m·s/rad.
    pub viscous: f64,
    /// Coulomb friction on the link side `|G| Tc` for q̇ > 0 and for q̇ < 0, N·m.
    pub coulomb: [f64; 2],
    /// Joint limits [lower, upper], rad.
    pub limits: [f64; 2],
    /// Largest drive torque either way, N·m.
    pub torque_limit: f64,
}

impl Link {
    /// The joint's DH parameters.
    pub fn dh(&self) -> &Dh {
        &self.dh
    }

    /// Sets the joint's DH parameters, and with them `sin α`, `cos α` and the motion subspace.
    pub fn set_dh(&mut self, dh: Dh) {
        let (sa, ca) = dh.alpha.sin_cos();
        self.dh = dh;
        (self.sin_alpha, self.cos_alpha) = (sa, ca);
        self.axis = Motion::new(
            Vector3::new(0.0, dh.a * ca, -dh.a * sa),
            Vector3::new(0.0, sa, ca),
        );
    }

    /// The joint's motion subspace in link coordinates: joint `i` turns about `z_{i−1}`, which in
    /// frame `i` is `(0, sin α, cos α)` through `o_{i−1}`; so
    /// `S = [0, a cos α, −a sin α, 0, sin α, cos α]`.
    #[inline]
    pub fn axis(&self) -> Motion {
        self.axis
    }

    /// The transform from frame `i−1` to frame `i` at joint angle `q`.
    #[inline]
    pub fn xform(&self, q: f64) -> Xform {
        let (s, c) = (q + self.dh.theta_offset).sin_cos();
        let (sa, ca) = (self.sin_alpha, self.cos_alpha);
        // R = Rz(θ) Rx(α); E = Rᵀ; origin of i in i−1 = (a c, a s, d).
        Xform {
            rot: Matrix3::new(c, s, 0.0, -s * ca, c * ca, sa, s * sa, -c * sa, ca),
            pos: Vector3::new(self.dh.a * c, self.dh.a * s, self.dh.d),
        }
    }

    /// The joint's friction on the link side at the rate `qd` (see [`Arm::friction`]) and its
    /// slope `d/dq̇` (the smoothed Coulomb part's with `smoothing`, none without).
    #[inline]
    pub fn friction(&self, qd: f64, smoothing: Option<f64>) -> (f64, f64) {
        // The Coulomb level for the direction of q̇: the Robotics Toolbox's rule.
        let tc = if qd > 0.0 {
            self.coulomb[0]
        } else if qd < 0.0 {
            self.coulomb[1]
        } else {
            0.0
        };
        match smoothing {
            Some(eps) => {
                let th = abs_tanh(qd / eps);
                (
                    self.viscous * qd + tc * th,
                    self.viscous + tc.abs() / eps * (1.0 - th * th),
                )
            }
            None => (self.viscous * qd + tc, self.viscous),
        }
    }
}

/// `|tanh x|` from one exponential, `(1 − e)/(1 + e)` with `e = e^(−2|x|)` (at most 1, so no
/// overflow), to within a few ulps of 1 absolute: what a friction level needs. The library's
/// `tanh` is accurate relative to its value near 0 and costs three times as much (an `expm1`),
/// and the friction is evaluated some 30 times a control period.
#[inline]
fn abs_tanh(x: f64) -> f64 {
    let e = (-2.0 * x.abs()).exp();
    (1.0 - e) / (1.0 + e)
}

/// The arm built from its model: kinematics, drives and link bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// The six links, base to tip.
    pub links: [Link; N_JOINTS],
    /// Pose of the base frame 0 in the vehicle frame `C` ([`Arm::t_body_base`]; set with
    /// [`Arm::set_mount`], which keeps [`Arm::mount`] in step).
    t_body_base: Isometry3<f64>,
    /// The same as a transform from `C` to `0` ([`Arm::mount`]).
    mount: Xform,
    /// Pose of the tool frame `G` in DH frame 6.
    pub t_flange_tool: Isometry3<f64>,
    /// Velocity scale of the smoothed Coulomb friction, rad/s.
    pub coulomb_smoothing: f64,
}

impl Arm {
    /// Builds the arm of `model` in the water of `env`.
    ///
    /// # Errors
    /// [`crate::Error::Input`] if the model's mount or tool rotation is not a rotation.
    pub fn new(model: &ArmModel, env: &Environment) -> Result<Self> {
        let links = std::array::from_fn(|i| link(&model.links[i], env, model.drag_strips));
        let mount = model::rotation(&model.mount_rotation, "arm.mount_rotation")?;
        let tool = model::rotation(&model.tool.rotation, "arm.tool.rotation")?;
        let mut arm = Arm {
            links,
            mount: Xform::IDENTITY,
            t_body_base: Isometry3::identity(),
            t_flange_tool: Isometry3::from_parts(
                Translation3::from(model::vector3(&model.tool.position)),
                UnitQuaternion::from_rotation_matrix(&tool),
            ),
            coulomb_smoothing: model.coulomb_smoothing,
        };
        arm.set_mount(&mount, &model::vector3(&model.mount_position));
        Ok(arm)
    }

    /// Pose of the base frame 0 in the vehicle frame `C`.
    pub fn t_body_base(&self) -> Isometry3<f64> {
        self.t_body_base
    }

    /// The mount as a transform from `C` to `0` (built from the exact rotation matrix).
    #[inline]
    pub fn mount(&self) -> &Xform {
        &self.mount
    }

    /// Mounts the base frame 0 at `position` in the vehicle frame `C`, turned by `rotation`.
    pub fn set_mount(&mut self, rotation: &Rotation3<f64>, position: &Vector3<f64>) {
        self.mount = Xform {
            rot: rotation.matrix().transpose(),
            pos: *position,
        };
        self.t_body_base = Isometry3::from_parts(
            Translation3::from(*position),
            UnitQuaternion::from_rotation_matrix(rotation),
        );
    }

    /// The link-side rotor inertias `G² Jm`, kg·m².
    pub fn armature(&self) -> JointVector {
        JointVector::from_fn(|i, _| self.links[i].armature)
    }

    /// Joint friction on the link side, the torque the drive must add to overcome it:
    /// `|G|(|G| B q̇ + Tc_sel)`. With `smoothing = None` the Robotics Toolbox's rule
    /// (`Tc_sel = Tc[0]` for q̇ > 0, `Tc[1]` for q̇ < 0, 0 at rest); with `Some(ε)` the Coulomb
    /// part is `Tc_sel · |tanh(q̇/ε)|`, continuous for an ODE solver.
    pub fn friction(&self, qd: &JointVector, smoothing: Option<f64>) -> JointVector {
        JointVector::from_fn(|i, _| self.links[i].friction(qd[i], smoothing).0)
    }

    /// The gravity vector in the base frame when the vehicle is level (NED gravity `g` m/s²
    /// along +z of the world, rotated by the mount).
    pub fn level_gravity(&self, g: f64) -> Vector3<f64> {
        self.mount.rot * Vector3::new(0.0, 0.0, g)
    }

    /// A wrench in the base frame (about its origin) in the vehicle frame `C` (about `C`'s
    /// origin), e.g. [`InverseDynamics::wrench_on_base`] as the arm's wrench on the vehicle.
    pub fn base_wrench_in_body(&self, w: &crate::spatial_algebra::Force) -> crate::spatial_algebra::Force {
        self.mount.force_inv(w)
    }

    /// Whether each joint of `q` is within its limits.
    pub fn within_limits(&self, q: &JointVector) -> bool {
        (0..N_JOINTS).all(|i| q[i] >= self.links[i].limits[0] && q[i] <= self.links[i].limits[1])
    }

    /// The least distance of `q` from a joint limit, rad (negative past one), and the joint
    /// (0-based).
    pub fn limit_margin(&self, q: &JointVector) -> (f64, usize) {
        let mut least = (f64::INFINITY, 0);
        for (j, link) in self.links.iter().enumerate() {
            let [lo, hi] = link.limits;
            let margin = (q[j] - lo).min(hi - q[j]);
            if margin < least.0 {
                least = (margin, j);
            }
        }
        least
    }
}

/// One link of the model as a [`Link`].
fn link(m: &model::LinkModel, env: &Environment, strips: usize) -> Link {
    let com = model::vector3(&m.center_of_mass);
    let rigid = Inertia::rigid(m.mass, &com, &model::matrix3(&m.inertia));
    let rho = env.water_density;
    let (added, volume, cob, drag) = match &m.hydro {
        None => (Inertia::ZERO, 0.0, Vector3::zeros(), Drag::None),
        Some(c) => {
            let axis = model::vector3(&c.axis).normalize();
            let center = model::vector3(&c.center);
            let area = std::f64::consts::PI * c.radius * c.radius;
            // Slender-body strip theory: C_a ρ π r² L across the axis, ρ π r² L³/12 about the two
            // transverse axes, nothing along or about the axis (DNV-RP-C205 App. D).
            let transverse = Matrix3::identity() - axis * axis.transpose();
            let a_trans = transverse * (c.added_mass_coefficient * rho * area * c.length);
            let a_rot = transverse * (c.added_mass_coefficient * rho * area * c.length.powi(3) / 12.0);
            let at_center = Inertia::from_blocks(a_trans, Matrix3::zeros(), a_rot);
            let added = Xform::translation(center).inertia_inv(&at_center);
            let volume = if c.volume_in_hull { 0.0 } else { area * c.length };
            let drag = Drag::Cylinder(Box::new(CylinderDrag::new(
                rho,
                c.radius,
                c.length,
                axis,
                center,
                c.drag_cross,
                c.drag_axial,
                strips,
                Vector6::from_column_slice(&c.linear_damping),
            )));
            (added, volume, center, drag)
        }
    };
    let g = m.gear_ratio;
    let mut link = Link {
        dh: m.dh,
        sin_alpha: 0.0,
        cos_alpha: 1.0,
        axis: Motion::ZERO,
        body: Body::new(
            rigid,
            added,
            MassMoment::at(m.mass, &com),
            MassMoment::at(rho * volume, &cob),
            drag,
        ),
        armature: g * g * m.motor_inertia,
        viscous: g * g * m.viscous_friction,
        coulomb: [g.abs() * m.coulomb_friction[0], g.abs() * m.coulomb_friction[1]],
        limits: m.joint_limits,
        torque_limit: m.torque_limit,
    };
    link.set_dh(m.dh);
    link
}

/// The default model's arm (AUV300 + PUMA 560), for the arm's unit tests.
#[cfg(test)]
pub(crate) fn test_arm() -> Arm {
    let m = crate::model::UvmsModel::default();
    Arm::new(&m.arm, &m.environment).expect("the default arm is valid")
}

#[cfg(test)]
mod tests {
    use super::abs_tanh;

    /// Within a few ulps of 1 of the library's `|tanh|`, from round-off small arguments to
    /// beyond saturation, and exact at 0 and at the infinities.
    #[test]
    fn abs_tanh_is_the_library_s_to_round_off() {
        let mut worst = 0.0_f64;
        for k in 0..=100_000 {
            for x in [k as f64 * 4e-4, k as f64 * 1e-9, -(k as f64) * 3e-4] {
                worst = worst.max((abs_tanh(x) - x.tanh().abs()).abs());
            }
        }
        assert!(worst <= 4.0 * f64::EPSILON, "{worst}");
        assert_eq!(abs_tanh(0.0), 0.0);
        assert_eq!(abs_tanh(f64::INFINITY), 1.0);
        assert_eq!(abs_tanh(f64::NEG_INFINITY), 1.0);
    }
}
