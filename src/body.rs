//! One body of the underwater multibody: its rigid inertia, its added mass, its weight and
//! buoyancy, and its drag, all at the body frame's origin in the body frame's axes.
//!
//! The wrench a body needs to follow a motion (the left-hand side of its Newton–Euler equation,
//! equations.md §3) is
//!
//! ```text
//! F = M_RB a + v ×* (M_RB v) + M_A a_r + v_r ×* (M_A v_r) + D(v_r) + g − f_FK
//! v_r = v − [c; 0],   a_r = a + [ω × c − ċ; 0]
//! g = −[(m − ρ∇) g_b ; (m r_g − ρ∇ r_b) × g_b]
//! f_FK = [ρ∇ ċ ; ρ∇ r_b × ċ]
//! ```
//!
//! with `c` the water's velocity, `ċ` its acceleration in the world (a current that changes)
//! and `g_b` the gravity vector, all in body axes. With no current the two inertias act as one
//! (`M_RB + M_A`), Kirchhoff's equations of a body in an ideal fluid; `v ×* (M v)` is Fossen's
//! `C(ν)ν` (Fossen 2011, Thm 3.2). A uniform flow that accelerates pushes the body twice: the
//! pressure gradient that accelerates the water pushes its displaced volume as buoyancy does
//! (the Froude–Krylov force `f_FK`, at the centre of buoyancy), and the added mass answers the
//! acceleration relative to the water (Fossen's `M_A ν̇_r`); a neutrally buoyant body whose
//! centres coincide is carried along with the water (Morison's inertia force `(ρ∇ + M_A) ċ`,
//! DNV-RP-C205 ch. 6).
//!
//! Drag models: Fossen's diagonal linear + quadratic damping at a point (the vehicle), or
//! strip theory along a cylinder (the links): each of N strips feels the cross-flow drag
//! `½ ρ C_d 2r Δs |u⊥| u⊥` of its own velocity `u`, the ends the axial drag
//! `½ ρ C_d,ax π r² |u_ax| u_ax` (DNV-RP-C205 App. E).

use crate::spatial_algebra::{Force, Inertia, Motion, Xform};
use nalgebra::{Vector3, Vector6};

/// Largest number of drag strips along a link.
pub const MAX_STRIPS: usize = 64;

/// The drag model of a body.
#[derive(Debug, Clone, PartialEq)]
pub enum Drag {
    /// No drag.
    None,
    /// Fossen: `D(ν_r) ν_r = (D_L + diag(d_q ⊙ |ν_r|)) ν_r` on the velocity at `origin`.
    Fossen {
        /// Where the damping acts, in the body frame, m.
        origin: Vector3<f64>,
        /// Linear damping, N·s/m and N·m·s.
        linear: Vector6<f64>,
        /// Quadratic damping, N·s²/m² and N·m·s².
        quadratic: Vector6<f64>,
    },
    /// Strip theory along a circular cylinder.
    Cylinder(Box<CylinderDrag>),
}

/// Strip-theory drag of a cylinder, coefficients with the water density folded in.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderDrag {
    /// Unit axis in the body frame.
    pub axis: Vector3<f64>,
    /// Centre in the body frame, m.
    pub center: Vector3<f64>,
    /// Offsets of the strip centres along the axis from `center`, m (`strips` used).
    pub offsets: [f64; MAX_STRIPS],
    /// Number of strips.
    pub strips: usize,
    /// `½ ρ C_d 2r Δs` per strip, N·s²/m².
    pub strip_coefficient: f64,
    /// `½ ρ C_d,ax π r²`, N·s²/m².
    pub axial_coefficient: f64,
    /// Linear damping on the centre's velocity `[v; ω]` (body axes), N·s/m and N·m·s.
    pub linear: Vector6<f64>,
}

