//! Navigation, the estimating half of NS (Figure 4): the vehicle's attitude, position and
//! velocity the controllers work with, from the sensors of [`super::sensors`].
//!
//! - **Attitude**: the gyros' rates integrated and pulled towards the measured attitude by a
//!   complementary filter of time constant `attitude_filter_s` (the rates' noise integrates to
//!   little, the attitude's noise is averaged). Fed raw, the attitude's noise, times the 1.5 m
//!   lever of the arm, shakes the IK set-points at the control rate and the arm's reaction on
//!   the vehicle with them. The filter starts at the attitude of the station held before the
//!   run, where it had been running: started at the first reading instead, that reading's
//!   noise (0.2 mrad) tilted the gravity the dead reckoning takes off by 2 mm/s² for the
//!   filter's second, and the position estimate lagged the vehicle's first motion by up to
//!   3.5 mm/s (‖e‖ 4–5 mm in the first seconds of some seeds).
//! - **Position and velocity** (world): the accelerometers' specific force, turned into the
//!   world with that attitude and gravity added back, integrated every control period (an
//!   inertial dead reckoning), and corrected at each delayed vision fix by a Kalman filter of
//!   the position, the velocity and the accelerometers' bias (per world axis, one covariance
//!   for the three: the noise is the same on each). It assumes the sensors' own noise — the
//!   accelerometers' density `accelerometer_noise_m_s2_per_rt_hz`, the fixes'
//!   `vision_noise_m` — and a bias that walks with `accelerometer_bias_walk` (the simulated
//!   bias is constant: the walk is the filter's margin, for the attitude's slow error times
//!   `g` too, some 2·10⁻⁴ m/s², and keeps it learning). The bias starts
//!   from the levelling at the station held before the run ([`Navigation::level`]: at rest the
//!   accelerometers read `−ᴼ_C Rᵀ g` plus their bias), and the covariance from the filter's
//!   steady state (it ran while the station was held; started as if it knew the position,
//!   the velocity and the bias exactly, its first gains were small and the vehicle's first
//!   motion went uncorrected for seconds). A fix describes the vehicle `vision_delay_s` ago:
//!   it is compared with the estimate of that instant (kept in a history), the filter's
//!   correction of that instant's state is carried forward to now through the history,
//!   exactly (the dead reckoning is linear in the state), and eq. (18) and the stabilisation
//!   work with where the vehicle *is*, not where it was a quarter of a second ago: with the
//!   tool held by the surface or the soil, a correction that lags the vehicle by the fix's
//!   delay pushes the vehicle through the arm with the delay, an oscillation the
//!   stabilisation cannot damp.
//!
//!   The fix's delay is why the gains matter: the estimate now is the fix's instant's carried
//!   over a quarter of a second by dead reckoning, so its velocity error counts as much as its
//!   position error. A third-order complementary filter with its three poles at −0.5 rad/s
//!   (this module's filter until then) corrected the velocity by 0.075 m/s per metre of a
//!   fix's residual where the Kalman filter's steady state corrects it by 0.21 m/s: its
//!   position error at rest was a quarter larger (1.32 against 1.06 mm, 3-D RMS over five
//!   draws of a minute of the default sensors, the corrections passed on at once).
//!
//!   The estimate the controllers see takes the corrections in gradually, not at once: a jump
//!   of the position made eq. (18)'s set-points jump at every fix, and the joints' reference
//!   filter turned each into a step of the commanded accelerations — steps of 20 N·m of the
//!   shoulder's drive torque that the identification of the external moments could follow
//!   only a few periods late. What is pending passes at the rate that would pass it within
//!   `correction_s`, the rate set anew at each fix: a fix's correction alone passes evenly
//!   over `correction_s`; with fixes more often than that (the default 0.3 s against the
//!   fixes' 0.1 s) each fix spreads what is left again with its own, and the corrections
//!   pass as through a lag of about `correction_s`.

