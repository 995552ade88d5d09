//! The vehicle's thrusters: allocation and first-order thrust dynamics.
//!
//! Thruster `j` at `r_j` pushing along the unit `d_j` (both in `C`) gives the body wrench
//! `B[:, j] T_j` with `B[:, j] = [d_j; r_j × d_j]` (equations.md §2), so `τ = B T`.
//!
//! **Allocation** ([`Thrusters::allocate`]): `T = B⁺ τ`, the minimum-norm least-squares solution
//! (`B⁺` from the SVD, computed once; for the default square, full-rank layout it is `B⁻¹`). A
//! wrench outside the span of `B` is reported (`in_span = false`, with the residual). If a
//! thrust exceeds its limit, the whole vector is scaled down by the largest ratio, so the
//! delivered wrench keeps the direction of the command and `scale < 1` says by how much it fell
//! short.
//!
//! **Dynamics** ([`Thrusters::step`]): each rotor state `s ∈ [−1, 1]` follows its command with a
//! first-order lag, `ṡ = (s_cmd − s)/τ_T`, integrated exactly over a step with the command held;
//! the thrust is `T = T_max s` (linear characteristic) or `T = T_max s|s|` (a propeller, thrust
//! ∝ n|n|). A thrust command is turned into `s_cmd` through the inverse characteristic and
//! saturates at `±T_max`.

use crate::error::{Error, Result};
use crate::integrate::lag_gain;
use crate::model::{self, StaticCharacteristic, ThrustersModel};
use crate::spatial_algebra::Force;
use nalgebra::{DMatrix, DVector, Vector6};

/// The thrusters of the vehicle, with their rotor states.
#[derive(Debug, Clone)]
pub struct Thrusters {
    b: DMatrix<f64>,
    b_pinv: DMatrix<f64>,
    max_thrust: Vec<f64>,
    time_constant: Vec<f64>,
    characteristic: StaticCharacteristic,
    state: Vec<f64>,
    thrust: DVector<f64>,
}

/// The result of an allocation.
#[derive(Debug, Clone, PartialEq)]
pub struct Allocation {
    /// Thrust per thruster, N, within the limits.
    pub thrusts: Vec<f64>,
    /// Factor (≤ 1) applied to the command to respect the limits: the delivered wrench is
    /// `scale · τ` (when `in_span`).
    pub scale: f64,
    /// Whether the commanded wrench lies in the span of the allocation matrix.
    pub in_span: bool,
    /// `‖B T₀ − τ‖` of the unscaled least-squares solution `T₀` (N, N·m mixed).
    pub residual: f64,
    /// The largest `|T₀_j| / T_max_j` of the unscaled solution (> 1: out of the limits).
    pub utilisation: f64,
}

impl Thrusters {
    /// The thrusters of `model`, at rest.
    ///
    /// # Errors
    /// [`Error::Input`] if the set is empty or a thruster's direction is zero (see
    /// [`crate::model::UvmsModel::validate`]).
    pub fn new(model: &ThrustersModel) -> Result<Self> {
        let n = model.units.len();
        if n == 0 {
            return Err(Error::input("thrusters.units", "at least one thruster is needed"));
        }
        let mut b = DMatrix::zeros(6, n);
        for (j, t) in model.units.iter().enumerate() {
            let d = model::vector3(&t.direction);
            if d.norm() < 1e-9 {
                return Err(Error::input(
                    format!("thrusters.units[{}].direction", j + 1),
                    "is zero",
                ));
            }
            let d = d.normalize();
            let m = model::vector3(&t.position).cross(&d);
            for r in 0..3 {
                b[(r, j)] = d[r];
                b[(r + 3, j)] = m[r];
            }
        }
        let b_pinv = b.clone().pseudo_inverse(1e-9).map_err(|e| {
            Error::input(
                "thrusters",
                format!("allocation matrix has no pseudo-inverse: {e}"),
            )
        })?;
        Ok(Thrusters {
            b,
            b_pinv,
            max_thrust: model.units.iter().map(|t| t.max_thrust).collect(),
            time_constant: model.units.iter().map(|t| t.time_constant).collect(),
            characteristic: model.static_characteristic,
            state: vec![0.0; n],
            thrust: DVector::zeros(n),
        })
    }

    /// Number of thrusters.
    pub fn len(&self) -> usize {
        self.max_thrust.len()
    }

    /// Whether there are no thrusters (never true for a built set).
    pub fn is_empty(&self) -> bool {
        self.max_thrust.is_empty()
    }

    /// The allocation matrix `B` (6 × n): column `j` is `[d_j; r_j × d_j]`.
    pub fn allocation_matrix(&self) -> &DMatrix<f64> {
        &self.b
    }

