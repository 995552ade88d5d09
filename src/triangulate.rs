//! The triangulated surface of a single-view scan: 2.5-D Delaunay in the camera's image plane.
//!
//! A stereo camera sees each surface point along one ray, so the scan is a height field over the
//! image: the points are projected centrally from the camera's centre onto an image plane
//! perpendicular to the direction of the points' centroid (normalised image coordinates),
//! triangulated there (Delaunay, spade) and lifted back to 3-D.
//! Delaunay fills the convex hull of the image, so triangles with an edge longer than
//! `max_edge_m` (holes, occlusion boundaries, gaps between objects) or seen at a grazing angle
//! (normal more than `max_view_angle_deg` from the view ray: the jump between a foreground and a
//! background surface) are dropped. The rest of the scan — points the same camera measured that
//! are not on this surface (seabed, stones, fragments the segmentation left out) — is triangulated
//! with it and every triangle touching one of those points is dropped too: each pixel sees one
//! surface point, so where a pixel between the surface's points saw something else, the surface
//! there is not the chord across it. (On the flank of a bottle turning away from the camera, the
//! samples are farther apart than the clustering tolerance and split off; the chord over them lay
//! 4.5 mm in front of the true surface, 50 mm along a test ray of the \[59\] accuracy check.)
//! Optionally each point is first moved onto the least-squares plane of its `smoothing_neighbours`
//! nearest neighbours, which takes out most of the sensor's noise (one step of a
//! moving-least-squares projection, Alexa et al. 2003). Triangles are wound so that their normals
//! face the camera (the outside of the scanned surface). Units: metres.

use crate::cloud::pca::{mean_covariance_of, median, sorted_eigen};
use crate::error::{Error, Result};
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// Configuration of the scan triangulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SurfaceConfig {
    /// Longest triangle edge kept, metres; 0 takes `edge_factor` × the median spacing of the points.
    pub max_edge_m: f64,
    /// Multiple of the median nearest-neighbour spacing used when `max_edge_m` is 0.
    pub edge_factor: f64,
    /// Largest angle between a triangle's normal and the ray from the camera, degrees (0 to 90).
    pub max_view_angle_deg: f64,
    /// Neighbours of the local plane each point is moved onto before triangulating; 0 keeps the
    /// raw points (at most [`MAX_SMOOTHING_NEIGHBOURS`]).
    pub smoothing_neighbours: usize,
}

impl Default for SurfaceConfig {
    fn default() -> Self {
        SurfaceConfig {
            max_edge_m: 0.0,
            edge_factor: 5.0,
            max_view_angle_deg: 85.0,
            smoothing_neighbours: 0,
        }
    }
}

/// Most neighbours of the smoothing plane: 20 times the usual values (10 to 50); each point
/// costs a k-NN query and a covariance of `k` points.
pub const MAX_SMOOTHING_NEIGHBOURS: usize = 1000;

impl SurfaceConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`surface.…`).
    pub fn validate(&self) -> Result<()> {
        crate::config::non_negative("surface.max_edge_m", self.max_edge_m)?;
        crate::config::positive("surface.edge_factor", self.edge_factor)?;
        // A normal more than 90° from the view ray is the same plane seen from behind.
        crate::config::require(
            self.max_view_angle_deg > 0.0 && self.max_view_angle_deg <= 90.0,
            "surface.max_view_angle_deg",
            format!(
                "must be in (0, 90] degrees, got {}",
                crate::config::shown(self.max_view_angle_deg)
            ),
        )?;
        crate::config::count_between(
            "surface.smoothing_neighbours",
            self.smoothing_neighbours,
            0,
            MAX_SMOOTHING_NEIGHBOURS,
        )
    }
}

struct Vertex {
    uv: Point2<f64>,
    index: u32,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.uv
    }
}

/// Moves every point onto the total-least-squares plane of its `k` nearest neighbours.
pub fn smooth_points(points: &[Point3<f64>], index: &KdIndex, k: usize) -> Vec<Point3<f64>> {
    points
        .par_iter()
        .map(|p| {
            let nb = index.knn(p, k.max(3));
            match mean_covariance_of(points, nb.iter().map(|n| n.index)) {
                Some((c, cov)) if nb.len() >= 3 => {
                    let (_, axes) = sorted_eigen(&cov);
                    let n: Vector3<f64> = axes.column(2).into_owned();
                    p - n * (p - c).dot(&n)
                }
                _ => *p,
            }
        })
        .collect()
}

/// Median distance from each point to its nearest other point, metres (0 for fewer than two).
pub fn median_spacing(points: &[Point3<f64>], index: &KdIndex) -> f64 {
    let mut d: Vec<f64> = points
        .par_iter()
        .filter_map(|p| index.knn(p, 2).get(1).map(|n| n.distance))
        .collect();
    median(&mut d).unwrap_or(0.0)
}