use super::sensors::{Measurements, SensorConfig};
use crate::config::{non_negative, positive, require, shown};
use crate::error::Result;
use crate::integrate::lag_gain;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Navigation filter parameters (`[sim.navigation]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavigationConfig {
    /// Time constant of the complementary filter on the attitude, s.
    pub attitude_filter_s: f64,
    /// Intensity of the random walk of the accelerometers' bias that the position filter
    /// assumes, m/s²/√s (the bias's change over `t` has the deviation `walk √t`).
    pub accelerometer_bias_walk: f64,
    /// Length of the levelling at the held station before the run (accelerometers averaged at
    /// the control rate), s.
    pub levelling_s: f64,
    /// The corrections of the position pass into the estimate at the rate that would pass
    /// what is pending within this long, set anew at each fix, s (0: at once).
    pub correction_s: f64,
}

impl Default for NavigationConfig {
    fn default() -> Self {
        NavigationConfig {
            attitude_filter_s: 1.0,
            accelerometer_bias_walk: 1e-4,
            levelling_s: 10.0,
            correction_s: 0.3,
        }
    }
}

impl NavigationConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        non_negative("sim.navigation.attitude_filter_s", self.attitude_filter_s)?;
        non_negative("sim.navigation.levelling_s", self.levelling_s)?;
        require(
            self.levelling_s <= 3600.0,
            "sim.navigation.levelling_s",
            format!("must be at most 3600 s, got {}", shown(self.levelling_s)),
        )?;
        non_negative("sim.navigation.correction_s", self.correction_s)?;
        positive(
            "sim.navigation.accelerometer_bias_walk",
            self.accelerometer_bias_walk,
        )
    }
}

/// The navigation filters' state.
#[derive(Debug, Clone)]
pub struct Navigation {
    cfg: NavigationConfig,
    gravity: Vector3<f64>,
    /// The accelerometers' noise density (m/s²/√Hz) and the fixes' deviation per coordinate (m).
    noise: (f64, f64),
    /// The filtered attitude (none before the levelling or the first measurement).
    attitude: Option<UnitQuaternion<f64>>,
    /// Estimated position of `C`'s origin (world), m, with the corrections passed on so far.
    pub position: Vector3<f64>,
    /// The filter's estimate of the position, with every correction.
    estimate: Vector3<f64>,
    /// The corrections not passed on yet, and how much of them passes per second.
    pending: (Vector3<f64>, Vector3<f64>),
    /// Estimated velocity of `C`'s origin (world), m/s.
    pub velocity: Vector3<f64>,
    /// Estimated accelerometer bias (`C` axes), m/s².
    bias: Vector3<f64>,
    /// Covariance of one world axis's `(position, velocity, bias)` at the latest fix's instant
    /// (the same for the three axes).
    covariance: Matrix3<f64>,
    /// Past estimates (time, position, velocity) not older than the latest fix.
    history: VecDeque<(f64, Vector3<f64>, Vector3<f64>)>,
    last_fix: f64,
}

impl Navigation {
    /// The vehicle at rest at `position` (the station held before the run), in gravity `g`
    /// (m/s², along +z of NED), seen by the sensors `sensors` (whose noise the filter
    /// assumes). The filter ran while the station was held: its covariance starts at the steady
    /// state of a fix every `1/vision_rate_hz`.
    pub fn new(cfg: &NavigationConfig, sensors: &SensorConfig, position: Vector3<f64>, g: f64) -> Self {
        let mut nav = Navigation {
            cfg: *cfg,
            gravity: Vector3::new(0.0, 0.0, g),
            noise: (sensors.accelerometer_noise_m_s2_per_rt_hz, sensors.vision_noise_m),
            attitude: None,
            position,
            estimate: position,
            pending: (Vector3::zeros(), Vector3::zeros()),
            velocity: Vector3::zeros(),
            bias: Vector3::zeros(),
            covariance: Matrix3::zeros(),
            history: VecDeque::new(),
            last_fix: f64::NEG_INFINITY,
        };
        // The Riccati recursion: some 700 fixes for the default sensors, more for a slower
        // bias walk (the cap bounds the start; the filter goes on converging in the run).
        let interval = 1.0 / sensors.vision_rate_hz;
        for _ in 0..100_000 {
            let before = nav.covariance;
            nav.predict_and_update(interval);
            if (nav.covariance - before).amax() <= 1e-12 * nav.covariance.amax() {
                break;
            }
        }
        nav
    }

    /// Levelling at rest with the attitude `attitude`: the accelerometers' mean reading
    /// `specific_force` gives their bias, and the attitude filter starts at `attitude` (it ran
    /// while the station was held; its error there, some 20 µrad with the default gyros and
    /// attitude readings, is left out).
    pub fn level(&mut self, specific_force: &Vector3<f64>, attitude: &UnitQuaternion<f64>) {
        self.bias = specific_force + attitude.inverse() * self.gravity;
        self.attitude = Some(*attitude);
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
        // A new fix: the residual against the estimate of its instant, the filter's correction
        // of that instant's state carried forward to now and through the history after it.
        if m.position_time > self.last_fix {
            if self.last_fix.is_finite() {
                while self.history.len() > 1 && self.history[1].0 <= m.position_time + 1e-12 {
                    self.history.pop_front();
                }
                if let Some(&(tf, pf, _)) = self.history.front() {
                    let gain = self.predict_and_update(m.position_time - self.last_fix);
                    let e = m.position - pf;
                    // The correction of (position, velocity, world bias) at `tf`, and what it
                    // becomes `τ` later: `(δp + δv τ − δb τ²/2, δv − δb τ)`.
                    let (dp, dv, db) = (e * gain.x, e * gain.y, e * gain.z);
                    let carried = |tau: f64| (dp + dv * tau - db * (0.5 * tau * tau), dv - db * tau);
                    for (ti, pi, vi) in &mut self.history {
                        let (p, v) = carried(*ti - tf);
                        *pi += p;
                        *vi += v;
                    }
                    let (jump, dv_now) = carried(t - tf);
                    // The world bias's correction in the body axes of now (the vehicle turns by
                    // milliradians over the fix's delay).
                    self.bias += attitude.inverse() * db;
                    self.estimate += jump;
                    self.velocity += dv_now;
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

    /// The Kalman gain of a fix `span` seconds after the last (per axis, of the residual on
    /// `(position, velocity, world bias)`), with the covariance moved to the fix and updated.
    ///
    /// Over `T` the state moves as `p += v T − b T²/2`, `v −= b T` (the world bias `b` is
    /// subtracted from the acceleration), with the accelerometers' white noise of intensity
    /// `q_a` (their density squared; `σ_a² dt` of a reading every `dt`) on the acceleration and
    /// the bias's walk `q_b` on `b`:
    ///
    /// ```text
    /// Q = q_a [T³/3 T²/2 0; T²/2 T 0; 0 0 0] + q_b [T⁵/20 T⁴/8 −T³/6; T⁴/8 T³/3 −T²/2; −T³/6 −T²/2 T]
    /// ```
    fn predict_and_update(&mut self, span: f64) -> Vector3<f64> {
        let t = span.max(0.0);
        let (t2, t3) = (t * t, t * t * t);
        let f = Matrix3::new(1.0, t, -0.5 * t2, 0.0, 1.0, -t, 0.0, 0.0, 1.0);
        let qa = self.noise.0.powi(2);
        let qb = self.cfg.accelerometer_bias_walk.powi(2);
        let q = Matrix3::new(t3 / 3.0, t2 / 2.0, 0.0, t2 / 2.0, t, 0.0, 0.0, 0.0, 0.0) * qa
            + Matrix3::new(
                t2 * t3 / 20.0,
                t2 * t2 / 8.0,
                -t3 / 6.0,
                t2 * t2 / 8.0,
                t3 / 3.0,
                -t2 / 2.0,
                -t3 / 6.0,
                -t2 / 2.0,
                t,
            ) * qb;
        let p = f * self.covariance * f.transpose() + q;
        let s = p[(0, 0)] + self.noise.1.powi(2);
        if s <= 0.0 {
            self.covariance = p;
            return Vector3::zeros();
        }
        let k = p.column(0) / s;
        let updated = p - k * k.transpose() * s;
        // Symmetric against round-off.
        self.covariance = (updated + updated.transpose()) * 0.5;
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::JointVector;
    use crate::sim::sensors::{SensorConfig, Sensors, Truth};

    fn at_rest(position: Vector3<f64>) -> Truth {
        Truth {
            q: JointVector::zeros(),
            qd: JointVector::zeros(),
            shaft_torque: JointVector::zeros(),
            attitude: UnitQuaternion::identity(),
            omega: Vector3::zeros(),
            position,
            specific_force: Vector3::new(0.0, 0.0, -9.81),
            water_flow: Vector3::zeros(),
        }
    }

    /// The filter levelled on 10 s of `sensors` at rest at 1 kHz.
    fn levelled(cfg: &NavigationConfig, assumed: &SensorConfig, sensors: &mut Sensors) -> Navigation {
        let rest = at_rest(Vector3::zeros());
        let mut nav = Navigation::new(cfg, assumed, Vector3::zeros(), 9.81);
        nav.level(&sensors.accelerometers_mean(&rest, 10_000), &rest.attitude);
        nav
    }

    /// A vehicle oscillating at 0.7 Hz seen by biased, noisy accelerometers and the 0.25 s
    /// delayed fix: the estimate follows where the vehicle is now, far closer than the fix.
    #[test]
    fn estimate_tracks_the_vehicle_despite_the_delayed_fix() {
        let cfg = SensorConfig::default();
        let mut sensors = Sensors::new(&cfg, 3, Vector3::zeros(), 1e-3);
        let mut nav = levelled(&NavigationConfig::default(), &cfg, &mut sensors);
        let (amp, w) = (0.02, 2.0 * std::f64::consts::PI * 0.7);
        let dt = 1e-3;
        let at = |t: f64| Truth {
            position: Vector3::new(amp * (1.0 - (w * t).cos()), 0.0, 0.0),
            specific_force: Vector3::new(amp * w * w * (w * t).cos(), 0.0, -9.81),
            ..at_rest(Vector3::zeros())
        };
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
        assert!(worst_est < 0.003, "{worst_est} vs the fix's {worst_fix}");
    }

    /// The gain settles where the discrete Riccati equation of the same model, iterated
    /// independently (numpy, 10⁵ fixes), puts it for accelerometers of 0.02 m/s² at 1 kHz
    /// (`0.02 √0.001` m/s²/√Hz, the default's 6.32·10⁻⁴ to three digits), 1 mm fixes at 10 Hz
    /// and the default bias walk (10⁻⁴ m/s²/√s): `K = (0.193613, 0.207970, −0.028397)`,
    /// posterior position variance 1.93613·10⁻⁷ m². The filter starts there.
    #[test]
    fn the_gain_settles_at_the_riccati_equation_s_steady_state() {
        let sensors = SensorConfig {
            accelerometer_noise_m_s2_per_rt_hz: 0.02 * 1e-3f64.sqrt(),
            ..SensorConfig::default()
        };
        let mut nav = Navigation::new(&NavigationConfig::default(), &sensors, Vector3::zeros(), 9.81);
        assert!((nav.covariance[(0, 0)] / 1.936_134_64e-7 - 1.0).abs() < 1e-5);
        let k = nav.predict_and_update(0.1);
        let expected = Vector3::new(0.193_613_46, 0.207_970_01, -0.028_396_95);
        assert!((k - expected).amax() < 1e-6, "{k} vs {expected}");
        assert!((nav.covariance[(0, 0)] / 1.936_134_64e-7 - 1.0).abs() < 1e-5);
    }

    /// The correction at a fix's instant is carried forward exactly: the estimate now equals
    /// the dead reckoning replayed from the fix's instant with the corrected position,
    /// velocity and bias over the same readings. A large bias the levelling did not see (0.05
    /// m/s² per axis) makes the bias's corrections count: carried without them, the estimate
    /// and its velocity part from the replay by 1.6 mm and mm/s within the 5 s.
    #[test]
    fn a_correction_is_carried_forward_as_a_replay_from_the_fix_s_instant() {
        let cfg = SensorConfig {
            attitude_noise_rad: 0.0,
            gyro_noise_rad_s_per_rt_hz: 0.0,
            accelerometer_bias_m_s2: 0.05,
            ..SensorConfig::default()
        };
        let dt = 1e-3;
        let g = Vector3::new(0.0, 0.0, 9.81);
        let truth = at_rest(Vector3::zeros());
        let mut sensors = Sensors::new(&cfg, 4, Vector3::zeros(), dt);
        let mut nav = Navigation::new(&NavigationConfig::default(), &cfg, Vector3::zeros(), 9.81);
        nav.level(&truth.specific_force, &truth.attitude);
        // The replay: every reading, the state after each, and the filter's gains by a twin.
        let mut twin = nav.clone();
        let (mut readings, mut states) = (Vec::new(), Vec::new());
        let (mut bias, mut last_fix) = (Vector3::zeros(), f64::NEG_INFINITY);
        let (mut p, mut v) = (Vector3::zeros(), Vector3::zeros());
        let mut worst = 0.0_f64;
        for k in 0..5000 {
            let t = k as f64 * dt;
            let m = sensors.read(t, &truth);
            nav.update(m, t, dt);
            readings.push(m.specific_force);
            let step = |p: &mut Vector3<f64>, v: &mut Vector3<f64>, f: &Vector3<f64>, b: &Vector3<f64>| {
                let a = f - b + g;
                *p += *v * dt + a * (0.5 * dt * dt);
                *v += a * dt;
            };
            step(&mut p, &mut v, &m.specific_force, &bias);
            states.push((t, p, v));
            if m.position_time > last_fix {
                if last_fix.is_finite() {
                    let i = states
                        .iter()
                        .rposition(|s| s.0 <= m.position_time + 1e-12)
                        .unwrap();
                    let k_fix = twin.predict_and_update(m.position_time - last_fix);
                    let e = m.position - states[i].1;
                    let (mut pf, mut vf) = (states[i].1 + e * k_fix.x, states[i].2 + e * k_fix.y);
                    bias += e * k_fix.z;
                    states[i] = (states[i].0, pf, vf);
                    for j in i + 1..states.len() {
                        step(&mut pf, &mut vf, &readings[j], &bias);
                        states[j] = (states[j].0, pf, vf);
                    }
                    (p, v) = (pf, vf);
                }
                last_fix = m.position_time;
            }
            worst = worst.max((nav.estimate - p).norm() + (nav.velocity - v).norm());
        }
        // The bias's corrections added up (to 13 mm/s² here): they count in the replay.
        assert!(nav.bias.norm() > 5e-3, "{}", nav.bias);
        assert!(worst < 1e-9, "{worst}");
    }

    /// The filter's own account of its error holds: at rest, with the default sensors, the
    /// estimate at each fix's instant (corrected) is off the truth by what the covariance
    /// says, on average over the axes, the fixes and five draws of the noise (0.93–1.00 over
    /// six sets of five draws: the errors of neighbouring fixes are correlated). Half or twice
    /// the accelerometers' noise assumed breaks it.
    #[test]
    fn the_error_at_the_fixes_is_what_the_covariance_says() {
        let ratio = |assumed_share: f64| {
            let sensors_cfg = SensorConfig::default();
            let assumed = SensorConfig {
                accelerometer_noise_m_s2_per_rt_hz: assumed_share
                    * sensors_cfg.accelerometer_noise_m_s2_per_rt_hz,
                ..sensors_cfg
            };
            let (mut squared, mut predicted) = (0.0, 0.0);
            let dt = 1e-3;
            let truth = at_rest(Vector3::zeros());
            for seed in 1..=5 {
                let mut sensors = Sensors::new(&sensors_cfg, seed, Vector3::zeros(), dt);
                let mut nav = levelled(&NavigationConfig::default(), &assumed, &mut sensors);
                let mut last_fix = nav.last_fix;
                for k in 0..120_000 {
                    let t = k as f64 * dt;
                    nav.update(sensors.read(t, &truth), t, dt);
                    if nav.last_fix > last_fix && t > 20.0 {
                        let (_, p, _) = nav.history[0];
                        squared += p.norm_squared() / 3.0;
                        predicted += nav.covariance[(0, 0)];
                    }
                    last_fix = nav.last_fix;
                }
            }
            squared / predicted
        };
        // 0.99; 1.41 and 0.84 with half and twice the noise assumed (the fixes' share of the
        // error is the same either way).
        let r = ratio(1.0);
        assert!((r - 1.0).abs() < 0.08, "{r}");
        assert!(ratio(0.5) > 1.25, "an optimistic filter");
        assert!(ratio(2.0) < 0.92, "a pessimistic filter");
    }

    /// A vehicle at rest, exact sensors, and the vehicle moved by 1 cm in an instant that the
    /// accelerometers do not see (as a fix's offset would): the fixes' corrections reach the
    /// estimate gradually over `correction_s`, never at once — and at once with
    /// `correction_s = 0`, the same corrections in all.
    #[test]
    fn the_fixes_corrections_pass_gradually_not_at_once() {
        let exact = SensorConfig {
            accelerometer_noise_m_s2_per_rt_hz: 0.0,
            accelerometer_bias_m_s2: 0.0,
            vision_noise_m: 0.0,
            ..SensorConfig::default()
        };
        let dt = 1e-3;
        let run = |correction_s: f64| {
            let cfg = NavigationConfig {
                correction_s,
                ..NavigationConfig::default()
            };
            let mut sensors = Sensors::new(&exact, 1, Vector3::zeros(), dt);
            // The filter assumes the default sensors' noise.
            let mut nav = levelled(&cfg, &SensorConfig::default(), &mut sensors);
            let mut last = nav.position;
            let mut biggest_step = 0.0_f64;
            for k in 0..30_000 {
                let t = k as f64 * dt;
                let x = if t >= 10.0 { 0.01 } else { 0.0 };
                nav.update(sensors.read(t, &at_rest(Vector3::new(x, 0.0, 0.0))), t, dt);
                biggest_step = biggest_step.max((nav.position - last).norm());
                last = nav.position;
            }
            (biggest_step, nav.position.x)
        };
        let (spread, x_spread) = run(0.3);
        let (at_once, x_at_once) = run(0.0);
        // The first fix's correction is 0.19 × 1 cm plus its velocity's part carried over
        // the delay, about 2.5 mm: at once one step, passed over 300 periods far less.
        assert!(at_once > 2e-3, "{at_once}");
        assert!(spread < at_once / 50.0, "{spread} vs {at_once}");
        // After 20 s the estimate has come to the vehicle, the same way either way.
        assert!(
            (x_spread - 0.01).abs() < 1e-3 && (x_at_once - 0.01).abs() < 1e-3,
            "{x_spread} {x_at_once}"
        );
        assert!((x_spread - x_at_once).abs() < 1e-4, "{x_spread} {x_at_once}");
    }
}