impl CylinderDrag {
    /// The drag of a cylinder of `radius` and `length` (m) along `axis` through `center`, in
    /// water of density `rho`, cut into `strips` strips (clamped to 1..=[`MAX_STRIPS`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        rho: f64,
        radius: f64,
        length: f64,
        axis: Vector3<f64>,
        center: Vector3<f64>,
        drag_cross: f64,
        drag_axial: f64,
        strips: usize,
        linear: Vector6<f64>,
    ) -> Self {
        let strips = strips.clamp(1, MAX_STRIPS);
        let ds = length / strips as f64;
        let mut offsets = [0.0; MAX_STRIPS];
        for (k, o) in offsets.iter_mut().take(strips).enumerate() {
            *o = -0.5 * length + (k as f64 + 0.5) * ds;
        }
        CylinderDrag {
            axis: axis.normalize(),
            center,
            offsets,
            strips,
            strip_coefficient: 0.5 * rho * drag_cross * 2.0 * radius * ds,
            axial_coefficient: 0.5 * rho * drag_axial * std::f64::consts::PI * radius * radius,
            linear,
        }
    }

    /// The drag wrench on the cylinder (the force of the water on it) for its velocity
    /// relative to the water `v` (body frame), about the body origin.
    ///
    /// Along the axis the cross-flow velocity is affine in the offset `s`:
    /// `u⊥(s) = a + s b` with `a = u⊥(centre)` and `b = ω × e` (which is already ⊥ `e`). With
    /// `w_k = |u⊥(s_k)|` the strip sums are then `Σ f_k = −k (S0 a + S1 b)` and
    /// `Σ s_k f_k = −k (S1 a + S2 b)`, `S_j = Σ w_k s_kʲ`, and the moment about the origin is
    /// `centre × Σ f_k + e × Σ s_k f_k`: the same strips, one square root each.
    fn wrench_on_body(&self, v: &Motion) -> Force {
        let e = &self.axis;
        let uc = v.lin + v.ang.cross(&self.center);
        let u_ax = uc.dot(e);
        let a = uc - e * u_ax;
        let b = v.ang.cross(e);
        let (aa, ab, bb) = (a.norm_squared(), 2.0 * a.dot(&b), b.norm_squared());
        let speed = |s: f64| (aa + s * (ab + s * bb)).max(0.0).sqrt();
        let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
        let mut add = |w: f64, s: f64| {
            s0 += w;
            s1 += w * s;
            s2 += w * s * s;
        };
        // Two strips at a time: their square roots are independent (one packed instruction).
        let mut pairs = self.offsets[..self.strips].chunks_exact(2);
        for p in &mut pairs {
            let (w0, w1) = (speed(p[0]), speed(p[1]));
            add(w0, p[0]);
            add(w1, p[1]);
        }
        for &s in pairs.remainder() {
            add(speed(s), s);
        }
        let k = -self.strip_coefficient;
        let f_cross = (a * s0 + b * s1) * k;
        let first_moment = (a * s1 + b * s2) * k;
        let fa = e * (-self.axial_coefficient * u_ax.abs() * u_ax);
        let fl = -self.linear.fixed_rows::<3>(0).component_mul(&uc);
        let nl = -self.linear.fixed_rows::<3>(3).component_mul(&v.ang);
        let f = f_cross + fa + fl;
        Force::new(f, self.center.cross(&f) + e.cross(&first_moment) + nl)
    }
}

/// A body of the multibody, at its frame's origin and in its frame's axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Rigid-body inertia `M_RB`.
    pub rigid: Inertia,
    /// Added mass `M_A`.
    pub added: Inertia,
    /// `M_RB + M_A`: what the mass matrix carries.
    pub total: Inertia,
    /// Mass minus displaced water mass `m − ρ∇`, kg (the weight in water is this times g).
    pub net_mass: f64,
    /// `m r_g − ρ∇ r_b`, kg·m: the moment of the weight in water is this × g.
    pub net_first_moment: Vector3<f64>,
    /// The displaced water, `ρ∇` and `ρ∇ r_b`: what the Froude–Krylov force pushes.
    pub displaced: MassMoment,
    /// The drag.
    pub drag: Drag,
}

/// A mass and its first moment about the body frame's origin (`m` and `m r`, kg and kg·m):
/// the body's own, or the water it displaces.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MassMoment {
    /// Mass, kg.
    pub mass: f64,
    /// Mass times the position of its centre, kg·m.
    pub first_moment: Vector3<f64>,
}

impl MassMoment {
    /// Nothing.
    pub const ZERO: MassMoment = MassMoment {
        mass: 0.0,
        first_moment: Vector3::new(0.0, 0.0, 0.0),
    };

    /// A mass `mass` centred at `center`.
    pub fn at(mass: f64, center: &Vector3<f64>) -> Self {
        MassMoment {
            mass,
            first_moment: center * mass,
        }
    }
}

