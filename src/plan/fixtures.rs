//! Analytic surfaces with exact distances and normals, and their simulated single-view scans.
//!
//! For tests and benchmarks of the planner before (and besides) the full synthetic scenes: a
//! cylinder (a bottle's body) and a rippled plane (a patch of seabed), each able to produce
//! - a closed or open noise-free [`TriangleMesh`] (the reference),
//! - a "scan": the part a camera at `viewpoint` sees (incidence below a limit), triangulated on a
//!   regular grid, every vertex displaced along its viewing ray by Gaussian noise (stereo depth
//!   noise), optionally with a hole,
//! - the truth: the distance of any point to the surface and the outward normal there.
//!
//! Frames: everything is in the scan frame `S` of the caller; metres.

use super::perpendicular;
use crate::mesh::TriangleMesh;
use crate::synth::random::gaussian;
use nalgebra::{Point3, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// A surface with a known distance function and normal field.
pub trait Truth {
    /// Distance from `p` to the surface, metres (unsigned).
    fn distance(&self, p: &Point3<f64>) -> f64;
    /// The outward unit normal at the surface point closest to `p`.
    fn normal(&self, p: &Point3<f64>) -> Vector3<f64>;
}

/// How a simulated scan is taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanSpec {
    /// The camera centre, metres.
    pub viewpoint: Point3<f64>,
    /// Grid spacing on the surface, metres.
    pub spacing: f64,
    /// Standard deviation of the depth noise along each viewing ray, metres.
    pub noise_sigma: f64,
    /// Surface points seen at a larger angle between normal and viewing ray are not scanned,
    /// degrees.
    pub max_incidence_deg: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for ScanSpec {
    fn default() -> Self {
        ScanSpec {
            viewpoint: Point3::origin(),
            spacing: 0.004,
            noise_sigma: 0.0005,
            max_incidence_deg: 75.0,
            seed: 1,
        }
    }
}

/// A finite cylinder (the lateral surface is what the truth describes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Centre of the axis segment, metres.
    pub centre: Point3<f64>,
    /// Unit axis direction.
    pub axis: Vector3<f64>,
    /// Radius, metres.
    pub radius: f64,
    /// Half the length along the axis, metres.
    pub half_length: f64,
}

impl Cylinder {
    /// The seed's bottle body: a cylinder 0.35 m in diameter and 0.6 m long, its axis along the
    /// scan frame's x, 1 m in front of a camera at the origin looking along z.
    pub fn bottle() -> Cylinder {
        Cylinder {
            centre: Point3::new(0.0, 0.0, 1.0),
            axis: Vector3::x(),
            radius: 0.175,
            half_length: 0.3,
        }
    }

    /// Two unit vectors completing `axis` to a right-handed orthonormal basis.
    fn basis(&self) -> (Vector3<f64>, Vector3<f64>) {
        let a = self.axis.normalize();
        let e1 = perpendicular(&a, &Vector3::zeros());
        (e1, a.cross(&e1))
    }

    /// The lateral surface point at axial coordinate `s` and angle `theta`.
    pub fn point(&self, s: f64, theta: f64) -> Point3<f64> {
        let (e1, e2) = self.basis();
        self.centre + self.axis.normalize() * s + (e1 * theta.cos() + e2 * theta.sin()) * self.radius
    }

    /// A closed, outward-wound mesh: `segments` around, `rings` along, with flat end caps.
    pub fn mesh(&self, segments: usize, rings: usize) -> TriangleMesh {
        let (m, r) = (segments.max(3), rings.max(1));
        let mut vertices = Vec::with_capacity(m * (r + 1) + 2);
        for i in 0..=r {
            let s = -self.half_length + 2.0 * self.half_length * i as f64 / r as f64;
            for j in 0..m {
                vertices.push(self.point(s, std::f64::consts::TAU * j as f64 / m as f64));
            }
        }
        let idx = |i: usize, j: usize| (i * m + j % m) as u32;
        let mut triangles = Vec::new();
        for i in 0..r {
            for j in 0..m {
                triangles.push([idx(i, j), idx(i, j + 1), idx(i + 1, j)]);
                triangles.push([idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)]);
            }
        }
        let a = self.axis.normalize();
        let bottom = vertices.len() as u32;
        vertices.push(self.centre - a * self.half_length);
        vertices.push(self.centre + a * self.half_length);
        for j in 0..m {
            triangles.push([bottom, idx(0, j + 1), idx(0, j)]);
            triangles.push([bottom + 1, idx(r, j), idx(r, j + 1)]);
        }
        TriangleMesh { vertices, triangles }
    }

    /// The part of the lateral surface the camera sees, as a noisy triangulated grid.
    pub fn scan(&self, spec: &ScanSpec) -> TriangleMesh {
        let na = ((2.0 * self.half_length / spec.spacing).round() as usize).max(1);
        let nt = ((std::f64::consts::TAU * self.radius / spec.spacing).round() as usize).max(3);
        let (e1, e2) = self.basis();
        let point = |i: usize, j: usize| {
            let s = -self.half_length + 2.0 * self.half_length * i as f64 / na as f64;
            let th = std::f64::consts::TAU * j as f64 / nt as f64;
            let n = e1 * th.cos() + e2 * th.sin();
            (self.centre + self.axis.normalize() * s + n * self.radius, n)
        };
        grid_scan(na + 1, nt, true, point, spec)
    }
}

