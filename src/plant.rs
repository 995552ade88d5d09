//! The simulated plant: the floating vehicle–manipulator multibody with its hydrodynamics, the
//! joint drives and the thrusters, advanced by fixed steps.
//!
//! One [`Plant::step`] of `dt`:
//! 1. the drive torques are clipped to the joints' torque limits;
//! 2. the multibody is integrated over `dt` (RK4 or semi-implicit Euler, see
//!    [`crate::integrate`]) with the thrusters' present wrench, the drive torques and the
//!    environment's tool wrench held (zero-order hold), or, in the semi-implicit step, its
//!    velocity dependence linearly implicit ([`Plant::step_with_tool_damping`]);
//! 3. the thrusters' rotors follow their commands over `dt` (exact first-order lag).
//!
//! A state that stops being finite ends the run with [`crate::Error::Failed`] (stage `sim`).

use crate::arm::JointVector;
use crate::error::{Error, Result};
use crate::integrate::{Integrator, exp_twist, rk4};
use crate::model::{N_JOINTS, UvmsModel};
use crate::multibody::{Accelerations, Inputs, Multibody, State, ToolDamping};
use crate::spatial_algebra::Force;
use crate::vehicle::thrusters::Thrusters;
use nalgebra::{Isometry3, Quaternion, SVector, Translation3, UnitQuaternion, Vector3, Vector6};

/// Length of the packed state `[p (3), quaternion (i, j, k, w), q (6), ν (6), q̇ (6)]`.
const NX: usize = 3 + 4 + 3 * N_JOINTS;
type Packed = SVector<f64, NX>;

/// The commands and loads held over one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantInput<'a> {
    /// Drive torques on the link side, N·m (clipped to the torque limits).
    pub tau_drive: JointVector,
    /// Thrust command per thruster, N.
    pub thrust_cmd: &'a [f64],
    /// The environment's wrench on the tool: world (NED) axes, moment about the tool point.
    pub f_env_on_tool: Force,
}

/// What happened over a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The accelerations the step integrated, with the shaft torques and the tool force of the
    /// step: RK4's first evaluation; for semi-implicit Euler the linearly implicit ones (the
    /// friction and the tool force at the step's end velocity, to first order).
    pub accelerations: Accelerations,
    /// The accelerations and shaft torques at the step's start, what instruments sampling the
    /// plant at that instant read: the state and the inputs there give them. RK4's first
    /// evaluation; for semi-implicit Euler the explicit solve at the start state (not the
    /// step's: a joint held by the steep friction answers a step of its drive torque at once
    /// by `H⁻¹ Δτ`, which the implicit step spreads over the step as `(H + h D)⁻¹ Δτ`).
    pub sample: Accelerations,
    /// The drive torques applied after clipping, N·m.
    pub tau_applied: JointVector,
    /// The thrusters' wrench applied over the step (`C` axes, about `C`'s origin).
    pub thruster_wrench: Force,
}

/// The plant: multibody, thrusters and their state.
#[derive(Debug, Clone)]
pub struct Plant {
    /// The floating multibody.
    pub system: Multibody,
    /// The thrusters with their rotor states.
    pub thrusters: Thrusters,
    /// The multibody's state.
    pub state: State,
    /// The integration method.
    pub integrator: Integrator,
    /// Simulated time, s.
    pub time: f64,
}

impl Plant {
    /// A plant of `model` starting at `initial` with thrusters at rest.
    ///
    /// # Errors
    /// [`Error::Input`] if the model does not validate or the initial state is not finite.
    pub fn new(model: &UvmsModel, initial: State, integrator: Integrator) -> Result<Self> {
        if !initial.is_finite() {
            return Err(Error::input("initial state", "not finite"));
        }
        Ok(Plant {
            system: Multibody::new(model)?,
            thrusters: Thrusters::new(&model.thrusters)?,
            state: initial,
            integrator,
            time: 0.0,
        })
    }

    /// Advances the plant by `dt` seconds.
    ///
    /// # Errors
    /// [`Error::Input`] for a wrong thrust command or a non-positive `dt`; [`Error::Failed`]
    /// (stage `sim`) if the state stops being finite or the mass matrix loses definiteness.
    pub fn step(&mut self, dt: f64, input: &PlantInput) -> Result<StepReport> {
        self.step_with_tool_damping(dt, input, None)
    }

