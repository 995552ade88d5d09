//! `Surface`: ray casting and closest-point queries on a triangle mesh.
//!
//! The one adapter to parry3d-f64 (glam-based since 0.26): glam types never leave this module.
//! Normals returned here are the triangles' own (by winding), whichever side a ray hits from.

use crate::error::{Error, Result};
use crate::mesh::{TriangleMesh, barycentric};
use nalgebra::{Point3, Vector3};
use parry3d_f64::math::Vector as GVec;
use parry3d_f64::query::{PointProjection, PointQuery, PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::TrianglePointLocation;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};

/// A triangle mesh prepared for queries (a BVH over its triangles).
pub struct Surface {
    mesh: TriMesh,
    /// Per vertex, the area-weighted mean of the adjacent triangles' unit normals
    /// ([`TriangleMesh::vertex_normals`]), for [`Surface::shaded_normal`].
    vertex_normals: Vec<Vector3<f64>>,
}

/// Where a ray meets the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// The hit point, metres.
    pub point: Point3<f64>,
    /// Distance along the (unit) ray direction, metres.
    pub distance: f64,
    /// Index of the triangle hit.
    pub triangle: usize,
    /// The triangle's unit normal (by its winding).
    pub normal: Vector3<f64>,
}

/// The closest point of the surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The closest surface point, metres.
    pub point: Point3<f64>,
    /// Distance from the query to `point`, metres.
    pub distance: f64,
    /// Index of the triangle that holds `point`.
    pub triangle: usize,
    /// Barycentric weights of `point` on that triangle's vertices.
    pub barycentric: [f64; 3],
    /// The triangle's unit normal (by its winding).
    pub normal: Vector3<f64>,
}

fn g(p: &Point3<f64>) -> GVec {
    GVec::new(p.x, p.y, p.z)
}
fn gv(v: &Vector3<f64>) -> GVec {
    GVec::new(v.x, v.y, v.z)
}
fn na(v: GVec) -> Point3<f64> {
    Point3::new(v.x, v.y, v.z)
}

