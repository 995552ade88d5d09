//! The vertices of a point set's convex hull, by quickhull (Barber, Dobkin & Huhdanpaa, "The
//! quickhull algorithm for convex hulls", ACM TOMS 1996).
//!
//! Hidden-point removal needs only which points are hull vertices, on point sets where nearly
//! half the points are (the spherically flipped near side of an object): this keeps a plain
//! triangle list with neighbour links and one outside set per face, and reports the vertices of
//! the final faces. A point counts as outside a face only when it lies more than a tolerance
//! (a few ulps of the coordinates' magnitude) above its plane, so points on a face or within
//! rounding of it are not vertices.

use nalgebra::{Point3, Vector3};

/// No face, no point.
const NONE: usize = usize::MAX;

/// One triangle of the hull under construction: counter-clockwise seen from outside.
struct Face {
    /// Vertex indices into the point set.
    v: [usize; 3],
    /// Face across edge `v[i] → v[i + 1]`.
    nb: [usize; 3],
    /// Unit outward normal.
    n: Vector3<f64>,
    /// Plane offset: `n · x = d` on the face.
    d: f64,
    /// First of the points above this face not yet on the hull (`NONE` if none; the others
    /// follow through `next`).
    outside: usize,
    /// Still part of the hull.
    alive: bool,
}

impl Face {
    fn new(points: &[Point3<f64>], v: [usize; 3]) -> Option<Face> {
        let [a, b, c] = v.map(|i| points[i]);
        let n = (b - a).cross(&(c - a)).try_normalize(0.0)?;
        Some(Face {
            v,
            nb: [usize::MAX; 3],
            n,
            d: n.dot(&a.coords),
            outside: NONE,
            alive: true,
        })
    }

    fn height(&self, p: &Point3<f64>) -> f64 {
        self.n.dot(&p.coords) - self.d
    }

    /// The slot `j` of the directed edge `a → b` (`v[j] = a`, `v[j + 1] = b`), if it has one.
    fn edge_slot(&self, a: usize, b: usize) -> Option<usize> {
        (0..3).find(|&j| self.v[j] == a && self.v[(j + 1) % 3] == b)
    }
}

/// Indices (increasing) of the points of `points` that are vertices of their convex hull; of
/// duplicate points one is reported. `None` when the hull is degenerate (fewer than four points
/// not in a plane) or the construction meets a numerical inconsistency.
pub fn hull_vertices(points: &[Point3<f64>]) -> Option<Vec<usize>> {
    let scale = points.iter().map(|p| p.coords.amax()).fold(0.0, f64::max);
    if points.len() < 4 || !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let eps = 64.0 * f64::EPSILON * scale;
    let mut faces = initial_simplex(points, eps)?;
    // Every other point goes to the outside set of the first face it is above; each set is a
    // list threaded through `next`.
    let mut next = vec![NONE; points.len()];
    let used: Vec<usize> = faces.iter().flat_map(|f| f.v).collect();
    for (i, p) in points.iter().enumerate() {
        if used.contains(&i) {
            continue;
        }
        if let Some(f) = faces.iter_mut().find(|f| f.height(p) > eps) {
            next[i] = f.outside;
            f.outside = i;
        }
    }
    let mut pending: Vec<usize> = (0..faces.len()).collect();
    let mut visible = Vec::new();
    let mut seen = vec![usize::MAX; faces.len()];
    let mut horizon: Vec<(usize, usize, usize)> = Vec::new();
    let mut orphans: Vec<usize> = Vec::new();
    while let Some(fi) = pending.pop() {
        if !faces[fi].alive || faces[fi].outside == NONE {
            continue;
        }
        // The farthest outside point of this face is certainly a hull vertex.
        let (mut eye, mut far) = (NONE, f64::NEG_INFINITY);
        let mut p = faces[fi].outside;
        while p != NONE {
            let h = faces[fi].height(&points[p]);
            if h > far {
                (eye, far) = (p, h);
            }
            p = next[p];
        }
        let e = points[eye];
        // The faces the eye sees: a connected patch around `fi`.
        visible.clear();
        visible.push(fi);
        seen.resize(faces.len(), usize::MAX);
        seen[fi] = eye;
        let mut k = 0;
        while k < visible.len() {
            let f = visible[k];
            k += 1;
            for g in faces[f].nb {
                if seen[g] != eye && faces[g].height(&e) > eps {
                    seen[g] = eye;
                    visible.push(g);
                }
            }
        }
        // Its border: edges a → b of visible faces whose neighbour g is not visible.
        horizon.clear();
        for &f in &visible {
            for i in 0..3 {
                let g = faces[f].nb[i];
                if seen[g] != eye {
                    horizon.push((faces[f].v[i], faces[f].v[(i + 1) % 3], g));
                }
            }
        }
        // Chain the border into one loop (it must be a simple cycle).
        let n = horizon.len();
        if n < 3 {
            return None;
        }
        for i in 0..n - 1 {
            let end = horizon[i].1;
            let j = (i + 1..n).find(|&j| horizon[j].0 == end)?;
            horizon.swap(i + 1, j);
        }
        if horizon[n - 1].1 != horizon[0].0 {
            return None;
        }
        // New faces from each border edge to the eye, linked to the old face across the edge and
        // to each other.
        let first = faces.len();
        for (idx, &(a, b, g)) in horizon.iter().enumerate() {
            let mut face = Face::new(points, [a, b, eye])?;
            face.nb = [g, first + (idx + 1) % n, first + (idx + n - 1) % n];
            let slot = faces[g].edge_slot(b, a)?;
            faces[g].nb[slot] = first + idx;
            faces.push(face);
        }
        // The visible faces' outside points go to the first new face they are above, or are
        // inside the hull now.
        orphans.clear();
        for &f in &visible {
            faces[f].alive = false;
            let mut p = std::mem::replace(&mut faces[f].outside, NONE);
            while p != NONE {
                orphans.push(p);
                p = next[p];
            }
        }
        for &p in &orphans {
            if p == eye {
                continue;
            }
            let x = &points[p];
            if let Some(f) = (first..faces.len()).find(|&f| faces[f].height(x) > eps) {
                next[p] = faces[f].outside;
                faces[f].outside = p;
            }
        }
        pending.extend(first..faces.len());
    }
    let mut out: Vec<usize> = faces.iter().filter(|f| f.alive).flat_map(|f| f.v).collect();
    out.sort_unstable();
    out.dedup();
    Some(out)
}