impl Body {
    /// A body from its parts: `weight` is the body's mass and its first moment (those of
    /// `rigid`), `displaced` the water's it displaces; `total` is the inertias' sum.
    pub fn new(
        rigid: Inertia,
        added: Inertia,
        weight: MassMoment,
        displaced: MassMoment,
        drag: Drag,
    ) -> Self {
        Body {
            rigid,
            added,
            total: rigid + added,
            net_mass: weight.mass - displaced.mass,
            net_first_moment: weight.first_moment - displaced.first_moment,
            displaced,
            drag,
        }
    }

    /// The wrench the body needs (left-hand side of its equation of motion, see the module
    /// docs) for velocity `v`, acceleration `a`, gravity `g` (m/s²), water velocity `current`
    /// (m/s) and the water's acceleration `current_rate` (m/s², the world's rate of the
    /// current), all in body axes.
    #[inline]
    pub fn wrench(
        &self,
        v: &Motion,
        a: &Motion,
        g: &Vector3<f64>,
        current: &Vector3<f64>,
        current_rate: &Vector3<f64>,
    ) -> Force {
        let still_rate = *current_rate == Vector3::zeros();
        let mut f = if *current == Vector3::zeros() && still_rate {
            self.total.mul(a) + v.cross_force(&self.total.mul(v))
        } else {
            let vr = Motion::new(v.lin - current, v.ang);
            let ar = Motion::new(a.lin + v.ang.cross(current) - current_rate, a.ang);
            self.rigid.mul(a)
                + v.cross_force(&self.rigid.mul(v))
                + self.added.mul(&ar)
                + vr.cross_force(&self.added.mul(&vr))
        };
        f -= self.drag_on_body(&Motion::new(v.lin - current, v.ang));
        // Gravity and buoyancy act on the body; the equation's left side carries their negative.
        f.lin -= g * self.net_mass;
        f.ang -= self.net_first_moment.cross(g);
        if !still_rate {
            // The Froude–Krylov force, as buoyancy is for gravity.
            f.lin -= current_rate * self.displaced.mass;
            f.ang -= self.displaced.first_moment.cross(current_rate);
        }
        f
    }

    /// The drag of the water on the body for its velocity `vr` relative to the water.
    #[inline]
    pub fn drag_on_body(&self, vr: &Motion) -> Force {
        match &self.drag {
            Drag::None => Force::ZERO,
            Drag::Fossen {
                origin,
                linear,
                quadratic,
            } => {
                let x = Xform::translation(*origin);
                let u = x.motion(vr).to_vector6();
                let d = -(linear + quadratic.component_mul(&u.abs())).component_mul(&u);
                x.force_inv(&Force::from_vector6(&d))
            }
            Drag::Cylinder(c) => c.wrench_on_body(vr),
        }
    }