impl Surface {
    /// Builds the query structure. Degenerate triangles are dropped; triangle indices in query
    /// results refer to the triangles that remain, in their original order.
    ///
    /// # Errors
    /// [`Error::Input`] if the mesh has no triangle, an index out of range, or a non-finite vertex.
    pub fn new(mesh: &TriangleMesh) -> Result<Self> {
        let n = mesh.vertices.len();
        if mesh.triangles.is_empty() {
            return Err(Error::input("surface", "mesh has no triangles"));
        }
        if mesh
            .vertices
            .iter()
            .any(|v| !v.coords.iter().all(|c| c.is_finite()))
        {
            return Err(Error::input("surface", "mesh has a non-finite vertex"));
        }
        if mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
            return Err(Error::input("surface", "a triangle index is out of range"));
        }
        let verts = mesh.vertices.iter().map(g).collect();
        let tri = TriMesh::with_flags(verts, mesh.triangles.clone(), TriMeshFlags::empty())
            .map_err(|e| Error::input("surface", format!("{e:?}")))?;
        Ok(Surface {
            mesh: tri,
            vertex_normals: mesh.vertex_normals(),
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.mesh.indices().len()
    }

    fn normal(&self, t: u32) -> Vector3<f64> {
        let n = self.mesh.triangle(t).normal().unwrap_or(GVec::Z);
        Vector3::new(n.x, n.y, n.z)
    }

    /// The normal of the smooth surface the mesh approximates at a projection's point: the
    /// vertex normals blended by its barycentric weights (Phong's interpolation), continuous
    /// across the triangles' edges where the triangles' own normals jump; the triangle's own
    /// where the blend vanishes.
    pub fn shaded_normal(&self, p: &Projection) -> Vector3<f64> {
        self.blend(p.triangle, p.barycentric).unwrap_or(p.normal)
    }

    /// [`Surface::shaded_normal`] where a ray hit the surface.
    pub fn shaded_normal_at_hit(&self, hit: &RayHit) -> Vector3<f64> {
        let Ok(t) = u32::try_from(hit.triangle) else {
            return hit.normal;
        };
        let tri = self.mesh.triangle(t);
        let weights = barycentric(&na(tri.a), &na(tri.b), &na(tri.c), &hit.point);
        self.blend(hit.triangle, weights).unwrap_or(hit.normal)
    }

    fn blend(&self, triangle: usize, weights: [f64; 3]) -> Option<Vector3<f64>> {
        let idx = self.mesh.indices().get(triangle)?;
        let n: Vector3<f64> = idx
            .iter()
            .zip(weights)
            .map(|(&v, w)| self.vertex_normals[v as usize] * w)
            .sum();
        n.try_normalize(1e-12)
    }

    /// The first hit of the ray `origin + s·dir` (`dir` need not be unit) for `0 ≤ s ≤ max_distance`
    /// metres, from either side of the triangles; `None` when it hits nothing.
    pub fn cast_ray(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_distance: f64) -> Option<RayHit> {
        let d = dir.try_normalize(1e-300)?;
        let ray = Ray::new(g(origin), gv(&d));
        let hit = self
            .mesh
            .cast_local_ray_and_get_normal(&ray, max_distance, false)?;
        let tri = hit.subshape;
        Some(RayHit {
            point: origin + d * hit.time_of_impact,
            distance: hit.time_of_impact,
            triangle: tri as usize,
            normal: self.normal(tri),
        })
    }

    /// The closest point of the surface to `p`.
    pub fn project(&self, p: &Point3<f64>) -> Projection {
        let (proj, (tri, loc)) = self.mesh.project_local_point_and_get_location(g(p), false);
        self.projection(p, &proj, tri, &loc)
    }

    /// [`Surface::project`] warm-started by the triangle `hint` (the last closest triangle of a
    /// point that moves a little between queries): the distance to it bounds the search, so the
    /// BVH descends only into boxes nearer than that. The closest point is the same; of
    /// triangles equally near (the point closest to a shared edge or vertex) the search may
    /// settle on another one than `project` would.
    pub fn project_near(&self, p: &Point3<f64>, hint: usize) -> Projection {
        let q = g(p);
        let Ok(hint) = u32::try_from(hint) else {
            return self.project(p);
        };
        if hint as usize >= self.triangle_count() {
            return self.project(p);
        }
        let bound = (self.mesh.triangle(hint).project_local_point(q, false).point - q).length();
        // Strictly inside the bound is what the search accepts: widen it by the round-off.
        let max_dist = bound * (1.0 + 1e-9) + 1e-12;
        match self
            .mesh
            .project_local_point_and_get_location_with_max_dist(q, false, max_dist)
        {
            Some((proj, (tri, loc))) => self.projection(p, &proj, tri, &loc),
            None => self.project(p),
        }
    }

    fn projection(
        &self,
        p: &Point3<f64>,
        proj: &PointProjection,
        tri: u32,
        loc: &TrianglePointLocation,
    ) -> Projection {
        let point = na(proj.point);
        Projection {
            point,
            distance: (point - p).norm(),
            triangle: tri as usize,
            barycentric: loc.barycentric_coordinates().unwrap_or([1.0 / 3.0; 3]),
            normal: self.normal(tri),
        }
    }

    /// True if `p` is inside the closed surface (odd number of crossings along a fixed ray).
    /// Meaningful only for closed meshes.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        // A direction unlikely to be parallel to any modelled edge or face.
        let dir = Vector3::new(0.5773, 0.5774, 0.5772).normalize();
        let mut origin = *p;
        let mut crossings = 0;
        while let Some(hit) = self.cast_ray(&origin, &dir, f64::MAX) {
            crossings += 1;
            origin = hit.point + dir * 1e-9;
            if crossings > 10_000 {
                break;
            }
        }
        crossings % 2 == 1
    }
}

