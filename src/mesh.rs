//! Triangle meshes (reference models, triangulated scan surfaces, true scene surfaces).

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

/// The barycentric weights of `p` (projected into the triangle's plane) on the triangle
/// `a, b, c`; the centroid's for a degenerate triangle.
pub fn barycentric(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>, p: &Point3<f64>) -> [f64; 3] {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11, d20, d21) = (v0.dot(&v0), v0.dot(&v1), v1.dot(&v1), v2.dot(&v0), v2.dot(&v1));
    let den = d00 * d11 - d01 * d01;
    if den.abs() < 1e-300 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    [1.0 - v - w, v, w]
}

/// An indexed triangle mesh; triangles are counter-clockwise seen from outside (normals point out).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions, metres.
    pub vertices: Vec<Point3<f64>>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The surface's area-weighted centroid and covariance (its second moment about the
    /// centroid per unit area), exact per triangle (`A/12 (Σ vᵢvᵢᵀ + s sᵀ)` with `s = Σ vᵢ`);
    /// `None` for a mesh without a finite, positive area. Triangle indices must be in range.
    pub fn surface_moments(&self) -> Option<(Point3<f64>, Matrix3<f64>)> {
        let mut area = 0.0;
        let mut first = Vector3::zeros();
        let mut second = Matrix3::zeros();
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize].coords);
            let at = 0.5 * (b - a).cross(&(c - a)).norm();
            let s = a + b + c;
            area += at;
            first += s * (at / 3.0);
            second +=
                (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose()) * (at / 12.0);
        }
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        let centre = first / area;
        Some((Point3::from(centre), second / area - centre * centre.transpose()))
    }

    /// Signed enclosed volume, cubic metres (divergence theorem): positive for a closed mesh
    /// wound outward, meaningless for an open one.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize].coords);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    /// The unit normal of triangle `t` (by its winding), or `None` for a degenerate triangle.
    pub fn triangle_normal(&self, t: usize) -> Option<Vector3<f64>> {
        let [a, b, c] = self.triangles[t].map(|i| self.vertices[i as usize]);
        (b - a).cross(&(c - a)).try_normalize(1e-300)
    }

    /// The triangles with an area (those with a normal, [`Self::triangle_normal`]), in their
    /// order. Triangle indices must be in range.
    pub fn triangles_with_area(&self) -> impl Iterator<Item = &[u32; 3]> {
        (0..self.triangles.len())
            .filter(|&t| self.triangle_normal(t).is_some())
            .map(|t| &self.triangles[t])
    }

    /// How many triangles with an area repeat an earlier one: the same three corners (by
    /// position, in any order or winding), as a two-sided surface or a face written twice has
    /// them (triangles without area, a strip's joints, are left out). Triangle indices must be
    /// in range.
    pub fn repeated_triangles(&self) -> usize {
        let mut seen = std::collections::HashSet::with_capacity(self.triangles.len());
        self.triangles_with_area()
            .filter(|t| {
                let mut corners = t.map(|i| self.vertices[i as usize].coords.map(|c| (c + 0.0).to_bits()));
                corners.sort_unstable_by_key(|c| (c.x, c.y, c.z));
                !seen.insert(corners)
            })
            .count()
    }

    /// The mesh with every vertex mapped by `pose`.
    pub fn transformed(&self, pose: &Isometry3<f64>) -> TriangleMesh {
        TriangleMesh {
            vertices: self.vertices.iter().map(|v| pose * v).collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// `n` points spread uniformly over the surface (area-weighted, seeded `ChaCha8Rng`) with the
    /// normals of the triangles they lie on. Degenerate triangles get none; an empty or
    /// zero-area mesh gives none. The cost is linear in `n`: callers bound it (the reference
    /// model's [`crate::register::MAX_MESH_SAMPLES`]).
    pub fn sample_surface(&self, n: usize, seed: u64) -> (Vec<Point3<f64>>, Vec<Vector3<f64>>) {
        use rand::{RngExt, SeedableRng};
        let nv = self.vertices.len();
        let mut cumulative = Vec::with_capacity(self.triangles.len());
        let mut total = 0.0;
        for t in &self.triangles {
            if t.iter().all(|&i| (i as usize) < nv) {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                total += 0.5 * (b - a).cross(&(c - a)).norm();
            }
            cumulative.push(total);
        }
        if !(total > 0.0 && total.is_finite()) {
            return (Vec::new(), Vec::new());
        }
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
        let mut points = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(n);
        while points.len() < n {
            let x = rng.random::<f64>() * total;
            let t = cumulative.partition_point(|&c| c <= x).min(cumulative.len() - 1);
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            let Some(normal) = self.triangle_normal(t) else {
                continue;
            };
            let [a, b, c] = self.triangles[t].map(|i| self.vertices[i as usize]);
            let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
            points.push(a + (b - a) * u + (c - a) * v);
            normals.push(normal);
        }
        (points, normals)
    }

    /// A square grid of `n × n` vertices `step` apart in x and y, centred on the origin, vertex
    /// `(i, j)` (`i` along x, the index `j·n + i`, made in that order) at the height
    /// `z(i, j)`, its triangles wound so that their normals point up (`−z`, NED).
    pub fn grid(n: u32, step: f64, mut z: impl FnMut(u32, u32) -> f64) -> TriangleMesh {
        let half = f64::from(n.saturating_sub(1)) / 2.0;
        let vertices = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .map(|(i, j)| {
                let (x, y) = ((f64::from(i) - half) * step, (f64::from(j) - half) * step);
                Point3::new(x, y, z(i, j))
            })
            .collect();
        let triangles = (0..n.saturating_sub(1))
            .flat_map(|j| (0..n - 1).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let (a, b, c, d) = (j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i);
                [[a, c, b], [a, d, c]]
            })
            .collect();
        TriangleMesh { vertices, triangles }
    }

    /// Per-vertex unit normals: the area-weighted mean of the adjacent triangles' normals (zero
    /// for a vertex no triangle uses).
    pub fn vertex_normals(&self) -> Vec<Vector3<f64>> {
        let mut n = vec![Vector3::zeros(); self.vertices.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let w = (b - a).cross(&(c - a)); // twice the area times the unit normal
            for &i in t {
                n[i as usize] += w;
            }
        }
        n.iter()
            .map(|v| v.try_normalize(1e-300).unwrap_or_else(Vector3::zeros))
            .collect()
    }

    /// Total surface area, square metres.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 × 3 grid 2 m apart: centred on the origin, 8 triangles covering its 16 m², every
    /// normal up (−z), the heights where asked.
    #[test]
    fn a_grid_is_centred_wound_up_and_at_its_heights() {
        let g = TriangleMesh::grid(3, 2.0, |i, j| f64::from(10 * j + i) * 1e-3);
        assert_eq!((g.vertices.len(), g.triangles.len()), (9, 8));
        assert_eq!(g.vertices[0], Point3::new(-2.0, -2.0, 0.0));
        assert_eq!(g.vertices[5], Point3::new(2.0, 0.0, 0.012));
        assert!((g.area() - 16.0).abs() < 1e-3);
        for n in g.vertex_normals() {
            assert!(n.z < -0.99, "{n}");
        }
    }

    /// A grid holds no repeated triangle; the same grid with its triangles again, turned
    /// round, or on vertices of their own at the same places, holds every one twice; two
    /// triangles without area on the same corners do not count.
    #[test]
    fn a_two_sided_surface_repeats_its_triangles() {
        let g = TriangleMesh::grid(3, 2.0, |_, _| 0.0);
        assert_eq!(g.repeated_triangles(), 0);
        let mut turned = g.clone();
        turned
            .triangles
            .extend(g.triangles.iter().map(|&[a, b, c]| [c, b, a]));
        assert_eq!(turned.repeated_triangles(), 8);
        let mut copied = g.clone();
        let n = g.vertices.len() as u32;
        copied.vertices.extend(g.vertices.iter().copied());
        copied
            .triangles
            .extend(g.triangles.iter().map(|&[a, b, c]| [b + n, a + n, c + n]));
        assert_eq!(copied.repeated_triangles(), 8);
        // A strip's joints, twice, have no area: none repeats.
        let mut joints = g.clone();
        joints.triangles.extend([[0, 1, 1], [1, 0, 1]]);
        assert_eq!(joints.repeated_triangles(), 0);
    }
}
