//! The seabed as a height field over the world frame `W` (NED: x north, y east, z down).
//!
//! Depth below the world origin at horizontal position `(x, y)`:
//! `z = tan(α)·(x cos β + y sin β) − ripple(x, y) − roughness(x, y) − extra(x, y)`, where `α` is
//! the slope and `β` the downhill azimuth of the mean plane (which passes through the origin), and
//! heights (ripple, roughness, the caller's `extra` such as silt) are positive upwards.
//!
//! Ripples: wave-formed sand ripples have sharp crests and flat troughs; the profile
//! `A·(cos θ + ¼ cos 2θ)` (zero mean, crest-to-trough height 2A) has that shape. The crests meander:
//! `θ = k·(p·d) + φ + 0.8 sin(2π (p·d⊥)/(5λ) + φ')` with `d` the direction across the crests.
//! Roughness: a [`WaveField`] with wavelengths from 3 cm (or four grid cells) to 30 cm.

use super::config::SeabedConfig;
use super::random::WaveField;
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use std::f64::consts::PI;

/// A sampled seabed (see the module docs).
#[derive(Debug, Clone)]
pub struct Seabed {
    tan_slope: f64,
    downhill: [f64; 2],
    across: [f64; 2],
    wavenumber: f64,
    wavelength: f64,
    amplitude: f64,
    phase: [f64; 2],
    roughness: WaveField,
}

impl Seabed {
    /// Draws the ripple phases and the roughness from `rng`. The azimuths must be resolved
    /// ([`super::SynthConfig::resolved`]); absent ones count as 0.
    pub fn new(cfg: &SeabedConfig, rng: &mut ChaCha8Rng) -> Seabed {
        let beta = cfg.slope_azimuth_deg.unwrap_or(0.0).to_radians();
        let gamma = cfg.ripple_azimuth_deg.unwrap_or(0.0).to_radians();
        let phase = [2.0 * PI * rng.random::<f64>(), 2.0 * PI * rng.random::<f64>()];
        let shortest = (4.0 * cfg.cell_m).max(0.03);
        let roughness = WaveField::new(rng, 32, [shortest, shortest.max(0.3)], cfg.roughness_m, true);
        Seabed {
            tan_slope: cfg.slope_deg.to_radians().tan(),
            downhill: [beta.cos(), beta.sin()],
            across: [gamma.cos(), gamma.sin()],
            wavenumber: 2.0 * PI / cfg.ripple_wavelength_m,
            wavelength: cfg.ripple_wavelength_m,
            amplitude: cfg.ripple_amplitude_m,
            phase,
            roughness,
        }
    }

    /// Unit normal of the mean plane in `W`, pointing up (towards negative `z`).
    pub fn up(&self) -> Vector3<f64> {
        Vector3::new(
            self.tan_slope * self.downhill[0],
            self.tan_slope * self.downhill[1],
            -1.0,
        )
        .normalize()
    }

    /// Depth of the mean plane at `(x, y)`, metres.
    pub fn plane_depth(&self, x: f64, y: f64) -> f64 {
        self.tan_slope * (x * self.downhill[0] + y * self.downhill[1])
    }

    /// Ripple phase angle `θ` at `(x, y)` (crests at multiples of 2π).
    fn ripple_phase(&self, x: f64, y: f64) -> f64 {
        let along = x * self.across[0] + y * self.across[1];
        let crest = -x * self.across[1] + y * self.across[0];
        self.wavenumber * along
            + self.phase[0]
            + 0.8 * (2.0 * PI * crest / (5.0 * self.wavelength) + self.phase[1]).sin()
    }

    /// Ripple height at `(x, y)`, metres (positive up).
    pub fn ripple(&self, x: f64, y: f64) -> f64 {
        let t = self.ripple_phase(x, y);
        self.amplitude * (t.cos() + 0.25 * (2.0 * t).cos())
    }

    /// Ripple height normalised to `[-0.75, 1.25]` (0 where there are no ripples).
    pub fn ripple_shape(&self, x: f64, y: f64) -> f64 {
        let t = self.ripple_phase(x, y);
        if self.amplitude > 0.0 {
            t.cos() + 0.25 * (2.0 * t).cos()
        } else {
            0.0
        }
    }