/// Indices of the points that are vertices of their convex hull (quickhull), increasing; `None`
/// when the hull is degenerate (fewer than four points not all in a plane) or fails numerically.
/// Duplicate points share one hull vertex: the first of them is reported.
pub fn convex_hull_vertices(points: &[Point3<f64>]) -> Option<Vec<usize>> {
    let pts: Vec<GVec> = points.iter().map(g).collect();
    let (hull, _) = parry3d_f64::transformation::try_convex_hull(&pts).ok()?;
    // The hull's vertices are exact copies of input points: find them back by their bits.
    let key = |v: &GVec| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let mut first = std::collections::HashMap::with_capacity(points.len());
    for (i, p) in pts.iter().enumerate() {
        first.entry(key(p)).or_insert(i);
    }
    let mut out: Vec<usize> = hull.iter().filter_map(|v| first.get(&key(v)).copied()).collect();
    out.sort_unstable();
    out.dedup();
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube [0,1]³ with outward, counter-clockwise triangles.
    pub(crate) fn cube() -> TriangleMesh {
        let v = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let t = vec![
            [0, 2, 1],
            [1, 2, 3], // z = 0
            [4, 5, 6],
            [5, 7, 6], // z = 1
            [0, 1, 4],
            [1, 5, 4], // y = 0
            [2, 6, 3],
            [3, 6, 7], // y = 1
            [0, 4, 2],
            [2, 4, 6], // x = 0
            [1, 3, 5],
            [3, 7, 5], // x = 1
        ];
        TriangleMesh {
            vertices: v,
            triangles: t,
        }
    }

    #[test]
    fn cube_normals_point_out() {
        let m = cube();
        let c = Point3::new(0.5, 0.5, 0.5);
        for t in 0..m.triangles.len() {
            let n = m.triangle_normal(t).unwrap();
            let p = m.vertices[m.triangles[t][0] as usize];
            assert!(n.dot(&(p - c)) > 0.0, "triangle {t}");
        }
    }

    #[test]
    fn ray_and_projection_on_cube() {
        let s = Surface::new(&cube()).unwrap();
        let hit = s
            .cast_ray(&Point3::new(0.5, 0.5, -1.0), &Vector3::new(0.0, 0.0, 2.0), 10.0)
            .unwrap();
        assert!((hit.distance - 1.0).abs() < 1e-12);
        assert!((hit.normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        // From inside, the ray meets the top face's back side; the normal stays the face's own.
        let hit = s
            .cast_ray(&Point3::new(0.5, 0.5, 0.5), &Vector3::z(), 10.0)
            .unwrap();
        assert!((hit.point.z - 1.0).abs() < 1e-12 && hit.normal.z > 0.99);
        assert!(
            s.cast_ray(&Point3::new(2.0, 2.0, -1.0), &Vector3::z(), 10.0)
                .is_none()
        );
        let p = s.project(&Point3::new(0.3, 0.4, 1.25));
        assert!((p.distance - 0.25).abs() < 1e-12 && p.normal.z > 0.99);
        let w = p.barycentric;
        let q = m_point(&cube(), p.triangle, w);
        assert!((q - p.point).norm() < 1e-12);
        assert!(s.contains(&Point3::new(0.3, 0.3, 0.3)));
        assert!(!s.contains(&Point3::new(1.3, 0.3, 0.3)));
    }

    #[test]
    fn projection_warm_started_anywhere_finds_the_same_closest_point() {
        let s = Surface::new(&cube()).unwrap();
        let mut rng = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.0
        };
        for _ in 0..200 {
            let p = Point3::new(next(), next(), next());
            let want = s.project(&p);
            for hint in [0, 5, 11, want.triangle, 99] {
                let got = s.project_near(&p, hint);
                assert!((got.point - want.point).norm() < 1e-12, "{p} from {hint}");
                assert_eq!(got.distance, want.distance);
            }
        }
    }

    fn m_point(m: &TriangleMesh, t: usize, w: [f64; 3]) -> Point3<f64> {
        let [a, b, c] = m.triangles[t].map(|i| m.vertices[i as usize].coords);
        Point3::from(a * w[0] + b * w[1] + c * w[2])
    }

    #[test]
    fn hull_vertices_of_a_cube_with_inner_points() {
        let mut pts = cube().vertices;
        pts.push(Point3::new(0.5, 0.5, 0.5));
        pts.push(Point3::new(0.2, 0.7, 0.4));
        pts.push(Point3::new(1.0, 1.0, 1.0)); // duplicate of vertex 7
        assert_eq!(convex_hull_vertices(&pts).unwrap(), (0..8).collect::<Vec<_>>());
        assert!(convex_hull_vertices(&pts[..2]).is_none());
    }

    #[test]
    fn rejects_bad_meshes() {
        let mut m = cube();
        m.triangles.push([0, 1, 99]);
        assert!(Surface::new(&m).is_err());
        assert!(Surface::new(&TriangleMesh::default()).is_err());
    }
}
