//! ICU, the identification unit of Figure 4: the contact force from joint moments, with no
//! six-axis force sensor.
//!
//! Eq. (1)–(2): the moment on each drive's output shaft is `M_dz = M_wz + M_ez`, so
//! `M_ez = M_dz − M_wz`, with `M_dz` from the one-axis joint-torque sensors and `M_wz` from the
//! IDP — the underwater RNEA ([`crate::arm::Arm::inverse_dynamics`]) of the *controller's*
//! arm model (which may differ from the plant's), at the measured `q`, `q̇`, the joint
//! accelerations, and the base motion the gyros give. The accelerations are the encoder rates'
//! derivative through a first-order filter, and `M_dz` passes the same filter, so that the
//! inertial moments of both sides line up and `M_ez` comes out as the filtered external
//! moments (no noise amplification, a lag of `1/(2π filter_hz)`). The accelerations the joint
//! controllers commanded can stand in (`acceleration = "commanded"`), but where the arm does
//! not follow them — at every contact transient — their difference enters `M_ez`, and through
//! the compensation of `M_ez` in the drives it feeds itself.
//!
//! The controller's model differs from the arm's (heavier links, less drag): in free space
//! `M_ez` is not zero but the model's error, mostly the weight and buoyancy on the shoulder.
//! During the trajectory's approach, until the identified force first exceeds
//! `tare_until_n` (the touch), the ICU zeroes it, as one zeroes a force sensor before
//! contact: an offset follows `M_ez` with the time constant `tare_s` and is subtracted from
//! then on.
//!
//! Eq. (3)–(12): a point contact at the tool tip loads joint `i` with `M_ez,i = J_v,iᵀ F_imp`
//! (the `J_v` columns of the tool-point Jacobian; `F_imp = −F_e` the force the tool exerts).
//! The seed solves three of these equations in closed form for one configuration (eq. 12 for
//! `q4 = q6 = 0`: joints 5, 3 and 1) and picks the three joints by rules near singular
//! configurations: joints 5, 4, 3 in general; 5, 3, 2 when `q5 = 0`; 3, 2, 1 when also
//! `q4 = 0`. [`ForceMethod::Seed`] solves the chosen 3 × 3 system `A F = m` (`A`'s rows the
//! chosen `J_v,iᵀ`) — eq. (12) is its closed-form solution in the seed's configuration.
//! [`ForceMethod::LeastSquares`] (the default) uses all six equations,
//! `(J_v J_vᵀ) F = J_v M_ez`, a 3 × 3 solve. Neither inverts the Jacobian.

use super::sensors::Measurements;
use crate::arm::dynamics::BaseMotion;
use crate::arm::{Arm, JointVector};
use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::integrate::{lag_gain, lag_gain_hz};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// How the tool force is computed from the external joint moments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ForceMethod {
    /// Least squares on all six joints: `(J_v J_vᵀ) F = J_v M_ez`.
    #[default]
    LeastSquares,
    /// The seed's choice of three joints (eq. 3–12 and its switching rules), a 3 × 3 solve.
    Seed,
}

/// Which joint accelerations enter the IDP of eq. (2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Acceleration {
    /// The measured ones: the encoder rates' filtered derivative, with the torque sensors'
    /// readings through the same filter so that the inertial moments line up.
    #[default]
    Measured,
    /// The ones the joint controllers commanded.
    Commanded,
}

/// ICU parameters (`[sim.icu]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IcuConfig {
    /// How the tool force is computed.
    pub method: ForceMethod,
    /// A joint angle closer to 0 than this counts as singular in the seed's rules, rad.
    pub singular_angle_rad: f64,
    /// The joint accelerations of the IDP.
    pub acceleration: Acceleration,
    /// Cut-off of the filter on the rates' derivative and on `M_dz` (`acceleration =
    /// "measured"`), Hz.
    pub filter_hz: f64,
    /// Time constant of the zeroing of `M_ez` in free space, s (0: no zeroing).
    pub tare_s: f64,
    /// The zeroing stops for good once the identified force exceeds this, N.
    pub tare_until_n: f64,
}

impl Default for IcuConfig {
    fn default() -> Self {
        IcuConfig {
            method: ForceMethod::LeastSquares,
            singular_angle_rad: 0.05,
            acceleration: Acceleration::Measured,
            filter_hz: 20.0,
            tare_s: 1.0,
            tare_until_n: 5.0,
        }
    }
}

impl IcuConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.icu.singular_angle_rad", self.singular_angle_rad)?;
        non_negative("sim.icu.tare_s", self.tare_s)?;
        non_negative("sim.icu.tare_until_n", self.tare_until_n)?;
        positive("sim.icu.filter_hz", self.filter_hz)
    }
}

