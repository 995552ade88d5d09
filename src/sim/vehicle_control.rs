//! AUV SS, the vehicle's stabilisation system of Figure 4, in the hovering mode.
//!
//! The body wrench asked of the thrusters is the sum of
//! - a closed loop (PID) on the pose error as NS knows it: position and velocity from the
//!   navigation filter (accelerometers and the delayed vision fix), attitude and rates from the
//!   gyros; errors in the body frame `C`;
//! - the model's restoring wrench `g(η)` of the vehicle itself (weight at the centre of gravity,
//!   buoyancy at the centre of buoyancy), cancelled at the measured attitude;
//! - the open loop of eq. (17): minus the force and moment the manipulator exerts on the
//!   vehicle, `ᶜF = ᶜF_D + ᶜ_G A ᴳF_e`, `ᶜM = ᶜM_D + ᶜM_e`, from the IDP of the arm (its motion,
//!   weight, buoyancy and water forces: `F_D`, `M_D`) loaded with the identified tool force
//!   (`F_e`, `M_e`) — computed by the caller with [`crate::arm::Arm::inverse_dynamics`].
//!
//! The wrench is then allocated to the thrusters ([`crate::vehicle::thrusters::Thrusters::allocate`]).

use super::navigation::Navigation;
use super::sensors::Measurements;
use crate::body::Body;
use crate::config::non_negative;
use crate::error::Result;
use crate::spatial_algebra::Force;
use nalgebra::{Isometry3, Vector3, Vector6};
use serde::{Deserialize, Serialize};

/// Stabilisation gains (`[sim.vehicle]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleControlConfig {
    /// Position gain, N/m.
    pub position_kp: f64,
    /// Position integral gain, N/(m·s).
    pub position_ki: f64,
    /// Position rate gain, N·s/m.
    pub position_kd: f64,
    /// Attitude gain, N·m/rad.
    pub attitude_kp: f64,
    /// Attitude integral gain, N·m/(rad·s).
    pub attitude_ki: f64,
    /// Attitude rate gain, N·m·s/rad.
    pub attitude_kd: f64,
}

/// The position gains are those a 0.25 s old feedback did not allow: on the navigation's
/// estimate (no delay) the position loop is about 1.8 rad/s, critically damped, with the
/// vehicle's mass and added mass (≈ 600 kg).
impl Default for VehicleControlConfig {
    fn default() -> Self {
        VehicleControlConfig {
            position_kp: 2000.0,
            position_ki: 50.0,
            position_kd: 2200.0,
            attitude_kp: 600.0,
            attitude_ki: 60.0,
            attitude_kd: 300.0,
        }
    }
}

impl VehicleControlConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.vehicle.position_kp", self.position_kp)?;
        non_negative("sim.vehicle.position_ki", self.position_ki)?;
        non_negative("sim.vehicle.position_kd", self.position_kd)?;
        non_negative("sim.vehicle.attitude_kp", self.attitude_kp)?;
        non_negative("sim.vehicle.attitude_ki", self.attitude_ki)?;
        non_negative("sim.vehicle.attitude_kd", self.attitude_kd)
    }
}

/// The stabilisation system with its integrators and velocity estimate.
#[derive(Debug, Clone)]
pub struct VehicleControl {
    cfg: VehicleControlConfig,
    hover: Isometry3<f64>,
    integral: Vector6<f64>,
}

impl VehicleControl {
    /// Holding the stabilisation pose `hover` (`t_world_body`), which is also the pose the
    /// vision system reported before the run.
    pub fn new(cfg: &VehicleControlConfig, hover: &Isometry3<f64>) -> Self {
        VehicleControl {
            cfg: *cfg,
            hover: *hover,
            integral: Vector6::zeros(),
        }
    }

    /// The body wrench (`C` axes, about `C`'s origin) for the measurements `m` (attitude and
    /// rates) and the navigation's position and velocity `nav`, with
    /// `vehicle` the controller's model of the vehicle body, `g` gravity (m/s²) and
    /// `open_loop` the wrench of eq. (17) to add (already negated: what the thrusters must
    /// supply to cancel the manipulator's action), over a control period `dt`.
    pub fn wrench(
        &mut self,
        m: &Measurements,
        nav: &Navigation,
        vehicle: &Body,
        g: f64,
        open_loop: &Force,
        dt: f64,
    ) -> Vector6<f64> {
        let c = &self.cfg;
        let r = m.attitude;
        let e_pos = r.inverse() * (self.hover.translation.vector - nav.position);
        let e_att = (r.inverse() * self.hover.rotation).scaled_axis();
        let v_body = r.inverse() * nav.velocity;
        let mut e = Vector6::zeros();
        e.fixed_rows_mut::<3>(0).copy_from(&e_pos);
        e.fixed_rows_mut::<3>(3).copy_from(&e_att);
        self.integral += e * dt;
        let lin =
            e_pos * c.position_kp + self.integral.fixed_rows::<3>(0) * c.position_ki - v_body * c.position_kd;
        let ang = e_att * c.attitude_kp + self.integral.fixed_rows::<3>(3) * c.attitude_ki
            - m.omega * c.attitude_kd;
        // Cancel the vehicle's own weight and buoyancy at the measured attitude.
        let g_body = r.inverse() * Vector3::new(0.0, 0.0, g);
        let restoring = Force::new(g_body * vehicle.net_mass, vehicle.net_first_moment.cross(&g_body));
        let mut tau = Vector6::zeros();
        tau.fixed_rows_mut::<3>(0)
            .copy_from(&(lin - restoring.lin + open_loop.lin));
        tau.fixed_rows_mut::<3>(3)
            .copy_from(&(ang - restoring.ang + open_loop.ang));
        tau
    }
}
