//! MM and its CS: the manipulator's joint controllers (Figure 4).
//!
//! The IK set-points (a step every control period; the navigation passes each vision fix's
//! correction of eq. 18 on over the fixes' period, so they do not jump) pass a critically damped second-order reference filter
//! (natural frequency `reference_filter_rad_s`) that gives smooth `q_ref`, `q̇_ref`, `q̈_ref`.
//! The drive torque is computed-torque control with the IDP as feed-forward and the
//! compensation of the identified external moments (the seed's adaptive corrective devices):
//! `a = q̈_ref + ω² (q_ref − q) + 2ζω (q̇_ref − q̇)`,
//! `τ = RNEA(q, q̇, a) + G²Jm a + friction(q̇_ref) + M̂_ez`,
//! all with the controller's model; the plant clips `τ` to the drives' torque limits.

use super::icu::Drive;
use crate::arm::dynamics::VelocityTerms;
use crate::arm::{Arm, JointVector};
use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::integrate::lag_gain_hz;
use crate::spatial_algebra::{Force, Motion};
use serde::{Deserialize, Serialize};

/// Joint-controller parameters (`[sim.joints]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JointControlConfig {
    /// Closed-loop natural frequency of each joint, rad/s.
    pub bandwidth_rad_s: f64,
    /// Damping ratio of each joint loop.
    pub damping_ratio: f64,
    /// Natural frequency of the reference filter on the set-points, rad/s.
    pub reference_filter_rad_s: f64,
    /// Cut-off of the low-pass on the set-points' rate, fed forward through the reference
    /// filter so that a set-point moving at a steady rate is followed without lag, Hz; 0 turns
    /// the feed-forward off. The TCU refreshes the rate every `⌊control rate / (20 × this)⌋`
    /// control periods (at least one), from the desired motion over that interval.
    pub rate_feedforward_hz: f64,
    /// Add the identified external moments `M̂_ez` to the drive torques.
    pub compensate_external: bool,
    /// Cut-off of the low-pass filter on `M̂_ez` before it is compensated, Hz.
    pub external_filter_hz: f64,
}

impl Default for JointControlConfig {
    fn default() -> Self {
        JointControlConfig {
            bandwidth_rad_s: 30.0,
            damping_ratio: 1.0,
            reference_filter_rad_s: 60.0,
            rate_feedforward_hz: 5.0,
            compensate_external: true,
            external_filter_hz: 30.0,
        }
    }
}

impl JointControlConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("sim.joints.bandwidth_rad_s", self.bandwidth_rad_s)?;
        positive("sim.joints.damping_ratio", self.damping_ratio)?;
        positive("sim.joints.reference_filter_rad_s", self.reference_filter_rad_s)?;
        non_negative("sim.joints.rate_feedforward_hz", self.rate_feedforward_hz)?;
        positive("sim.joints.external_filter_hz", self.external_filter_hz)
    }
}

/// The joint controllers with their reference filter.
#[derive(Debug, Clone)]
pub struct JointControl {
    cfg: JointControlConfig,
    /// Filtered reference angles, rad.
    pub q_ref: JointVector,
    /// Filtered reference rates, rad/s.
    pub qd_ref: JointVector,
    /// Filtered reference accelerations, rad/s².
    pub qdd_ref: JointVector,
    /// The set-points' low-passed rate, rad/s.
    qd_set: JointVector,
    m_ez: JointVector,
    /// The joint accelerations commanded last (the computed-torque loop's `a`), rad/s².
    pub commanded: JointVector,
    /// The drive torques commanded last (before the plant's clipping), N·m; `None` before the
    /// first.
    last_torque: Option<JointVector>,
}

impl JointControl {
    /// Controllers holding `q0`.
    pub fn new(cfg: &JointControlConfig, q0: &JointVector) -> Self {
        JointControl {
            cfg: *cfg,
            q_ref: *q0,
            qd_ref: JointVector::zeros(),
            qdd_ref: JointVector::zeros(),
            qd_set: JointVector::zeros(),
            m_ez: JointVector::zeros(),
            commanded: JointVector::zeros(),
            last_torque: None,
        }
    }

    /// What the ICU knows of the drives: the last commanded accelerations and torques.
    pub fn drive(&self) -> Drive {
        Drive {
            commanded: self.commanded,
            torque: self.last_torque,
        }
    }

    /// Advances the reference filter by `dt` towards the set-point `q_set` moving at `qd_set`
    /// (exact discretisation would need a matrix exponential; a semi-implicit step at ω·dt ≪ 1
    /// is within 0.1 % of it here). With the rate feed-forward the filter is
    /// `q̈_ref = ω² (q_set − q_ref) + 2ω (q̇_set − q̇_ref)`, `q̇_set` low-passed: a set-point that
    /// moves steadily is followed without the filter's `2/ω` lag.
    pub fn follow(&mut self, q_set: &JointVector, qd_set: &JointVector, dt: f64) {
        let c = &self.cfg;
        if c.rate_feedforward_hz > 0.0 {
            self.qd_set += (qd_set - self.qd_set) * lag_gain_hz(dt, c.rate_feedforward_hz);
        }
        let w = c.reference_filter_rad_s;
        self.qdd_ref = (q_set - self.q_ref) * (w * w) + (self.qd_set - self.qd_ref) * (2.0 * w);
        self.qd_ref += self.qdd_ref * dt;
        self.q_ref += self.qd_ref * dt;
    }