/// A tetrahedron of extreme points, its faces outward and linked; `None` if the points are
/// (within `eps`) on a plane.
fn initial_simplex(points: &[Point3<f64>], eps: f64) -> Option<Vec<Face>> {
    // The farthest apart pair among the extremes along the axes.
    let mut ext = [0usize; 6];
    for (i, p) in points.iter().enumerate() {
        for a in 0..3 {
            if p[a] < points[ext[2 * a]][a] {
                ext[2 * a] = i;
            }
            if p[a] > points[ext[2 * a + 1]][a] {
                ext[2 * a + 1] = i;
            }
        }
    }
    let (mut i0, mut i1, mut best) = (0, 0, 0.0);
    for &a in &ext {
        for &b in &ext {
            let d = (points[a] - points[b]).norm_squared();
            if d > best {
                (i0, i1, best) = (a, b, d);
            }
        }
    }
    if best.sqrt() <= eps {
        return None;
    }
    let axis = (points[i1] - points[i0]).normalize();
    let off_line = |p: &Point3<f64>| {
        let v = p - points[i0];
        (v - axis * v.dot(&axis)).norm()
    };
    let i2 = (0..points.len()).max_by(|&a, &b| off_line(&points[a]).total_cmp(&off_line(&points[b])))?;
    if off_line(&points[i2]) <= eps {
        return None;
    }
    let n = (points[i1] - points[i0])
        .cross(&(points[i2] - points[i0]))
        .normalize();
    let off_plane = |p: &Point3<f64>| n.dot(&(p - points[i0]));
    let i3 = (0..points.len()).max_by(|&a, &b| {
        off_plane(&points[a])
            .abs()
            .total_cmp(&off_plane(&points[b]).abs())
    })?;
    if off_plane(&points[i3]).abs() <= eps {
        return None;
    }
    // Orient the base so that the apex is behind it.
    let (b0, b1, b2) = if off_plane(&points[i3]) > 0.0 {
        (i0, i2, i1)
    } else {
        (i0, i1, i2)
    };
    let tri = [[b0, b1, b2], [b0, i3, b1], [b1, i3, b2], [b2, i3, b0]];
    let mut faces: Vec<Face> = tri.iter().map(|&v| Face::new(points, v)).collect::<Option<_>>()?;
    for f in 0..4 {
        for i in 0..3 {
            let (a, b) = (faces[f].v[i], faces[f].v[(i + 1) % 3]);
            faces[f].nb[i] = (0..4).find(|&g| g != f && faces[g].edge_slot(b, a).is_some())?;
        }
    }
    Some(faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn a_cube_and_degenerate_sets() {
        let mut pts: Vec<Point3<f64>> = (0..8)
            .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        // Inside, and on a face: not vertices.
        pts.push(Point3::new(0.5, 0.5, 0.5));
        pts.push(Point3::new(0.5, 0.5, 1.0));
        assert_eq!(hull_vertices(&pts).unwrap(), (0..8).collect::<Vec<_>>());
        assert!(hull_vertices(&pts[..3]).is_none());
        let flat: Vec<Point3<f64>> = (0..10)
            .map(|i| Point3::new(i as f64, (i * i) as f64, 0.0))
            .collect();
        assert!(hull_vertices(&flat).is_none());
    }

    #[test]
    fn matches_parry_on_random_and_near_spherical_sets() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(11);
        for case in 0..6 {
            let n = 500 + 700 * case;
            let pts: Vec<Point3<f64>> = (0..n)
                .map(|_| {
                    let v = Vector3::new(
                        rng.random::<f64>() - 0.5,
                        rng.random::<f64>() - 0.5,
                        rng.random::<f64>() - 0.5,
                    );
                    match case % 3 {
                        0 => Point3::from(v),
                        // On a sphere to 1e-6: most points are vertices.
                        1 => Point3::from(v.normalize() * (1.0 + 1e-6 * rng.random::<f64>())),
                        // A flipped cap: a far, thin, curved shell plus its apex.
                        _ => Point3::from(
                            (Vector3::new(0.0, 0.0, 1.0) + 0.2 * v).normalize()
                                * (100.0 - 0.1 * rng.random::<f64>()),
                        ),
                    }
                })
                .chain(std::iter::once(Point3::origin()))
                .collect();
            let ours = hull_vertices(&pts).unwrap();
            let theirs = crate::surface::convex_hull_vertices(&pts).unwrap();
            assert_eq!(ours, theirs, "case {case}");
        }
    }
}