    /// Thrusts for the body wrench `tau` (`[force; moment]` in `C` about its origin), scaled to
    /// the limits keeping the wrench's direction (see the module docs).
    pub fn allocate(&self, tau: &Vector6<f64>) -> Allocation {
        let mut thrusts: Vec<f64> = self.unscaled(tau).collect();
        let residual = (0..6)
            .map(|r| {
                let achieved: f64 = thrusts.iter().enumerate().map(|(j, t)| self.b[(r, j)] * t).sum();
                (achieved - tau[r]).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let ratio = self.ratio(thrusts.iter().copied());
        let scale = if ratio > 1.0 { 1.0 / ratio } else { 1.0 };
        for t in &mut thrusts {
            *t *= scale;
        }
        Allocation {
            thrusts,
            scale,
            in_span: residual <= 1e-9 * (1.0 + tau.norm()),
            residual,
            utilisation: ratio,
        }
    }

    /// The [`Allocation::utilisation`] of `tau` alone, without allocating.
    pub fn utilisation(&self, tau: &Vector6<f64>) -> f64 {
        self.ratio(self.unscaled(tau))
    }

    /// The least-squares thrusts `B⁺ τ` before scaling.
    fn unscaled<'a>(&'a self, tau: &'a Vector6<f64>) -> impl Iterator<Item = f64> + 'a {
        (0..self.len()).map(|j| {
            let mut t = 0.0;
            for (i, x) in tau.iter().enumerate() {
                t += self.b_pinv[(j, i)] * x;
            }
            t
        })
    }

    /// The largest `|T_j|/T_max,j` of the thrusts `t`.
    fn ratio(&self, t: impl Iterator<Item = f64>) -> f64 {
        t.zip(&self.max_thrust)
            .map(|(ti, m)| ti.abs() / m)
            .fold(0.0, f64::max)
    }

    /// Advances the rotors by `dt` (s) with the thrust commands `cmd` (N) held.
    ///
    /// # Errors
    /// [`Error::Input`] if `cmd` does not have one value per thruster or a value is not finite.
    pub fn step(&mut self, dt: f64, cmd: &[f64]) -> Result<()> {
        if cmd.len() != self.len() {
            return Err(Error::input(
                "thrust command",
                format!("expected {} values, got {}", self.len(), cmd.len()),
            ));
        }
        if cmd.iter().any(|c| !c.is_finite()) {
            return Err(Error::input("thrust command", "not finite"));
        }
        for (j, c) in cmd.iter().enumerate() {
            let u = (c / self.max_thrust[j]).clamp(-1.0, 1.0);
            let s_cmd = match self.characteristic {
                StaticCharacteristic::Linear => u,
                StaticCharacteristic::Quadratic => u.signum() * u.abs().sqrt(),
            };
            let k = lag_gain(dt, self.time_constant[j]);
            self.state[j] += k * (s_cmd - self.state[j]);
            let s = self.state[j];
            self.thrust[j] = self.max_thrust[j]
                * match self.characteristic {
                    StaticCharacteristic::Linear => s,
                    StaticCharacteristic::Quadratic => s * s.abs(),
                };
        }
        Ok(())
    }

    /// Sets every rotor to the steady state of the commands `cmd` (N): thrusters that have
    /// been holding these commands for a long time.
    ///
    /// # Errors
    /// As [`Thrusters::step`].
    pub fn hold(&mut self, cmd: &[f64]) -> Result<()> {
        // An infinitely long step of the exact first-order lag lands on the steady state.
        self.step(f64::INFINITY, cmd)
    }

    /// The thrusts now, N.
    pub fn thrusts(&self) -> &[f64] {
        self.thrust.as_slice()
    }

    /// The body wrench of the thrusts now, `C` axes about its origin.
    pub fn wrench(&self) -> Force {
        let mut w = Vector6::zeros();
        for (col, t) in self.b.column_iter().zip(self.thrust.iter()) {
            for r in 0..6 {
                w[r] += col[r] * t;
            }
        }
        Force::from_vector6(&w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;

    #[test]
    fn allocation_matrix_is_the_research_layout() {
        // parameters.json: B for thrusters at z = 0 in a frame at the CG. Ours sit in the CG's
        // plane 0.163 m below C's origin; moving the moments to the CG must give the same B.
        let m = UvmsModel::default();
        let th = Thrusters::new(&m.thrusters).unwrap();
        let want = [
            [1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            [0.0, 0.0, 0.0, 0.0, 0.3, -0.3],
            [0.0, 0.0, 0.0, -0.55, 0.55, 0.55],
            [-0.3, 0.3, 0.55, 0.0, 0.0, 0.0],
        ];
        let r_g = model::vector3(&m.vehicle.center_of_gravity);
        let want = DMatrix::from_fn(6, 6, |r, c| want[r][c]);
        let mut at_cg = th.allocation_matrix().clone();
        for mut col in at_cg.column_iter_mut() {
            let f = nalgebra::Vector3::new(col[0], col[1], col[2]);
            let n = nalgebra::Vector3::new(col[3], col[4], col[5]) - r_g.cross(&f);
            col.rows_mut(3, 3).copy_from(&n);
        }
        assert!((at_cg - want).abs().max() < 1e-12);
        let sv = th.allocation_matrix().clone().singular_values();
        let cond = sv.max() / sv.min();
        assert!(cond.is_finite() && sv.min() > 1e-3);
    }

    #[test]
    fn allocation_reproduces_the_wrench_and_scales_keeping_its_direction() {
        let m = UvmsModel::default();
        let th = Thrusters::new(&m.thrusters).unwrap();
        let b = th.allocation_matrix().clone();
        let small = Vector6::new(20.0, -10.0, 60.0, 5.0, 36.0, -4.0);
        let a = th.allocate(&small);
        assert!(a.in_span && a.scale == 1.0);
        let got = &b * DVector::from_vec(a.thrusts.clone());
        assert!((got - DVector::from_column_slice(small.as_slice())).norm() < 1e-9);
        let big = small * 20.0;
        // Either way round: the limiting thruster pushing or pulling.
        for big in [big, -big] {
            let a = th.allocate(&big);
            assert!(a.scale < 1.0 && a.in_span);
            let max = a.thrusts.iter().map(|t| t.abs()).fold(0.0, f64::max);
            assert!(
                (max - 150.0).abs() < 1e-9,
                "the limiting thruster sits at its limit: {max}"
            );
            let got = &b * DVector::from_vec(a.thrusts.clone());
            assert!((got - DVector::from_column_slice((big * a.scale).as_slice())).norm() < 1e-9);
        }
        for tau in [small, big] {
            assert_eq!(th.utilisation(&tau), th.allocate(&tau).utilisation);
        }
    }

    #[test]
    fn a_wrench_out_of_reach_is_reported() {
        // Only the two surge thrusters: a sway force cannot be made.
        let mut m = UvmsModel::default().thrusters;
        m.units.truncate(2);
        let th = Thrusters::new(&m).unwrap();
        let a = th.allocate(&Vector6::new(0.0, 50.0, 0.0, 0.0, 0.0, 0.0));
        assert!(!a.in_span && a.residual > 49.0);
        // A surge force through the thrusters' plane (the CG, 0.163 m below C) can.
        let z = UvmsModel::default().vehicle.center_of_gravity[2];
        assert!(
            th.allocate(&Vector6::new(30.0, 0.0, 0.0, 0.0, 30.0 * z, 0.0))
                .in_span
        );
        assert!(!th.allocate(&Vector6::new(30.0, 0.0, 0.0, 0.0, 0.0, 0.0)).in_span);
    }

    #[test]
    fn thrust_follows_a_step_with_its_time_constant() {
        for ch in [StaticCharacteristic::Linear, StaticCharacteristic::Quadratic] {
            let mut m = UvmsModel::default().thrusters;
            m.static_characteristic = ch;
            let mut th = Thrusters::new(&m).unwrap();
            let cmd = [100.0, 0.0, 0.0, 0.0, 0.0, -150.0];
            // One time constant in 200 steps: the rotor state is at 1 − e⁻¹ of its command.
            for _ in 0..200 {
                th.step(0.001, &cmd).unwrap();
            }
            let frac = 1.0 - (-1.0f64).exp();
            let s_cmd: f64 = match ch {
                StaticCharacteristic::Linear => 100.0 / 150.0,
                StaticCharacteristic::Quadratic => (100.0f64 / 150.0).sqrt(),
            };
            let s = frac * s_cmd;
            let want = 150.0
                * if ch == StaticCharacteristic::Linear {
                    s
                } else {
                    s * s
                };
            assert!(
                (th.thrusts()[0] - want).abs() < 1e-9,
                "{ch:?}: {} vs {want}",
                th.thrusts()[0]
            );
            for _ in 0..5000 {
                th.step(0.001, &[400.0, 0.0, 0.0, 0.0, 0.0, -150.0]).unwrap();
            }
            assert!((th.thrusts()[0] - 150.0).abs() < 1e-6, "saturates at the maximum");
            assert!((th.thrusts()[5] + 150.0).abs() < 1e-6);
        }
        let mut th = Thrusters::new(&UvmsModel::default().thrusters).unwrap();
        assert_eq!(th.step(0.001, &[1.0]).unwrap_err().exit_code(), 2);
    }
}