    /// Height of ripples plus roughness above the mean plane at `(x, y)`, metres.
    pub fn relief(&self, x: f64, y: f64) -> f64 {
        self.ripple(x, y) + self.roughness.at(&Point3::new(x, y, 0.0))
    }

    /// The height field over `x ∈ [lo[0], hi[0]]`, `y ∈ [lo[1], hi[1]]` (metres in `W`) as a
    /// triangle mesh in `W` with grid spacing at most `cell`, raised by `extra(x, y)` metres.
    /// Triangles face up (counter-clockwise seen from above).
    pub fn mesh(
        &self,
        lo: [f64; 2],
        hi: [f64; 2],
        cell: f64,
        extra: impl Fn(f64, f64) -> f64,
    ) -> TriangleMesh {
        let nx = (((hi[0] - lo[0]) / cell).ceil() as usize).max(1);
        let ny = (((hi[1] - lo[1]) / cell).ceil() as usize).max(1);
        let (dx, dy) = ((hi[0] - lo[0]) / nx as f64, (hi[1] - lo[1]) / ny as f64);
        let mut vertices = Vec::with_capacity((nx + 1) * (ny + 1));
        for i in 0..=nx {
            let x = lo[0] + i as f64 * dx;
            for j in 0..=ny {
                let y = lo[1] + j as f64 * dy;
                vertices.push(Point3::new(
                    x,
                    y,
                    self.plane_depth(x, y) - self.relief(x, y) - extra(x, y),
                ));
            }
        }
        let at = |i: usize, j: usize| (i * (ny + 1) + j) as u32;
        let mut triangles = Vec::with_capacity(2 * nx * ny);
        for i in 0..nx {
            for j in 0..ny {
                // In NED, (east × north) points up: order the corners north-east-wise reversed.
                triangles.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
                triangles.push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
            }
        }
        TriangleMesh { vertices, triangles }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::random::stream;

    fn cfg() -> SeabedConfig {
        SeabedConfig {
            slope_deg: 10.0,
            slope_azimuth_deg: Some(60.0),
            ripple_azimuth_deg: Some(20.0),
            ..Default::default()
        }
    }

    #[test]
    fn mesh_faces_up_and_lies_on_the_field() {
        let s = Seabed::new(&cfg(), &mut stream(1, 0, 0));
        let m = s.mesh([-0.5, -0.4], [0.5, 0.6], 0.01, |_, _| 0.0);
        let up = Vector3::new(0.0, 0.0, -1.0);
        for t in 0..m.triangles.len() {
            assert!(m.triangle_normal(t).unwrap().dot(&up) > 0.5, "triangle {t}");
        }
        for v in m.vertices.iter().step_by(97) {
            assert!((v.z - (s.plane_depth(v.x, v.y) - s.relief(v.x, v.y))).abs() < 1e-15);
        }
    }

    #[test]
    fn mean_plane_and_ripples() {
        let s = Seabed::new(&cfg(), &mut stream(1, 0, 0));
        // The up normal is perpendicular to the plane's downhill and level directions.
        let up = s.up();
        let (b, t) = (60f64.to_radians(), 10f64.to_radians().tan());
        let downhill = Vector3::new(b.cos(), b.sin(), t);
        let level = Vector3::new(-b.sin(), b.cos(), 0.0);
        assert!(up.dot(&downhill).abs() < 1e-12 && up.dot(&level).abs() < 1e-12 && up.z < 0.0);
        assert!((up.z + 10f64.to_radians().cos()).abs() < 1e-12);
        // Ripples: zero mean, crest-to-trough 2A = 16 mm.
        let (mut sum, mut lo, mut hi) = (0.0, f64::MAX, f64::MIN);
        let n = 4000;
        for i in 0..n {
            let r = s.ripple(i as f64 * 0.00731, i as f64 * 0.00313);
            sum += r;
            lo = lo.min(r);
            hi = hi.max(r);
        }
        assert!((sum / n as f64).abs() < 3e-4, "{}", sum / n as f64);
        assert!((hi - 0.01).abs() < 2e-4 && (lo + 0.006).abs() < 2e-4, "{lo} {hi}");
    }
}