/// One identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Identification {
    /// `M_ez = M_dz − M_wz`, N·m.
    pub m_ez: JointVector,
    /// The force the tool exerts on the surface, `F_imp = −F_e`, arm-base axes, N.
    pub f_imp_base: Vector3<f64>,
}

/// The ICU with its filters.
#[derive(Debug, Clone)]
pub struct Icu {
    cfg: IcuConfig,
    /// Filtered rates and filtered `M_dz` (none before the first measurement).
    filtered: Option<(JointVector, JointVector)>,
    /// The free-space offset of `M_ez`, N·m.
    offset: JointVector,
    /// Whether the tool has touched (the zeroing is over).
    touched: bool,
}

impl Icu {
    /// An ICU that has seen no measurement yet.
    pub fn new(cfg: &IcuConfig) -> Self {
        Icu {
            cfg: *cfg,
            filtered: None,
            offset: JointVector::zeros(),
            touched: false,
        }
    }

    /// Eq. (1)–(12) for the measurements `m` of a control period `dt`, with `arm` the
    /// controller's model, `commanded` the joint accelerations commanded when the measurements
    /// were taken, `base` the base motion it believes and `approach` whether the trajectory is
    /// in its approach (the offset is learnt then, until the touch).
    pub fn identify(
        &mut self,
        arm: &Arm,
        m: &Measurements,
        commanded: &JointVector,
        base: &BaseMotion,
        approach: bool,
        dt: f64,
    ) -> Identification {
        let (qdd, m_dz) = match self.cfg.acceleration {
            Acceleration::Commanded => (*commanded, m.m_dz),
            Acceleration::Measured => {
                let k = lag_gain_hz(dt, self.cfg.filter_hz);
                let (rates, torques) = self.filtered.get_or_insert((m.qd, m.m_dz));
                let step = (m.qd - *rates) * k;
                *rates += step;
                *torques += (m.m_dz - *torques) * k;
                (step / dt, *torques)
            }
        };
        let m_wz = arm.inverse_dynamics(&m.q, &m.qd, &qdd, base, None).tau_rigid;
        let raw = m_dz - m_wz;
        let f_imp_base = tool_force(arm, &m.q, &(raw - self.offset), &self.cfg);
        self.touched |= !approach || f_imp_base.norm() > self.cfg.tare_until_n;
        if !self.touched && self.cfg.tare_s > 0.0 {
            self.offset += (raw - self.offset) * lag_gain(dt, self.cfg.tare_s);
        }
        let m_ez = raw - self.offset;
        Identification {
            m_ez,
            f_imp_base: tool_force(arm, &m.q, &m_ez, &self.cfg),
        }
    }
}

/// The joints the seed's rules pick (0-based) at `q`.
pub fn seed_joints(q: &JointVector, singular: f64) -> [usize; 3] {
    let zero = |v: f64| v.abs() < singular;
    match (zero(q[4]), zero(q[3])) {
        (false, _) => [4, 3, 2],
        (true, false) => [4, 2, 1],
        (true, true) => [2, 1, 0],
    }
}