/// Triangulates the surface `points` of a single-view scan seen from `camera` (the origin for a
/// scan in `S`); `others` are the scan's other points (not on this surface, may be empty): no
/// triangle spans one of them. The mesh's vertices are `points` (smoothed if configured) in front
/// of the camera.
///
/// # Errors
/// [`Error::Input`] for a bad configuration; [`Error::Failed`] (stage `surface`) when fewer than
/// three points lie in front of the camera or no triangle survives the filters.
pub fn triangulate_view(
    points: &[Point3<f64>],
    others: &[Point3<f64>],
    camera: &Point3<f64>,
    cfg: &SurfaceConfig,
) -> Result<TriangleMesh> {
    cfg.validate()?;
    let centroid = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len().max(1) as f64;
    let d = (centroid - camera.coords)
        .try_normalize(1e-12)
        .ok_or_else(|| Error::failed("surface", "the points' centroid is at the camera"))?;
    let (e1, e2) = crate::spatial::perpendicular_basis(&d);
    let depth = |p: &Point3<f64>| (p - camera).dot(&d);
    let front: Vec<Point3<f64>> = points.iter().filter(|p| depth(p) > 1e-9).copied().collect();
    if front.len() < 3 {
        return Err(Error::failed(
            "surface",
            format!("{} points in front of the camera, need 3", front.len()),
        ));
    }
    let index = KdIndex::new(&front)?;
    let vertices = if cfg.smoothing_neighbours > 0 {
        smooth_points(&front, &index, cfg.smoothing_neighbours)
    } else {
        front.clone()
    };
    let max_edge = if cfg.max_edge_m > 0.0 {
        cfg.max_edge_m
    } else {
        cfg.edge_factor * median_spacing(&front, &index)
    };
    let uv = |p: &Point3<f64>| {
        let v = p - camera;
        Point2::new(v.dot(&e1) / depth(p), v.dot(&e2) / depth(p))
    };
    let mut verts: Vec<Vertex> = vertices
        .iter()
        .enumerate()
        .filter(|(_, p)| depth(p) > 1e-9)
        .map(|(i, p)| Vertex {
            uv: uv(p),
            index: i as u32,
        })
        .collect();
    // The other points inside the surface's image box, numbered after the surface's vertices.
    let (lo, hi) = verts.iter().fold(
        (Point2::new(f64::MAX, f64::MAX), Point2::new(f64::MIN, f64::MIN)),
        |(lo, hi), v| {
            (
                Point2::new(lo.x.min(v.uv.x), lo.y.min(v.uv.y)),
                Point2::new(hi.x.max(v.uv.x), hi.y.max(v.uv.y)),
            )
        },
    );
    let surface_vertices = vertices.len() as u32;
    verts.extend(
        others
            .iter()
            .filter(|p| depth(p) > 1e-9)
            .map(uv)
            .filter(|q| (lo.x..=hi.x).contains(&q.x) && (lo.y..=hi.y).contains(&q.y))
            .map(|uv| Vertex {
                uv,
                index: surface_vertices,
            }),
    );
    let dt: DelaunayTriangulation<Vertex> = DelaunayTriangulation::bulk_load(verts)
        .map_err(|e| Error::failed("surface", format!("Delaunay: {e:?}")))?;
    let cos_view = cfg.max_view_angle_deg.to_radians().cos();
    let triangles: Vec<[u32; 3]> = dt
        .inner_faces()
        .filter_map(|f| {
            let [a, b, c] = f.vertices().map(|v| v.data().index);
            if a.max(b).max(c) >= surface_vertices {
                return None;
            }
            let [pa, pb, pc] = [a, b, c].map(|i| vertices[i as usize]);
            if (pb - pa).norm() > max_edge || (pc - pb).norm() > max_edge || (pa - pc).norm() > max_edge {
                return None;
            }
            let n = (pb - pa).cross(&(pc - pa)).try_normalize(1e-300)?;
            let centroid = Point3::from((pa.coords + pb.coords + pc.coords) / 3.0);
            let to_camera = (camera - centroid).normalize();
            let facing = n.dot(&to_camera);
            if facing.abs() < cos_view {
                return None;
            }
            Some(if facing > 0.0 { [a, b, c] } else { [a, c, b] })
        })
        .collect();
    if triangles.is_empty() {
        return Err(Error::failed(
            "surface",
            format!("no triangle with edges ≤ {max_edge:.4} m facing the camera"),
        ));
    }
    Ok(TriangleMesh { vertices, triangles })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A grid of points on the sphere |p − (0,0,1)| = 0.2 seen from the origin (front cap).
    fn cap(noise: f64) -> Vec<Point3<f64>> {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(1);
        let c = Point3::new(0.0, 0.0, 1.0);
        let mut pts = Vec::new();
        for i in -50..=50 {
            for j in -50..=50 {
                let (x, y) = (i as f64 * 0.003, j as f64 * 0.003);
                if x * x + y * y < 0.15 * 0.15 {
                    let z = 1.0 - (0.04 - x * x - y * y).sqrt();
                    let p = Point3::new(x, y, z);
                    let ray = p.coords.normalize();
                    pts.push(c + (p - c) + ray * noise * (rng.random::<f64>() - 0.5) * 3.46);
                }
            }
        }
        pts
    }

    #[test]
    fn front_cap_of_a_sphere() {
        let pts = cap(0.0);
        let mesh = triangulate_view(&pts, &[], &Point3::origin(), &SurfaceConfig::default()).unwrap();
        // Area of the spherical cap with base radius 0.15 on a 0.2 m sphere: 2πR·h.
        let h = 0.2 - (0.04f64 - 0.0225).sqrt();
        let area = std::f64::consts::TAU * 0.2 * h;
        assert!(
            (mesh.area() / area - 1.0).abs() < 0.05,
            "{} vs {area}",
            mesh.area()
        );
        for t in 0..mesh.triangles.len() {
            let n = mesh.triangle_normal(t).unwrap();
            let v = mesh.vertices[mesh.triangles[t][0] as usize];
            assert!(
                n.dot(&(-v.coords)) > 0.0,
                "triangle {t} faces away from the camera"
            );
        }
    }

    #[test]
    fn long_edges_split_separate_patches() {
        let mut pts = cap(0.0);
        let n = pts.len();
        // A second patch far to the side: no triangle may bridge the gap.
        pts.extend(cap(0.0).iter().map(|p| p + Vector3::new(0.6, 0.0, 0.0)));
        let mesh = triangulate_view(&pts, &[], &Point3::origin(), &SurfaceConfig::default()).unwrap();
        for t in &mesh.triangles {
            let side = t.map(|i| (i as usize) < n);
            assert!(side.iter().all(|&s| s) || side.iter().all(|&s| !s));
        }
    }

    #[test]
    fn no_triangle_across_another_surface() {
        // The 3 × 3 points at the cap's centre belong to something 5 cm behind: without them the
        // gap is short enough to bridge, with them it stays open.
        let (mut surface, mut others) = (Vec::new(), Vec::new());
        for p in cap(0.0) {
            if p.x.abs() < 0.004 && p.y.abs() < 0.004 {
                others.push(p + p.coords.normalize() * 0.05);
            } else {
                surface.push(p);
            }
        }
        assert_eq!(others.len(), 9);
        let hits = |others: &[Point3<f64>]| {
            let mesh =
                triangulate_view(&surface, others, &Point3::origin(), &SurfaceConfig::default()).unwrap();
            assert_eq!(mesh.vertices.len(), surface.len());
            crate::surface::Surface::new(&mesh)
                .unwrap()
                .cast_ray(&Point3::origin(), &Vector3::z(), 2.0)
                .is_some()
        };
        assert!(hits(&[]));
        assert!(!hits(&others));
    }

    #[test]
    fn smoothing_takes_out_noise() {
        let noisy = cap(0.002);
        let c = Point3::new(0.0, 0.0, 1.0);
        let rms = |pts: &[Point3<f64>]| {
            (pts.iter().map(|p| ((p - c).norm() - 0.2).powi(2)).sum::<f64>() / pts.len() as f64).sqrt()
        };
        let raw = rms(&noisy);
        let mesh = triangulate_view(
            &noisy,
            &[],
            &Point3::origin(),
            &SurfaceConfig {
                smoothing_neighbours: 20,
                ..Default::default()
            },
        )
        .unwrap();
        let smooth = rms(&mesh.vertices);
        assert!(smooth < 0.4 * raw, "{smooth} vs {raw}");
        assert!(triangulate_view(&noisy[..2], &[], &Point3::origin(), &SurfaceConfig::default()).is_err());
    }

    #[test]
    fn bad_values_name_their_field() {
        let pts = cap(0.0);
        for (cfg, field) in [
            (
                SurfaceConfig {
                    max_view_angle_deg: f64::INFINITY,
                    ..Default::default()
                },
                "surface.max_view_angle_deg",
            ),
            (
                SurfaceConfig {
                    max_view_angle_deg: f64::NAN,
                    ..Default::default()
                },
                "surface.max_view_angle_deg",
            ),
            (
                SurfaceConfig {
                    max_edge_m: f64::NAN,
                    ..Default::default()
                },
                "surface.max_edge_m",
            ),
            (
                SurfaceConfig {
                    edge_factor: f64::INFINITY,
                    ..Default::default()
                },
                "surface.edge_factor",
            ),
            (
                SurfaceConfig {
                    smoothing_neighbours: usize::MAX,
                    ..Default::default()
                },
                "surface.smoothing_neighbours",
            ),
        ] {
            crate::perception::assert_bad_input(triangulate_view(&pts, &[], &Point3::origin(), &cfg), field);
        }
    }
}
