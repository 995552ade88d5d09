//! Spatial vector algebra (Featherstone, *Rigid Body Dynamics Algorithms*, 2008, ch. 2), with
//! 6-vectors ordered [linear; angular] as in Fossen.
//!
//! - [`Motion`] `[v; ω]`: a twist (velocity or acceleration) of a body, `v` the velocity of the
//!   point at the frame's origin, both in the frame's axes (m/s, rad/s).
//! - [`Force`] `[f; n]`: a wrench, `n` the moment about the frame's origin (N, N·m).
//! - [`Xform`]: the Plücker transform from frame `p` to frame `c`, built from the pose `t_p_c`.
//! - [`Inertia`]: a symmetric 6×6 generalised mass at a frame's origin, in three 3×3 blocks.
//!   A rigid body's inertia and a body's added mass (which is not a rigid-body inertia: a
//!   cylinder's is anisotropic in translation) share the type.
//!
//! Cross products: `V × m = [ω×u + v×ν; ω×ν]`, `V ×* f = [ω×f; v×f + ω×n]`, so that Fossen's
//! Coriolis–centripetal term is `C(ν)ν = ν ×* (M ν)`.

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// The skew-symmetric matrix `S(a)` with `S(a) b = a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// A spatial motion vector `[v; ω]` (velocity or acceleration), m/s and rad/s (or their rates).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Linear part: the velocity of the point at the frame's origin, in the frame's axes.
    pub lin: Vector3<f64>,
    /// Angular part.
    pub ang: Vector3<f64>,
}

/// A spatial force vector (wrench) `[f; n]`, N and N·m, the moment about the frame's origin.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Force {
    /// Force.
    pub lin: Vector3<f64>,
    /// Moment about the frame's origin.
    pub ang: Vector3<f64>,
}

macro_rules! spatial_vector_ops {
    ($t:ident) => {
        impl $t {
            /// The zero vector.
            pub const ZERO: $t = $t {
                lin: Vector3::new(0.0, 0.0, 0.0),
                ang: Vector3::new(0.0, 0.0, 0.0),
            };
            /// From its linear and angular parts.
            #[inline]
            pub fn new(lin: Vector3<f64>, ang: Vector3<f64>) -> Self {
                $t { lin, ang }
            }
            /// From a 6-vector `[linear; angular]`.
            #[inline]
            pub fn from_vector6(v: &Vector6<f64>) -> Self {
                $t {
                    lin: Vector3::new(v[0], v[1], v[2]),
                    ang: Vector3::new(v[3], v[4], v[5]),
                }
            }
            /// As a 6-vector `[linear; angular]`.
            #[inline]
            pub fn to_vector6(&self) -> Vector6<f64> {
                Vector6::new(
                    self.lin.x, self.lin.y, self.lin.z, self.ang.x, self.ang.y, self.ang.z,
                )
            }
        }
        impl Add for $t {
            type Output = $t;
            #[inline]
            fn add(self, o: $t) -> $t {
                $t {
                    lin: self.lin + o.lin,
                    ang: self.ang + o.ang,
                }
            }
        }
        impl Sub for $t {
            type Output = $t;
            #[inline]
            fn sub(self, o: $t) -> $t {
                $t {
                    lin: self.lin - o.lin,
                    ang: self.ang - o.ang,
                }
            }
        }
        impl AddAssign for $t {
            #[inline]
            fn add_assign(&mut self, o: $t) {
                self.lin += o.lin;
                self.ang += o.ang;
            }
        }
        impl SubAssign for $t {
            #[inline]
            fn sub_assign(&mut self, o: $t) {
                self.lin -= o.lin;
                self.ang -= o.ang;
            }
        }
        impl Neg for $t {
            type Output = $t;
            #[inline]
            fn neg(self) -> $t {
                $t {
                    lin: -self.lin,
                    ang: -self.ang,
                }
            }
        }
        impl Mul<f64> for $t {
            type Output = $t;
            #[inline]
            fn mul(self, s: f64) -> $t {
                $t {
                    lin: self.lin * s,
                    ang: self.ang * s,
                }
            }
        }
    };
}
spatial_vector_ops!(Motion);
spatial_vector_ops!(Force);

