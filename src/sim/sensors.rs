//! NS, the navigation and sensing system of Figure 4: everything the controllers know of the
//! plant comes through here.
//!
//! - joint encoders (quantised angle) and tachometers (noisy rate);
//! - one-axis joint-torque sensors on the drives' output shafts: `M_dz` of eq. (1), with noise;
//! - gyros (an attitude and heading reference): attitude and body rates without delay, with noise;
//! - accelerometers (the inertial unit at `C`'s origin): the specific force `a − g` in `C` axes,
//!   with noise and a constant bias per axis (drawn once from the seed);
//! - the vision system: the vehicle's position relative to the (fixed) object, delayed by
//!   0.25 s, at a finite rate, with noise — the seed's delayed fix that eq. (18) works with;
//! - optionally (not in the seed's set, off by default) a Doppler velocity log's water track:
//!   the water's velocity past the vehicle, `C` axes, at its ping rate, with noise per ping.
//!
//! The tachometers', torque sensors', gyros' and accelerometers' noise is given as a density
//! (a datasheet's figure, e.g. an accelerometer's 64 µg/√Hz), white over the band the control
//! rate samples: a reading's deviation is the density over `√dt` (the noise averaged over the
//! period, the usual convention of inertial-sensor models), and a faster control rate
//! reads the same sensors more often, each reading noisier. The attitude's noise (an attitude
//! reference's output) and the vision fixes' are per reading. Every random draw comes from one
//! `ChaCha8Rng` seeded from the configuration, the water track's from a stream of its own.

use crate::arm::JointVector;
use crate::config::{non_negative, positive, require, shown};
use crate::error::Result;
use crate::synth::random::{NormalPairs, stream};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The random stream of the water track's noise (apart from the other sensors').
const WATER_TRACK_STREAM: u64 = 0x4456_4c00; // "DVL"

/// Sensor parameters (`[sim.sensors]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Encoder resolution, rad (link side).
    pub encoder_resolution_rad: f64,
    /// Noise density of the tachometers (the joint rates), rad/s/√Hz.
    pub joint_rate_noise_rad_s_per_rt_hz: f64,
    /// Noise density of the joint-torque sensors, N·m/√Hz.
    pub torque_noise_nm_per_rt_hz: f64,
    /// Standard deviation of the attitude angles, rad.
    pub attitude_noise_rad: f64,
    /// Noise density of the gyro rates, rad/s/√Hz.
    pub gyro_noise_rad_s_per_rt_hz: f64,
    /// Noise density of the accelerometers, m/s²/√Hz.
    pub accelerometer_noise_m_s2_per_rt_hz: f64,
    /// Standard deviation of the accelerometers' constant bias (one draw per axis), m/s².
    pub accelerometer_bias_m_s2: f64,
    /// Delay of the vision system's position fix, s (the seed's 0.25 s; at most 10 s).
    pub vision_delay_s: f64,
    /// Rate of the vision fixes, Hz.
    pub vision_rate_hz: f64,
    /// Standard deviation of each coordinate of a fix, m.
    pub vision_noise_m: f64,
    /// Ping rate of the water track (a DVL's water velocity past the vehicle), Hz; 0: none.
    pub water_track_rate_hz: f64,
    /// Standard deviation of each component of a water-track ping, m/s.
    pub water_track_noise_m_s: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            encoder_resolution_rad: 2.0 * std::f64::consts::PI / 131_072.0,
            joint_rate_noise_rad_s_per_rt_hz: 3.16e-5,
            torque_noise_nm_per_rt_hz: 1.58e-3,
            attitude_noise_rad: 2e-4,
            gyro_noise_rad_s_per_rt_hz: 3.16e-5,
            accelerometer_noise_m_s2_per_rt_hz: 6.32e-4,
            accelerometer_bias_m_s2: 0.01,
            vision_delay_s: 0.25,
            vision_rate_hz: 10.0,
            vision_noise_m: 1e-3,
            water_track_rate_hz: 0.0,
            water_track_noise_m_s: 0.005,
        }
    }
}

