//! How good is an alignment? The seed's method \[59\] without ground truth, and the usual pose
//! metrics with it.
//!
//! **\[59\]** (Konoplin & Pyatavin 2020, cited by the seed as its accuracy check): a family of test
//! trajectories is projected onto both triangulated surfaces — the scanned object and the aligned
//! reference — and the distances between corresponding points are summarised by their RMS and
//! maximum. Here the trajectories are `lines` parallel straight lines across the object (along its
//! minor image axis, spaced along its major one), in the plane perpendicular to the camera's view
//! direction (camera → object centroid), each sampled at `samples_per_line` points; each sample is
//! projected along the view direction, so corresponding points lie on one ray and their distance
//! is the difference of the two hit distances. `coverage` is the fraction of the samples that hit
//! the scanned surface which also hit the reference.
//!
//! **With ground truth**: rotation and translation error of `t_scan_reference`, and ADD-S
//! (Hinterstoisser et al. 2012; Xiang et al. 2018, PoseCNN): the mean over the model's points,
//! placed by the true pose, of the distance to the nearest model point placed by the estimate —
//! symmetric objects are not penalised for a turn they do not show. Units: metres, degrees.

use crate::cloud::pca::{mean_covariance, principal_axes, sorted_eigen};
use crate::error::{Error, Result};
use crate::frames::{Pose, pose_error};
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use crate::surface::Surface;
use nalgebra::{Matrix3, Point3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Configuration of the \[59\] accuracy estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccuracyConfig {
    /// Parallel test lines across the object (1 to [`MAX_LINES`]).
    pub lines: usize,
    /// Samples along each line (1 to [`MAX_SAMPLES_PER_LINE`]).
    pub samples_per_line: usize,
    /// The lines cover the object's extent in the image plane shrunk by this fraction at each
    /// end (0: edge to edge).
    pub inset: f64,
    /// Fail when more than this fraction of the aligned reference's points the camera would see
    /// face-on lie where it saw past them ([`free_space`]; in [0, 1], 1 never fails).
    pub max_free_space: f64,
}

impl Default for AccuracyConfig {
    fn default() -> Self {
        AccuracyConfig {
            lines: 21,
            samples_per_line: 101,
            inset: 0.02,
            max_free_space: 0.01,
        }
    }
}

/// Most test lines, and most samples per line: 50 and 10 times the defaults, so at most a
/// million rays (56 MB), each cast on both surfaces.
pub const MAX_LINES: usize = 1000;
/// See [`MAX_LINES`].
pub const MAX_SAMPLES_PER_LINE: usize = 1000;

impl AccuracyConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`accuracy.…`).
    pub fn validate(&self) -> Result<()> {
        use crate::config::count_between;
        count_between("accuracy.lines", self.lines, 1, MAX_LINES)?;
        count_between(
            "accuracy.samples_per_line",
            self.samples_per_line,
            1,
            MAX_SAMPLES_PER_LINE,
        )?;
        crate::config::require(
            (0.0..0.5).contains(&self.inset),
            "accuracy.inset",
            format!("must be in [0, 0.5), got {}", crate::config::shown(self.inset)),
        )?;
        crate::config::require(
            (0.0..=1.0).contains(&self.max_free_space),
            "accuracy.max_free_space",
            format!(
                "must be in [0, 1], got {}",
                crate::config::shown(self.max_free_space)
            ),
        )
    }
}

/// One test ray: where a sample of a test line starts and the direction it is projected along.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TestRay {
    /// Start (in front of the object, on the camera's side), metres.
    pub origin: Point3<f64>,
    /// Unit projection direction (the view direction).
    pub direction: Vector3<f64>,
    /// Index of the line this sample belongs to.
    pub line: usize,
}