impl Motion {
    /// The motion cross product `self × m = [ω×u + v×ν; ω×ν]` (`self = [v; ω]`, `m = [u; ν]`).
    #[inline]
    pub fn cross(&self, m: &Motion) -> Motion {
        Motion {
            lin: self.ang.cross(&m.lin) + self.lin.cross(&m.ang),
            ang: self.ang.cross(&m.ang),
        }
    }

    /// The force cross product `self ×* f = [ω×f; v×f + ω×n]`.
    #[inline]
    pub fn cross_force(&self, f: &Force) -> Force {
        Force {
            lin: self.ang.cross(&f.lin),
            ang: self.lin.cross(&f.lin) + self.ang.cross(&f.ang),
        }
    }

    /// The power `m · f` of a wrench on a motion, W.
    #[inline]
    pub fn dot(&self, f: &Force) -> f64 {
        self.lin.dot(&f.lin) + self.ang.dot(&f.ang)
    }
}

/// The Plücker transform from frame `p` to frame `c`: `rot` is `E = R_p_cᵀ` (rotates `p`
/// components into `c` components), `pos` the origin of `c` in `p` coordinates (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xform {
    /// `E = R_p_cᵀ`.
    pub rot: Matrix3<f64>,
    /// Origin of `c` in `p` coordinates, m.
    pub pos: Vector3<f64>,
}

impl Default for Xform {
    fn default() -> Self {
        Xform::IDENTITY
    }
}

impl Xform {
    /// The identity transform.
    pub const IDENTITY: Xform = Xform {
        rot: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        pos: Vector3::new(0.0, 0.0, 0.0),
    };

    /// The transform from `p` to `c` given the pose `t_p_c` (maps `c` coordinates into `p`).
    pub fn from_pose(t_p_c: &Isometry3<f64>) -> Self {
        Xform {
            rot: t_p_c.rotation.to_rotation_matrix().into_inner().transpose(),
            pos: t_p_c.translation.vector,
        }
    }

    /// The pose `t_p_c` of this transform.
    pub fn to_pose(&self) -> Isometry3<f64> {
        let r = nalgebra::Rotation3::from_matrix_unchecked(self.rot.transpose());
        Isometry3::from_parts(
            self.pos.into(),
            nalgebra::UnitQuaternion::from_rotation_matrix(&r),
        )
    }

    /// A pure translation: `c` is `p` moved to `pos` (in `p` coordinates).
    pub fn translation(pos: Vector3<f64>) -> Self {
        Xform {
            rot: Matrix3::identity(),
            pos,
        }
    }

    /// Motion from `p` to `c` coordinates: `[E(v − r×ω); Eω]`.
    #[inline]
    pub fn motion(&self, m: &Motion) -> Motion {
        Motion {
            lin: self.rot * (m.lin - self.pos.cross(&m.ang)),
            ang: self.rot * m.ang,
        }
    }

    /// Motion from `c` to `p` coordinates: `[Eᵀv + r×Eᵀω; Eᵀω]`.
    #[inline]
    pub fn motion_inv(&self, m: &Motion) -> Motion {
        let ang = self.rot.tr_mul(&m.ang);
        Motion {
            lin: self.rot.tr_mul(&m.lin) + self.pos.cross(&ang),
            ang,
        }
    }

    /// Force from `p` to `c` coordinates: `[Ef; E(n − r×f)]`.
    #[inline]
    pub fn force(&self, f: &Force) -> Force {
        Force {
            lin: self.rot * f.lin,
            ang: self.rot * (f.ang - self.pos.cross(&f.lin)),
        }
    }

    /// Force from `c` to `p` coordinates: `[Eᵀf; Eᵀn + r×Eᵀf]`.
    #[inline]
    pub fn force_inv(&self, f: &Force) -> Force {
        let lin = self.rot.tr_mul(&f.lin);
        Force {
            lin,
            ang: self.rot.tr_mul(&f.ang) + self.pos.cross(&lin),
        }
    }

    /// The composition `p → c → d` of `self` (`p → c`) and `next` (`c → d`).
    #[inline]
    pub fn then(&self, next: &Xform) -> Xform {
        Xform {
            rot: next.rot * self.rot,
            pos: self.pos + self.rot.tr_mul(&next.pos),
        }
    }

