//! FCU, the force control unit of Figure 4: eq. (13)–(16).
//!
//! - (13) `ΔF_imp = F*_imp − k (k · F_imp)`: the desired force `F*_imp = f* k` minus the
//!   projection of the identified force onto the desired direction `k`;
//! - (15) the sign of the scalar error from the angle `α` between `ΔF_imp` and `F*_imp`:
//!   `+1` if `|α| < π/2`, else `−1`; `ΔF = sign · ‖ΔF_imp‖`;
//! - (14) a PID on `ΔF` gives the extra tool offset `x̃ = Kp ΔF + Ki ∫ΔF dt + Kd dΔF/dt`
//!   (the seed's gains Kp = 1e-5 m/N, Ki = 4e-4 m/(N·s), Kd = 4e-9 m·s/N by default);
//! - (16) `ΔP* = x̃ k`, added to the desired tool position by the TCU.
//!
//! The offset is bounded (`max_offset_m`), with the integral frozen while it is (anti-windup).

use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::integrate::lag_gain_hz;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// FCU parameters (`[sim.force]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FcuConfig {
    /// Proportional gain, m/N.
    pub kp: f64,
    /// Integral gain, m/(N·s).
    pub ki: f64,
    /// Derivative gain, m·s/N.
    pub kd: f64,
    /// Cut-off of the low-pass filter on the derivative, Hz.
    pub derivative_filter_hz: f64,
    /// Largest offset `|x̃|`, m.
    pub max_offset_m: f64,
}

impl Default for FcuConfig {
    fn default() -> Self {
        FcuConfig {
            kp: 1e-5,
            ki: 4e-4,
            kd: 4e-9,
            derivative_filter_hz: 20.0,
            max_offset_m: 0.05,
        }
    }
}

impl FcuConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.force.kp", self.kp)?;
        non_negative("sim.force.ki", self.ki)?;
        non_negative("sim.force.kd", self.kd)?;
        positive("sim.force.derivative_filter_hz", self.derivative_filter_hz)?;
        positive("sim.force.max_offset_m", self.max_offset_m)
    }
}

/// The signed scalar force error of eq. (13) and (15): positive when the tool must press
/// harder.
pub fn force_error(f_desired: f64, k: &Vector3<f64>, f_imp: &Vector3<f64>) -> f64 {
    let desired = k * f_desired;
    let delta = desired - k * k.dot(f_imp);
    let norm = delta.norm();
    if norm == 0.0 {
        return 0.0;
    }
    // With no desired force the angle is taken against k itself (the direction of pressing).
    let reference = if f_desired > 0.0 { desired } else { *k };
    let cos_alpha = delta.dot(&reference) / (norm * reference.norm());
    if cos_alpha > 0.0 { norm } else { -norm }
}

/// The PID of eq. (14) with its state.
#[derive(Debug, Clone, Default)]
pub struct Fcu {
    cfg: FcuConfig,
    integral: f64,
    prev_error: Option<f64>,
    derivative: f64,
    offset: f64,
    /// The guarded start's advance (`advance`), m.
    advanced: f64,
}

impl Fcu {
    /// A unit at rest (`x̃ = 0`).
    pub fn new(cfg: &FcuConfig) -> Self {
        Fcu {
            cfg: *cfg,
            ..Fcu::default()
        }
    }

    /// The present offset `x̃`, m.
    pub fn offset(&self) -> f64 {
        self.offset
    }

    /// Moves the offset, and the origin the PID works from, by `step` (m) along `k`, within the
    /// offset's bound: a guarded start's advance towards a surface not yet felt.
    pub fn advance(&mut self, step: f64) {
        let to = (self.offset + step).clamp(-self.cfg.max_offset_m, self.cfg.max_offset_m);
        self.advanced += to - self.offset;
        self.offset = to;
    }