/// The test trajectories for the object `points` (scan frame, camera at `viewpoint`).
///
/// # Errors
/// [`Error::Input`] for a bad configuration ([`AccuracyConfig::validate`]); [`Error::Failed`]
/// (stage `accuracy`) for an empty object.
pub fn test_rays(
    points: &[Point3<f64>],
    viewpoint: &Point3<f64>,
    cfg: &AccuracyConfig,
) -> Result<Vec<TestRay>> {
    cfg.validate()?;
    let shape = principal_axes(points, 0.0).ok_or_else(|| Error::failed("accuracy", "no object points"))?;
    let to_object = shape.centroid - viewpoint;
    let range = to_object.norm();
    let d = to_object
        .try_normalize(1e-12)
        .ok_or_else(|| Error::failed("accuracy", "the object's centroid is at the camera"))?;
    // Major axis of the object, projected into the image plane.
    let major: Vector3<f64> = shape.axes.column(0).into_owned();
    let e1 = (major - d * major.dot(&d))
        .try_normalize(1e-9)
        .unwrap_or_else(|| {
            d.cross(&if d.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            })
            .normalize()
        });
    let e2 = d.cross(&e1);
    let (mut lo1, mut hi1, mut lo2, mut hi2) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in points {
        let v = p - shape.centroid;
        let (a, b) = (v.dot(&e1), v.dot(&e2));
        (lo1, hi1, lo2, hi2) = (lo1.min(a), hi1.max(a), lo2.min(b), hi2.max(b));
    }
    let inset = |lo: f64, hi: f64| (lo + cfg.inset * (hi - lo), hi - cfg.inset * (hi - lo));
    let ((lo1, hi1), (lo2, hi2)) = (inset(lo1, hi1), inset(lo2, hi2));
    let at = |lo: f64, hi: f64, k: usize, n: usize| {
        if n == 1 {
            0.5 * (lo + hi)
        } else {
            lo + (hi - lo) * k as f64 / (n - 1) as f64
        }
    };
    let back = 0.5 * range;
    let mut rays = Vec::with_capacity(cfg.lines * cfg.samples_per_line);
    for line in 0..cfg.lines {
        let a = at(lo1, hi1, line, cfg.lines);
        for k in 0..cfg.samples_per_line {
            let b = at(lo2, hi2, k, cfg.samples_per_line);
            rays.push(TestRay {
                origin: shape.centroid + e1 * a + e2 * b - d * back,
                direction: d,
                line,
            });
        }
    }
    Ok(rays)
}

/// The distance along each ray to its first hit on `surface` (within `max_distance` metres), or
/// `None` where it misses.
pub fn cast_rays(surface: &Surface, rays: &[TestRay], max_distance: f64) -> Vec<Option<f64>> {
    rays.par_iter()
        .map(|r| {
            surface
                .cast_ray(&r.origin, &r.direction, max_distance)
                .map(|h| h.distance)
        })
        .collect()
}

/// Summary of the distances between corresponding points of two projected trajectory families.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Deviation {
    /// RMS distance between corresponding points, metres.
    pub rms_m: f64,
    /// Largest distance, metres.
    pub max_m: f64,
    /// Mean signed distance (second surface minus first, along the view direction), metres.
    pub mean_signed_m: f64,
    /// Samples on both surfaces.
    pub samples: usize,
    /// Samples that hit the first surface.
    pub first_hits: usize,
    /// `samples / first_hits` (0 when nothing hit the first surface).
    pub coverage: f64,
}

/// The smallest cosine between a model point's normal and its line of sight for [`free_space`]
/// to judge it.
const MIN_FACING: f64 = 0.5;

/// How much of the aligned model lies where the camera saw past it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FreeSpace {
    /// The model's seen points that lie in front of everything the camera saw around them.
    pub violating: usize,
    /// The model's seen points with scan points around their line of sight.
    pub judged: usize,
    /// How far in front of the nearest scan point around it the worst one lies, metres.
    pub max_m: f64,
}

impl FreeSpace {
    /// `violating / judged` (0 when nothing was judged).
    pub fn fraction(&self) -> f64 {
        if self.judged > 0 {
            self.violating as f64 / self.judged as f64
        } else {
            0.0
        }
    }
}