/// The longest delay of the vision fix a configuration may set, s.
const MAX_VISION_DELAY_S: f64 = 10.0;

impl SensorConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.sensors.encoder_resolution_rad", self.encoder_resolution_rad)?;
        non_negative(
            "sim.sensors.joint_rate_noise_rad_s_per_rt_hz",
            self.joint_rate_noise_rad_s_per_rt_hz,
        )?;
        non_negative(
            "sim.sensors.torque_noise_nm_per_rt_hz",
            self.torque_noise_nm_per_rt_hz,
        )?;
        non_negative("sim.sensors.attitude_noise_rad", self.attitude_noise_rad)?;
        non_negative(
            "sim.sensors.gyro_noise_rad_s_per_rt_hz",
            self.gyro_noise_rad_s_per_rt_hz,
        )?;
        non_negative(
            "sim.sensors.accelerometer_noise_m_s2_per_rt_hz",
            self.accelerometer_noise_m_s2_per_rt_hz,
        )?;
        non_negative(
            "sim.sensors.accelerometer_bias_m_s2",
            self.accelerometer_bias_m_s2,
        )?;
        non_negative("sim.sensors.vision_delay_s", self.vision_delay_s)?;
        // Stereo processing or an acoustic fix takes a second or two; a fix older than the
        // run describes the station held before it, not the vehicle.
        require(
            self.vision_delay_s <= MAX_VISION_DELAY_S,
            "sim.sensors.vision_delay_s",
            format!(
                "must be at most {MAX_VISION_DELAY_S} s (a fix that old no longer tells where the vehicle is), got {} s",
                shown(self.vision_delay_s)
            ),
        )?;
        non_negative("sim.sensors.vision_noise_m", self.vision_noise_m)?;
        non_negative("sim.sensors.water_track_rate_hz", self.water_track_rate_hz)?;
        non_negative("sim.sensors.water_track_noise_m_s", self.water_track_noise_m_s)?;
        positive("sim.sensors.vision_rate_hz", self.vision_rate_hz)
    }

    /// The standard deviations of one reading of the sensors given as noise densities, read
    /// every `dt` seconds: white noise of density `N` sampled every `dt` has `σ = N/√dt`, so the
    /// sensors are the same at any control rate.
    pub fn reading_noise(&self, dt: f64) -> ReadingNoise {
        let per_reading = 1.0 / dt.sqrt();
        ReadingNoise {
            joint_rate: self.joint_rate_noise_rad_s_per_rt_hz * per_reading,
            torque: self.torque_noise_nm_per_rt_hz * per_reading,
            gyro: self.gyro_noise_rad_s_per_rt_hz * per_reading,
            accelerometer: self.accelerometer_noise_m_s2_per_rt_hz * per_reading,
        }
    }
}

/// The standard deviations of one reading ([`SensorConfig::reading_noise`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingNoise {
    /// Of a tachometer, rad/s.
    pub joint_rate: f64,
    /// Of a joint-torque sensor, N·m.
    pub torque: f64,
    /// Of a gyro rate, rad/s.
    pub gyro: f64,
    /// Of an accelerometer, m/s².
    pub accelerometer: f64,
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
    /// The water's velocity past `C`'s origin (the current less the vehicle's velocity),
    /// `C` axes, m/s.
    pub water_flow: Vector3<f64>,
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
    /// The latest water-track ping, `C` axes, m/s (none without a water track).
    pub water_flow: Option<Vector3<f64>>,
}

/// The sensors, with their noise source and the vision system's pipeline.
#[derive(Debug)]
pub struct Sensors {
    cfg: SensorConfig,
    /// The readings' standard deviations at the rate the sensors are read.
    sigma: ReadingNoise,
    noise: NormalPairs,
    /// True positions not yet old enough to be reported: (time, position).
    pending: VecDeque<(f64, Vector3<f64>)>,
    fix: (f64, Vector3<f64>),
    next_fix: f64,
    accelerometer_bias: Vector3<f64>,
    /// When the water track pings next, s, its latest ping, and its own noise stream (so that
    /// fitting one leaves every other sensor's draws as they were).
    next_ping: f64,
    ping: Option<Vector3<f64>>,
    ping_noise: NormalPairs,
}