    /// The drive torques for the measured `q`, `q̇` of `vt` (the velocity terms of the
    /// controller's model `arm` at them and the base motion the controller believes, its
    /// acceleration taken as zero), the identified external moments `m_ez`; and, from the
    /// same inverse dynamics, the wrench the commanded motion exerts on the arm's base (base
    /// frame, about its origin) with the environment's wrench `f_env_on_tool` on the tool
    /// (base-frame axes, about the tool point), for the vehicle's open loop (eq. 17).
    pub fn torque(
        &mut self,
        arm: &Arm,
        vt: &VelocityTerms,
        m_ez: &JointVector,
        f_env_on_tool: &Force,
        dt: f64,
    ) -> (JointVector, Force) {
        let (q, qd) = (&vt.q, &vt.qd);
        let c = &self.cfg;
        let w = c.bandwidth_rad_s;
        let a = self.qdd_ref + (self.q_ref - q) * (w * w) + (self.qd_ref - qd) * (2.0 * c.damping_ratio * w);
        self.commanded = a;
        let (id, on_base) = arm.inverse_dynamics_loaded(vt, &a, &Motion::ZERO, f_env_on_tool);
        let mut tau = id.tau_rigid
            + arm.armature().component_mul(&a)
            + arm.friction(&self.qd_ref, Some(arm.coulomb_smoothing));
        if c.compensate_external {
            let k = lag_gain_hz(dt, c.external_filter_hz);
            self.m_ez += (m_ez - self.m_ez) * k;
            tau += self.m_ez;
        }
        self.last_torque = Some(tau);
        (tau, on_base)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set-point ramp: the critically damped filter alone lags by `2v/ω`; fed its rate it
    /// follows without lag.
    #[test]
    fn rate_feedforward_removes_the_ramp_lag() {
        let (v, dt) = (0.05, 1e-3);
        let lag = |feedforward_hz: f64| {
            let cfg = JointControlConfig {
                rate_feedforward_hz: feedforward_hz,
                ..JointControlConfig::default()
            };
            let mut jc = JointControl::new(&cfg, &JointVector::zeros());
            let rate = JointVector::repeat(v);
            let mut q_set = JointVector::zeros();
            for _ in 0..3000 {
                q_set += rate * dt;
                jc.follow(&q_set, &rate, dt);
            }
            q_set[0] - jc.q_ref[0]
        };
        // Sampled after the step, both lags are one step's motion `v·dt` less.
        let w = JointControlConfig::default().reference_filter_rad_s;
        let step = v * dt;
        assert!((lag(0.0) - (2.0 * v / w - step)).abs() < 1e-9, "{}", lag(0.0));
        assert!((lag(5.0) + step).abs() < 1e-9, "{}", lag(5.0));
    }

    /// The control law of the module docs term by term, against the controller's model: the
    /// RNEA of `a` with the rotors, the friction at the reference rate, and the identified
    /// moments through their low-pass; `a` the reference's acceleration plus the PD on its
    /// errors.
    #[test]
    fn the_drive_torque_is_the_computed_torque_law() {
        use crate::arm::dynamics::BaseMotion;
        let arm = crate::multibody::Multibody::new(&crate::model::UvmsModel::default())
            .unwrap()
            .arm;
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        let cfg = JointControlConfig::default();
        let q0 = JointVector::new(0.3, 0.9, -2.0, 0.4, 0.7, -0.5);
        let mut jc = JointControl::new(&cfg, &q0);
        let dt = 1e-3;
        for _ in 0..50 {
            jc.follow(&(q0 + JointVector::repeat(0.05)), &JointVector::zeros(), dt);
        }
        let q = q0 + JointVector::new(0.01, -0.02, 0.005, 0.0, 0.01, -0.01);
        let qd = JointVector::new(0.05, -0.1, 0.02, 0.0, 0.03, 0.01);
        let m_ez = JointVector::new(3.0, -2.0, 1.0, 0.5, -0.2, 0.1);
        let vt = arm.velocity_terms(&q, &qd, &base);
        let (w, z) = (cfg.bandwidth_rad_s, cfg.damping_ratio);
        let a = jc.qdd_ref + (jc.q_ref - q) * (w * w) + (jc.qd_ref - qd) * (2.0 * z * w);
        let (tau, _) = jc.torque(&arm, &vt, &m_ez, &Force::ZERO, dt);
        let rigid = arm.inverse_dynamics(&q, &qd, &a, &base, None).tau_rigid;
        let expected = rigid
            + arm.armature().component_mul(&a)
            + arm.friction(&jc.qd_ref, Some(arm.coulomb_smoothing))
            + m_ez * lag_gain_hz(dt, cfg.external_filter_hz);
        assert!((tau - expected).amax() < 1e-9, "{tau} vs {expected}");
        assert!(jc.qdd_ref.amax() > 0.1 && (jc.qd_ref - qd).amax() > 0.01);
    }

    #[test]
    fn reference_filter_reaches_a_step_without_overshoot() {
        let mut jc = JointControl::new(&JointControlConfig::default(), &JointVector::zeros());
        let target = JointVector::repeat(0.1);
        let mut peak: f64 = 0.0;
        for _ in 0..1000 {
            jc.follow(&target, &JointVector::zeros(), 1e-3);
            peak = peak.max(jc.q_ref[0]);
        }
        assert!((jc.q_ref[0] - 0.1).abs() < 1e-6);
        assert!(peak <= 0.1 + 1e-4, "{peak}");
    }
}
