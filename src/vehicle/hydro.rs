//! The vehicle's rigid-body and hydrodynamic model after Fossen (*Handbook of Marine Craft
//! Hydrodynamics and Motion Control*, 2011 / 2021, ch. 3, 6, 8):
//!
//! ```text
//! M_RB ν̇ + C_RB(ν)ν + M_A ν̇_r + C_A(ν_r)ν_r + D(ν_r)ν_r + g(η) = τ
//! ```
//!
//! in the body frame `C` (x forward, y starboard, z down, origin at the centre of buoyancy).
//! [`vehicle_body`] builds the vehicle as a [`Body`] of the multibody: `M_RB` from the mass, the
//! centre of gravity and the inertia about it; `M_A` and the damping moved from the model's
//! hydrodynamic origin to `C`'s origin; the restoring wrench from the weight at the centre of
//! gravity and the buoyancy at the centre of buoyancy. The multibody evaluates the Coriolis
//! terms as `ν ×* (M ν)`; [`coriolis_matrix`] is Fossen's matrix form of the same (Thm 3.2,
//! `m2c`), and [`restoring`] his closed form of `g(η)` in Euler angles, both for checks and for
//! controllers that want the textbook matrices.

use crate::body::{Body, Drag, MassMoment};
use crate::model::{self, Environment, VehicleModel};
use crate::spatial_algebra::{Inertia, Xform, skew};
use nalgebra::{Matrix6, Vector3, Vector6};

/// The vehicle as a body of the multibody, at the origin of `C` in `C` axes.
pub fn vehicle_body(v: &VehicleModel, env: &Environment) -> Body {
    let r_g = model::vector3(&v.center_of_gravity);
    let r_b = model::vector3(&v.center_of_buoyancy);
    let origin = model::vector3(&v.hydrodynamic_origin);
    let rigid = Inertia::rigid(v.mass, &r_g, &model::matrix3(&v.inertia));
    let added =
        Xform::translation(origin).inertia_inv(&Inertia::from_matrix6(&model::matrix6(&v.added_mass)));
    let displaced = env.water_density * v.displaced_volume;
    Body::new(
        rigid,
        added,
        MassMoment::at(v.mass, &r_g),
        MassMoment::at(displaced, &r_b),
        Drag::Fossen {
            origin,
            linear: Vector6::from_column_slice(&v.linear_damping),
            quadratic: Vector6::from_column_slice(&v.quadratic_damping),
        },
    )
}

/// Fossen's Coriolis–centripetal matrix of a symmetric 6×6 mass `m` at velocity `nu`
/// (`[p; h] = M ν`, `C = [0, −S(p); −S(p), −S(h)]`), so that `C(ν)ν = ν ×* (M ν)` and
/// `νᵀ C(ν) ν = 0`.
pub fn coriolis_matrix(m: &Matrix6<f64>, nu: &Vector6<f64>) -> Matrix6<f64> {
    let ph = m * nu;
    let sp = skew(&Vector3::new(ph[0], ph[1], ph[2]));
    let sh = skew(&Vector3::new(ph[3], ph[4], ph[5]));
    let mut c = Matrix6::zeros();
    c.fixed_view_mut::<3, 3>(0, 3).copy_from(&-sp);
    c.fixed_view_mut::<3, 3>(3, 0).copy_from(&-sp);
    c.fixed_view_mut::<3, 3>(3, 3).copy_from(&-sh);
    c
}

/// Fossen's restoring wrench `g(η)` (left-hand side) for weight `w` and buoyancy `b` (N)
/// acting at `r_g` and `r_b` (m, body frame), at roll `phi` and pitch `theta` (rad):
/// `[(W−B)sθ; −(W−B)cθsφ; −(W−B)cθcφ; −(y_gW−y_bB)cθcφ + (z_gW−z_bB)cθsφ;
///   (z_gW−z_bB)sθ + (x_gW−x_bB)cθcφ; −(x_gW−x_bB)cθsφ − (y_gW−y_bB)sθ]`.
pub fn restoring(
    w: f64,
    b: f64,
    r_g: &Vector3<f64>,
    r_b: &Vector3<f64>,
    phi: f64,
    theta: f64,
) -> Vector6<f64> {
    let (sf, cf) = phi.sin_cos();
    let (st, ct) = theta.sin_cos();
    let m = r_g * w - r_b * b;
    Vector6::new(
        (w - b) * st,
        -(w - b) * ct * sf,
        -(w - b) * ct * cf,
        -m.y * ct * cf + m.z * ct * sf,
        m.z * st + m.x * ct * cf,
        -m.x * ct * sf - m.y * st,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;
    use crate::spatial_algebra::Motion;
    use nalgebra::UnitQuaternion;

    fn nu() -> Vector6<f64> {
        Vector6::new(0.4, -0.2, 0.1, 0.05, -0.3, 0.2)
    }

    #[test]
    fn coriolis_does_no_work_and_is_the_force_cross_product() {
        let m = UvmsModel::default();
        let body = vehicle_body(&m.vehicle, &m.environment);
        for mass in [
            body.rigid.to_matrix6(),
            body.added.to_matrix6(),
            body.total.to_matrix6(),
        ] {
            let c = coriolis_matrix(&mass, &nu());
            assert!((nu().dot(&(c * nu()))).abs() < 1e-12, "nu^T C nu != 0");
            let v = Motion::from_vector6(&nu());
            let spatial = v.cross_force(&Inertia::from_matrix6(&mass).mul(&v)).to_vector6();
            assert!((c * nu() - spatial).norm() < 1e-12);
        }
    }

    #[test]
    fn body_restoring_equals_fossens_closed_form() {
        let m = UvmsModel::default();
        let mut v = m.vehicle.clone();
        v.center_of_gravity = [0.02, -0.01, 0.16];
        v.center_of_buoyancy = [-0.01, 0.03, 0.0];
        let body = vehicle_body(&v, &m.environment);
        let (phi, theta, psi) = (0.3, -0.2, 1.1);
        let r = UnitQuaternion::from_euler_angles(phi, theta, psi);
        let g_body = r.inverse() * Vector3::new(0.0, 0.0, m.environment.gravity);
        let zero = Motion::ZERO;
        let got = body
            .wrench(&zero, &zero, &g_body, &Vector3::zeros(), &Vector3::zeros())
            .to_vector6();
        let w = v.mass * m.environment.gravity;
        let b = m.environment.water_density * m.environment.gravity * v.displaced_volume;
        let want = restoring(
            w,
            b,
            &model::vector3(&v.center_of_gravity),
            &model::vector3(&v.center_of_buoyancy),
            phi,
            theta,
        );
        assert!((got - want).norm() < 1e-9, "{got} vs {want}");
    }

    #[test]
    fn added_mass_moves_to_the_body_origin() {
        // At the hydrodynamic origin (the CG) the added mass is the model's matrix.
        let m = UvmsModel::default();
        let body = vehicle_body(&m.vehicle, &m.environment);
        // Express it in the frame at h: the transform from there to C is a shift by −h.
        let inv = Xform::translation(-model::vector3(&m.vehicle.hydrodynamic_origin));
        let at_h = inv.inertia_inv(&body.added).to_matrix6();
        assert!((at_h - model::matrix6(&m.vehicle.added_mass)).abs().max() < 1e-9);
    }
}