/// The force the tool exerts (arm-base axes) that explains the external moments `m_ez` at `q`
/// (see the module docs).
pub fn tool_force(arm: &Arm, q: &JointVector, m_ez: &JointVector, cfg: &IcuConfig) -> Vector3<f64> {
    let jv = arm.jacobian(q).fixed_rows::<3>(0).into_owned();
    let least_squares = || {
        let a = jv * jv.transpose();
        a.cholesky()
            .map_or_else(Vector3::zeros, |c| c.solve(&(jv * m_ez)))
    };
    match cfg.method {
        ForceMethod::LeastSquares => least_squares(),
        ForceMethod::Seed => {
            let rows = seed_joints(q, cfg.singular_angle_rad);
            let a = Matrix3::from_fn(|r, c| jv[(c, rows[r])]);
            let m = Vector3::from_fn(|r, _| m_ez[rows[r]]);
            let scale = jv.norm().max(1e-12);
            if a.determinant().abs() < 1e-6 * scale.powi(3) {
                least_squares()
            } else {
                a.lu().solve(&m).unwrap_or_else(least_squares)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;
    use crate::multibody::Multibody;
    use crate::spatial_algebra::Force;

    fn arm() -> Arm {
        Multibody::new(&UvmsModel::default()).unwrap().arm
    }

    #[test]
    fn a_known_tool_force_is_recovered_by_both_methods() {
        let arm = arm();
        let f = Vector3::new(12.0, -7.0, 60.0);
        for q in [
            JointVector::new(0.3, 0.9, -2.0, 0.4, 0.7, -0.5),
            JointVector::new(-0.2, 1.2, -2.4, 0.0, 0.9, 0.0),
            JointVector::new(0.1, 0.8, -1.9, 0.6, 0.02, 0.3),
        ] {
            let m_ez = arm.jacobian(&q).fixed_rows::<3>(0).transpose() * f;
            for method in [ForceMethod::LeastSquares, ForceMethod::Seed] {
                let cfg = IcuConfig {
                    method,
                    ..IcuConfig::default()
                };
                let est = tool_force(&arm, &q, &m_ez, &cfg);
                assert!((est - f).norm() < 1e-8, "{method:?} at {q}: {est}");
            }
        }
    }

    #[test]
    fn seed_rules_switch_near_singular_wrists() {
        let s = 0.05;
        assert_eq!(
            seed_joints(&JointVector::new(0.0, 1.0, -2.0, 0.3, 0.5, 0.0), s),
            [4, 3, 2]
        );
        assert_eq!(
            seed_joints(&JointVector::new(0.0, 1.0, -2.0, 0.3, 0.01, 0.0), s),
            [4, 2, 1]
        );
        assert_eq!(
            seed_joints(&JointVector::new(0.0, 1.0, -2.0, 0.0, 0.01, 0.0), s),
            [2, 1, 0]
        );
    }

    /// With exact sensors and the plant's own model, `M_ez` is exactly `J_vᵀ F_imp` of the force
    /// the plant applied: eq. (1)–(2) close on the multibody's own joint torques.
    #[test]
    fn external_moments_close_on_the_plants_dynamics() {
        let arm = arm();
        let q = JointVector::new(0.3, 0.9, -2.0, 0.4, 0.7, -0.5);
        let qd = JointVector::new(0.05, -0.02, 0.03, 0.0, 0.01, 0.0);
        let qdd = JointVector::new(0.1, 0.0, -0.2, 0.0, 0.0, 0.3);
        let g = arm.level_gravity(9.81);
        let base = BaseMotion::fixed(g);
        let f_env_base = Vector3::new(-5.0, 3.0, -60.0);
        let env = Force::new(f_env_base, Vector3::zeros());
        // What a perfect torque sensor reads: the rigid torques with the contact.
        let m_dz = arm.inverse_dynamics(&q, &qd, &qdd, &base, Some(&env)).tau_rigid;
        let m_wz = arm.inverse_dynamics(&q, &qd, &qdd, &base, None).tau_rigid;
        let f_imp = tool_force(&arm, &q, &(m_dz - m_wz), &IcuConfig::default());
        assert!((f_imp + f_env_base).norm() < 1e-8, "{f_imp}");
    }

    /// The controller's model errs by a constant moment `b` in free space: zeroed in the
    /// approach, `M_ez` starts from zero at the touch and then carries exactly the contact's
    /// moments (the offset frozen); without the zeroing it carries `b`.
    #[test]
    fn zeroing_in_the_approach_removes_the_model_offset_and_stops_at_the_touch() {
        let arm = arm();
        let q = JointVector::new(0.3, 0.9, -2.0, 0.4, 0.7, -0.5);
        let zero = JointVector::zeros();
        let base = BaseMotion::fixed(arm.level_gravity(9.81));
        let m_wz = arm.inverse_dynamics(&q, &zero, &zero, &base, None).tau_rigid;
        // A shoulder-heavy error whose apparent tool force (3 N) stays below the touch threshold.
        let b = JointVector::new(0.2, -0.8, 0.3, 0.0, 0.05, 0.0);
        let b = b * (3.0 / tool_force(&arm, &q, &b, &IcuConfig::default()).norm());
        let f = Vector3::new(0.0, 0.0, 60.0);
        let contact = arm.jacobian(&q).fixed_rows::<3>(0).transpose() * f;
        let meas = |m_dz: JointVector| Measurements {
            q,
            qd: zero,
            m_dz,
            attitude: nalgebra::UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            specific_force: Vector3::zeros(),
            position: Vector3::zeros(),
            position_time: 0.0,
        };
        let dt = 1e-3;
        for (tare_s, free_space_left) in [(1.0, 0.0), (0.0, 1.0)] {
            let mut icu = Icu::new(&IcuConfig {
                tare_s,
                ..IcuConfig::default()
            });
            let mut id = None;
            for _ in 0..8000 {
                id = Some(icu.identify(&arm, &meas(m_wz + b), &zero, &base, true, dt));
            }
            let free = id.unwrap().m_ez;
            assert!((free - b * free_space_left).amax() < 1e-3 * b.amax(), "{free}");
            // The touch and the contact phase: the offset no longer moves.
            for _ in 0..3000 {
                id = Some(icu.identify(&arm, &meas(m_wz + b + contact), &zero, &base, false, dt));
            }
            let loaded = id.unwrap();
            let expect = contact + b * free_space_left;
            assert!(
                (loaded.m_ez - expect).amax() < 1e-3 * contact.amax(),
                "{}",
                loaded.m_ez
            );
            if tare_s > 0.0 {
                assert!((loaded.f_imp_base - f).norm() < 0.1, "{}", loaded.f_imp_base);
            }
        }
    }
}
