//! The sea current the plant moves in (plant side, like [`super::contact`]): the scenario's mean
//! `[sim.scenario] current_m_s` and, with `current_variation_m_s`, a fluctuation about it.
//!
//! Each world axis fluctuates as a first-order Gauss–Markov process (an Ornstein–Uhlenbeck
//! process, the model of a slowly varying current in Fossen, *Handbook of Marine Craft
//! Hydrodynamics and Motion Control*, 2011, ch. 8, and in the UUV Simulator):
//! `v̇ = −(v − v̄)/τ + w`, with the stationary standard deviation `σ` of the axis and the
//! correlation time `τ` (`current_correlation_s`). It is sampled exactly at the control
//! period `dt`: `v ← v̄ + a (v − v̄) + σ √(1 − a²) ξ`, `a = e^{−dt/τ}`, `ξ` standard normal from
//! the run's seed, so its statistics do not depend on the control rate. It starts at the mean
//! (the station was held before the run in the mean current) and reaches its full spread
//! after a few `τ`. The controllers never read it: they feel it through the vehicle's motion
//! and estimate it themselves ([`super::vehicle_control`]).

use crate::synth::random::{NormalPairs, stream};
use nalgebra::Vector3;

/// The random stream of the current's fluctuation (apart from the sensors' noise).
const STREAM: u64 = 0x4355_5252; // "CURR"

/// The sea current of a run.
#[derive(Debug)]
pub struct SeaCurrent {
    mean: Vector3<f64>,
    /// Each axis's standard deviation times `√(1 − a²)`: a step's spread.
    step_sigma: Vector3<f64>,
    /// `a = e^{−dt/τ}`.
    a: f64,
    now: Vector3<f64>,
    noise: NormalPairs,
}

impl SeaCurrent {
    /// A current of mean `mean` and per-axis stationary standard deviation `sigma` (m/s, world),
    /// correlated over `correlation_s` (s), stepped every `dt` (s), its fluctuation drawn from
    /// `seed`.
    pub fn new(mean: [f64; 3], sigma: [f64; 3], correlation_s: f64, dt: f64, seed: u64) -> Self {
        let a = (-dt / correlation_s).exp();
        SeaCurrent {
            mean: mean.into(),
            step_sigma: Vector3::from(sigma) * (1.0 - a * a).sqrt(),
            a,
            now: mean.into(),
            noise: NormalPairs::new(stream(seed, STREAM, 0)),
        }
    }

    /// The current now, m/s (world).
    pub fn now(&self) -> Vector3<f64> {
        self.now
    }

    /// Advances the current by a period and returns it. A steady current (no variation) draws
    /// nothing and stays exactly at its mean.
    pub fn step(&mut self) -> Vector3<f64> {
        if self.step_sigma != Vector3::zeros() {
            for i in 0..3 {
                let xi = self.noise.sample();
                self.now[i] = self.mean[i] + self.a * (self.now[i] - self.mean[i]) + self.step_sigma[i] * xi;
            }
        }
        self.now
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampled process has the Gauss–Markov process's statistics: the mean, the stationary
    /// standard deviation of each axis, and the autocorrelation `e^{−lag/τ}`, at three
    /// control rates: the exact discretisation does not depend on `dt`, even at `dt = τ` (where
    /// an Euler step's spread would be off by a factor of √2 and its correlation zero).
    #[test]
    fn the_fluctuation_has_the_gauss_markov_statistics() {
        let (mean, sigma, tau) = ([0.3, -0.1, 0.0], [0.1, 0.05, 0.02], 2.0);
        for dt in [1e-3, 1e-2, tau] {
            let mut c = SeaCurrent::new(mean, sigma, tau, dt, 7);
            // Settle to the stationary spread, then sample 2000 correlation times.
            let settle = (10.0 * tau / dt) as usize;
            for _ in 0..settle {
                c.step();
            }
            let n = (2000.0 * tau / dt) as usize;
            let v: Vec<Vector3<f64>> = (0..n).map(|_| c.step()).collect();
            let lag = (tau / dt) as usize;
            for i in 0..3 {
                let x: Vec<f64> = v.iter().map(|v| v[i] - mean[i]).collect();
                let m = x.iter().sum::<f64>() / n as f64;
                let var = x.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
                let cov =
                    x.windows(lag + 1).map(|w| (w[0] - m) * (w[lag] - m)).sum::<f64>() / (n - lag) as f64;
                // 2000 correlation times: the mean's standard error is about σ √(2/2000).
                assert!(m.abs() < 0.1 * sigma[i], "axis {i} dt {dt}: mean off by {m}");
                let sd = var.sqrt();
                assert!((sd / sigma[i] - 1.0).abs() < 0.1, "axis {i} dt {dt}: sd {sd}");
                let rho = cov / var;
                assert!(
                    (rho - (-1.0f64).exp()).abs() < 0.06,
                    "axis {i} dt {dt}: autocorrelation at τ {rho}"
                );
            }
        }
    }

    /// A steady current stays exactly at its mean; a varying one starts there, and is the same
    /// for the same seed and differs for another.
    #[test]
    fn a_steady_current_is_its_mean_and_the_draws_are_seeded() {
        let mut steady = SeaCurrent::new([0.2, 0.1, -0.05], [0.0; 3], 10.0, 1e-3, 1);
        for _ in 0..1000 {
            assert_eq!(steady.step(), Vector3::new(0.2, 0.1, -0.05));
        }
        let run = |seed| {
            let mut c = SeaCurrent::new([0.0; 3], [0.1; 3], 10.0, 1e-3, seed);
            assert_eq!(c.now(), Vector3::zeros());
            (0..1000).map(|_| c.step()).last().unwrap()
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
    }
}
