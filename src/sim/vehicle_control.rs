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
//!   (`F_e`, `M_e`) — computed by the caller with [`crate::arm::Arm::inverse_dynamics`]. The
//!   thrusters follow their command with a first-order lag (0.2 s on the model's), which left
//!   the vehicle to take a fast change of the manipulator's action alone: when the soil's force
//!   on the sampler turned by 126 N within 0.4 s at the drag's start, the vehicle turned by
//!   40 mrad and drifted 23 mm. The open loop therefore passes the lag's inverse behind a short
//!   low-pass (`open_loop_lag_s`), so the thrust follows it with that lag instead.
//!
//! The wrench is then allocated to the thrusters ([`crate::vehicle::thrusters::Thrusters::allocate`]).
//!
//! The controllers' model knows no sea current, but the stabilisation feels one: until the
//! tool touches, the closed loop's linear thrust, low-passed over `current_filter_s`, is what
//! holds the vehicle against the water, and the vehicle's drag model gives the relative
//! velocity that meets it ([`VehicleControl::current`]). The IDP takes that current, so the
//! water's drag on the arm goes into `M_wz` and the open loop instead of into the identified
//! external moments, where it reads as contact. From the touch on the estimate is held: the
//! thrust then also holds the errors of the identified tool force (several newtons of the
//! sampler's 100 N in soil), which it cannot tell from the water's drag; learnt through the
//! soil run's contact, the estimate wandered by 8 cm/s and the identification's median error
//! rose from 0.21 to 0.30 N·m. A vehicle with a water track (a DVL's: the water's velocity past
//! it, `[sim.sensors] water_track_rate_hz`) measures the current instead, through the contact
//! too: the pings turned into the world plus the vehicle's velocity, low-passed over
//! `water_track_filter_s`.

use super::navigation::Navigation;
use super::sensors::Measurements;
use crate::body::Body;
use crate::config::non_negative;
use crate::error::Result;
use crate::integrate::lag_gain;
use crate::spatial_algebra::{Force, Motion};
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
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
    /// The open loop of eq. (17) passes the inverse of the thrusters' first-order lag behind a
    /// low-pass of this time constant, so that the thrust follows the manipulator's action with
    /// this lag instead of the thrusters' own, s (0: no compensation).
    pub open_loop_lag_s: f64,
    /// Time constant of the low-pass on the closed loop's linear thrust from which the sea
    /// current is estimated, s (0: the controllers assume still water).
    pub current_filter_s: f64,
    /// Time constant of the low-pass on the water track's pings (with
    /// `[sim.sensors] water_track_rate_hz`), from which the current is then estimated, s
    /// (`current_filter_s = 0` assumes still water and leaves the track unused).
    pub water_track_filter_s: f64,
    /// Time constant of the low-pass on the rate of that estimate, the water's acceleration
    /// that the IDP then takes and whose push on the hull the stabilisation cancels, s (0: the
    /// water taken as not accelerating).
    pub water_track_rate_filter_s: f64,
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
            open_loop_lag_s: 0.05,
            current_filter_s: 5.0,
            water_track_filter_s: 0.1,
            water_track_rate_filter_s: 0.3,
        }
    }
}

impl VehicleControlConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.vehicle.position_kp", self.position_kp)?;
        non_negative("sim.vehicle.position_ki", self.position_ki)?;
        non_negative("sim.vehicle.position_kd", self.position_kd)?;
        non_negative("sim.vehicle.attitude_kp", self.attitude_kp)?;
        non_negative("sim.vehicle.attitude_ki", self.attitude_ki)?;
        non_negative("sim.vehicle.attitude_kd", self.attitude_kd)?;
        non_negative("sim.vehicle.open_loop_lag_s", self.open_loop_lag_s)?;
        non_negative("sim.vehicle.current_filter_s", self.current_filter_s)?;
        non_negative("sim.vehicle.water_track_filter_s", self.water_track_filter_s)?;
        non_negative(
            "sim.vehicle.water_track_rate_filter_s",
            self.water_track_rate_filter_s,
        )
    }
}