    /// A generalised mass given in `c` (at its origin, in its axes) expressed in `p`: `Xᵀ I X`.
    #[inline]
    pub fn inertia_inv(&self, i: &Inertia) -> Inertia {
        let e = &self.rot;
        let r = &self.pos;
        let c1 = congruence(e, &i.c);
        if i.rigid {
            // a = m 1, b = −S(h): h' = Eᵀh + m r, C' = C1 − h' rᵀ − r h1ᵀ + (r·h' + r·h1) 1.
            let m = i.a[(0, 0)];
            let h1 = e.tr_mul(&i.first_moment());
            let h2 = h1 + r * m;
            let c = c1 - h2 * r.transpose() - r * h1.transpose()
                + Matrix3::identity() * (r.dot(&h2) + r.dot(&h1));
            return Inertia {
                a: i.a,
                b: -skew(&h2),
                c,
                rigid: true,
            };
        }
        // Rotate into p axes (still about c's origin), then move the reference point to p's
        // origin: B' = B − A S(r), C' = C + S(r) B' − Bᵀ S(r). The products with `S(r)` are
        // cross products: row k of `A S(r)` is `(A e_k × r)ᵀ` (A symmetric), element `(k, l)`
        // of `S(r) B'` is `(r × B' e_l)_k` and of `Bᵀ S(r)` is `(B e_k × r)_l`; C' is symmetric
        // (`S B − Bᵀ S = S B + (S B)ᵀ`, `S A S`), its upper triangle is mirrored.
        let a = congruence(e, &i.a);
        let b = e.tr_mul(&(i.b * e));
        let mut b2 = b;
        for k in 0..3 {
            let row = a.column(k).cross(r);
            for l in 0..3 {
                b2[(k, l)] -= row[l];
            }
        }
        let sb2: [Vector3<f64>; 3] = std::array::from_fn(|l| r.cross(&b2.column(l)));
        let bts: [Vector3<f64>; 3] = std::array::from_fn(|k| b.column(k).cross(r));
        let mut c = c1;
        for l in 0..3 {
            for k in 0..=l {
                c[(k, l)] += sb2[l][k] - bts[k][l];
                c[(l, k)] = c[(k, l)];
            }
        }
        Inertia {
            a,
            b: b2,
            c,
            rigid: false,
        }
    }

    /// The 6×6 matrix of the motion transform, [linear; angular] order.
    pub fn motion_matrix(&self) -> Matrix6<f64> {
        let mut x = Matrix6::zeros();
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rot);
        x.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-self.rot * skew(&self.pos)));
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.rot);
        x
    }
}

/// `Eᵀ X E` of a symmetric `X`: its upper triangle (the dot products of `E`'s columns with
/// those of `X E`), mirrored.
#[inline]
fn congruence(e: &Matrix3<f64>, x: &Matrix3<f64>) -> Matrix3<f64> {
    let xe = x * e;
    let mut m = Matrix3::zeros();
    for l in 0..3 {
        for k in 0..=l {
            m[(k, l)] = e.column(k).dot(&xe.column(l));
            m[(l, k)] = m[(k, l)];
        }
    }
    m
}

/// A symmetric 6×6 generalised mass at a frame's origin, [linear; angular] order:
/// `[f; n] = [a v + b ω; bᵀ v + c ω]`. For a rigid body of mass m with centre of mass `c_m`
/// and inertia `I_c` about it: `a = m 1`, `b = −m S(c_m)`, `c = I_c − m S(c_m)²`; rigid-body
/// inertias (and sums of them) are flagged and take cheaper paths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    /// Translational block (symmetric), kg.
    a: Matrix3<f64>,
    /// Coupling block, kg·m.
    b: Matrix3<f64>,
    /// Rotational block (symmetric), kg·m².
    c: Matrix3<f64>,
    /// `a = m 1` and `b = −S(h)`: a rigid body's inertia.
    rigid: bool,
}

impl Default for Inertia {
    fn default() -> Self {
        Inertia::ZERO
    }
}

impl Inertia {
    /// No mass.
    pub const ZERO: Inertia = Inertia {
        a: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        b: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        c: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        rigid: true,
    };

    /// A general generalised mass from its blocks (`a`, `c` symmetric): `[f; n] = [a v + b ω;
    /// bᵀ v + c ω]`.
    pub fn from_blocks(a: Matrix3<f64>, b: Matrix3<f64>, c: Matrix3<f64>) -> Self {
        Inertia {
            a,
            b,
            c,
            rigid: false,
        }
    }