    /// [`Plant::step`] with the environment's tool force depending on the tool point's velocity
    /// with the slope `tool` (−∂F/∂v and the tool point's Jacobian at the step's start): the
    /// semi-implicit Euler step takes it linearly implicit
    /// ([`Multibody::step_accelerations`]), the force applied over the step is the report's
    /// `accelerations.tool_force`; RK4 holds `input.f_env_on_tool` (explicit).
    ///
    /// # Errors
    /// As [`Plant::step`].
    pub fn step_with_tool_damping(
        &mut self,
        dt: f64,
        input: &PlantInput,
        tool: Option<&ToolDamping>,
    ) -> Result<StepReport> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::input("dt", "must be a positive number of seconds"));
        }
        let tau = JointVector::from_fn(|i, _| {
            let lim = self.system.arm.links[i].torque_limit;
            input.tau_drive[i].clamp(-lim, lim)
        });
        let u = Inputs {
            tau_drive: tau,
            body_wrench: self.thrusters.wrench(),
            f_env_on_tool: input.f_env_on_tool,
        };
        let (next, acc, sample) = match self.integrator {
            Integrator::Rk4 => {
                let mut first = None;
                let x = rk4(&pack(&self.state), dt, |x| {
                    let (rate, acc) = self.rate(x, &u)?;
                    first.get_or_insert(acc);
                    Ok::<_, Error>(rate)
                })?;
                let acc = first.ok_or_else(|| Error::failed("sim", "RK4 made no evaluation"))?;
                (unpack(&x), acc, acc)
            }
            Integrator::SemiImplicitEuler => {
                let (acc, sample) = self.system.step_accelerations(&self.state, &u, dt, tool)?;
                let s = &self.state;
                let nu = s.nu + acc.nu_dot * dt;
                let qd = s.qd + acc.qdd * dt;
                let next = State {
                    t_world_body: exp_twist(&s.t_world_body, &nu, dt),
                    nu,
                    q: s.q + qd * dt,
                    qd,
                };
                (next, acc, sample)
            }
        };
        if !next.is_finite() {
            return Err(Error::failed(
                "plant",
                format!("the state diverged at t = {:.6} s", self.time + dt),
            ));
        }
        self.thrusters.step(dt, input.thrust_cmd)?;
        self.state = next;
        self.time += dt;
        Ok(StepReport {
            accelerations: acc,
            sample,
            tau_applied: tau,
            thruster_wrench: u.body_wrench,
        })
    }

    /// The rate of the packed state, and the accelerations.
    fn rate(&self, x: &Packed, u: &Inputs) -> Result<(Packed, Accelerations)> {
        let s = unpack_raw(x);
        let acc = self.system.accelerations(&s.0, u)?;
        // The rate of the stage's unnormalised quaternion keeps RK4 a plain vector method.
        let (pd, qd_raw) = Multibody::pose_rate(&s.1, &s.0.nu);
        let mut r = Packed::zeros();
        r.fixed_rows_mut::<3>(0).copy_from(&pd);
        r.fixed_rows_mut::<4>(3).copy_from(&qd_raw.coords);
        r.fixed_rows_mut::<N_JOINTS>(7).copy_from(&s.0.qd);
        r.fixed_rows_mut::<6>(7 + N_JOINTS).copy_from(&acc.nu_dot);
        r.fixed_rows_mut::<N_JOINTS>(13 + N_JOINTS).copy_from(&acc.qdd);
        Ok((r, acc))
    }
}

fn pack(s: &State) -> Packed {
    let mut x = Packed::zeros();
    x.fixed_rows_mut::<3>(0)
        .copy_from(&s.t_world_body.translation.vector);
    x.fixed_rows_mut::<4>(3)
        .copy_from(&s.t_world_body.rotation.coords);
    x.fixed_rows_mut::<N_JOINTS>(7).copy_from(&s.q);
    x.fixed_rows_mut::<6>(7 + N_JOINTS).copy_from(&s.nu);
    x.fixed_rows_mut::<N_JOINTS>(13 + N_JOINTS).copy_from(&s.qd);
    x
}

/// The state of a packed vector (attitude normalised) and the raw quaternion.
fn unpack_raw(x: &Packed) -> (State, Quaternion<f64>) {
    let quat = Quaternion::from(x.fixed_rows::<4>(3).into_owned());
    let s = State {
        t_world_body: Isometry3::from_parts(
            Translation3::from(Vector3::from(x.fixed_rows::<3>(0).into_owned())),
            UnitQuaternion::from_quaternion(quat),
        ),
        q: x.fixed_rows::<N_JOINTS>(7).into_owned(),
        nu: Vector6::from(x.fixed_rows::<6>(7 + N_JOINTS).into_owned()),
        qd: x.fixed_rows::<N_JOINTS>(13 + N_JOINTS).into_owned(),
    };
    (s, quat)
}

fn unpack(x: &Packed) -> State {
    unpack_raw(x).0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plant() -> Plant {
        let s = State::at_rest(
            Isometry3::identity(),
            JointVector::new(0.0, 0.9, -2.0, 0.0, 0.5, 0.0),
        );
        Plant::new(&UvmsModel::default(), s, Integrator::Rk4).unwrap()
    }

    #[test]
    fn drive_torques_are_clipped_to_the_limits() {
        let mut p = plant();
        let cmd = [0.0; 6];
        let input = PlantInput {
            tau_drive: JointVector::new(500.0, -500.0, 10.0, 0.0, 0.0, 0.0),
            thrust_cmd: &cmd,
            f_env_on_tool: Force::ZERO,
        };
        let r = p.step(1e-3, &input).unwrap();
        assert_eq!(r.tau_applied[0], 97.6);
        assert_eq!(r.tau_applied[1], -186.4);
        assert_eq!(r.tau_applied[2], 10.0);
        assert!((p.time - 1e-3).abs() < 1e-15);
    }

    #[test]
    fn bad_steps_are_input_errors() {
        let mut p = plant();
        let input = PlantInput {
            tau_drive: JointVector::zeros(),
            thrust_cmd: &[0.0; 6],
            f_env_on_tool: Force::ZERO,
        };
        assert_eq!(p.step(0.0, &input).unwrap_err().exit_code(), 2);
        let short = PlantInput {
            thrust_cmd: &[0.0; 3],
            ..input
        };
        assert_eq!(p.step(1e-3, &short).unwrap_err().exit_code(), 2);
        let mut s = p.state;
        s.nu[0] = f64::NAN;
        assert!(Plant::new(&UvmsModel::default(), s, Integrator::Rk4).is_err());
    }
}
