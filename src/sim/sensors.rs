//! NS, the navigation and sensing system of Figure 4: everything the controllers know of the
//! plant comes through here.
//!
//! - joint encoders (quantised angle) and tachometers (noisy rate);
//! - one-axis joint-torque sensors on the drives' output shafts: `M_dz` of eq. (1), with noise;
//! - gyros (an attitude and heading reference): attitude and body rates without delay, with noise;
//! - accelerometers (the inertial unit at `C`'s origin): the specific force `a − g` in `C` axes,
//!   with noise and a constant bias per axis (drawn once from the seed);
//! - the vision system: the vehicle's position relative to the (fixed) object, delayed by
//!   0.25 s, at a finite rate, with noise — the seed's delayed fix that eq. (18) works with.
//!
//! Every random draw comes from one `ChaCha8Rng` seeded from the configuration.

use crate::arm::JointVector;
use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::synth::random::NormalPairs;
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Sensor parameters (`[sim.sensors]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Encoder resolution, rad (link side).
    pub encoder_resolution_rad: f64,
    /// Standard deviation of the joint-rate measurement, rad/s.
    pub joint_rate_noise_rad_s: f64,
    /// Standard deviation of the joint-torque sensors, N·m.
    pub torque_noise_nm: f64,
    /// Standard deviation of the attitude angles, rad.
    pub attitude_noise_rad: f64,
    /// Standard deviation of the gyro rates, rad/s.
    pub gyro_noise_rad_s: f64,
    /// Standard deviation of the accelerometers, m/s².
    pub accelerometer_noise_m_s2: f64,
    /// Standard deviation of the accelerometers' constant bias (one draw per axis), m/s².
    pub accelerometer_bias_m_s2: f64,
    /// Delay of the vision system's position fix, s (the seed's 0.25 s).
    pub vision_delay_s: f64,
    /// Rate of the vision fixes, Hz.
    pub vision_rate_hz: f64,
    /// Standard deviation of each coordinate of a fix, m.
    pub vision_noise_m: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            encoder_resolution_rad: 2.0 * std::f64::consts::PI / 131_072.0,
            joint_rate_noise_rad_s: 1e-3,
            torque_noise_nm: 0.05,
            attitude_noise_rad: 2e-4,
            gyro_noise_rad_s: 1e-3,
            accelerometer_noise_m_s2: 0.02,
            accelerometer_bias_m_s2: 0.01,
            vision_delay_s: 0.25,
            vision_rate_hz: 10.0,
            vision_noise_m: 1e-3,
        }
    }
}

impl SensorConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.sensors.encoder_resolution_rad", self.encoder_resolution_rad)?;
        non_negative("sim.sensors.joint_rate_noise_rad_s", self.joint_rate_noise_rad_s)?;
        non_negative("sim.sensors.torque_noise_nm", self.torque_noise_nm)?;
        non_negative("sim.sensors.attitude_noise_rad", self.attitude_noise_rad)?;
        non_negative("sim.sensors.gyro_noise_rad_s", self.gyro_noise_rad_s)?;
        non_negative(
            "sim.sensors.accelerometer_noise_m_s2",
            self.accelerometer_noise_m_s2,
        )?;
        non_negative(
            "sim.sensors.accelerometer_bias_m_s2",
            self.accelerometer_bias_m_s2,
        )?;
        non_negative("sim.sensors.vision_delay_s", self.vision_delay_s)?;
        non_negative("sim.sensors.vision_noise_m", self.vision_noise_m)?;
        positive("sim.sensors.vision_rate_hz", self.vision_rate_hz)
    }
}

/// The true quantities the sensors read at one instant (from the plant).
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    /// Joint angles, rad.
    pub q: JointVector,
    /// Joint rates, rad/s.
    pub qd: JointVector,
    /// Output-shaft torques, N·m.
    pub shaft_torque: JointVector,
    /// Vehicle attitude in the world.
    pub attitude: UnitQuaternion<f64>,
    /// Vehicle angular velocity, body axes, rad/s.
    pub omega: Vector3<f64>,
    /// Vehicle position (origin of `C`) in the world, m.
    pub position: Vector3<f64>,
    /// Specific force at `C`'s origin (its acceleration minus gravity), `C` axes, m/s².
    pub specific_force: Vector3<f64>,
}

/// What the controllers get.
#[derive(Debug, Clone, Copy)]
pub struct Measurements {
    /// Encoder angles, rad.
    pub q: JointVector,
    /// Joint rates, rad/s.
    pub qd: JointVector,
    /// Joint-torque sensors, `M_dz`, N·m.
    pub m_dz: JointVector,
    /// Attitude from the gyros.
    pub attitude: UnitQuaternion<f64>,
    /// Body rates from the gyros, rad/s.
    pub omega: Vector3<f64>,
    /// Specific force from the accelerometers, `C` axes, m/s².
    pub specific_force: Vector3<f64>,
    /// The latest vision fix of the vehicle's position (world), m.
    pub position: Vector3<f64>,
    /// The time the latest fix refers to (its measurement time minus the delay), s.
    pub position_time: f64,
}

/// The sensors, with their noise source and the vision system's pipeline.
#[derive(Debug)]
pub struct Sensors {
    cfg: SensorConfig,
    noise: NormalPairs,
    /// True positions not yet old enough to be reported: (time, position).
    pending: VecDeque<(f64, Vector3<f64>)>,
    fix: (f64, Vector3<f64>),
    next_fix: f64,
    accelerometer_bias: Vector3<f64>,
}

impl Sensors {
    /// Sensors seeded with `seed`; before the first delayed fix arrives, the vision system
    /// reports `position0` (the vehicle held its station before the run).
    pub fn new(cfg: &SensorConfig, seed: u64, position0: Vector3<f64>) -> Self {
        let mut s = Sensors {
            cfg: *cfg,
            noise: NormalPairs::new(ChaCha8Rng::seed_from_u64(seed)),
            pending: VecDeque::new(),
            fix: (-cfg.vision_delay_s, position0),
            next_fix: 0.0,
            accelerometer_bias: Vector3::zeros(),
        };
        s.accelerometer_bias = Vector3::from_fn(|_, _| s.noise(cfg.accelerometer_bias_m_s2));
        s
    }

    fn noise(&mut self, sigma: f64) -> f64 {
        if sigma > 0.0 {
            sigma * self.noise.sample()
        } else {
            0.0
        }
    }

    /// Reads the accelerometers alone.
    fn accelerometers(&mut self, truth: &Truth) -> Vector3<f64> {
        let sigma = self.cfg.accelerometer_noise_m_s2;
        truth.specific_force + self.accelerometer_bias + Vector3::from_fn(|_, _| self.noise(sigma))
    }

    /// The accelerometers' mean over `readings` readings of `truth` (at least one): the
    /// levelling at the station held before the run.
    pub fn accelerometers_mean(&mut self, truth: &Truth, readings: usize) -> Vector3<f64> {
        let n = readings.max(1);
        (0..n).fold(Vector3::zeros(), |acc, _| acc + self.accelerometers(truth)) / n as f64
    }

    /// Reads every sensor at time `t`.
    pub fn read(&mut self, t: f64, truth: &Truth) -> Measurements {
        let c = self.cfg;
        let res = c.encoder_resolution_rad;
        let q = truth
            .q
            .map(|v| if res > 0.0 { (v / res).round() * res } else { v });
        let qd = truth.qd.map(|v| v + self.noise(c.joint_rate_noise_rad_s));
        let m_dz = truth.shaft_torque.map(|v| v + self.noise(c.torque_noise_nm));
        let tilt = Vector3::from_fn(|_, _| self.noise(c.attitude_noise_rad));
        let attitude = truth.attitude * UnitQuaternion::from_scaled_axis(tilt);
        let omega = truth.omega.map(|v| v + self.noise(c.gyro_noise_rad_s));
        let specific_force = self.accelerometers(truth);
        // Vision: a fix every 1/rate, reporting where the vehicle was `delay` ago.
        self.pending.push_back((t, truth.position));
        if t + 1e-12 >= self.next_fix {
            self.next_fix += 1.0 / c.vision_rate_hz;
            let when = t - c.vision_delay_s;
            while self.pending.len() > 1 && self.pending[1].0 <= when + 1e-12 {
                self.pending.pop_front();
            }
            if let Some(&(tp, p)) = self.pending.front()
                && tp <= when + 1e-12
            {
                let n = Vector3::from_fn(|_, _| self.noise(c.vision_noise_m));
                self.fix = (tp, p + n);
            }
        }
        Measurements {
            q,
            qd,
            m_dz,
            attitude,
            omega,
            specific_force,
            position: self.fix.1,
            position_time: self.fix.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth(x: f64) -> Truth {
        Truth {
            q: JointVector::new(0.1, 0.2, 0.3, 0.4, 0.5, 0.6),
            qd: JointVector::zeros(),
            shaft_torque: JointVector::repeat(1.0),
            attitude: UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            position: Vector3::new(x, 0.0, 0.0),
            specific_force: Vector3::zeros(),
        }
    }

    #[test]
    fn vision_fix_is_delayed_and_sampled() {
        let cfg = SensorConfig {
            vision_noise_m: 0.0,
            ..SensorConfig::default()
        };
        let mut s = Sensors::new(&cfg, 1, Vector3::new(-1.0, 0.0, 0.0));
        let dt = 1e-3;
        let mut seen = Vec::new();
        for k in 0..1000 {
            let t = k as f64 * dt;
            // The vehicle moves at 1 m/s: its position is t.
            let m = s.read(t, &truth(t));
            seen.push((t, m.position.x, m.position_time));
        }
        // Before 0.25 s: the station held before the run.
        assert_eq!(seen[100].1, -1.0);
        // At 0.5 s the latest fix was taken at 0.5 s and describes 0.25 s.
        let (t, x, when) = seen[500];
        assert!((t - 0.5).abs() < 1e-12);
        assert!(
            (x - 0.25).abs() < 1e-9 && (when - 0.25).abs() < 1e-9,
            "{x} {when}"
        );
        // Between fixes the value is held (10 Hz).
        assert_eq!(seen[550].1, seen[599].1);
        assert!((seen[650].1 - 0.35).abs() < 1e-9);
    }

    #[test]
    fn noise_has_the_configured_spread_and_is_seeded() {
        let cfg = SensorConfig::default();
        let mut a = Sensors::new(&cfg, 7, Vector3::zeros());
        let mut b = Sensors::new(&cfg, 7, Vector3::zeros());
        let n = 20_000;
        let mut sum2 = 0.0;
        for k in 0..n {
            let t = k as f64 * 1e-3;
            let ma = a.read(t, &truth(0.0));
            let mb = b.read(t, &truth(0.0));
            assert_eq!(ma.m_dz, mb.m_dz);
            sum2 += (ma.m_dz[0] - 1.0).powi(2);
        }
        let sigma = (sum2 / n as f64).sqrt();
        assert!((sigma - 0.05).abs() < 0.002, "{sigma}");
        // Encoders are quantised to their resolution.
        let q = a.read(0.0, &truth(0.0)).q;
        let r = cfg.encoder_resolution_rad;
        assert!((q[1] / r - (q[1] / r).round()).abs() < 1e-9);
        assert!((q[1] - 0.2).abs() <= r / 2.0 + 1e-15);
    }
}