    /// The blocks `(a, b, c)`.
    pub fn blocks(&self) -> (&Matrix3<f64>, &Matrix3<f64>, &Matrix3<f64>) {
        (&self.a, &self.b, &self.c)
    }

    /// Whether this is a rigid body's inertia (`a = m 1`, `b` skew).
    pub fn is_rigid(&self) -> bool {
        self.rigid
    }

    /// `h` of a rigid inertia (`b = −S(h)`, `h = m c_m`).
    #[inline]
    fn first_moment(&self) -> Vector3<f64> {
        Vector3::new(-self.b[(2, 1)], -self.b[(0, 2)], -self.b[(1, 0)])
    }

    /// A rigid body: `mass` (kg), centre of mass `com` from the origin (m), inertia `inertia_com`
    /// about the centre of mass (kg·m²), all in the frame's axes.
    pub fn rigid(mass: f64, com: &Vector3<f64>, inertia_com: &Matrix3<f64>) -> Self {
        let s = skew(com);
        Inertia {
            a: Matrix3::identity() * mass,
            b: -s * mass,
            c: inertia_com - s * s * mass,
            rigid: true,
        }
    }

    /// From a symmetric 6×6 matrix (the upper-right block is `b`).
    pub fn from_matrix6(m: &Matrix6<f64>) -> Self {
        Inertia {
            a: m.fixed_view::<3, 3>(0, 0).into_owned(),
            b: m.fixed_view::<3, 3>(0, 3).into_owned(),
            c: m.fixed_view::<3, 3>(3, 3).into_owned(),
            rigid: false,
        }
    }

    /// The 6×6 matrix.
    pub fn to_matrix6(&self) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.a);
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&self.b);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&self.b.transpose());
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.c);
        m
    }

    /// The momentum `I m` of a motion.
    #[inline]
    pub fn mul(&self, m: &Motion) -> Force {
        if self.rigid {
            // f = m v + ω × h, n = h × v + C ω.
            let h = self.first_moment();
            return Force {
                lin: m.lin * self.a[(0, 0)] + m.ang.cross(&h),
                ang: h.cross(&m.lin) + self.c * m.ang,
            };
        }
        Force {
            lin: self.a * m.lin + self.b * m.ang,
            ang: self.b.tr_mul(&m.lin) + self.c * m.ang,
        }
    }

    /// Kinetic energy `½ vᵀ I v` of a velocity, J.
    #[inline]
    pub fn energy(&self, v: &Motion) -> f64 {
        0.5 * v.dot(&self.mul(v))
    }
}

impl Add for Inertia {
    type Output = Inertia;
    #[inline]
    fn add(self, o: Inertia) -> Inertia {
        Inertia {
            a: self.a + o.a,
            b: self.b + o.b,
            c: self.c + o.c,
            rigid: self.rigid && o.rigid,
        }
    }
}

