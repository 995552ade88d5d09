//! Fixed-step integrators.
//!
//! - [`rk4`]: the classical fourth-order Runge–Kutta step on a state vector. For the floating
//!   system the attitude quaternion is integrated as four numbers and renormalised after the
//!   step (the rate `½ q ⊗ [0; ω]` keeps the norm to first order).
//! - Semi-implicit (symplectic) Euler steps the velocities first, then the configuration with
//!   the new velocities; the vehicle's pose moves on SE(3) by the exponential of the body twist
//!   ([`exp_twist`]), so the attitude stays a rotation without renormalising. The joints' steep
//!   smoothed Coulomb friction is taken linearly implicit in the velocity update. The default:
//!   one evaluation per step instead of four.
//!
//! Both are used by [`crate::plant::Plant::step`].
//! - [`lag_gain`]: the exact step of a first-order lag, for every filter of the controllers and
//!   the thrusters' dynamics.

use nalgebra::{Isometry3, Matrix3, SVector, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

/// The integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Classical Runge–Kutta, 4 evaluations per step.
    Rk4,
    /// Semi-implicit Euler on the configuration manifold, 1 evaluation per step, with the
    /// joints' friction linearly implicit (see
    /// [`crate::multibody::Multibody::step_accelerations`]).
    #[default]
    SemiImplicitEuler,
}

/// The gain `1 − e^(−dt/τ)` of one exact step of the first-order lag `ẏ = (u − y)/τ` with `u`
/// held over `dt`: `y += (u − y) · gain`. A time constant of zero passes `u` straight through.
pub fn lag_gain(dt: f64, time_constant_s: f64) -> f64 {
    if time_constant_s > 0.0 {
        1.0 - (-dt / time_constant_s).exp()
    } else {
        1.0
    }
}

/// [`lag_gain`] for the cut-off frequency `hz` (`τ = 1/(2π hz)`).
pub fn lag_gain_hz(dt: f64, hz: f64) -> f64 {
    1.0 - (-2.0 * std::f64::consts::PI * hz * dt).exp()
}

/// One classical RK4 step of `ẋ = f(x)` with step `h`; stops at the first error of `f`.
///
/// # Errors
/// Whatever `f` returns.
pub fn rk4<const N: usize, E>(
    x: &SVector<f64, N>,
    h: f64,
    mut f: impl FnMut(&SVector<f64, N>) -> Result<SVector<f64, N>, E>,
) -> Result<SVector<f64, N>, E> {
    let k1 = f(x)?;
    let k2 = f(&(x + k1 * (0.5 * h)))?;
    let k3 = f(&(x + k2 * (0.5 * h)))?;
    let k4 = f(&(x + k3 * h))?;
    Ok(x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0))
}

/// The pose reached from `t_world_body` by holding the body twist `nu = [v; ω]` (body axes)
/// for `h` seconds: `t · exp(h ν̂)` on SE(3).
pub fn exp_twist(t_world_body: &Isometry3<f64>, nu: &Vector6<f64>, h: f64) -> Isometry3<f64> {
    let v = Vector3::new(nu[0], nu[1], nu[2]) * h;
    let phi = Vector3::new(nu[3], nu[4], nu[5]) * h;
    let theta = phi.norm();
    let s = crate::spatial_algebra::skew(&phi);
    // V = I + (1 − cos θ)/θ² S + (θ − sin θ)/θ³ S², with its series near θ = 0.
    let (a, b) = if theta < 1e-6 {
        (0.5 - theta * theta / 24.0, 1.0 / 6.0 - theta * theta / 120.0)
    } else {
        (
            (1.0 - theta.cos()) / (theta * theta),
            (theta - theta.sin()) / (theta * theta * theta),
        )
    };
    let vmat = Matrix3::identity() + s * a + s * s * b;
    let step = Isometry3::from_parts(
        Translation3::from(vmat * v),
        UnitQuaternion::from_scaled_axis(phi),
    );
    t_world_body * step
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rk4_is_fourth_order() {
        // ẋ = x: one step of h from 1 gives 1 + h + h²/2 + h³/6 + h⁴/24.
        let x = SVector::<f64, 1>::new(1.0);
        let h = 0.1;
        let y = rk4(&x, h, |x| Ok::<_, ()>(*x)).unwrap();
        assert!((y[0] - (1.0 + h + h * h / 2.0 + h.powi(3) / 6.0 + h.powi(4) / 24.0)).abs() < 1e-15);
    }

    #[test]
    fn exp_twist_follows_a_helix() {
        // Constant body twist = screw motion: spinning at ω about body z while moving at v
        // along body x traces a circle of radius v/ω.
        let nu = Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, 2.0);
        let t = exp_twist(&Isometry3::identity(), &nu, std::f64::consts::PI / 2.0);
        // After half a turn the body is at (0, 2r, 0) facing −x; r = 0.5.
        assert!((t.translation.vector - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        assert!((t.rotation * Vector3::x() + Vector3::x()).norm() < 1e-12);
        // Composition: two half steps equal one step.
        let half = exp_twist(&exp_twist(&Isometry3::identity(), &nu, 0.3), &nu, 0.3);
        let full = exp_twist(&Isometry3::identity(), &nu, 0.6);
        assert!((half.to_homogeneous() - full.to_homogeneous()).abs().max() < 1e-12);
    }
}
