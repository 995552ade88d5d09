//! Seeded randomness for the synthetic scenes: independent ChaCha8 streams, Gaussian samples and
//! smooth random fields.
//!
//! A stream is keyed by `(seed, stream, index)` through ChaCha8's 256-bit seed, so streams never
//! collide and a row of pixels rendered on any thread draws the same numbers.
//!
//! [`WaveField`] is a sum of random plane waves (random-phase spectral synthesis): a stationary,
//! smooth, zero-mean field whose RMS is set exactly, with wavelengths spread log-uniformly over a
//! band and amplitudes proportional to the wavelength (a red spectrum, as for seabed roughness).

use nalgebra::{Point3, Vector3};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use std::f64::consts::PI;

/// The random stream `stream` of `seed`, sub-stream `index` (e.g. an image row).
pub fn stream(seed: u64, stream: u64, index: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..16].copy_from_slice(&stream.to_le_bytes());
    key[16..24].copy_from_slice(&index.to_le_bytes());
    ChaCha8Rng::from_seed(key)
}

/// A standard normal sample (Box–Muller).
pub fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    // 1 - u lies in (0, 1], so the logarithm is finite.
    let u: f64 = 1.0 - rng.random::<f64>();
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
}

/// Standard normal samples two at a time (Marsaglia's polar method): a point `(u, v)` uniform
/// in the unit disc (drawn in the square, the 1 − π/4 outside thrown away), `s = u² + v²`, gives
/// `u·f` and `v·f`, `f = √(−2 ln s / s)`, independent standard normals, with one logarithm and
/// no trigonometry for the pair — about a third of [`gaussian`]'s work per sample, for streams drawn every
/// control period (the simulation's sensors). [`gaussian`] stays the synthetic scenes' sampler:
/// the committed scans are its output.
#[derive(Debug)]
pub struct NormalPairs {
    rng: ChaCha8Rng,
    spare: Option<f64>,
}

impl NormalPairs {
    /// Samples drawn from `rng`.
    pub fn new(rng: ChaCha8Rng) -> Self {
        NormalPairs { rng, spare: None }
    }

    /// The next sample.
    pub fn sample(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        loop {
            let u = 2.0 * self.rng.random::<f64>() - 1.0;
            let v = 2.0 * self.rng.random::<f64>() - 1.0;
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let f = (-2.0 * s.ln() / s).sqrt();
                self.spare = Some(v * f);
                return u * f;
            }
        }
    }
}

/// A uniform sample in `[r[0], r[1]]` (the single value when the range is empty).
pub fn uniform(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    r[0] + (r[1] - r[0]) * rng.random::<f64>()
}

/// A smooth random field: a sum of plane waves (see the module docs).
#[derive(Debug, Clone)]
pub struct WaveField {
    /// Per wave: wave vector (rad/m), phase (rad), amplitude. Plain arrays: this is evaluated
    /// millions of times and must stay fast in unoptimised test builds too.
    waves: Vec<([f64; 3], f64, f64)>,
}

impl WaveField {
    /// `n` waves with wavelengths in `[min_wavelength, max_wavelength]` metres and overall RMS
    /// `rms`; directions are uniform on the circle in the `xy` plane (`planar`) or on the sphere.
    pub fn new(rng: &mut ChaCha8Rng, n: usize, wavelengths: [f64; 2], rms: f64, planar: bool) -> Self {
        let mut waves: Vec<([f64; 3], f64, f64)> = (0..n)
            .map(|_| {
                let lambda = wavelengths[0] * (wavelengths[1] / wavelengths[0]).powf(rng.random::<f64>());
                let dir = if planar {
                    let a = 2.0 * PI * rng.random::<f64>();
                    Vector3::new(a.cos(), a.sin(), 0.0)
                } else {
                    let z = 2.0 * rng.random::<f64>() - 1.0;
                    let a = 2.0 * PI * rng.random::<f64>();
                    let s = (1.0 - z * z).sqrt();
                    Vector3::new(s * a.cos(), s * a.sin(), z)
                };
                let phase = 2.0 * PI * rng.random::<f64>();
                let k = dir * (2.0 * PI / lambda);
                ([k.x, k.y, k.z], phase, lambda)
            })
            .collect();
        // Each wave a·cos(...) contributes a²/2 to the variance.
        let var: f64 = waves.iter().map(|w| w.2 * w.2 / 2.0).sum();
        let scale = if var > 0.0 { rms / var.sqrt() } else { 0.0 };
        for w in &mut waves {
            w.2 *= scale;
        }
        WaveField { waves }
    }