/// Free-space consistency: a model point seen from `camera` at range `d` lies in free space when
/// every scan point around its line of sight (its bin and the 8 around it, of a grid of the
/// image plane whose cells are twice the scan's angular spacing `spacing_rad`) is farther than
/// `d + tolerance_m`: the camera saw through where the model claims to be (a model too large,
/// slid past the scanned object's end, or turned end for end), which no distance from the scan
/// to the model shows. Lines of sight with no scan point around them (stereo holes, the scan's
/// edge) are not judged, nor points whose (unit) normal in `model_normals` is more than 60° from
/// the line of sight: at a silhouette a cell spans the object's edge and what lies behind it, and
/// a stereo camera's edge pixels take the far depth (on correct alignments of synthetic bottles
/// every point in free space faced the camera within a cosine of 0.4).
pub fn free_space(
    scan: &[Point3<f64>],
    model_seen: &[Point3<f64>],
    model_normals: &[Vector3<f64>],
    camera: &Point3<f64>,
    spacing_rad: f64,
    tolerance_m: f64,
) -> FreeSpace {
    use std::collections::HashMap;
    let mut nearest: HashMap<(i64, i64), f64> = HashMap::new();
    let step = 2.0 * spacing_rad;
    let Some(axis) = model_seen
        .iter()
        .map(|p| p - camera)
        .sum::<Vector3<f64>>()
        .try_normalize(1e-12)
    else {
        return FreeSpace::default();
    };
    let (e1, e2) = crate::spatial::perpendicular_basis(&axis);
    // The image-plane cell and the range of a point, for points in front of the camera.
    let cell = |p: &Point3<f64>| -> Option<((i64, i64), f64)> {
        let v = p - camera;
        let z = v.dot(&axis);
        (z > 0.0).then(|| {
            let key = (
                (v.dot(&e1) / z / step).floor() as i64,
                (v.dot(&e2) / z / step).floor() as i64,
            );
            (key, v.norm())
        })
    };
    for (key, d) in scan.iter().filter_map(cell) {
        let e = nearest.entry(key).or_insert(f64::INFINITY);
        *e = e.min(d);
    }
    let (mut violating, mut judged, mut max_m) = (0usize, 0usize, 0.0f64);
    for (p, n) in model_seen.iter().zip(model_normals) {
        let Some((key, d)) = cell(p) else { continue };
        if !nearest.contains_key(&key) || n.dot(&(p - camera)).abs() < MIN_FACING * d {
            continue;
        }
        let around = (-1..=1)
            .flat_map(|i| (-1..=1).map(move |j| (key.0 + i, key.1 + j)))
            .filter_map(|k| nearest.get(&k))
            .fold(f64::INFINITY, |a, &b| a.min(b));
        judged += 1;
        if around > d + tolerance_m {
            violating += 1;
            max_m = max_m.max(around - d);
        }
    }
    FreeSpace {
        violating,
        judged,
        max_m,
    }
}

/// Compares hit distances `first` and `second` (same rays), over the rays where `mask` (if given)
/// is true.
pub fn deviation(first: &[Option<f64>], second: &[Option<f64>], mask: Option<&[bool]>) -> Deviation {
    let (mut n, mut hits, mut s2, mut s1, mut max) = (0usize, 0usize, 0.0, 0.0, 0.0f64);
    for (i, (a, b)) in first.iter().zip(second).enumerate() {
        if mask.is_some_and(|m| !m.get(i).copied().unwrap_or(false)) {
            continue;
        }
        let Some(a) = a else { continue };
        hits += 1;
        if let Some(b) = b {
            let d = b - a;
            n += 1;
            s1 += d;
            s2 += d * d;
            max = max.max(d.abs());
        }
    }
    let k = n.max(1) as f64;
    Deviation {
        rms_m: (s2 / k).sqrt(),
        max_m: max,
        mean_signed_m: s1 / k,
        samples: n,
        first_hits: hits,
        coverage: if hits > 0 { n as f64 / hits as f64 } else { 0.0 },
    }
}

/// The seed's \[59\] estimate: test trajectories over the scanned object `object` (seen from
/// `camera`) projected onto the scanned surface and the aligned reference surface.
///
/// # Errors
/// As [`test_rays`].
pub fn trajectory_accuracy(
    object: &[Point3<f64>],
    camera: &Point3<f64>,
    scan_surface: &Surface,
    reference_surface: &Surface,
    cfg: &AccuracyConfig,
) -> Result<Deviation> {
    let rays = test_rays(object, camera, cfg)?;
    let reach = 2.0 * object.iter().map(|p| (p - camera).norm()).fold(0.0, f64::max);
    Ok(deviation(
        &cast_rays(scan_surface, &rays, reach),
        &cast_rays(reference_surface, &rays, reach),
        None,
    ))
}