    /// The velocity relative to the water (body axes, m/s) at which the body, translating,
    /// meets the drag `−f`: on each axis the root of Fossen's `(D_L + d_q |u|) u = f`, written
    /// `2f / (D_L + √(D_L² + 4 d_q |f|))` (no cancellation for small `f`, and `√(f/d_q)` without
    /// linear damping). `None` unless the drag is Fossen's with damping on every linear axis.
    pub fn velocity_against_drag(&self, f: &Vector3<f64>) -> Option<Vector3<f64>> {
        let Drag::Fossen {
            linear, quadratic, ..
        } = &self.drag
        else {
            return None;
        };
        let mut u = Vector3::zeros();
        for i in 0..3 {
            let (l, q) = (linear[i], quadratic[i]);
            if l <= 0.0 && q <= 0.0 {
                return None;
            }
            if f[i] != 0.0 {
                u[i] = 2.0 * f[i] / (l + (l * l + 4.0 * q * f[i].abs()).sqrt());
            }
        }
        Some(u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn strip_drag_of_a_translating_cylinder_is_the_cross_flow_formula() {
        // A cylinder along x moving sideways at 0.5 m/s: F = ½ρ C_d (2rL) u², opposing.
        let (rho, r, l) = (1025.0, 0.075, 0.55);
        let c = CylinderDrag::new(
            rho,
            r,
            l,
            Vector3::x(),
            Vector3::new(0.1, 0.0, 0.2),
            1.1,
            0.9,
            8,
            Vector6::zeros(),
        );
        let f = c.wrench_on_body(&Motion::new(Vector3::new(0.0, 0.5, 0.0), Vector3::zeros()));
        let want = 0.5 * rho * 1.1 * 2.0 * r * l * 0.25;
        assert!((f.lin - Vector3::new(0.0, -want, 0.0)).norm() < 1e-9);
        // Acting at the centre: moment = centre × force.
        assert!((f.ang - Vector3::new(0.1, 0.0, 0.2).cross(&f.lin)).norm() < 1e-9);
        // Axial motion: only the end drag ½ρ C_ax π r² u².
        let f = c.wrench_on_body(&Motion::new(Vector3::new(-0.4, 0.0, 0.0), Vector3::zeros()));
        let want = 0.5 * rho * 0.9 * std::f64::consts::PI * r * r * 0.16;
        assert!((f.lin - Vector3::new(want, 0.0, 0.0)).norm() < 1e-9);
    }

    #[test]
    fn strip_drag_of_a_spinning_cylinder_converges_to_the_integral() {
        // Spinning about a transverse axis through the centre at ω: the moment is
        // ∫ ½ρC_d 2r |ωs| ωs · s ds = ρ C_d r ω² L⁴ / 32 (parameters.md), opposing.
        let (rho, r, l, w) = (1000.0, 0.05, 0.4, 2.0);
        let c = CylinderDrag::new(
            rho,
            r,
            l,
            Vector3::z(),
            Vector3::zeros(),
            1.0,
            0.0,
            64,
            Vector6::zeros(),
        );
        let f = c.wrench_on_body(&Motion::new(Vector3::zeros(), Vector3::new(w, 0.0, 0.0)));
        let want = rho * 1.0 * r * w * w * l.powi(4) / 32.0;
        assert!(f.lin.norm() < 1e-9);
        assert!(((-f.ang.x) - want).abs() < 1e-3 * want, "{} vs {want}", -f.ang.x);
    }

    #[test]
    fn strip_sums_equal_the_strip_by_strip_wrench() {
        // The per-strip law summed directly, for an oblique cylinder in a general motion.
        let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
        let center = Vector3::new(0.1, -0.05, 0.2);
        let lin = Vector6::new(1.0, 2.0, 3.0, 0.1, 0.2, 0.3);
        let c = CylinderDrag::new(1025.0, 0.06, 0.45, axis, center, 1.1, 0.9, 8, lin);
        for v in [
            Motion::new(Vector3::new(0.3, -0.2, 0.1), Vector3::new(0.5, -1.0, 0.7)),
            Motion::new(Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 2.0, 0.0)),
            Motion::new(axis * 0.4, Vector3::zeros()),
        ] {
            let (mut f, mut n) = (Vector3::zeros(), Vector3::zeros());
            for &s in &c.offsets[..c.strips] {
                let p = center + axis * s;
                let u = v.lin + v.ang.cross(&p);
                let u_perp = u - axis * u.dot(&axis);
                let fk = u_perp * (-c.strip_coefficient * u_perp.norm());
                f += fk;
                n += p.cross(&fk);
            }
            let uc = v.lin + v.ang.cross(&center);
            let u_ax = uc.dot(&axis);
            let fa = axis * (-c.axial_coefficient * u_ax.abs() * u_ax);
            let fl = -lin.fixed_rows::<3>(0).component_mul(&uc);
            let nl = -lin.fixed_rows::<3>(3).component_mul(&v.ang);
            f += fa + fl;
            n += center.cross(&(fa + fl)) + nl;
            let got = c.wrench_on_body(&v);
            assert!(
                (got.lin - f).norm() < 1e-12 * (1.0 + f.norm()),
                "{} vs {f}",
                got.lin
            );
            assert!(
                (got.ang - n).norm() < 1e-12 * (1.0 + n.norm()),
                "{} vs {n}",
                got.ang
            );
        }
    }

    #[test]
    fn current_enters_through_relative_velocity() {
        // A body drifting with the current feels no drag and, at rest in still water, none either.
        let i = Inertia::rigid(2.0, &Vector3::zeros(), &Matrix3::identity());
        let added = Inertia::rigid(1.0, &Vector3::zeros(), &(Matrix3::identity() * 0.1));
        let drag = Drag::Fossen {
            origin: Vector3::new(0.0, 0.0, 0.1),
            linear: Vector6::repeat(3.0),
            quadratic: Vector6::repeat(5.0),
        };
        let b = Body::new(i, added, MassMoment::ZERO, MassMoment::ZERO, drag);
        let c = Vector3::new(0.3, -0.1, 0.2);
        let f = b.wrench(
            &Motion::new(c, Vector3::zeros()),
            &Motion::ZERO,
            &Vector3::zeros(),
            &c,
            &Vector3::zeros(),
        );
        assert!(f.to_vector6().norm() < 1e-12);
    }

    /// In water that accelerates, a body at rest needs Morison's inertia force against it,
    /// `(ρ∇ + M_A) ċ` at the centre of buoyancy; a neutrally buoyant body whose centres
    /// coincide, moving with the water and accelerating with it, needs none (it is carried).
    #[test]
    fn accelerating_water_pushes_the_displaced_water_and_the_added_mass() {
        let center = Vector3::new(0.1, -0.05, 0.2);
        let i = Inertia::rigid(3.0, &center, &(Matrix3::identity() * 0.2));
        let added = Inertia::rigid(1.5, &center, &(Matrix3::identity() * 0.05));
        let drag = Drag::Fossen {
            origin: Vector3::zeros(),
            linear: Vector6::repeat(3.0),
            quadratic: Vector6::repeat(5.0),
        };
        let (weight, water) = (MassMoment::at(3.0, &center), MassMoment::at(3.0, &center));
        let body = Body::new(i, added, weight, water, drag);
        let (g, c, rate) = (
            Vector3::new(0.0, 0.0, 9.81),
            Vector3::new(0.2, 0.1, -0.1),
            Vector3::new(0.3, -0.2, 0.5),
        );
        let carried = body.wrench(
            &Motion::new(c, Vector3::zeros()),
            &Motion::new(rate, Vector3::zeros()),
            &g,
            &c,
            &rate,
        );
        assert!(carried.to_vector6().norm() < 1e-12, "{:?}", carried);
        // Held still in still-moving water: the force on it is (ρ∇ + M_A) ċ at the centre.
        let held = body.wrench(
            &Motion::ZERO,
            &Motion::ZERO,
            &Vector3::zeros(),
            &Vector3::zeros(),
            &rate,
        );
        let push = rate * (3.0 + 1.5);
        assert!((held.lin + push).norm() < 1e-12, "{:?}", held);
        assert!((held.ang + center.cross(&push)).norm() < 1e-12, "{:?}", held);
    }

    /// The velocity found for a holding force meets, translating, exactly that drag — with
    /// and without linear or quadratic damping, on either side, small and large.
    #[test]
    fn velocity_against_drag_inverts_the_fossen_drag() {
        let body = |linear: f64, quadratic: f64| {
            let drag = Drag::Fossen {
                origin: Vector3::new(0.1, -0.2, 0.3),
                linear: Vector6::new(linear, 2.0 * linear, 10.0 * linear, 1.0, 1.0, 1.0),
                quadratic: Vector6::new(quadratic, 1.3 * quadratic, 2.4 * quadratic, 1.0, 1.0, 1.0),
            };
            Body::new(
                Inertia::ZERO,
                Inertia::ZERO,
                MassMoment::ZERO,
                MassMoment::ZERO,
                drag,
            )
        };
        for (linear, quadratic) in [(16.0, 221.0), (0.0, 221.0), (16.0, 0.0)] {
            let b = body(linear, quadratic);
            for f in [
                Vector3::new(30.0, -25.0, 4.0),
                Vector3::new(-1e-6, 2e-3, -0.5),
                Vector3::zeros(),
            ] {
                let u = b.velocity_against_drag(&f).unwrap();
                let drag = b.drag_on_body(&Motion::new(u, Vector3::zeros())).lin;
                assert!(
                    (drag + f).norm() <= 1e-12 * (1.0 + f.norm()),
                    "{linear} {quadratic}: {u} {drag} {f}"
                );
            }
        }
        assert!(body(0.0, 0.0).velocity_against_drag(&Vector3::x()).is_none());
        let cylinder = Body::new(
            Inertia::ZERO,
            Inertia::ZERO,
            MassMoment::ZERO,
            MassMoment::ZERO,
            Drag::None,
        );
        assert!(cylinder.velocity_against_drag(&Vector3::x()).is_none());
    }
}
