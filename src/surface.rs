//! `Surface`: ray casting and closest-point queries on a triangle mesh.
//!
//! The one adapter to parry3d-f64 (glam-based since 0.26): glam types never leave this module.
//! Normals returned here are the triangles' own (by winding), whichever side a ray hits from.

use crate::error::{Error, Result};
use crate::mesh::{TriangleMesh, barycentric};
use nalgebra::{Point3, Vector3};
use parry3d_f64::math::Vector as GVec;
use parry3d_f64::partitioning::BvhNode;
use parry3d_f64::query::{PointProjection, PointQuery, PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::TrianglePointLocation;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use std::collections::{HashMap, HashSet};

/// A triangle mesh prepared for queries (a BVH over its triangles).
pub struct Surface {
    mesh: TriMesh,
    /// Per vertex, the area-weighted mean of the adjacent triangles' unit normals
    /// ([`TriangleMesh::vertex_normals`]), for [`Surface::shaded_normal`].
    vertex_normals: Vec<Vector3<f64>>,
    /// The rim of an open mesh: the edges of one triangle only (vertex pairs, the lower index
    /// first), and whether each vertex is on one, for [`Surface::on_rim`].
    rim: HashSet<(u32, u32)>,
    rim_vertices: Vec<bool>,
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

/// The triangles around a point, for [`Surface::project_tracked`]: every triangle within
/// `radius` of `centre`, with its distance from there, nearest first. Empty until the first
/// query.
#[derive(Debug, Clone)]
pub struct Neighbourhood {
    /// How far a query may stray from the centre before the list is rebuilt, m: a longer list
    /// against fewer rebuilds.
    reach: f64,
    centre: GVec,
    radius: f64,
    /// The distance from the centre to the closest triangle, m.
    closest: f64,
    triangles: Vec<(f64, u32)>,
    /// The last query's nearest triangles, with their projections.
    nearest: Vec<(u32, PointProjection, TrianglePointLocation)>,
}

impl Neighbourhood {
    /// An empty list that will cover `reach` metres around the point it is built for.
    pub fn new(reach: f64) -> Self {
        Neighbourhood {
            reach,
            centre: GVec::ZERO,
            radius: f64::NEG_INFINITY,
            closest: f64::INFINITY,
            triangles: Vec::new(),
            nearest: Vec::new(),
        }
    }
}

/// The margin on the distances compared in [`Surface::project_tracked`], m: far above their
/// round-off for coordinates within kilometres of the origin, far below anything a query
/// could gain from it.
const NEAR_SLACK_M: f64 = 1e-9;

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
    /// [`Error::Input`] if the mesh has no triangle with an area, an index out of range, or a
    /// non-finite vertex.
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
        // A triangle without area has no side to push from, and its edges would hide an open
        // mesh's rim.
        let triangles: Vec<[u32; 3]> = mesh.triangles_with_area().copied().collect();
        if triangles.is_empty() {
            return Err(Error::input("surface", "mesh has no triangles with an area"));
        }
        let verts = mesh.vertices.iter().map(g).collect();
        let tri = TriMesh::with_flags(verts, triangles, TriMeshFlags::empty())
            .map_err(|e| Error::input("surface", format!("{e:?}")))?;
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in tri.indices() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let rim: HashSet<(u32, u32)> = edges
            .into_iter()
            .filter(|&(_, n)| n == 1)
            .map(|(e, _)| e)
            .collect();
        let mut rim_vertices = vec![false; n];
        for &(a, b) in &rim {
            rim_vertices[a as usize] = true;
            rim_vertices[b as usize] = true;
        }
        Ok(Surface {
            mesh: tri,
            vertex_normals: mesh.vertex_normals(),
            rim,
            rim_vertices,
        })
    }

    /// Whether a projection's point lies on the rim of an open mesh (an edge of one triangle
    /// only, or a vertex of such an edge): a point beyond the rim is closest to it, and there is
    /// no surface, nor material behind it, out there.
    pub fn on_rim(&self, p: &Projection) -> bool {
        let Some(idx) = self.mesh.indices().get(p.triangle) else {
            return false;
        };
        let w = p.barycentric;
        let rim = |a: usize, b: usize| {
            let (a, b) = (idx[a], idx[b]);
            self.rim.contains(&(a.min(b), a.max(b)))
        };
        // On a vertex: one of the rim's, whichever triangle of its fan the point was found on.
        let rim_vertex = |a: usize| self.rim_vertices.get(idx[a] as usize).copied().unwrap_or(false);
        match (w[0] == 0.0, w[1] == 0.0, w[2] == 0.0) {
            // On the edge opposite the vertex whose weight is zero.
            (true, false, false) => rim(1, 2),
            (false, true, false) => rim(2, 0),
            (false, false, true) => rim(0, 1),
            (false, true, true) => rim_vertex(0),
            (true, false, true) => rim_vertex(1),
            (true, true, false) => rim_vertex(2),
            _ => false,
        }
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

    /// [`Surface::shaded_normal`] at the point of `triangle` (an index as in the query
    /// results, below [`Surface::triangle_count`]) with the barycentric `weights`.
    pub fn shaded_normal_in(&self, triangle: usize, weights: [f64; 3]) -> Vector3<f64> {
        self.blend(triangle, weights)
            .unwrap_or_else(|| u32::try_from(triangle).map_or(Vector3::z(), |t| self.normal(t)))
    }

    /// The corners of `triangle` (an index as in the query results), in its winding.
    pub fn corners(&self, triangle: usize) -> Option<[Point3<f64>; 3]> {
        let index = u32::try_from(triangle)
            .ok()
            .filter(|_| triangle < self.triangle_count())?;
        let t = self.mesh.triangle(index);
        Some([na(t.a), na(t.b), na(t.c)])
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

    /// The distance from `p` to the surface when it is at most `max_distance`; `None` beyond
    /// (the tree's search stops there).
    pub fn distance_within(&self, p: &Point3<f64>, max_distance: f64) -> Option<f64> {
        let q = g(p);
        self.mesh
            .project_local_point_with_max_dist(q, false, max_distance)
            .map(|proj| (proj.point - q).length())
    }

    /// The closest point of the surface to `p`.
    pub fn project(&self, p: &Point3<f64>) -> Projection {
        let (proj, (tri, loc)) = self.mesh.project_local_point_and_get_location(g(p), false);
        self.projection(p, &proj, tri, &loc)
    }

    /// [`Surface::project`] for a point that moves a little between queries (a tool tip along
    /// its path), over the triangles `near` lists around an earlier point instead of the whole
    /// mesh; `near` is rebuilt around `p` when `p` has left the part of space where that is
    /// exact. The same projection as [`Surface::project`], which is the first of the equally
    /// near triangles (the point closest to a shared edge or vertex) in its tree's order:
    /// `Surface::first_in_tree_order` settles those.
    ///
    /// Why the list suffices: it holds every triangle within `radius` of its centre `c`, whose
    /// closest triangle is `d_c` away. From `p` at `m = |p − c|` the closest triangle is at most
    /// `d_c + m` away, so at most `d_c + 2m` from `c`: listed while `d_c + 2m ≤ radius`. The
    /// list is sorted by the distance `d_t` from `c`, and a triangle is at least `d_t − m` from
    /// `p`: the scan stops at the first one that cannot be as near as the best so far. The
    /// round-off of the distances (~1e-16 of the coordinates) is covered by `NEAR_SLACK_M`.
    pub fn project_tracked(&self, p: &Point3<f64>, near: &mut Neighbourhood) -> Projection {
        let q = g(p);
        let mut m = (q - near.centre).length();
        // (False for a point that is not finite too: the list is rebuilt, finds nothing, and
        // the full search answers.)
        let covered = near.closest + 2.0 * m + NEAR_SLACK_M <= near.radius;
        if !covered {
            self.gather(q, near);
            m = 0.0;
        }
        // The nearest triangles (all of them when equally near): the search's cost, computed
        // as it does.
        let mut best = f64::MAX;
        near.nearest.clear();
        for &(d_t, t) in &near.triangles {
            if d_t - m > best + NEAR_SLACK_M {
                break;
            }
            let (proj, loc) = self
                .mesh
                .triangle(t)
                .project_local_point_and_get_location(q, false);
            let cost = (proj.point - q).length();
            if cost < best {
                best = cost;
                near.nearest.clear();
            }
            if cost == best {
                near.nearest.push((t, proj, loc));
            }
        }
        let chosen = match near.nearest[..] {
            [] => None,
            [one] => Some(one),
            ref tied => self.first_in_tree_order(q, tied),
        };
        match chosen {
            Some((t, proj, loc)) => self.projection(p, &proj, t, &loc),
            None => self.project(p),
        }
    }

    /// Of equally near triangles, the one [`Surface::project`]'s search settles on: the first
    /// it meets. It walks the tree depth first, at each node into the child whose box is
    /// nearer (the left one of two equally near); walked in the same way through the boxes
    /// that hold one of the closest points (all others skipped), it meets the same one first.
    fn first_in_tree_order(
        &self,
        q: GVec,
        tied: &[(u32, PointProjection, TrianglePointLocation)],
    ) -> Option<(u32, PointProjection, TrianglePointLocation)> {
        let slack = GVec::splat(NEAR_SLACK_M);
        let box_cost = |node: &BvhNode, _: f64| {
            let b = node.aabb();
            let holds = |(_, proj, _): &(u32, PointProjection, TrianglePointLocation)| {
                (b.mins - slack).cmple(proj.point).all() && proj.point.cmple(b.maxs + slack).all()
            };
            // `f64::MAX`: the search does not enter the box.
            if tied.iter().any(holds) {
                b.distance_to_local_point(q, true)
            } else {
                f64::MAX
            }
        };
        // The first tied triangle met ends the search: nothing costs less than zero.
        let leaf_cost = |leaf: u32, _: f64| tied.iter().any(|c| c.0 == leaf).then_some(0.0);
        let (first, _) = self.mesh.bvh().find_best(f64::MAX, box_cost, leaf_cost)?;
        tied.iter().find(|c| c.0 == first).copied()
    }

    /// Lists in `near` every triangle within `d + 2·near.reach` of `q` (`d`: the distance to
    /// the closest one), nearest first.
    fn gather(&self, q: GVec, near: &mut Neighbourhood) {
        let (proj, _) = self.mesh.project_local_point_and_get_location(q, false);
        let radius = (proj.point - q).length() + 2.0 * near.reach + NEAR_SLACK_M;
        near.triangles.clear();
        // A box is at most as far as anything in it.
        let within = |node: &BvhNode| node.aabb().distance_to_local_point(q, true) <= radius + NEAR_SLACK_M;
        for t in self.mesh.bvh().leaves(within) {
            let d = (self.mesh.triangle(t).project_local_point(q, false).point - q).length();
            if d <= radius {
                near.triangles.push((d, t));
            }
        }
        near.triangles
            .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        near.centre = q;
        near.radius = radius;
        near.closest = near.triangles.first().map_or(f64::INFINITY, |&(d, _)| d);
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
pub(crate) mod tests {
    use super::*;

    /// The rim of an open mesh: a fan of three triangles around the vertex 0 at the middle of
    /// a half-disc's straight side. A point on the straight side, its ends or the arc, or at the
    /// fan's centre whichever triangle it is found on (the middle one's two edges there are
    /// inside the fan), is on the rim; a point on an inner edge or inside a triangle is not;
    /// a closed cube has no rim.
    #[test]
    fn the_rim_is_the_edges_of_one_triangle_and_their_vertices() {
        let fan = TriangleMesh {
            vertices: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.5, 1.0, 0.0),
                Point3::new(-0.5, 1.0, 0.0),
                Point3::new(-1.0, 0.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]],
        };
        let s = Surface::new(&fan).unwrap();
        let at = |triangle: usize, barycentric: [f64; 3]| Projection {
            point: Point3::origin(),
            distance: 0.0,
            triangle,
            barycentric,
            normal: Vector3::z(),
        };
        for (t, w) in [
            (1, [1.0, 0.0, 0.0]),
            (0, [0.5, 0.5, 0.0]),
            (2, [0.0, 0.0, 1.0]),
            (0, [0.0, 0.5, 0.5]),
        ] {
            assert!(s.on_rim(&at(t, w)), "triangle {t} at {w:?}");
        }
        for (t, w) in [(1, [0.5, 0.5, 0.0]), (1, [0.2, 0.3, 0.5])] {
            assert!(!s.on_rim(&at(t, w)), "triangle {t} at {w:?}");
        }
        let cube = Surface::new(&cube()).unwrap();
        assert!(!cube.on_rim(&at(0, [1.0, 0.0, 0.0])));
    }

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

    /// A bumpy heightfield of 2 × 40 × 40 triangles over the unit square: a tree of some depth,
    /// and vertices at peaks and in pits.
    fn bumps() -> TriangleMesh {
        let n = 41_u32;
        let z = |x: f64, y: f64| 0.05 * (9.0 * x).sin() * (7.0 * y).cos();
        let vertices = (0..n * n)
            .map(|i| {
                let (x, y) = (f64::from(i % n) / 40.0, f64::from(i / n) / 40.0);
                Point3::new(x, y, z(x, y))
            })
            .collect();
        let triangles = (0..n - 1)
            .flat_map(|j| (0..n - 1).map(move |i| j * n + i))
            .flat_map(|v| [[v, v + 1, v + n + 1], [v, v + n + 1, v + n]])
            .collect();
        TriangleMesh { vertices, triangles }
    }

    /// The tracked projection is the full search's, triangle and all: along random walks of
    /// small steps (a tool tip) with jumps anywhere now and then, and from points whose closest
    /// point is a vertex or lies on an edge, where several triangles are equally near and the
    /// search's own order decides.
    #[test]
    fn tracked_projection_is_the_full_search_s() {
        use rand::rngs::ChaCha8Rng;
        use rand::{RngExt, SeedableRng};
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (mesh, step) in [(cube(), 0.01), (bumps(), 0.002)] {
            let s = Surface::new(&mesh).unwrap();
            let mut near = Neighbourhood::new(0.005);
            let mut p = Point3::new(0.5, 0.5, 0.2);
            for k in 0..4000 {
                let mut r = |a: f64, b: f64| rng.random_range(a..b);
                p = if k % 97 == 0 {
                    Point3::new(r(-1.0, 2.0), r(-1.0, 2.0), r(-1.0, 2.0))
                } else {
                    p + Vector3::new(r(-step, step), r(-step, step), r(-step, step))
                };
                assert_eq!(s.project_tracked(&p, &mut near), s.project(&p), "{p} at {k}");
            }
            // Off the vertices and the edges' midpoints along the mean of their triangles'
            // normals (outside and inside); the list finds the equally near triangles.
            let normals = mesh.vertex_normals();
            let (mut probes, mut ties) = (0, 0);
            for t in mesh.triangles.iter().step_by(3) {
                for e in 0..3 {
                    let (i, j) = (t[e] as usize, t[(e + 1) % 3] as usize);
                    let (vi, vj) = (mesh.vertices[i], mesh.vertices[j]);
                    for (base, n) in [(vi, normals[i]), (vi + (vj - vi) / 2.0, normals[i] + normals[j])] {
                        for h in [0.003, -0.003] {
                            let p = base + n.normalize() * h;
                            assert_eq!(s.project_tracked(&p, &mut near), s.project(&p), "{p}");
                            ties += usize::from(near.nearest.len() > 1);
                            probes += 1;
                        }
                    }
                }
            }
            assert!(4 * ties > probes, "{ties} ties of {probes}");
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
