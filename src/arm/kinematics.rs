//! Forward kinematics and the geometric Jacobian of the arm, in the base frame 0.
//!
//! `t_base_flange(q)` is the product of the DH transforms `T_i = Rz(q_i + θ_i) Tz(d_i) Tx(a_i)
//! Rx(α_i)`; `t_base_tool(q)` appends the tool transform. The Jacobian `J(q)` maps joint rates to
//! the twist of a point fixed to link 6, rows `[vx vy vz wx wy wz]` in base axes: column `i` is
//! `[z_{i−1} × (p − o_{i−1}); z_{i−1}]` (the Robotics Toolbox's `jacob0`, Pinocchio's
//! `LOCAL_WORLD_ALIGNED`). Units m, rad.

use super::dynamics::LinkTransforms;
use super::{Arm, JointVector};
use crate::model::N_JOINTS;
use crate::spatial_algebra::Xform;
use nalgebra::{Isometry3, Matrix3, Matrix6, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Rotation and origin of every link frame in the base frame.
#[derive(Debug, Clone, Copy)]
pub struct Chain {
    /// `R_0_i` for i = 1..6 (index i − 1).
    pub rot: [Matrix3<f64>; N_JOINTS],
    /// Origin `o_i` in the base frame, m (index i − 1).
    pub pos: [Vector3<f64>; N_JOINTS],
}

impl Arm {
    /// The frames of all links at `q`.
    pub fn chain(&self, q: &JointVector) -> Chain {
        Self::chain_of(&self.transforms(q))
    }

    /// The frames of all links from the link transforms `xs` (of [`Arm::transforms`]).
    pub fn chain_of(xs: &LinkTransforms) -> Chain {
        let mut rot = [Matrix3::identity(); N_JOINTS];
        let mut pos = [Vector3::zeros(); N_JOINTS];
        let (mut r, mut p) = (Matrix3::identity(), Vector3::zeros());
        for (i, x) in xs.x.iter().enumerate() {
            step(&mut r, &mut p, x);
            rot[i] = r;
            pos[i] = p;
        }
        Chain { rot, pos }
    }

    /// Moves the frame of link `first` (`r`, `p`: its rotation and origin in the base frame; the
    /// base frame itself for `first = 0`) through the joints `first + 1 ..= first + q.len()` at
    /// the angles `q`.
    #[inline]
    pub(crate) fn advance(&self, r: &mut Matrix3<f64>, p: &mut Vector3<f64>, first: usize, q: &[f64]) {
        for (link, &qi) in self.links[first..].iter().zip(q) {
            step(r, p, &link.xform(qi));
        }
    }

    /// Pose of DH frame 6 (the flange) in the base frame.
    pub fn t_base_flange(&self, q: &JointVector) -> Isometry3<f64> {
        self.chain(q).t_base_flange()
    }

    /// Pose of the tool frame `G` in the base frame.
    pub fn t_base_tool(&self, q: &JointVector) -> Isometry3<f64> {
        self.t_base_flange(q) * self.t_flange_tool
    }

    /// Geometric Jacobian of the tool point (origin of `G`), base frame, rows `[v; ω]`.
    pub fn jacobian(&self, q: &JointVector) -> Matrix6<f64> {
        self.tool_jacobian(&self.chain(q))
    }

    /// [`Arm::jacobian`] at the link frames `chain`.
    pub fn tool_jacobian(&self, chain: &Chain) -> Matrix6<f64> {
        chain.jacobian_at(&self.t_flange_tool.translation.vector)
    }

    /// The tool point (origin of `G`) in the base frame at the link frames `chain`, m.
    pub fn tool_point(&self, chain: &Chain) -> Vector3<f64> {
        chain.point(&self.t_flange_tool.translation.vector)
    }

    /// Geometric Jacobian of the point `p6` (m, in frame 6 coordinates) fixed to link 6.
    pub fn jacobian_at(&self, q: &JointVector, p6: &Vector3<f64>) -> Matrix6<f64> {
        self.chain(q).jacobian_at(p6)
    }
}

impl Chain {
    /// Pose of DH frame 6 (the flange) in the base frame.
    pub fn t_base_flange(&self) -> Isometry3<f64> {
        isometry(&self.rot[N_JOINTS - 1], &self.pos[N_JOINTS - 1])
    }

    /// The point `p6` (m, in frame 6 coordinates) fixed to link 6 in the base frame.
    pub fn point(&self, p6: &Vector3<f64>) -> Vector3<f64> {
        self.pos[N_JOINTS - 1] + self.rot[N_JOINTS - 1] * p6
    }

    /// Geometric Jacobian of the point `p6` (m, in frame 6 coordinates) fixed to link 6, as
    /// [`Arm::jacobian_at`].
    pub fn jacobian_at(&self, p6: &Vector3<f64>) -> Matrix6<f64> {
        let c = self;
        let p = c.point(p6);
        let mut j = Matrix6::zeros();
        for i in 0..N_JOINTS {
            let (z, o) = if i == 0 {
                (Vector3::z(), Vector3::zeros())
            } else {
                (c.rot[i - 1].column(2).into_owned(), c.pos[i - 1])
            };
            let v = z.cross(&(p - o));
            j.fixed_view_mut::<3, 1>(0, i).copy_from(&v);
            j.fixed_view_mut::<3, 1>(3, i).copy_from(&z);
        }
        j
    }
}

/// Moves a frame (`r`, `p`: its rotation and origin in the base frame) through the link
/// transform `x` into the next link's frame.
#[inline]
fn step(r: &mut Matrix3<f64>, p: &mut Vector3<f64>, x: &Xform) {
    *p += *r * x.pos;
    *r *= x.rot.transpose();
}

/// The isometry of a rotation matrix (orthonormal by construction) and a translation.
pub(crate) fn isometry(r: &Matrix3<f64>, p: &Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(*p),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::arm::test_arm as arm;

    #[test]
    fn jacobian_matches_finite_differences_of_fk() {
        let arm = arm();
        let q = JointVector::new(0.3, 0.9, -2.1, 0.4, 0.7, -0.5);
        let j = arm.jacobian(&q);
        let t0 = arm.t_base_tool(&q);
        let h = 1e-6;
        for i in 0..6 {
            let mut qp = q;
            qp[i] += h;
            let t1 = arm.t_base_tool(&qp);
            let v = (t1.translation.vector - t0.translation.vector) / h;
            let w = (t1.rotation * t0.rotation.inverse()).scaled_axis() / h;
            assert!((j.fixed_view::<3, 1>(0, i) - v).norm() < 1e-5, "v column {i}");
            assert!((j.fixed_view::<3, 1>(3, i) - w).norm() < 1e-5, "w column {i}");
        }
    }

    /// New DH parameters and a new mount set on a built arm move its kinematics, joint axes and
    /// mount transforms as an arm built with them.
    #[test]
    fn set_dh_and_mount_equal_building_with_them() {
        let mut m = crate::model::UvmsModel::default();
        let mut arm = arm();
        let dh = crate::model::Dh {
            alpha: 0.3,
            a: 0.05,
            ..*arm.links[3].dh()
        };
        arm.links[3].set_dh(dh);
        m.arm.links[3].dh = dh;
        let rotation = nalgebra::Rotation3::from_euler_angles(0.1, -0.2, 0.3);
        let position = nalgebra::Vector3::new(0.2, -0.1, 0.4);
        arm.set_mount(&rotation, &position);
        m.arm.mount_rotation = rotation.into_inner().transpose().into();
        m.arm.mount_position = position.into();
        let built = Arm::new(&m.arm, &m.environment).unwrap();
        assert_eq!(arm, built);
        let q = JointVector::new(0.3, 0.9, -2.1, 0.4, 0.7, -0.5);
        assert_eq!(arm.t_base_tool(&q), built.t_base_tool(&q));
    }

    #[test]
    fn hanging_arm_at_zero_reaches_below_the_mount() {
        // Mount R = I (base z down): at q = 0 the PUMA's forearm (d4 along z3 = +z0) points
        // down, and the tool tip sits at a2 + a3 forward, d3 to port... all in the base frame.
        let arm = arm();
        let t = arm.t_base_flange(&JointVector::zeros());
        let want = Vector3::new(0.4318 + 0.0203, -0.15005, 0.4318);
        assert!(
            (t.translation.vector - want).norm() < 1e-12,
            "{}",
            t.translation.vector
        );
    }
}