/// The stabilisation system with its integrators and velocity estimate.
#[derive(Debug, Clone)]
pub struct VehicleControl {
    cfg: VehicleControlConfig,
    hover: Isometry3<f64>,
    integral: Vector6<f64>,
    /// The thrusters' time constant (the controller's model), s.
    thruster_lag_s: f64,
    /// The open loop's low-pass (none before the first period).
    open_loop_low_pass: Option<Vector6<f64>>,
    /// The closed loop's linear thrust, low-passed (`C` axes), N.
    holding: Vector3<f64>,
    /// Whether the low-pass takes the thrust in (the current is being learnt).
    learning: bool,
    /// The current's estimate (world), m/s.
    estimate: Vector3<f64>,
    /// The water track's pings in the world, low-passed (none without a water track), m/s.
    flow: Option<Vector3<f64>>,
    /// That estimate's rate, low-passed, m/s².
    flow_rate: Vector3<f64>,
}

impl VehicleControl {
    /// Holding the stabilisation pose `hover` (`t_world_body`), which is also the pose the
    /// vision system reported before the run.
    /// `thruster_lag_s` is the thrusters' first-order time constant in the controller's model
    /// (their mean if they differ).
    pub fn new(cfg: &VehicleControlConfig, hover: &Isometry3<f64>, thruster_lag_s: f64) -> Self {
        VehicleControl {
            cfg: *cfg,
            hover: *hover,
            integral: Vector6::zeros(),
            thruster_lag_s,
            open_loop_low_pass: None,
            holding: Vector3::zeros(),
            learning: true,
            estimate: Vector3::zeros(),
            flow: None,
            flow_rate: Vector3::zeros(),
        }
    }

    /// Sets the integral so that the closed loop, at no error, asks for `wrench` (`[F; M]`,
    /// `C` axes) — what it had converged to while the station was held before the run — and
    /// the current's estimate to what that linear part holds against. An axis without
    /// integral gain keeps its integral at zero: the loop then asks for less than `wrench`,
    /// and, at no error, holds nothing against the current (the vehicle settles off the
    /// station by what is left over the position gain).
    pub fn trim(&mut self, wrench: &Vector6<f64>) {
        let c = &self.cfg;
        for i in 0..6 {
            let ki = if i < 3 { c.position_ki } else { c.attitude_ki };
            self.integral[i] = if ki > 0.0 { wrench[i] / ki } else { 0.0 };
        }
        self.holding = if c.position_ki > 0.0 {
            wrench.fixed_rows::<3>(0).into_owned()
        } else {
            Vector3::zeros()
        };
    }

    /// The water track's reading at the station held before the run (`C` axes, the vehicle at
    /// `attitude`), where its low-pass had converged; none without a water track.
    pub fn settle_water_track(&mut self, flow: Option<Vector3<f64>>, attitude: &UnitQuaternion<f64>) {
        self.flow = flow.map(|f| attitude * f);
    }

    /// Whether the current is learnt from the thrust from now on (`true` at the start; the
    /// simulation learns it until the ICU judges the tool has touched), or the estimate held.
    pub fn learn_current(&mut self, on: bool) {
        self.learning = on;
    }

    /// The sea current the controllers assume (world axes, m/s) for the vehicle `vehicle`
    /// (the controllers' model) at `attitude`: the water's velocity past the station, opposite
    /// to the vehicle's velocity through the water at which its drag meets the low-passed
    /// linear thrust of the closed loop ([`Body::velocity_against_drag`]). It is the flow past
    /// the vehicle on average, as the IDP wants it: the IDP's base has no linear velocity of
    /// its own (the controllers feed it the gyros' rates alone). While the current is learnt
    /// the estimate follows the thrust; held, it stays as it was, in the world. With a water
    /// track (`[sim.sensors] water_track_rate_hz`) it is the track's pings instead, turned into
    /// the world and low-passed over `water_track_filter_s`, through the contact too (the
    /// track does not feel the tool). Still water with `current_filter_s = 0` (the water
    /// track unused too) or, without a water track, a vehicle without Fossen damping.
    pub fn current(&mut self, vehicle: &Body, attitude: &UnitQuaternion<f64>) -> Vector3<f64> {
        if self.cfg.current_filter_s <= 0.0 {
            return Vector3::zeros();
        }
        if let Some(flow) = self.flow {
            // Measured, through the contact too: the water track does not see the tool.
            self.estimate = flow;
        } else if self.learning {
            self.estimate = vehicle
                .velocity_against_drag(&self.holding)
                .map_or_else(Vector3::zeros, |u| -(attitude * u));
        }
        self.estimate
    }