    /// One step of `dt` with the force error `delta_f` (N); returns `x̃` (m).
    pub fn update(&mut self, delta_f: f64, dt: f64) -> f64 {
        let c = &self.cfg;
        if let Some(prev) = self.prev_error {
            let a = lag_gain_hz(dt, c.derivative_filter_hz);
            self.derivative += ((delta_f - prev) / dt - self.derivative) * a;
        }
        self.prev_error = Some(delta_f);
        let candidate = self.integral + delta_f * dt;
        let unclamped = c.kp * delta_f + c.ki * candidate + c.kd * self.derivative + self.advanced;
        if unclamped.abs() <= c.max_offset_m {
            self.integral = candidate;
        }
        self.offset = (c.kp * delta_f + c.ki * self.integral + c.kd * self.derivative + self.advanced)
            .clamp(-c.max_offset_m, c.max_offset_m);
        self.offset
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_rule_is_the_sign_of_the_shortfall_along_k() {
        let k = Vector3::new(0.0, 0.6, 0.8);
        // Pressing with 40 N along k (plus a sideways part that k·k does not see): 20 N short.
        let f = k * 40.0 + Vector3::new(5.0, 0.0, 0.0);
        assert!((force_error(60.0, &k, &f) - 20.0).abs() < 1e-12);
        // Pressing with 85 N: 25 N too much.
        assert!((force_error(60.0, &k, &(k * 85.0)) + 25.0).abs() < 1e-12);
        // Pulling (negative along k) is a shortfall larger than the setpoint.
        assert!((force_error(60.0, &k, &(k * -10.0)) - 70.0).abs() < 1e-12);
        assert_eq!(force_error(60.0, &k, &(k * 60.0)), 0.0);
    }

    /// Against a spring of stiffness k_s the loop `F = k_s x̃`, `x̃ = PID(F* − F)` settles at
    /// the setpoint, first order with the time constant `(1 + Kp k_s)/(Ki k_s)` = 0.275 s for
    /// the seed's gains, without overshoot.
    #[test]
    fn closes_on_a_spring_at_the_setpoint() {
        let mut fcu = Fcu::new(&FcuConfig::default());
        let ks = 1e4;
        let dt = 1e-3;
        let mut f = 0.0;
        let mut peak: f64 = 0.0;
        let mut t63 = None;
        for i in 0..3000 {
            let x = fcu.update(60.0 - f, dt);
            f = ks * x;
            peak = peak.max(f);
            if t63.is_none() && f >= 60.0 * (1.0 - (-1.0f64).exp()) {
                t63 = Some(i as f64 * dt);
            }
        }
        assert!((f - 60.0).abs() < 1e-3, "{f}");
        assert!(peak < 60.5, "{peak}");
        // The proportional part jumps the force to 60·0.1/1.1 N at once; from there it rises
        // with τ = 0.275 s and crosses 63 % of 60 N at τ·(1 − ln 1.1).
        let t63 = t63.unwrap();
        assert!((t63 - 0.275 * (1.0 - 1.1f64.ln())).abs() < 0.002, "{t63}");
    }

    /// Eq. (14) term by term, each alone: `Kp ΔF`, `Ki ∫ΔF dt`, and `Kd` times the error's
    /// rate (through its low-pass, settled on a ramp).
    #[test]
    fn each_term_of_the_pid_is_eq_14_s() {
        let only = |kp: f64, ki: f64, kd: f64| {
            Fcu::new(&FcuConfig {
                kp,
                ki,
                kd,
                max_offset_m: 1e3,
                ..FcuConfig::default()
            })
        };
        let dt = 1e-3;
        assert!((only(2e-3, 0.0, 0.0).update(5.0, dt) - 1e-2).abs() < 1e-15);
        let mut integral = only(0.0, 1e-3, 0.0);
        let last = (0..2000).map(|_| integral.update(5.0, dt)).last().unwrap();
        assert!((last - 1e-3 * 5.0 * 2.0).abs() < 1e-12, "{last}");
        // An error rising at 40 N/s.
        let mut derivative = only(0.0, 0.0, 1e-3);
        let last = (0..2000)
            .map(|k| derivative.update(40.0 * k as f64 * dt, dt))
            .last()
            .unwrap();
        assert!((last - 1e-3 * 40.0).abs() < 1e-9, "{last}");
    }

    #[test]
    fn offset_is_bounded_without_windup() {
        let mut fcu = Fcu::new(&FcuConfig::default());
        for _ in 0..100_000 {
            fcu.update(60.0, 1e-3);
        }
        // The integral stops within one step's increment of the bound.
        assert!(fcu.offset() <= 0.05 && fcu.offset() > 0.05 - 4e-4 * 60.0 * 1e-3 - 1e-12);
        // Once the error reverses, the offset leaves the bound at once.
        fcu.update(-60.0, 1e-3);
        assert!(fcu.offset() < 0.05);
    }

    /// A guarded start's advance moves the origin the PID works from: against a spring whose
    /// surface lies 2 mm beyond the start, the loop advanced to it and the loop alone both settle
    /// at the set-point, the integral's share of the offset (`ki ∫ΔF dt`) 2 mm less in the first;
    /// an advance past the bound stops at it, and a force too large pulls the offset back.
    #[test]
    fn an_advance_is_the_origin_the_pid_works_from() {
        let (ks, gap, dt) = (1e4, 0.002, 1e-3);
        let settle = |advance: f64| {
            let mut fcu = Fcu::new(&FcuConfig::default());
            fcu.advance(advance);
            assert!((fcu.offset() - advance).abs() < 1e-15);
            let mut f: f64 = 0.0;
            for _ in 0..5000 {
                f = ks * (fcu.update(60.0 - f, dt) - gap).max(0.0);
            }
            (f, fcu.integral)
        };
        let (f_alone, i_alone) = settle(0.0);
        let (f_advanced, i_advanced) = settle(gap);
        assert!((f_alone - 60.0).abs() < 1e-3 && (f_advanced - 60.0).abs() < 1e-3);
        assert!((FcuConfig::default().ki * (i_alone - i_advanced) - gap).abs() < 1e-6);
        // Advanced past the bound, the offset stops there and a force too large pulls it back.
        let mut fcu = Fcu::new(&FcuConfig::default());
        fcu.advance(1.0);
        assert_eq!(fcu.offset(), 0.05);
        assert_eq!(fcu.update(0.0, dt), 0.05);
        assert!(fcu.update(-10.0, dt) < 0.05);
    }
}
