//! The sea current the plant moves in (plant side, like [`super::contact`]): the scenario's mean
//! `[sim.scenario] current_m_s` and, with `current_variation_m_s`, a fluctuation about it.
//!
//! Each world axis fluctuates as a second-order Gauss–Markov process: a first-order one (an
//! Ornstein–Uhlenbeck process, the model of a slowly varying current in Fossen, *Handbook of
//! Marine Craft Hydrodynamics and Motion Control*, 2011, ch. 8, and in the UUV Simulator),
//! `u̇ = −u/τ + w`, correlated over `τ` (`current_correlation_s`), smoothed by a first-order
//! lag over `τ_s` (`current_smoothing_s`), `v̇ = (u − v)/τ_s`; the current is the mean plus `v`.
//! The lag gives the water an acceleration, `(u − v)/τ_s`, continuous in time, that the plant
//! feels (the Froude–Krylov force and the added mass's, [`crate::body`]); a first-order
//! process alone has none (its paths have no derivative). `u`'s spread is chosen so that `v`'s
//! stationary standard deviation is the axis's `σ`: the stationary covariance of `(u, v)` is
//! `σ² [[(τ + τ_s)/τ, 1], [1, 1]]`; `v`'s autocorrelation at lag `s` is
//! `(τ e^{−s/τ} − τ_s e^{−s/τ_s})/(τ − τ_s)`, its acceleration's standard deviation
//! `σ/√(τ τ_s)`.
//!
//! It is sampled exactly at the control period `dt`: `x ← Φ x + L ξ` with `x = (u, v)` about the
//! mean, `Φ = e^{A dt}` and `L L^T = P − Φ P Φ^T` (`P` the stationary covariance, so each step
//! keeps it), `ξ` standard normal from the run's seed: its statistics do not depend on the
//! control rate. It starts at the mean (the station was held before the run in the mean
//! current) and reaches its full spread after a few `τ`. The controllers never read it: they
//! feel it through the vehicle's motion and estimate it themselves ([`super::vehicle_control`]).

use crate::synth::random::{NormalPairs, stream};
use nalgebra::{Matrix2, Vector2, Vector3};

/// The random stream of the current's fluctuation (apart from the sensors' noise).
const STREAM: u64 = 0x4355_5252; // "CURR"

/// The sea current of a run.
#[derive(Debug)]
pub struct SeaCurrent {
    mean: Vector3<f64>,
    sigma: Vector3<f64>,
    /// The step's transition `e^{A dt}` and the Cholesky factor of its noise's covariance for
    /// `σ = 1` (each axis's is `σ` times it).
    phi: Matrix2<f64>,
    noise_factor: Matrix2<f64>,
    smoothing_s: f64,
    /// Each axis's `(u, v)` about the mean.
    state: [Vector2<f64>; 3],
    noise: NormalPairs,
}

impl SeaCurrent {
    /// A current of mean `mean` and per-axis stationary standard deviation `sigma` (m/s, world),
    /// correlated over `correlation_s` and smoothed over `smoothing_s` (s, both positive),
    /// stepped every `dt` (s), its fluctuation drawn from `seed`.
    pub fn new(
        mean: [f64; 3],
        sigma: [f64; 3],
        correlation_s: f64,
        smoothing_s: f64,
        dt: f64,
        seed: u64,
    ) -> Self {
        let (tau, tau_s) = (correlation_s, smoothing_s);
        let a = Matrix2::new(-1.0 / tau, 0.0, 1.0 / tau_s, -1.0 / tau_s);
        let phi = (a * dt).exp();
        let p = Matrix2::new((tau + tau_s) / tau, 1.0, 1.0, 1.0);
        let q = p - phi * p * phi.transpose();
        // The 2×2 Cholesky factor, its last pivot kept from round-off below zero.
        let l11 = q[(0, 0)].max(0.0).sqrt();
        let l21 = if l11 > 0.0 { q[(1, 0)] / l11 } else { 0.0 };
        let l22 = (q[(1, 1)] - l21 * l21).max(0.0).sqrt();
        SeaCurrent {
            mean: mean.into(),
            sigma: sigma.into(),
            phi,
            noise_factor: Matrix2::new(l11, 0.0, l21, l22),
            smoothing_s,
            state: [Vector2::zeros(); 3],
            noise: NormalPairs::new(stream(seed, STREAM, 0)),
        }
    }

    /// The current now, m/s (world).
    pub fn now(&self) -> Vector3<f64> {
        self.mean + Vector3::from_fn(|i, _| self.state[i].y)
    }

    /// The current's rate now, m/s² (world): the water's acceleration.
    pub fn rate(&self) -> Vector3<f64> {
        Vector3::from_fn(|i, _| (self.state[i].x - self.state[i].y) / self.smoothing_s)
    }