    /// The water's acceleration the controllers assume (world axes, m/s²): with a water track
    /// and `water_track_rate_filter_s > 0`, the rate of the track's estimate of the current
    /// ([`VehicleControl::current`]) low-passed over that time; none otherwise (nothing else
    /// measures it).
    pub fn current_rate(&self) -> Vector3<f64> {
        let c = &self.cfg;
        if self.flow.is_some() && c.current_filter_s > 0.0 && c.water_track_rate_filter_s > 0.0 {
            self.flow_rate
        } else {
            Vector3::zeros()
        }
    }

    /// The command that makes thrusters of time constant `τ_T` (held over the period) deliver
    /// `open_loop` through a first-order low-pass of `τ_f = open_loop_lag_s`: the thrust that
    /// is the low-pass's output `y` now moves to its next value, `y + (x − y) k_f / k_T` with
    /// `k = 1 − e^(−dt/τ)` (the lag's inverse `1 + τ_T s` after `1/(1 + τ_f s)`, exact for the
    /// held command).
    fn lead(&mut self, open_loop: &Force, dt: f64) -> Force {
        let tf = self.cfg.open_loop_lag_s;
        // Nothing to compensate for thrusters without lag; nothing to do in no time.
        let k_t = lag_gain(dt, self.thruster_lag_s);
        if tf <= 0.0 || self.thruster_lag_s <= 0.0 || k_t <= 0.0 {
            return *open_loop;
        }
        let x = open_loop.to_vector6();
        let y = self.open_loop_low_pass.get_or_insert(x);
        let step = (x - *y) * lag_gain(dt, tf);
        let command = *y + step / k_t;
        *y += step;
        Force::from_vector6(&command)
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
        let open_loop = self.lead(open_loop, dt);
        let c = &self.cfg;
        if let (Some(flow), Some(ping)) = (self.flow.as_mut(), m.water_flow) {
            // The water's velocity over the ground: the flow past the vehicle plus the
            // vehicle's own velocity (the IDP takes the vehicle's linear motion as none).
            let water = m.attitude * ping + nav.velocity;
            let step = (water - *flow) * lag_gain(dt, c.water_track_filter_s);
            *flow += step;
            if dt > 0.0 {
                self.flow_rate += (step / dt - self.flow_rate) * lag_gain(dt, c.water_track_rate_filter_s);
            }
        }
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
        if self.learning && c.current_filter_s > 0.0 {
            self.holding += (lin - self.holding) * lag_gain(dt, c.current_filter_s);
        }
        // Cancel the vehicle's own weight and buoyancy at the measured attitude.
        let g_body = r.inverse() * Vector3::new(0.0, 0.0, g);
        let restoring = Force::new(g_body * vehicle.net_mass, vehicle.net_first_moment.cross(&g_body));
        let mut tau = Vector6::zeros();
        tau.fixed_rows_mut::<3>(0)
            .copy_from(&(lin - restoring.lin + open_loop.lin));
        tau.fixed_rows_mut::<3>(3)
            .copy_from(&(ang - restoring.ang + open_loop.ang));
        // Cancel the push of the water's acceleration on the hull (the displaced water's and
        // the added mass's), as eq. (17) cancels the arm's, when the water track gives it.
        let rate = self.current_rate();
        if rate != Vector3::zeros() {
            let z = Vector3::zeros();
            let held = vehicle.wrench(&Motion::ZERO, &Motion::ZERO, &z, &z, &(r.inverse() * rate));
            tau += held.to_vector6();
        }
        tau
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the sensors read of a vehicle at rest at `position` with `attitude`, in gravity `g`
    /// (the accelerometers read `−g`; the wrench uses the attitude and rates alone).
    fn read_at_rest(attitude: UnitQuaternion<f64>, position: Vector3<f64>, g: f64) -> Measurements {
        Measurements {
            q: crate::arm::JointVector::zeros(),
            qd: crate::arm::JointVector::zeros(),
            m_dz: crate::arm::JointVector::zeros(),
            attitude,
            omega: Vector3::zeros(),
            specific_force: attitude.inverse() * Vector3::new(0.0, 0.0, -g),
            position,
            position_time: 0.0,
            water_flow: None,
        }
    }

    /// A step of the open loop reaches thrusters of the model's lag through the compensation
    /// as the first-order response of `open_loop_lag_s` (to round-off); without it, with the
    /// thrusters' own 0.2 s.
    #[test]
    fn open_loop_thrust_follows_with_the_short_lag() {
        let (dt, tau_t) = (1e-3, 0.2);
        let step = Force::new(Vector3::new(100.0, 0.0, 0.0), Vector3::new(0.0, 0.0, -40.0));
        let thrust_after = |lag_s: f64, t: f64| {
            let cfg = VehicleControlConfig {
                open_loop_lag_s: lag_s,
                ..VehicleControlConfig::default()
            };
            let mut vc = VehicleControl::new(&cfg, &Isometry3::identity(), tau_t);
            // At rest before the step, then the thrusters' exact lag with the command held.
            let mut thrust = vc.lead(&Force::ZERO, dt).to_vector6();
            let k = lag_gain(dt, tau_t);
            for _ in 0..(t / dt).round() as usize {
                let command = vc.lead(&step, dt).to_vector6();
                thrust += (command - thrust) * k;
            }
            thrust
        };
        let target = step.to_vector6();
        for t in [0.01, 0.05, 0.2, 0.5] {
            let expected = target * (1.0 - (-t / 0.05f64).exp());
            let got = thrust_after(0.05, t);
            assert!(
                (got - expected).amax() < 1e-9 * target.amax(),
                "{t}: {got} {expected}"
            );
        }
        // Without the compensation the thrust after 50 ms is 22 % of the step, not 63 %.
        let plain = thrust_after(0.0, 0.05)[0];
        assert!(
            (plain - 100.0 * (1.0 - (-0.05f64 / tau_t).exp())).abs() < 1e-9,
            "{plain}"
        );
    }

    /// The stabilisation's parts, each against the physics it answers: at the station, at
    /// rest, tilted, the thrust is what holds the vehicle's weight and buoyancy (its equation
    /// of motion at rest, [`Body::wrench`]) plus the open loop of eq. (17) as given; off the
    /// station it pushes back towards it by `position_kp` per metre, and moving it pushes
    /// against the motion by `position_kd` per m/s (world axes).
    #[test]
    fn the_stabilisation_holds_the_weight_pushes_back_and_damps() {
        use crate::spatial_algebra::Motion;
        let vehicle = crate::multibody::Multibody::new(&crate::model::UvmsModel::default())
            .unwrap()
            .vehicle;
        let g = 9.81;
        let attitude = UnitQuaternion::from_euler_angles(0.1, -0.05, 0.3);
        let hover = Isometry3::from_parts(Vector3::new(1.0, 2.0, 3.0).into(), attitude);
        // No integral, no lead on the open loop, still water: the loop's parts alone.
        let cfg = VehicleControlConfig {
            position_ki: 0.0,
            attitude_ki: 0.0,
            open_loop_lag_s: 0.0,
            current_filter_s: 0.0,
            ..VehicleControlConfig::default()
        };
        let open_loop = Force::new(Vector3::new(30.0, -20.0, 10.0), Vector3::new(5.0, 4.0, -3.0));
        let m = read_at_rest(attitude, hover.translation.vector, g);
        let thrust = |position: Vector3<f64>, velocity: Vector3<f64>| {
            let mut nav = Navigation::new(&Default::default(), &Default::default(), position, g);
            nav.velocity = velocity;
            let mut vc = VehicleControl::new(&cfg, &hover, 0.2);
            vc.wrench(&m, &nav, &vehicle, g, &open_loop, 1e-3)
        };
        let at_station = thrust(hover.translation.vector, Vector3::zeros());
        let g_body = attitude.inverse() * Vector3::new(0.0, 0.0, g);
        let holding = vehicle.wrench(
            &Motion::ZERO,
            &Motion::ZERO,
            &g_body,
            &Vector3::zeros(),
            &Vector3::zeros(),
        );
        let expected = holding.to_vector6() + open_loop.to_vector6();
        assert!(
            (at_station - expected).amax() < 1e-9,
            "{at_station} vs {expected}"
        );
        let world_lin = |tau: Vector6<f64>| attitude * (tau - at_station).fixed_rows::<3>(0).into_owned();
        let off = world_lin(thrust(
            hover.translation.vector + Vector3::new(0.1, 0.0, 0.0),
            Vector3::zeros(),
        ));
        assert!(
            (off - Vector3::new(-0.1 * cfg.position_kp, 0.0, 0.0)).norm() < 1e-6,
            "{off}"
        );
        let moving = world_lin(thrust(hover.translation.vector, Vector3::new(0.0, 0.2, 0.0)));
        assert!(
            (moving - Vector3::new(0.0, -0.2 * cfg.position_kd, 0.0)).norm() < 1e-6,
            "{moving}"
        );
    }

    /// The default model's vehicle (the controllers' own) and an attitude turned on every axis.
    fn vehicle_turned() -> (Body, UnitQuaternion<f64>) {
        let vehicle = crate::multibody::Multibody::new(&crate::model::UvmsModel::default())
            .unwrap()
            .vehicle;
        (vehicle, UnitQuaternion::from_euler_angles(0.05, -0.03, 1.2))
    }

    /// A stabilisation trimmed to hold its vehicle at rest against the drag of a current
    /// reports that current (world axes, the vehicle turned); without integral gain the loop
    /// holds nothing at the station (its error zero) and reports still water. While the
    /// current is not learnt the estimate stays, in the world, as the thrust changes and the
    /// vehicle turns; learnt, it follows the thrust. With `current_filter_s = 0` the
    /// controllers assume still water.
    #[test]
    fn the_trimmed_thrust_gives_the_current_back() {
        use crate::spatial_algebra::Motion;
        let (vehicle, attitude) = vehicle_turned();
        let current = Vector3::new(0.3, -0.2, 0.05);
        // At rest the vehicle moves through the water at `−c`, and the thrust holds the drag.
        let drag = vehicle.drag_on_body(&Motion::new(attitude.inverse() * -current, Vector3::zeros()));
        let mut holding = Vector6::zeros();
        holding.fixed_rows_mut::<3>(0).copy_from(&-drag.lin);
        let hover = Isometry3::from_parts(Vector3::zeros().into(), attitude);
        let trimmed = |cfg: &VehicleControlConfig| {
            let mut vc = VehicleControl::new(cfg, &hover, 0.2);
            assert_eq!(vc.current(&vehicle, &attitude), Vector3::zeros());
            vc.trim(&holding);
            vc
        };
        let cfg = VehicleControlConfig::default();
        let mut vc = trimmed(&cfg);
        let at_rest = vc.current(&vehicle, &attitude);
        assert!((at_rest - current).norm() < 1e-12, "{at_rest}");
        let no_integral = VehicleControlConfig {
            position_ki: 0.0,
            ..cfg
        };
        assert_eq!(
            trimmed(&no_integral).current(&vehicle, &attitude),
            Vector3::zeros()
        );
        // A decimetre off station: the closed loop's thrust changes.
        let nav = Navigation::new(
            &Default::default(),
            &Default::default(),
            Vector3::new(0.1, 0.0, 0.0),
            9.81,
        );
        let m = read_at_rest(attitude, Vector3::new(0.1, 0.0, 0.0), 9.81);
        let turned = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3) * attitude;
        let after_a_second = |learn: bool| {
            let mut vc = vc.clone();
            vc.learn_current(learn);
            for _ in 0..1000 {
                vc.wrench(&m, &nav, &vehicle, 9.81, &Force::ZERO, 1e-3);
            }
            vc.current(&vehicle, &turned)
        };
        assert_eq!(after_a_second(false), at_rest);
        assert!((after_a_second(true) - at_rest).norm() > 0.01);
        let still = VehicleControlConfig {
            current_filter_s: 0.0,
            ..cfg
        };
        assert_eq!(trimmed(&still).current(&vehicle, &attitude), Vector3::zeros());
        assert_eq!(vc.current(&vehicle, &attitude), at_rest);
    }