    /// The field's value at `p`.
    pub fn at(&self, p: &Point3<f64>) -> f64 {
        let (x, y, z) = (p.x, p.y, p.z);
        let mut sum = 0.0;
        for (k, phase, a) in &self.waves {
            sum += a * (k[0] * x + k[1] * y + k[2] * z + phase).cos();
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_repeat() {
        let a: u64 = stream(1, 2, 3).random();
        assert_eq!(a, stream(1, 2, 3).random::<u64>());
        assert_ne!(a, stream(1, 2, 4).random::<u64>());
        assert_ne!(a, stream(1, 3, 3).random::<u64>());
        assert_ne!(a, stream(2, 2, 3).random::<u64>());
    }

    #[test]
    fn gaussian_moments() {
        let mut rng = stream(9, 0, 0);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| gaussian(&mut rng)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.01, "{mean} {var}");
        let beyond2 = xs.iter().filter(|x| x.abs() > 2.0).count() as f64 / n as f64;
        assert!((beyond2 - 0.0455).abs() < 0.003, "{beyond2}");
    }

    /// The polar method's samples, the odd (the pairs' first) and the even (their second) apart,
    /// have the distribution of [`gaussian`]'s (two-sample Kolmogorov–Smirnov at the 0.1 %
    /// level), their mean and variance are 0 and 1, and consecutive samples are uncorrelated.
    #[test]
    fn normal_pairs_are_standard_normal_and_independent() {
        let n = 100_000;
        let mut rng = stream(11, 0, 0);
        let mut reference: Vec<f64> = (0..n).map(|_| gaussian(&mut rng)).collect();
        reference.sort_by(f64::total_cmp);
        let mut pairs = NormalPairs::new(stream(12, 0, 0));
        let drawn: Vec<f64> = (0..2 * n).map(|_| pairs.sample()).collect();
        let ks = |mut xs: Vec<f64>| {
            xs.sort_by(f64::total_cmp);
            let (mut i, mut j, mut d) = (0, 0, 0.0f64);
            while i < n && j < n {
                if xs[i] <= reference[j] {
                    i += 1;
                } else {
                    j += 1;
                }
                d = d.max((i as f64 - j as f64).abs() / n as f64);
            }
            d
        };
        // The critical distance for n = m at 0.1 %: 1.95 √(2/n).
        let critical = 1.95 * (2.0 / n as f64).sqrt();
        for half in 0..2 {
            let xs: Vec<f64> = drawn.iter().skip(half).step_by(2).copied().collect();
            let d = ks(xs);
            assert!(d < critical, "half {half}: D = {d}, critical {critical}");
        }
        // Standard errors 1/√(2n) ≈ 0.0022 (mean) and 1/√n ≈ 0.0032 (variance): a 2 % error
        // of the scale shows.
        let mean = drawn.iter().sum::<f64>() / (2 * n) as f64;
        let var = drawn.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (2 * n) as f64;
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.015, "{mean} {var}");
        let lag1 = drawn.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (2 * n - 1) as f64;
        assert!(lag1.abs() < 0.01, "{lag1}");
    }

    #[test]
    fn wave_field_has_its_rms() {
        let mut rng = stream(3, 0, 0);
        let f = WaveField::new(&mut rng, 32, [0.03, 0.3], 0.002, true);
        // Average over a region much larger than the longest wavelength.
        let mut s2 = 0.0;
        let n = 200;
        for i in 0..n {
            for j in 0..n {
                let v = f.at(&Point3::new(i as f64 * 0.037, j as f64 * 0.041, 0.0));
                s2 += v * v;
            }
        }
        let rms = (s2 / (n * n) as f64).sqrt();
        assert!((rms - 0.002).abs() < 0.0002, "{rms}");
    }
}