    /// Advances the current by a period and returns it. A steady current (no variation) draws
    /// nothing and stays exactly at its mean, its rate zero.
    pub fn step(&mut self) -> Vector3<f64> {
        for i in 0..3 {
            if self.sigma[i] != 0.0 {
                let xi = Vector2::new(self.noise.sample(), self.noise.sample());
                self.state[i] = self.phi * self.state[i] + self.noise_factor * xi * self.sigma[i];
            }
        }
        self.now()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mean and standard deviation of `x`.
    fn mean_sd(x: &[f64]) -> (f64, f64) {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        let var = x.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / x.len() as f64;
        (m, var.sqrt())
    }

    /// The sampled process has the second-order Gauss–Markov process's statistics: the mean, the
    /// stationary standard deviation of each axis, the autocorrelation at one correlation time
    /// `(τ e^{−1} − τ_s e^{−τ/τ_s})/(τ − τ_s)`, and the rate's standard deviation `σ/√(τ τ_s)`,
    /// at three control rates: the exact discretisation does not depend on `dt`, even at
    /// `dt = τ` (where an Euler step would be unstable for `τ_s < τ/2`).
    #[test]
    fn the_fluctuation_has_the_gauss_markov_statistics() {
        let (mean, sigma, tau, tau_s) = ([0.3, -0.1, 0.0], [0.1, 0.05, 0.02], 2.0, 0.5);
        let rho_tau = (tau * (-1.0f64).exp() - tau_s * (-tau / tau_s).exp()) / (tau - tau_s);
        for dt in [1e-3, 1e-2, tau] {
            let mut c = SeaCurrent::new(mean, sigma, tau, tau_s, dt, 7);
            // Settle to the stationary spread, then sample 2000 correlation times or more.
            for _ in 0..(10.0 * tau / dt) as usize {
                c.step();
            }
            // Kept every 10 ms or every step if longer (at least 20,000 samples: one a
            // correlation time at dt = τ).
            let stride = ((0.01 / dt).round() as usize).max(1);
            let n = ((2000.0 * tau / (dt * stride as f64)) as usize).max(20_000);
            let (v, rate): (Vec<_>, Vec<_>) = (0..n)
                .map(|_| {
                    for _ in 1..stride {
                        c.step();
                    }
                    (c.step(), c.rate())
                })
                .unzip();
            let lag = (tau / (dt * stride as f64)).round() as usize;
            for i in 0..3 {
                let x: Vec<f64> = v.iter().map(|v| v[i] - mean[i]).collect();
                let (m, sd) = mean_sd(&x);
                let cov =
                    x.windows(lag + 1).map(|w| (w[0] - m) * (w[lag] - m)).sum::<f64>() / (n - lag) as f64;
                // 2000 correlation times: the mean's standard error is about σ √(2/2000).
                assert!(m.abs() < 0.1 * sigma[i], "axis {i} dt {dt}: mean off by {m}");
                assert!((sd / sigma[i] - 1.0).abs() < 0.1, "axis {i} dt {dt}: sd {sd}");
                let rho = cov / (sd * sd);
                assert!(
                    (rho - rho_tau).abs() < 0.06,
                    "axis {i} dt {dt}: autocorrelation at τ {rho} against {rho_tau}"
                );
                let (_, rate_sd) = mean_sd(&rate.iter().map(|r| r[i]).collect::<Vec<_>>());
                let expected = sigma[i] / (tau * tau_s).sqrt();
                assert!(
                    (rate_sd / expected - 1.0).abs() < 0.1,
                    "axis {i} dt {dt}: rate sd {rate_sd} against {expected}"
                );
            }
        }
    }

    /// The rate is the current's derivative: the current's change over 20 s is the integral of
    /// its sampled rates (the trapezoid rule at 1 ms), to a small fraction of its spread.
    #[test]
    fn the_rate_is_the_current_s_derivative() {
        let (dt, sigma) = (1e-3, [0.1, 0.1, 0.05]);
        let mut c = SeaCurrent::new([0.1, 0.0, -0.2], sigma, 10.0, 1.0, dt, 3);
        let (start, mut r) = (c.now(), c.rate());
        let (mut integral, mut worst, mut moved) =
            (Vector3::zeros(), Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
        for _ in 0..20_000 {
            let (v1, r1) = (c.step(), c.rate());
            integral += (r + r1) * (dt / 2.0);
            r = r1;
            worst = worst.sup(&(v1 - start - integral).abs());
            moved = moved.sup(&(v1 - start).abs());
        }
        for i in 0..3 {
            assert!(moved[i] > sigma[i] / 2.0, "axis {i}: moved only {}", moved[i]);
            assert!(
                worst[i] < 0.01 * sigma[i],
                "axis {i}: the rates' integral off by {}",
                worst[i]
            );
        }
    }

    /// A steady current stays exactly at its mean with no rate; a varying one starts there,
    /// and is the same for the same seed and differs for another.
    #[test]
    fn a_steady_current_is_its_mean_and_the_draws_are_seeded() {
        let mut steady = SeaCurrent::new([0.2, 0.1, -0.05], [0.0; 3], 10.0, 1.0, 1e-3, 1);
        for _ in 0..1000 {
            assert_eq!(steady.step(), Vector3::new(0.2, 0.1, -0.05));
            assert_eq!(steady.rate(), Vector3::zeros());
        }
        let run = |seed| {
            let mut c = SeaCurrent::new([0.0; 3], [0.1; 3], 10.0, 1.0, 1e-3, seed);
            assert_eq!(c.now(), Vector3::zeros());
            (0..1000).map(|_| c.step()).last().unwrap()
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }
}
