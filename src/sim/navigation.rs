//! Navigation, the estimating half of NS (Figure 4): the vehicle's attitude, position and
//! velocity the controllers work with, from the sensors of [`super::sensors`].
//!
//! - **Attitude**: the gyros' rates integrated and pulled towards the measured attitude by a
//!   complementary filter of time constant `attitude_filter_s` (the rates' noise integrates to
//!   little, the attitude's noise is averaged). Fed raw, the attitude's noise, times the 1.5 m
//!   lever of the arm, shakes the IK set-points at the control rate and the arm's reaction on
//!   the vehicle with them.
//! - **Position and velocity** (world): the accelerometers' specific force, turned into the
//!   world with that attitude and gravity added back, integrated every control period (an
//!   inertial dead reckoning), and pulled towards the delayed vision fix by a third-order
//!   complementary filter (position, velocity, accelerometer bias; its three poles at
//!   `−position_bandwidth_rad_s`). The bias starts from the levelling at the station held
//!   before the run ([`Navigation::level`]: at rest the accelerometers read `−ᴼ_C Rᵀ g` plus
//!   their bias). A fix describes the vehicle `vision_delay_s` ago: it is
//!   compared with the estimate of that instant (kept in a history), and the correction is
//!   carried forward to now. Eq. (18) and the stabilisation then work with where the vehicle
//!   *is*, not where it was a quarter of a second ago: with the tool held by the surface or the
//!   soil, a correction that lags the vehicle by the fix's delay pushes the vehicle through the
//!   arm with the delay, an oscillation the stabilisation cannot damp.
//!
//!   The estimate the controllers see takes each fix's correction of the position in evenly
//!   over `correction_s` (by default the fixes' 0.1 s period), not at once: a jump of the
//!   position made eq. (18)'s set-points jump at every fix, and the joints' reference filter
//!   turned each into a step of the commanded accelerations — steps of 20 N·m of the
//!   shoulder's drive torque that the identification of the external moments could follow only
//!   a few periods late.

