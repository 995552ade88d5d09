//! Stones: rough, flattened ellipsoids.
//!
//! A unit icosphere (an icosahedron subdivided twice, 320 triangles) is roughened radially by a
//! smooth random field (±15 %), scaled to semi-axes `a ≥ b ≥ c` (flattened as beach and seabed
//! stones are) and turned about the vertical. Radial roughening of a star-shaped surface and a
//! positive scaling keep the mesh closed and outward-wound.

use super::random::{WaveField, uniform};
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Rotation3, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use std::collections::HashMap;

/// A unit sphere: an icosahedron subdivided `levels` times, outward-wound.
pub fn icosphere(levels: u32) -> TriangleMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<Point3<f64>> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Point3::from(Vector3::new(x, y, z).normalize()))
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Point3<f64>>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (v[a as usize].coords + v[b as usize].coords).normalize();
                v.push(Point3::from(m));
                (v.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    TriangleMesh { vertices, triangles }
}

/// A stone of longest diameter `size` metres centred at the origin, its flat side down along
/// `up` (unit); returns the mesh and the extent `(lowest, highest)` along `up`, metres.
pub fn stone(size: f64, up: &Vector3<f64>, rng: &mut ChaCha8Rng) -> (TriangleMesh, f64, f64) {
    let mut m = icosphere(2);
    let field = WaveField::new(rng, 12, [0.8, 3.0], 0.07, false);
    let a = 0.5 * size / 1.2; // the roughening can stretch a radius by up to ~20 %
    let b = a * uniform(rng, [0.6, 0.9]);
    let c = a * uniform(rng, [0.35, 0.6]);
    // Local frame: third axis along `up`, first turned by a random yaw about it.
    let yaw = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(*up),
        rng.random_range(0.0..std::f64::consts::TAU),
    );
    let e1 = up
        .cross(&Vector3::x())
        .try_normalize(1e-9)
        .unwrap_or_else(|| up.cross(&Vector3::y()).normalize());
    let e2 = up.cross(&e1);
    let basis = nalgebra::Matrix3::from_columns(&[e1, e2, *up]);
    for v in &mut m.vertices {
        let r = (1.0 + field.at(v).clamp(-0.15, 0.15)) * v.coords;
        let local = Vector3::new(a * r.x, b * r.y, c * r.z);
        *v = Point3::from(yaw * (basis * local));
    }
    let heights = m.vertices.iter().map(|v| v.coords.dot(up));
    let (lo, hi) = heights.fold((f64::MAX, f64::MIN), |(lo, hi), h| (lo.min(h), hi.max(h)));
    (m, lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::random::stream;

    #[test]
    fn icosphere_is_closed_and_outward() {
        let m = icosphere(2);
        assert_eq!((m.vertices.len(), m.triangles.len()), (162, 320));
        let v = m.signed_volume();
        assert!(v > 0.95 * 4.0 / 3.0 * std::f64::consts::PI * 0.97 && v < 4.0 / 3.0 * std::f64::consts::PI);
        for t in 0..m.triangles.len() {
            let c = m.vertices[m.triangles[t][0] as usize];
            assert!(m.triangle_normal(t).unwrap().dot(&c.coords) > 0.0);
        }
    }

    #[test]
    fn stone_is_flat_and_sized() {
        let up = Vector3::new(0.1, 0.0, -1.0).normalize();
        let (m, lo, hi) = stone(0.1, &up, &mut stream(1, 0, 0));
        assert!(m.signed_volume() > 0.0);
        let (bl, bh) = crate::cloud::bbox(&m.vertices).unwrap();
        let longest = (bh - bl).norm();
        assert!(longest < 0.12 && longest > 0.05, "{longest}");
        assert!(hi - lo < 0.06 && hi - lo > 0.02, "height {}", hi - lo);
    }
}