    /// With a water track the estimate is the track's: settled at the station to the flow it
    /// read, then following its pings (the flow past the vehicle turned into the world, plus
    /// the vehicle's velocity) through the filter's lag — held from the touch or not, since the
    /// track does not feel the tool.
    #[test]
    fn a_water_track_gives_the_current_through_the_contact() {
        let (vehicle, attitude) = vehicle_turned();
        let hover = Isometry3::from_parts(Vector3::zeros().into(), attitude);
        let cfg = VehicleControlConfig::default();
        let mut vc = VehicleControl::new(&cfg, &hover, 0.2);
        let current = Vector3::new(0.3, -0.2, 0.05);
        vc.settle_water_track(Some(attitude.inverse() * current), &attitude);
        assert!((vc.current(&vehicle, &attitude) - current).norm() < 1e-12);
        // The water turns to another current; the tool has touched.
        vc.learn_current(false);
        let turned = Vector3::new(-0.1, 0.2, 0.0);
        let mut m = read_at_rest(attitude, Vector3::zeros(), 9.81);
        // The vehicle moving at `v`: the track reads the flow past it, `turned − v`, and the
        // estimate is the water's velocity over the ground, `turned`.
        let mut nav = Navigation::new(&Default::default(), &Default::default(), Vector3::zeros(), 9.81);
        let v = Vector3::new(0.05, -0.02, 0.01);
        nav.velocity = v;
        m.water_flow = Some(attitude.inverse() * (turned - v));
        let dt = 1e-3;
        let steps = (cfg.water_track_filter_s / dt).round() as usize;
        for _ in 0..steps {
            vc.wrench(&m, &nav, &vehicle, 9.81, &Force::ZERO, dt);
        }
        // One time constant: 1 − 1/e of the way.
        let got = vc.current(&vehicle, &attitude);
        let expected = turned + (current - turned) * (-1.0f64).exp();
        assert!((got - expected).norm() < 1e-9, "{got} against {expected}");
    }