impl AddAssign for Inertia {
    #[inline]
    fn add_assign(&mut self, o: Inertia) {
        self.a += o.a;
        self.b += o.b;
        self.c += o.c;
        self.rigid &= o.rigid;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    fn pose() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.3, -0.7, 1.1),
            UnitQuaternion::from_euler_angles(0.4, -1.2, 2.3),
        )
    }
    fn m(a: f64) -> Motion {
        Motion::new(Vector3::new(a, -2.0, 0.5), Vector3::new(0.1, a * 0.3, -0.9))
    }
    fn f(a: f64) -> Force {
        Force::new(Vector3::new(3.0, a, -1.0), Vector3::new(-0.2, 0.7, a))
    }
    fn close(a: &Vector6<f64>, b: &Vector6<f64>) -> bool {
        (a - b).abs().max() < 1e-12
    }

    #[test]
    fn motion_transform_is_the_rigid_velocity_field() {
        // A body moving with ω and velocity v at p's origin: at c's origin the velocity is
        // v + ω × r; in c axes, rotated by E.
        let t = pose();
        let x = Xform::from_pose(&t);
        let v = m(1.5);
        let at_c = v.lin + v.ang.cross(&t.translation.vector);
        let r = t.rotation.inverse();
        let want = Motion::new(r * at_c, r * v.ang);
        assert!(close(&x.motion(&v).to_vector6(), &want.to_vector6()));
        assert!(close(&x.motion_inv(&x.motion(&v)).to_vector6(), &v.to_vector6()));
        assert!(close(
            &(x.motion_matrix() * v.to_vector6()),
            &x.motion(&v).to_vector6()
        ));
    }

    #[test]
    fn force_transform_is_dual_and_preserves_power() {
        let x = Xform::from_pose(&pose());
        let (v, w) = (m(0.4), f(2.0));
        // Power is frame independent: (X m) · (X* f) = m · f.
        assert!((x.motion(&v).dot(&x.force(&w)) - v.dot(&w)).abs() < 1e-12);
        assert!(close(&x.force_inv(&x.force(&w)).to_vector6(), &w.to_vector6()));
        // X* = X⁻ᵀ: force_inv is Xᵀ.
        assert!(close(
            &(x.motion_matrix().transpose() * w.to_vector6()),
            &x.force_inv(&w).to_vector6()
        ));
    }

    #[test]
    fn cross_products_are_dual() {
        // (v × m) · f = −m · (v ×* f), and v ×* is −(v×)ᵀ.
        let (v, u, w) = (m(0.3), m(-1.1), f(0.8));
        assert!((v.cross(&u).dot(&w) + u.dot(&v.cross_force(&w))).abs() < 1e-12);
        // v × v = 0.
        assert!(v.cross(&v).to_vector6().norm() < 1e-15);
    }

    #[test]
    fn composition_and_inertia_transform_match_matrices() {
        let x1 = Xform::from_pose(&pose());
        let x2 = Xform::from_pose(&Isometry3::new(
            Vector3::new(-0.2, 0.5, 0.1),
            Vector3::new(0.3, 0.2, -0.4),
        ));
        let x12 = x1.then(&x2);
        assert!(
            (x12.motion_matrix() - x2.motion_matrix() * x1.motion_matrix())
                .abs()
                .max()
                < 1e-12
        );
        assert!(
            (x12.to_pose().to_homogeneous() - (pose() * x2.to_pose()).to_homogeneous())
                .abs()
                .max()
                < 1e-12
        );
        let mut a6 = Matrix6::from_fn(|r, c| ((r * 7 + c * 3) % 5) as f64 * 0.1);
        a6 = a6 * a6.transpose() + Matrix6::identity();
        let i = Inertia::from_matrix6(&a6);
        let want = x1.motion_matrix().transpose() * a6 * x1.motion_matrix();
        assert!((x1.inertia_inv(&i).to_matrix6() - want).abs().max() < 1e-12);
    }

    #[test]
    fn rigid_paths_equal_the_general_ones() {
        let com = Vector3::new(0.1, -0.2, 0.3);
        let ic = Matrix3::new(2.0, 0.1, 0.0, 0.1, 3.0, -0.2, 0.0, -0.2, 4.0);
        let rigid = Inertia::rigid(5.0, &com, &ic) + Inertia::rigid(1.5, &-com, &(ic * 0.3));
        assert!(rigid.is_rigid());
        let general = Inertia::from_matrix6(&rigid.to_matrix6());
        assert!(!general.is_rigid());
        let x = Xform::from_pose(&pose());
        let (r, g) = (x.inertia_inv(&rigid), x.inertia_inv(&general));
        assert!(r.is_rigid());
        assert!((r.to_matrix6() - g.to_matrix6()).abs().max() < 1e-12);
        assert!((rigid.mul(&m(0.3)).to_vector6() - general.mul(&m(0.3)).to_vector6()).norm() < 1e-12);
    }

    #[test]
    fn rigid_inertia_gives_momentum_and_energy() {
        let com = Vector3::new(0.1, -0.2, 0.3);
        let ic = Matrix3::new(2.0, 0.1, 0.0, 0.1, 3.0, -0.2, 0.0, -0.2, 4.0);
        let i = Inertia::rigid(5.0, &com, &ic);
        let v = m(0.7);
        let v_com = v.lin + v.ang.cross(&com);
        let h = i.mul(&v);
        assert!((h.lin - v_com * 5.0).norm() < 1e-12);
        assert!((h.ang - (ic * v.ang + com.cross(&(v_com * 5.0)))).norm() < 1e-12);
        let e = 0.5 * 5.0 * v_com.norm_squared() + 0.5 * v.ang.dot(&(ic * v.ang));
        assert!((i.energy(&v) - e).abs() < 1e-12);
    }
}
