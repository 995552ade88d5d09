//! Fouling on the object: bumps (marine growth) and dents (deformation of the thin PET wall).
//!
//! Each feature is centred on a point drawn uniformly by area over the object's upward-facing
//! surface above the silt line, and displaces the vertices within its radius `ρ` along their
//! normals by `h·(1 − (g/ρ)²)²` (`g` the distance to the centre; `h > 0` a bump, `h < 0` a
//! dent). The profile is smooth and exactly zero beyond `ρ`, so the true surface equals the
//! reference everywhere else.

use super::config::FoulingConfig;
use super::random::uniform;
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use serde::Serialize;

/// One bump or dent, in the object's model frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FoulingFeature {
    /// Centre on the reference surface, metres (model frame).
    pub centre: Point3<f64>,
    /// Radius of the affected area, metres.
    pub radius_m: f64,
    /// Displacement at the centre along the outward normal, metres (positive bump, negative dent).
    pub height_m: f64,
}

/// Draws the features on `mesh` (model frame). A surface point qualifies when its normal's
/// component along `up` (unit, model frame) exceeds 0.3 and `height(p)` exceeds `min_height`.
pub fn place(
    mesh: &TriangleMesh,
    up: &Vector3<f64>,
    height: impl Fn(&Point3<f64>) -> f64,
    min_height: f64,
    cfg: &FoulingConfig,
    rng: &mut ChaCha8Rng,
) -> Vec<FoulingFeature> {
    let mut cumulative = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        total += 0.5 * (b - a).cross(&(c - a)).norm();
        cumulative.push(total);
    }
    let mut features = Vec::new();
    if total <= 0.0 {
        return features;
    }
    let kinds = (0..cfg.bumps)
        .map(|_| (1.0, cfg.bump_height_m, cfg.bump_radius_m))
        .chain((0..cfg.dents).map(|_| (-1.0, cfg.dent_depth_m, cfg.dent_radius_m)));
    for (sign, heights, radii) in kinds {
        let h = sign * uniform(rng, heights);
        let radius = uniform(rng, radii);
        for _ in 0..1000 {
            let u = rng.random::<f64>() * total;
            let t = cumulative
                .partition_point(|&c| c < u)
                .min(mesh.triangles.len() - 1);
            let (r1, r2): (f64, f64) = (rng.random(), rng.random());
            let [a, b, c] = mesh.triangles[t].map(|i| mesh.vertices[i as usize]);
            let s = r1.sqrt();
            let p = Point3::from(a.coords * (1.0 - s) + b.coords * (s * (1.0 - r2)) + c.coords * (s * r2));
            let up_facing = mesh.triangle_normal(t).is_some_and(|n| n.dot(up) > 0.3);
            if up_facing && height(&p) > min_height {
                features.push(FoulingFeature {
                    centre: p,
                    radius_m: radius,
                    height_m: h,
                });
                break;
            }
        }
    }
    features
}

/// The mesh with the features applied, and each vertex's displacement along its normal, metres.
pub fn deform(mesh: &TriangleMesh, features: &[FoulingFeature]) -> (TriangleMesh, Vec<f64>) {
    let normals = mesh.vertex_normals();
    let mut out = mesh.clone();
    let mut shift = vec![0.0; mesh.vertices.len()];
    for (i, v) in mesh.vertices.iter().enumerate() {
        let d: f64 = features
            .iter()
            .map(|f| {
                let q = (v - f.centre).norm() / f.radius_m;
                if q < 1.0 {
                    f.height_m * (1.0 - q * q).powi(2)
                } else {
                    0.0
                }
            })
            .sum();
        if d != 0.0 {
            shift[i] = d;
            out.vertices[i] = v + normals[i] * d;
        }
    }
    (out, shift)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::bottle::{BottleConfig, bottle_mesh};
    use crate::synth::random::stream;

    #[test]
    fn features_sit_on_top_and_deform_only_locally() {
        let m = bottle_mesh(&BottleConfig::default()).unwrap();
        let up = Vector3::z();
        let cfg = FoulingConfig::default();
        let f = place(&m, &up, |p| p.z, 0.05, &cfg, &mut stream(4, 0, 0));
        assert_eq!(f.len(), (cfg.bumps + cfg.dents) as usize);
        assert!(f.iter().all(|f| f.centre.z > 0.05));
        assert_eq!(f.iter().filter(|f| f.height_m < 0.0).count(), cfg.dents as usize);
        let (d, shift) = deform(&m, &f);
        let normals = m.vertex_normals();
        for i in 0..m.vertices.len() {
            let near = f.iter().any(|f| (m.vertices[i] - f.centre).norm() < f.radius_m);
            if !near {
                assert_eq!(d.vertices[i], m.vertices[i]);
                assert_eq!(shift[i], 0.0);
            }
            assert!(((d.vertices[i] - m.vertices[i]) - normals[i] * shift[i]).norm() < 1e-15);
        }
        // The largest bump reaches close to its full height at some vertex.
        let tallest = f.iter().map(|f| f.height_m).fold(0.0, f64::max);
        let top = shift.iter().cloned().fold(0.0, f64::max);
        assert!(top > 0.5 * tallest && top <= tallest * 2.0, "{top} {tallest}");
    }
}