impl Sensors {
    /// Sensors seeded with `seed`, read every `dt` seconds; before the first delayed fix
    /// arrives, the vision system reports `position0` (the vehicle held its station before the
    /// run).
    pub fn new(cfg: &SensorConfig, seed: u64, position0: Vector3<f64>, dt: f64) -> Self {
        let mut s = Sensors {
            cfg: *cfg,
            sigma: cfg.reading_noise(dt),
            noise: NormalPairs::new(ChaCha8Rng::seed_from_u64(seed)),
            pending: VecDeque::new(),
            fix: (-cfg.vision_delay_s, position0),
            next_fix: 0.0,
            accelerometer_bias: Vector3::zeros(),
            next_ping: 0.0,
            ping: None,
            ping_noise: NormalPairs::new(stream(seed, WATER_TRACK_STREAM, 0)),
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
        let sigma = self.sigma.accelerometer;
        truth.specific_force + self.accelerometer_bias + Vector3::from_fn(|_, _| self.noise(sigma))
    }

    /// The accelerometers' mean over `readings` readings of `truth` (at least one): the
    /// levelling at the station held before the run.
    pub fn accelerometers_mean(&mut self, truth: &Truth, readings: usize) -> Vector3<f64> {
        let n = readings.max(1);
        (0..n).fold(Vector3::zeros(), |acc, _| acc + self.accelerometers(truth)) / n as f64
    }

    /// A water-track ping of the flow `flow` (`C` axes).
    fn water_track(&mut self, flow: &Vector3<f64>) -> Vector3<f64> {
        let sigma = self.cfg.water_track_noise_m_s;
        flow + Vector3::from_fn(|_, _| sigma * self.ping_noise.sample())
    }

    /// The water track's mean over `pings` pings of the flow `flow` (`C` axes; at least one
    /// ping), none without a water track: what it read at the station held before the run.
    pub fn water_track_mean(&mut self, flow: &Vector3<f64>, pings: usize) -> Option<Vector3<f64>> {
        let n = pings.max(1);
        (self.cfg.water_track_rate_hz > 0.0)
            .then(|| (0..n).fold(Vector3::zeros(), |acc, _| acc + self.water_track(flow)) / n as f64)
    }

    /// Reads every sensor at time `t`.
    pub fn read(&mut self, t: f64, truth: &Truth) -> Measurements {
        let (c, sigma) = (self.cfg, self.sigma);
        let res = c.encoder_resolution_rad;
        let q = truth
            .q
            .map(|v| if res > 0.0 { (v / res).round() * res } else { v });
        let qd = truth.qd.map(|v| v + self.noise(sigma.joint_rate));
        let m_dz = truth.shaft_torque.map(|v| v + self.noise(sigma.torque));
        let tilt = Vector3::from_fn(|_, _| self.noise(c.attitude_noise_rad));
        let attitude = truth.attitude * UnitQuaternion::from_scaled_axis(tilt);
        let omega = truth.omega.map(|v| v + self.noise(sigma.gyro));
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
        // Water track: a ping every 1/rate, without delay.
        if c.water_track_rate_hz > 0.0 && t + 1e-12 >= self.next_ping {
            self.next_ping += 1.0 / c.water_track_rate_hz;
            self.ping = Some(self.water_track(&truth.water_flow));
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
            water_flow: self.ping,
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
            water_flow: Vector3::new(0.1, -0.05, 0.02),
        }
    }

    #[test]
    fn vision_fix_is_delayed_and_sampled() {
        let cfg = SensorConfig {
            vision_noise_m: 0.0,
            ..SensorConfig::default()
        };
        let dt = 1e-3;
        let mut s = Sensors::new(&cfg, 1, Vector3::new(-1.0, 0.0, 0.0), dt);
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

    /// The water track pings at its rate, without delay, the flow past the vehicle with its
    /// noise, held between pings; without one, nothing.
    #[test]
    fn the_water_track_pings_the_flow_at_its_rate() {
        let dt = 1e-3;
        let none = Sensors::new(&SensorConfig::default(), 1, Vector3::zeros(), dt).read(0.0, &truth(0.0));
        assert_eq!(none.water_flow, None);
        let cfg = SensorConfig {
            water_track_rate_hz: 10.0,
            ..SensorConfig::default()
        };
        let mut s = Sensors::new(&cfg, 1, Vector3::zeros(), dt);
        let flow = truth(0.0).water_flow;
        let pings: Vec<Vector3<f64>> = (0..200_000)
            .map(|k| s.read(k as f64 * dt, &truth(0.0)).water_flow.unwrap())
            .collect();
        // Held for 100 periods, then a new ping.
        assert_eq!(pings[0], pings[99]);
        assert_ne!(pings[99], pings[100]);
        let per_ping: Vec<Vector3<f64>> = pings.iter().step_by(100).copied().collect();
        let n = per_ping.len() as f64;
        let mean = per_ping.iter().sum::<Vector3<f64>>() / n;
        assert!((mean - flow).norm() < 4.0 * cfg.water_track_noise_m_s / n.sqrt() * 3f64.sqrt());
        let sd = (per_ping.iter().map(|p| (p.x - mean.x).powi(2)).sum::<f64>() / n).sqrt();
        assert!((sd / cfg.water_track_noise_m_s - 1.0).abs() < 0.1, "{sd}");
    }

    /// The standard deviations of the tachometer, torque sensor, gyro and accelerometer
    /// readings (one axis each) over `n` readings `dt` apart.
    fn spreads(cfg: &SensorConfig, seed: u64, dt: f64, n: usize) -> [f64; 4] {
        let mut s = Sensors::new(cfg, seed, Vector3::zeros(), dt);
        let readings: Vec<[f64; 4]> = (0..n)
            .map(|k| {
                let m = s.read(k as f64 * dt, &truth(0.0));
                [m.qd[0], m.m_dz[0], m.omega.x, m.specific_force.x]
            })
            .collect();
        std::array::from_fn(|c| {
            let mean = readings.iter().map(|r| r[c]).sum::<f64>() / n as f64;
            (readings.iter().map(|r| (r[c] - mean).powi(2)).sum::<f64>() / n as f64).sqrt()
        })
    }

    #[test]
    fn noise_has_the_configured_density_and_is_seeded() {
        let cfg = SensorConfig::default();
        let mut a = Sensors::new(&cfg, 7, Vector3::zeros(), 1e-3);
        let mut b = Sensors::new(&cfg, 7, Vector3::zeros(), 1e-3);
        for k in 0..100 {
            let t = k as f64 * 1e-3;
            assert_eq!(a.read(t, &truth(0.0)).m_dz, b.read(t, &truth(0.0)).m_dz);
        }
        // A reading's deviation is the density over √dt: some 0.05 N·m for the torque sensors
        // at 1 kHz, twice that at 4 kHz (the same sensor read more often).
        let densities = [
            cfg.joint_rate_noise_rad_s_per_rt_hz,
            cfg.torque_noise_nm_per_rt_hz,
            cfg.gyro_noise_rad_s_per_rt_hz,
            cfg.accelerometer_noise_m_s2_per_rt_hz,
        ];
        for (dt, n) in [(1e-3, 40_000), (0.25e-3, 160_000)] {
            let measured = spreads(&cfg, 7, dt, n);
            for (sigma, density) in measured.iter().zip(densities) {
                let expected = density / dt.sqrt();
                assert!(
                    (sigma / expected - 1.0).abs() < 0.02,
                    "{sigma} against {expected} at {dt} s"
                );
            }
        }
        // Encoders are quantised to their resolution.
        let q = a.read(0.0, &truth(0.0)).q;
        let r = cfg.encoder_resolution_rad;
        assert!((q[1] / r - (q[1] / r).round()).abs() < 1e-9);
        assert!((q[1] - 0.2).abs() <= r / 2.0 + 1e-15);
    }
}