use super::sensors::Measurements;
use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::integrate::lag_gain;
use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Navigation filter parameters (`[sim.navigation]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavigationConfig {
    /// Time constant of the complementary filter on the attitude, s.
    pub attitude_filter_s: f64,
    /// Bandwidth of the complementary filter of the accelerometers and the vision fix, rad/s.
    pub position_bandwidth_rad_s: f64,
    /// Length of the levelling at the held station before the run (accelerometers averaged at
    /// the control rate), s.
    pub levelling_s: f64,
    /// Each fix's correction of the position passes into the estimate evenly over this long,
    /// s (0: at once).
    pub correction_s: f64,
}

impl Default for NavigationConfig {
    fn default() -> Self {
        NavigationConfig {
            attitude_filter_s: 1.0,
            position_bandwidth_rad_s: 0.5,
            levelling_s: 10.0,
            correction_s: 0.1,
        }
    }
}

impl NavigationConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.navigation.attitude_filter_s", self.attitude_filter_s)?;
        non_negative("sim.navigation.levelling_s", self.levelling_s)?;
        non_negative("sim.navigation.correction_s", self.correction_s)?;
        positive(
            "sim.navigation.position_bandwidth_rad_s",
            self.position_bandwidth_rad_s,
        )
    }
}

/// The navigation filters' state.
#[derive(Debug, Clone)]
pub struct Navigation {
    cfg: NavigationConfig,
    gravity: Vector3<f64>,
    /// The filtered attitude (none before the first measurement).
    attitude: Option<UnitQuaternion<f64>>,
    /// Estimated position of `C`'s origin (world), m, with the corrections passed on so far.
    pub position: Vector3<f64>,
    /// The filter's estimate of the position, with every correction.
    estimate: Vector3<f64>,
    /// The corrections not passed on yet, and how much of them passes per second.
    pending: (Vector3<f64>, Vector3<f64>),
    /// Estimated velocity of `C`'s origin (world), m/s.
    pub velocity: Vector3<f64>,
    bias: Vector3<f64>,
    /// Past estimates (time, position, velocity) not older than the latest fix.
    history: VecDeque<(f64, Vector3<f64>, Vector3<f64>)>,
    last_fix: f64,
}

impl Navigation {
    /// The vehicle at rest at `position` (the station held before the run), in gravity `g`
    /// (m/s², along +z of NED).
    pub fn new(cfg: &NavigationConfig, position: Vector3<f64>, g: f64) -> Self {
        Navigation {
            cfg: *cfg,
            gravity: Vector3::new(0.0, 0.0, g),
            attitude: None,
            position,
            estimate: position,
            pending: (Vector3::zeros(), Vector3::zeros()),
            velocity: Vector3::zeros(),
            bias: Vector3::zeros(),
            history: VecDeque::new(),
            last_fix: f64::NEG_INFINITY,
        }
    }

    /// Levelling at rest with the attitude `attitude`: the accelerometers' mean reading
    /// `specific_force` gives their bias.
    pub fn level(&mut self, specific_force: &Vector3<f64>, attitude: &UnitQuaternion<f64>) {
        self.bias = specific_force + attitude.inverse() * self.gravity;
    }

    /// Takes the measurements `m` read at time `t`, over a control period `dt`: returns them
    /// with the filtered attitude, and advances the position and velocity estimates.
    pub fn update(&mut self, mut m: Measurements, t: f64, dt: f64) -> Measurements {
        let predicted = self
            .attitude
            .map_or(m.attitude, |a| a * UnitQuaternion::from_scaled_axis(m.omega * dt));
        let attitude = predicted.slerp(&m.attitude, lag_gain(dt, self.cfg.attitude_filter_s));
        self.attitude = Some(attitude);
        m.attitude = attitude;
        // Dead reckoning.
        let a = attitude * (m.specific_force - self.bias) + self.gravity;
        self.estimate += self.velocity * dt + a * (0.5 * dt * dt);
        self.velocity += a * dt;
        self.history.push_back((t, self.estimate, self.velocity));
        // A new fix: the residual against the estimate of its instant, the correction carried
        // forward to now and through the history still ahead of it.
        if m.position_time > self.last_fix {
            if self.last_fix.is_finite() {
                while self.history.len() > 1 && self.history[1].0 <= m.position_time + 1e-12 {
                    self.history.pop_front();
                }
                if let Some(&(tf, pf, _)) = self.history.front() {
                    let w = self.cfg.position_bandwidth_rad_s;
                    let span = m.position_time - self.last_fix;
                    let e = m.position - pf;
                    let dp = e * (3.0 * w * span);
                    let dv = e * (3.0 * w * w * span);
                    self.bias -= attitude.inverse() * e * (w * w * w * span);
                    for (ti, pi, vi) in &mut self.history {
                        *pi += dp + dv * (*ti - tf);
                        *vi += dv;
                    }
                    let jump = dp + dv * (t - tf);
                    self.estimate += jump;
                    self.velocity += dv;
                    self.pending.0 += jump;
                    self.pending.1 = self.pending.0 / self.cfg.correction_s.max(dt);
                }
            }
            self.last_fix = m.position_time;
        }
        // The pending correction shrinks along a straight line to zero.
        let (left, rate) = &mut self.pending;
        let step = *rate * dt;
        *left = if step.norm_squared() >= left.norm_squared() {
            Vector3::zeros()
        } else {
            *left - step
        };
        self.position = self.estimate - *left;
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::JointVector;
    use crate::sim::sensors::{SensorConfig, Sensors, Truth};

    /// A vehicle oscillating at 0.7 Hz seen by biased, noisy accelerometers and the 0.25 s
    /// delayed fix: the estimate follows where the vehicle is now, far closer than the fix.
    #[test]
    fn estimate_tracks_the_vehicle_despite_the_delayed_fix() {
        let cfg = SensorConfig::default();
        let mut sensors = Sensors::new(&cfg, 3, Vector3::zeros());
        let mut nav = Navigation::new(&NavigationConfig::default(), Vector3::zeros(), 9.81);
        let (amp, w) = (0.02, 2.0 * std::f64::consts::PI * 0.7);
        let dt = 1e-3;
        let at = |t: f64| Truth {
            q: JointVector::zeros(),
            qd: JointVector::zeros(),
            shaft_torque: JointVector::zeros(),
            attitude: UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            position: Vector3::new(amp * (1.0 - (w * t).cos()), 0.0, 0.0),
            specific_force: Vector3::new(amp * w * w * (w * t).cos(), 0.0, -9.81),
        };
        // Levelled at rest at the start.
        let rest = Truth {
            specific_force: Vector3::new(0.0, 0.0, -9.81),
            ..at(0.0)
        };
        let n = 10_000;
        let mean = (0..n).fold(Vector3::zeros(), |acc, _| acc + sensors.accelerometers(&rest)) / n as f64;
        nav.level(&mean, &rest.attitude);
        let (mut worst_est, mut worst_fix) = (0.0_f64, 0.0_f64);
        for k in 0..20_000 {
            let t = k as f64 * dt;
            let truth = at(t);
            let m = nav.update(sensors.read(t, &truth), t, dt);
            if t > 1.0 {
                worst_est = worst_est.max((nav.position - truth.position).norm());
                worst_fix = worst_fix.max((m.position - truth.position).norm());
            }
        }
        assert!(worst_fix > 0.02, "{worst_fix}");
        assert!(worst_est < 0.004, "{worst_est} vs the fix's {worst_fix}");
    }

    /// A vehicle at rest, an estimate started 1 cm off and exact sensors: each fix's
    /// correction reaches the estimate in even steps over `correction_s`, never at once — and
    /// at once with `correction_s = 0`, the same corrections in all.
    #[test]
    fn a_fix_corrects_the_position_evenly_over_correction_s() {
        let sensor_cfg = SensorConfig {
            accelerometer_noise_m_s2: 0.0,
            accelerometer_bias_m_s2: 0.0,
            vision_noise_m: 0.0,
            ..SensorConfig::default()
        };
        let truth = Truth {
            q: JointVector::zeros(),
            qd: JointVector::zeros(),
            shaft_torque: JointVector::zeros(),
            attitude: UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            position: Vector3::zeros(),
            specific_force: Vector3::new(0.0, 0.0, -9.81),
        };
        let dt = 1e-3;
        let run = |correction_s: f64| {
            let cfg = NavigationConfig {
                correction_s,
                ..NavigationConfig::default()
            };
            let mut sensors = Sensors::new(&sensor_cfg, 1, Vector3::zeros());
            let mut nav = Navigation::new(&cfg, Vector3::new(0.01, 0.0, 0.0), 9.81);
            nav.level(&truth.specific_force, &truth.attitude);
            let mut last = nav.position;
            let mut biggest_step = 0.0_f64;
            for k in 0..3000 {
                nav.update(sensors.read(k as f64 * dt, &truth), k as f64 * dt, dt);
                biggest_step = biggest_step.max((nav.position - last).norm());
                last = nav.position;
            }
            (biggest_step, nav.position.x)
        };
        let (spread, x_spread) = run(0.1);
        let (at_once, x_at_once) = run(0.0);
        // The first fix's correction is 0.15 × 1 cm plus its velocity's part, about 1.7 mm:
        // at once it is one step; spread over 100 periods, a hundredth of that.
        assert!(at_once > 1.5e-3, "{at_once}");
        assert!(spread < at_once / 50.0, "{spread} vs {at_once}");
        // After 3 s the estimate has come most of the way back, the same way either way
        // (the spread corrections lag by at most one fix).
        assert!(
            x_spread.abs() < 0.005 && x_at_once.abs() < 0.005,
            "{x_spread} {x_at_once}"
        );
        assert!((x_spread - x_at_once).abs() < 2e-3, "{x_spread} {x_at_once}");
    }
}