/// Pose errors against ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruthErrors {
    /// Rotation angle between the estimate and the truth, degrees.
    pub rotation_error_deg: f64,
    /// Angle between the model's distinct axis ([`distinct_axis`]) under the estimated and the
    /// true pose, degrees: the rotation error without the turn about that axis, which is all a
    /// scan of a body of revolution (the bottle) can show. None for a model none of whose
    /// principal axes stands apart (a cube, a sphere).
    pub axis_error_deg: Option<f64>,
    /// Distance between their translations, metres.
    pub translation_error_m: f64,
    /// ADD-S: mean closest-point distance between the model under the true and the estimated
    /// pose, metres.
    pub add_s_m: f64,
    /// ADD: mean distance between corresponding model points under the two poses, metres.
    pub add_m: f64,
}

/// The principal axis of a covariance whose variance stands apart from the other two: the axis
/// of revolution of a body of revolution (the long axis of a bottle, the normal of a disc). It
/// stands apart when its variance's gap to the nearer of the other two is at least twice the
/// gap between those two and a thousandth of the largest variance; None otherwise (a cube, a
/// sphere: every axis alike).
pub fn distinct_axis(covariance: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let (v, axes) = sorted_eigen(covariance);
    let (g01, g12) = (v[0] - v[1], v[1] - v[2]);
    let (k, gap, other) = if g01 >= g12 { (0, g01, g12) } else { (2, g12, g01) };
    (gap > 1e-3 * v[0] && gap >= 2.0 * other).then(|| axes.column(k).into_owned())
}

/// Distance from a point to the closest point of the model under the estimated pose.
type ClosestDistance = dyn Fn(&Point3<f64>) -> f64 + Sync;