    /// Water whose velocity grows steadily: once the two lags have passed, the estimate of the
    /// water's acceleration is that acceleration (the derivative of a ramp through a lag is
    /// the ramp's slope), and the stabilisation adds the thrust that cancels its push on the
    /// hull (Morison's `(ρ∇ + M_A) ċ` at the centre of buoyancy, so the thrust `−(ρ∇ + M_A) ċ`),
    /// from the controllers' model; without a
    /// water track, or with the rate's filter off, neither.
    #[test]
    fn a_water_track_gives_the_water_s_acceleration() {
        let (vehicle, attitude) = vehicle_turned();
        let hover = Isometry3::from_parts(Vector3::zeros().into(), attitude);
        let cfg = VehicleControlConfig::default();
        let nav = Navigation::new(&Default::default(), &Default::default(), Vector3::zeros(), 9.81);
        let (start, slope) = (Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.02, -0.03, 0.005));
        let ramp = |cfg: &VehicleControlConfig, track: bool| {
            let mut vc = VehicleControl::new(cfg, &hover, 0.2);
            vc.settle_water_track(track.then(|| attitude.inverse() * start), &attitude);
            let mut m = read_at_rest(attitude, Vector3::zeros(), 9.81);
            let dt = 1e-3;
            let mut tau = Vector6::zeros();
            for k in 0..5000 {
                let water = start + slope * (k as f64 * dt);
                m.water_flow = track.then(|| attitude.inverse() * water);
                tau = vc.wrench(&m, &nav, &vehicle, 9.81, &Force::ZERO, dt);
            }
            (vc.current_rate(), tau)
        };
        let (rate, tau) = ramp(&cfg, true);
        assert!(
            (rate - slope).norm() < 1e-6 * slope.norm(),
            "{rate} against {slope}"
        );
        let off = VehicleControlConfig {
            water_track_rate_filter_s: 0.0,
            ..cfg
        };
        let (rate_off, tau_off) = ramp(&off, true);
        assert_eq!(rate_off, Vector3::zeros());
        assert_eq!(ramp(&cfg, false).0, Vector3::zeros());
        // The same closed loop but for the push's cancellation: the model hull's wrench held
        // at rest in water accelerating at the estimate (Morison's, `body::tests`), in `C`.
        let lhs = vehicle
            .wrench(
                &Motion::ZERO,
                &Motion::ZERO,
                &Vector3::zeros(),
                &Vector3::zeros(),
                &(attitude.inverse() * slope),
            )
            .to_vector6();
        assert!(
            (tau - tau_off - lhs).norm() < 1e-5 * lhs.norm(),
            "{} against {lhs}",
            tau - tau_off
        );
        assert!(lhs.norm() > 1.0);
    }
}