impl Truth for Cylinder {
    fn distance(&self, p: &Point3<f64>) -> f64 {
        let a = self.axis.normalize();
        let d = p - self.centre;
        ((d - a * a.dot(&d)).norm() - self.radius).abs()
    }

    fn normal(&self, p: &Point3<f64>) -> Vector3<f64> {
        let a = self.axis.normalize();
        let d = p - self.centre;
        (d - a * a.dot(&d)).normalize()
    }
}

/// A plane with a sinusoidal ripple: height `amplitude · sin(2π x/λ) · cos(2π y/λ)` along
/// `normal` over the local coordinates `x`, `y` of the square `[-half_size, half_size]²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RippledPlane {
    /// Origin of the local coordinates, metres.
    pub origin: Point3<f64>,
    /// Unit normal of the mean plane; the side the surface faces (towards the camera).
    pub normal: Vector3<f64>,
    /// Ripple amplitude, metres.
    pub amplitude: f64,
    /// Ripple wavelength, metres.
    pub wavelength: f64,
    /// Half the side of the square patch, metres.
    pub half_size: f64,
}

impl RippledPlane {
    fn basis(&self) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let n = self.normal.normalize();
        let ex = perpendicular(&n, &Vector3::zeros());
        (ex, n.cross(&ex), n)
    }

    fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
        let k = std::f64::consts::TAU / self.wavelength;
        let (sx, cx, sy, cy) = ((k * x).sin(), (k * x).cos(), (k * y).sin(), (k * y).cos());
        (
            self.amplitude * sx * cy,
            self.amplitude * k * cx * cy,
            -self.amplitude * k * sx * sy,
        )
    }

    fn local(&self, p: &Point3<f64>) -> (f64, f64, f64) {
        let (ex, ey, n) = self.basis();
        let d = p - self.origin;
        (d.dot(&ex), d.dot(&ey), d.dot(&n))
    }

    /// The surface point above local coordinates (`x`, `y`) and its unit normal.
    pub fn point(&self, x: f64, y: f64) -> (Point3<f64>, Vector3<f64>) {
        let (ex, ey, n) = self.basis();
        let (h, hx, hy) = self.height(x, y);
        (
            self.origin + ex * x + ey * y + n * h,
            (n - ex * hx - ey * hy).normalize(),
        )
    }

    /// A noise-free open mesh on a grid of `cells` × `cells`, wound so its normals face `normal`.
    pub fn mesh(&self, cells: usize) -> TriangleMesh {
        let spec = ScanSpec {
            spacing: 2.0 * self.half_size / cells.max(1) as f64,
            noise_sigma: 0.0,
            max_incidence_deg: 90.0,
            ..ScanSpec::default()
        };
        self.grid(&spec, false)
    }

    /// The patch seen from `spec.viewpoint`, as a noisy triangulated grid.
    pub fn scan(&self, spec: &ScanSpec) -> TriangleMesh {
        self.grid(spec, true)
    }

    fn grid(&self, spec: &ScanSpec, visibility: bool) -> TriangleMesh {
        let n = ((2.0 * self.half_size / spec.spacing).round() as usize).max(1) + 1;
        let step = 2.0 * self.half_size / (n - 1) as f64;
        let point = |i: usize, j: usize| {
            self.point(
                -self.half_size + i as f64 * step,
                -self.half_size + j as f64 * step,
            )
        };
        let spec = if visibility {
            *spec
        } else {
            ScanSpec {
                max_incidence_deg: 180.0,
                ..*spec
            }
        };
        grid_scan(n, n, false, point, &spec)
    }
}

impl Truth for RippledPlane {
    /// First-order distance: the height difference scaled by the local slope (exact to
    /// O(distance² · curvature)).
    fn distance(&self, p: &Point3<f64>) -> f64 {
        let (x, y, z) = self.local(p);
        let (h, hx, hy) = self.height(x, y);
        (z - h).abs() / (1.0 + hx * hx + hy * hy).sqrt()
    }

    fn normal(&self, p: &Point3<f64>) -> Vector3<f64> {
        let (x, y, _) = self.local(p);
        self.point(x, y).1
    }
}