/// Rotation/translation error, the distinct axis's error, ADD-S and ADD of `estimate` against
/// `truth` for the model points `model` (model frame). With the model's `mesh`, ADD-S takes the
/// closest point on the surface under the estimated pose (exact, free of the sampling's
/// spacing); without it, the nearest model point.
///
/// # Errors
/// [`Error::Failed`] (stage `accuracy`) for an empty model.
pub fn truth_errors(
    model: &[Point3<f64>],
    mesh: Option<&TriangleMesh>,
    estimate: &Pose,
    truth: &Pose,
) -> Result<TruthErrors> {
    if model.is_empty() {
        return Err(Error::failed("accuracy", "no model points for ADD-S"));
    }
    // The surface's exact moments when there is a mesh: 20,000 random samples of the bottle
    // tilt its axis by some 0.3°.
    let covariance = mesh
        .and_then(TriangleMesh::surface_moments)
        .or_else(|| mean_covariance(model))
        .map(|(_, c)| c)
        .unwrap_or_else(Matrix3::identity);
    let axis_error_deg = distinct_axis(&covariance).map(|axis| {
        (estimate.rotation * axis)
            .angle(&(truth.rotation * axis))
            .to_degrees()
    });
    let closest: Box<ClosestDistance> = match mesh {
        Some(m) => {
            let surface = Surface::new(&m.transformed(estimate))?;
            Box::new(move |q| surface.project(q).distance)
        }
        None => {
            let est: Vec<Point3<f64>> = model.iter().map(|p| estimate * p).collect();
            let index = KdIndex::new(&est)?;
            Box::new(move |q| index.nearest(q).map_or(0.0, |n| n.distance))
        }
    };
    let (add_s, add) = model
        .par_iter()
        .map(|p| {
            let t = truth * p;
            (closest(&t), (t - estimate * p).norm())
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let (rotation_error_deg, translation_error_m) = pose_error(estimate, truth);
    Ok(TruthErrors {
        rotation_error_deg,
        axis_error_deg,
        translation_error_m,
        add_s_m: add_s / model.len() as f64,
        add_m: add / model.len() as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TriangleMesh;
    use nalgebra::{Isometry3, Translation3};

    /// A 0.2 m square plate face-on 1 m from the camera before a seabed 1.5 m away, both
    /// scanned every 2 mrad with nothing behind the plate: the plate's model where it is, moved
    /// back, slid by a quarter of its width, and brought 30 mm nearer.
    #[test]
    fn free_space_is_where_the_camera_saw_past_the_model() {
        let grid = |half: f64, z: f64, keep: &dyn Fn(f64, f64) -> bool| -> Vec<Point3<f64>> {
            let n = (half / 0.002).round() as i32;
            (-n..=n)
                .flat_map(|i| (-n..=n).map(move |j| (i as f64 * 0.002 * z, j as f64 * 0.002 * z)))
                .filter(|&(x, y)| keep(x / z, y / z))
                .map(|(x, y)| Point3::new(x, y, z))
                .collect()
        };
        let on_plate = |a: f64, b: f64| a.abs() <= 0.1 && b.abs() <= 0.1;
        let plate = grid(0.1, 1.0, &|_, _| true);
        let mut scan = plate.clone();
        scan.extend(grid(0.5, 1.5, &|a, b| !on_plate(a, b)));
        let facing = vec![-Vector3::z(); plate.len()];
        let camera = Point3::origin();
        let at = |dx: f64, dz: f64, normals: &[Vector3<f64>]| {
            let model: Vec<_> = plate.iter().map(|p| p + Vector3::new(dx, 0.0, dz)).collect();
            free_space(&scan, &model, normals, &camera, 0.002, 0.01)
        };
        assert_eq!(at(0.0, 0.0, &facing).violating, 0);
        assert_eq!(at(0.0, 0.03, &facing).violating, 0);
        // Slid by 50 mm: the quarter beyond the plate's edge, less the cell next to it.
        let slid = at(0.05, 0.0, &facing);
        assert!((0.2..=0.25).contains(&slid.fraction()), "{slid:?}");
        assert!((slid.max_m - 0.5).abs() < 0.01, "{slid:?}");
        let near = at(0.0, -0.03, &facing);
        assert!(
            near.fraction() > 0.99 && (near.max_m - 0.03).abs() < 1e-9,
            "{near:?}"
        );
        // Seen edge-on, no point is judged.
        let grazing = vec![Vector3::new(0.9, 0.0, -0.3).normalize(); plate.len()];
        assert_eq!(at(0.05, 0.0, &grazing).judged, 0);
    }

    /// A square plate of side 0.4 m, 1 m in front of the camera, facing it.
    fn plate(z: f64) -> TriangleMesh {
        TriangleMesh {
            vertices: vec![
                Point3::new(-0.2, -0.2, z),
                Point3::new(0.2, -0.2, z),
                Point3::new(0.2, 0.2, z),
                Point3::new(-0.2, 0.2, z),
            ],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
        }
    }

    #[test]
    fn offset_plates_give_their_offset() {
        let object: Vec<Point3<f64>> = (0..400)
            .map(|i| Point3::new(-0.1 + 0.0005 * i as f64, 0.05 * ((i % 7) as f64 - 3.0) / 3.0, 1.0))
            .collect();
        let scan = Surface::new(&plate(1.0)).unwrap();
        let reference = Surface::new(&plate(1.003)).unwrap();
        let d = trajectory_accuracy(
            &object,
            &Point3::origin(),
            &scan,
            &reference,
            &AccuracyConfig::default(),
        )
        .unwrap();
        assert_eq!(d.samples, 21 * 101);
        assert!((d.coverage - 1.0).abs() < 1e-12);
        // Rays are parallel to the view direction, which is nearly +z: distances ≈ 3 mm / cos.
        assert!((d.rms_m - 0.003).abs() < 1e-4 && d.max_m < 0.0031, "{d:?}");
        assert!(d.mean_signed_m > 0.0);
        // A reference shifted sideways by more than the object leaves it uncovered.
        let away = Surface::new(&plate(1.0).transformed(&Isometry3::translation(0.5, 0.0, 0.0))).unwrap();
        let d = trajectory_accuracy(
            &object,
            &Point3::origin(),
            &scan,
            &away,
            &AccuracyConfig::default(),
        )
        .unwrap();
        assert!(d.coverage < 0.5, "{d:?}");
    }

    #[test]
    fn the_distinct_axis_is_the_axis_of_revolution() {
        // A long thin tube along x and a flat ring in the xy-plane, both about their axis.
        let around = |i: usize, r: f64| {
            let a = i as f64 * 0.7;
            (r * a.cos(), r * a.sin())
        };
        let tube: Vec<Point3<f64>> = (0..2000)
            .map(|i| {
                let (y, z) = around(i, 0.05);
                Point3::new(i as f64 * 5e-4, y, z)
            })
            .collect();
        let ring: Vec<Point3<f64>> = (0..2000)
            .map(|i| {
                let (x, y) = around(i, 0.3);
                Point3::new(x, y, 0.0)
            })
            .collect();
        for (points, axis) in [(tube, Vector3::x()), (ring, Vector3::z())] {
            let a = distinct_axis(&mean_covariance(&points).unwrap().1).unwrap();
            assert!(a.dot(&axis).abs() > 1.0 - 1e-6, "{a}");
        }
        // A cube's corners, and a box whose middle variance lies midway: no axis stands apart.
        let corners = |s: [f64; 3]| -> Vec<Point3<f64>> {
            (0..8)
                .map(|i| {
                    Point3::new(
                        s[0] * f64::from(i & 1),
                        s[1] * f64::from((i >> 1) & 1),
                        s[2] * f64::from(i >> 2),
                    )
                })
                .collect()
        };
        for s in [[1.0, 1.0, 1.0], [1.0, 0.75, 0.3]] {
            let c = mean_covariance(&corners(s)).unwrap().1;
            assert_eq!(distinct_axis(&c), None, "{s:?}");
        }
        // A box twice as long as it is wide and deep has its long axis.
        let a = distinct_axis(&mean_covariance(&corners([1.0, 0.5, 0.45])).unwrap().1).unwrap();
        assert!(a.x.abs() > 1.0 - 1e-9, "{a}");
    }

    #[test]
    fn add_s_ignores_symmetry_add_does_not() {
        // A ring of points: turning it about its axis changes nothing for ADD-S.
        let model: Vec<Point3<f64>> = (0..3600)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 3600.0;
                Point3::new(0.1 * a.cos(), 0.1 * a.sin(), 0.0)
            })
            .collect();
        let truth = Isometry3::translation(0.0, 0.0, 1.0);
        let turned = truth * Isometry3::rotation(Vector3::z() * 0.5);
        let e = truth_errors(&model, None, &turned, &truth).unwrap();
        assert!(e.add_s_m < 1e-4, "{e:?}");
        assert!(e.add_m > 0.04);
        assert!((e.rotation_error_deg - 0.5f64.to_degrees()).abs() < 1e-9);
        // The ring's axis (its normal) did not move; tilted about x, it turns with the tilt.
        assert!(e.axis_error_deg.unwrap() < 1e-6, "{e:?}");
        let tilted = turned * Isometry3::rotation(Vector3::x() * 0.2);
        let e = truth_errors(&model, None, &tilted, &truth).unwrap();
        assert!(
            (e.axis_error_deg.unwrap() - 0.2f64.to_degrees()).abs() < 1e-6,
            "{e:?}"
        );
        let shifted = Translation3::new(0.002, 0.0, 0.0) * truth;
        let e = truth_errors(&model, None, &shifted, &truth).unwrap();
        assert!((e.translation_error_m - 0.002).abs() < 1e-12);
        assert!(e.add_s_m > 0.001 && e.add_s_m < 0.002);
    }

    #[test]
    fn huge_ray_counts_are_input_errors_not_allocations() {
        let object = [Point3::new(0.0, 0.0, 1.0), Point3::new(0.1, 0.05, 1.0)];
        for (lines, samples, field) in [
            (usize::MAX, 101, "accuracy.lines"),
            (1_000_000_000, 101, "accuracy.lines"),
            (21, usize::MAX, "accuracy.samples_per_line"),
            (21, 1_000_000_000, "accuracy.samples_per_line"),
            (0, 101, "accuracy.lines"),
        ] {
            let cfg = AccuracyConfig {
                lines,
                samples_per_line: samples,
                ..AccuracyConfig::default()
            };
            crate::perception::assert_bad_input(test_rays(&object, &Point3::origin(), &cfg), field);
        }
        let cfg = AccuracyConfig {
            inset: f64::NAN,
            ..AccuracyConfig::default()
        };
        crate::perception::assert_bad_input(cfg.validate(), "accuracy.inset");
    }
}