/// Triangulates a grid of surface points (`point(i, j)` → position and outward normal) over the
/// cells whose four corners the camera sees; `wrap_j` closes the grid in `j`. Triangles are
/// wound so that their normals follow the outward normals.
fn grid_scan(
    ni: usize,
    nj: usize,
    wrap_j: bool,
    point: impl Fn(usize, usize) -> (Point3<f64>, Vector3<f64>),
    spec: &ScanSpec,
) -> TriangleMesh {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let cos_max = spec.max_incidence_deg.to_radians().cos();
    let mut index = vec![None; ni * nj];
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    for i in 0..ni {
        for j in 0..nj {
            let (p, n) = point(i, j);
            let ray = p - spec.viewpoint;
            let dist = ray.norm();
            if -n.dot(&ray) < cos_max * dist {
                continue;
            }
            let noise = spec.noise_sigma * gaussian(&mut rng);
            index[i * nj + j] = Some(mesh.vertices.len() as u32);
            mesh.vertices.push(p + ray / dist * noise);
            normals.push(n);
        }
    }
    let jmax = if wrap_j { nj } else { nj - 1 };
    for i in 0..ni - 1 {
        for j in 0..jmax {
            let j1 = (j + 1) % nj;
            let c = [(i, j), (i + 1, j), (i + 1, j1), (i, j1)].map(|(a, b)| index[a * nj + b]);
            let [Some(a), Some(b), Some(cc), Some(d)] = c else {
                continue;
            };
            for t in [[a, b, d], [b, cc, d]] {
                let [p, q, r] = t.map(|v| mesh.vertices[v as usize]);
                let n = normals[t[0] as usize];
                let tri = if (q - p).cross(&(r - p)).dot(&n) >= 0.0 {
                    t
                } else {
                    [t[0], t[2], t[1]]
                };
                mesh.triangles.push(tri);
            }
        }
    }
    mesh
}

/// The mesh without the triangles whose centroid lies within `radius` of `centre` (a hole).
pub fn with_hole(mesh: &TriangleMesh, centre: &Point3<f64>, radius: f64) -> TriangleMesh {
    TriangleMesh {
        vertices: mesh.vertices.clone(),
        triangles: mesh
            .triangles
            .iter()
            .copied()
            .filter(|t| {
                let c = t
                    .iter()
                    .fold(Vector3::zeros(), |acc, &i| acc + mesh.vertices[i as usize].coords)
                    / 3.0;
                (Point3::from(c) - centre).norm() > radius
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bottle() -> Cylinder {
        Cylinder::bottle()
    }

    #[test]
    fn cylinder_mesh_is_closed_and_outward() {
        let c = bottle();
        let m = c.mesh(64, 8);
        for t in 0..m.triangles.len() {
            let n = m.triangle_normal(t).unwrap();
            let [a, b, cc] = m.triangles[t].map(|i| m.vertices[i as usize].coords);
            let centroid = Point3::from((a + b + cc) / 3.0);
            assert!(n.dot(&(centroid - c.centre)) > 0.0, "triangle {t}");
        }
        let area = 2.0 * std::f64::consts::PI * c.radius * 2.0 * c.half_length;
        // A 64-gon's lateral area is below the circle's by about (2π/64)²/6.
        assert!((m.area() - area - 2.0 * std::f64::consts::PI * c.radius.powi(2)).abs() / area < 0.01);
    }

    #[test]
    fn cylinder_scan_sees_the_near_side_within_its_noise() {
        let c = bottle();
        let spec = ScanSpec::default();
        let m = c.scan(&spec);
        assert!(!m.triangles.is_empty());
        for v in &m.vertices {
            assert!(c.distance(v) < 6.0 * spec.noise_sigma);
            // Seen side: normals face the camera (origin, above the cylinder at z = 1).
            assert!(c.normal(v).z < 0.0);
        }
        for t in 0..m.triangles.len() {
            let v = m.vertices[m.triangles[t][0] as usize];
            assert!(m.triangle_normal(t).unwrap().dot(&c.normal(&v)) > 0.5);
        }
    }

    #[test]
    fn rippled_plane_truth_matches_its_mesh() {
        let r = RippledPlane {
            origin: Point3::new(0.0, 0.0, 1.2),
            normal: -Vector3::z(),
            amplitude: 0.01,
            wavelength: 0.2,
            half_size: 0.3,
        };
        let m = r.mesh(120);
        for v in &m.vertices {
            assert!(r.distance(v) < 1e-12);
        }
        let (p, n) = r.point(0.013, -0.041);
        let off = p + n * 0.002;
        assert!((r.distance(&off) - 0.002).abs() < 2e-5);
        assert!((r.normal(&off) - n).norm() < 0.01);
        for t in 0..m.triangles.len() {
            assert!(m.triangle_normal(t).unwrap().z < 0.0);
        }
    }
}
