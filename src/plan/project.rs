//! Projection of a pattern onto the triangulated scan surface.
//!
//! A pattern is a family of guide rays (origin, direction, reach) indexed by a parameter `τ`.
//! Each ray is cast on the scanned surface (the object as it is: silted, fouled, deformed); where
//! the scan has a hole the ray is cast on the aligned reference mesh instead and the point is
//! flagged as a fallback. Lines of the pattern are walked outwards from a centre, one guide ray
//! every `step_m`, until the requested arc length along the surface is covered, the scan ends
//! (a miss on both surfaces, or a jump of more than [`JUMP_FACTOR`] steps between neighbouring
//! hits: an occluding edge), or the parameter range is exhausted.
//!
//! Normals are smoothed so that stereo noise does not shake the tool: the surface is sampled
//! (one sample per triangle, or a low-discrepancy set of about one sample per (radius / 2)² on
//! larger triangles), every sample carries its share of its triangle's area and its unit normal, and the normal
//! at a point is the sum of the sample normals within the radius weighted by the smooth,
//! compactly supported kernel `(1 - d²/r²)²` — the area-weighted vertex normal of the classic mesh-smoothing literature, averaged
//! over a ball. The same weights give a local centroid; with `smooth_positions` the point is
//! moved along the smoothed normal onto the plane through that centroid (one step of a
//! moving-least-squares projection, Alexa et al. 2003), by at most `tolerance_m`, so the path
//! never leaves the scanned surface by more than the tolerance.
//!
//! Triangle normals of the scan are oriented towards the camera (a single-view scan sees only
//! surfaces facing it); those of the reference follow its winding (outward). The normal of a
//! path point is finally turned to face the guide ray's origin (the side the tool comes from).
//! Frame: the scan frame `S`; metres.

use crate::config::{non_negative, positive};
use crate::error::{Error, Result};
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use crate::surface::{Projection, RayHit, Surface};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Two neighbouring hits farther apart than this many guide steps mark an edge of the surface
/// (an occluding contour or a gap), where a walk stops.
pub const JUMP_FACTOR: f64 = 20.0;

/// Settings of the projection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProjectionConfig {
    /// Spacing of the guide rays, metres (in the pattern's own coordinates).
    pub step_m: f64,
    /// Radius over which surface normals (and positions) are smoothed, metres.
    pub smoothing_radius_m: f64,
    /// Move each point onto the smoothed local surface (at most `tolerance_m`).
    pub smooth_positions: bool,
    /// The most a path point may lie off the scanned surface, metres.
    pub tolerance_m: f64,
    /// Trim a band or line that extends beyond the scanned surface instead of failing.
    pub clip: bool,
    /// Holes in the scan up to this long (along the path) are bridged by the aligned reference;
    /// a longer one ends a line of the pattern, metres.
    pub max_hole_m: f64,
}

impl Default for ProjectionConfig {
    fn default() -> Self {
        ProjectionConfig {
            step_m: 0.001,
            smoothing_radius_m: 0.015,
            smooth_positions: true,
            tolerance_m: 0.005,
            clip: false,
            max_hole_m: 0.1,
        }
    }
}

impl ProjectionConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("projection.step_m", self.step_m)?;
        positive("projection.smoothing_radius_m", self.smoothing_radius_m)?;
        positive("projection.tolerance_m", self.tolerance_m)?;
        non_negative("projection.max_hole_m", self.max_hole_m)?;
        if self.step_m < 1e-5 {
            return Err(Error::input("projection.step_m", "must be at least 1e-5 m"));
        }
        if self.smoothing_radius_m < 2.0 * self.step_m {
            return Err(Error::input(
                "projection.smoothing_radius_m",
                "must be at least twice projection.step_m",
            ));
        }
        Ok(())
    }
}

/// The most samples, guide rays or passes one trajectory may need: beyond it the settings are
/// taken as a mistake (a microscopic step, a band kilometres wide) rather than a run that would
/// exhaust the memory.
pub const MAX_COUNT: f64 = 1e7;

/// `Ok` if `numerator / denominator` (a count of steps) is at most [`MAX_COUNT`], else an input
/// error naming `what`, its reason starting with `context` (what needs the steps, or "").
pub(crate) fn bounded_count(what: &str, numerator: f64, denominator: f64, context: &str) -> Result<()> {
    if numerator / denominator <= MAX_COUNT {
        Ok(())
    } else {
        Err(Error::input(
            what,
            format!(
                "{context}would need {:.3e} steps (at most {MAX_COUNT:.0e}); use a coarser step or a smaller extent",
                numerator / denominator
            ),
        ))
    }
}

/// How the triangle normals of a surface are oriented before smoothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Facing {
    /// By the triangles' winding (a closed reference mesh, counter-clockwise from outside).
    Winding,
    /// Towards a viewpoint (a single-view scan).
    Toward(Point3<f64>),
}

/// A triangle mesh prepared for ray casting and for smoothed normals.
pub struct SmoothSurface {
    surface: Surface,
    samples: Vec<Point3<f64>>,
    /// Oriented unit normal times the sample's area.
    weighted_normals: Vec<Vector3<f64>>,
    index: KdIndex,
    radius: f64,
}

/// The most samples drawn on one (large) triangle.
const MAX_SAMPLES_PER_TRIANGLE: usize = 4096;

/// The R2 low-discrepancy sequence's increments (Roberts 2018).
const R2: (f64, f64) = (0.754_877_666_246_692_7, 0.569_840_290_998_053_2);

impl SmoothSurface {
    /// Samples the mesh for smoothing over `radius` metres.
    ///
    /// # Errors
    /// [`Error::Input`] for a mesh without triangles, with a bad index or a non-finite vertex.
    pub fn new(mesh: &TriangleMesh, facing: Facing, radius: f64) -> Result<Self> {
        let surface = Surface::new(mesh)?;
        // About one sample per (radius / 2)² of area.
        let h = radius / 2.0;
        let mut samples = Vec::with_capacity(mesh.triangles.len());
        let mut weighted_normals = Vec::with_capacity(mesh.triangles.len());
        for t in 0..mesh.triangles.len() {
            let Some(mut n) = mesh.triangle_normal(t) else {
                continue;
            };
            let [a, b, c] = mesh.triangles[t].map(|i| mesh.vertices[i as usize]);
            let centroid = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            if let Facing::Toward(view) = facing
                && n.dot(&(view - centroid)) < 0.0
            {
                n = -n;
            }
            let area = 0.5 * (b - a).cross(&(c - a)).norm();
            let count = ((area / (h * h)).ceil() as usize).clamp(1, MAX_SAMPLES_PER_TRIANGLE);
            if count == 1 {
                samples.push(centroid);
                weighted_normals.push(n * area);
                continue;
            }
            // A low-discrepancy (R2) sequence on the unit square, folded onto the triangle.
            for i in 0..count {
                let (mut u, mut v) = ((0.5 + i as f64 * R2.0).fract(), (0.5 + i as f64 * R2.1).fract());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                samples.push(a + (b - a) * u + (c - a) * v);
                weighted_normals.push(n * (area / count as f64));
            }
        }
        let index = KdIndex::new(&samples)?;
        Ok(SmoothSurface {
            surface,
            samples,
            weighted_normals,
            index,
            radius,
        })
    }

    /// The first hit of a ray (see [`Surface::cast_ray`]).
    pub fn cast(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_distance: f64) -> Option<RayHit> {
        self.surface.cast_ray(origin, dir, max_distance)
    }

    /// The closest surface point (see [`Surface::project`]).
    pub fn project(&self, p: &Point3<f64>) -> Projection {
        self.surface.project(p)
    }

    /// The smoothed unit normal at `p` and the weighted centroid of the samples around it; when
    /// no sample lies within the radius, `fallback` and `None`.
    pub fn local_plane(
        &self,
        p: &Point3<f64>,
        fallback: &Vector3<f64>,
    ) -> (Vector3<f64>, Option<Point3<f64>>) {
        // A smooth kernel with compact support, (1 - d²/r²)²: points entering or leaving the
        // ball carry no weight, so the result varies smoothly along the path.
        let inv = 1.0 / (self.radius * self.radius);
        let (mut n, mut c, mut wsum) = (Vector3::zeros(), Vector3::zeros(), 0.0);
        self.index.within_visit(p, self.radius, |nb| {
            let g = (1.0 - nb.distance * nb.distance * inv).max(0.0).powi(2);
            let wn = self.weighted_normals[nb.index] * g;
            let w = wn.norm();
            n += wn;
            c += self.samples[nb.index].coords * w;
            wsum += w;
        });
        match n.try_normalize(1e-300) {
            Some(n) if wsum > 0.0 => (n, Some(Point3::from(c / wsum))),
            _ => (*fallback, None),
        }
    }
}

/// One guide ray of a pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guide {
    /// Ray origin, metres (outside the object, on the tool's side).
    pub origin: Point3<f64>,
    /// Unit ray direction (into the surface).
    pub dir: Vector3<f64>,
    /// How far the ray reaches, metres.
    pub reach: f64,
}

/// A projected point of the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Position on the surface, metres.
    pub point: Point3<f64>,
    /// Smoothed unit surface normal, facing the tool (out of the object).
    pub normal: Vector3<f64>,
    /// True if the point lies on the reference mesh (a hole in the scan).
    pub fallback: bool,
    /// The pattern parameter of the guide ray.
    pub tau: f64,
    /// Desired force, N.
    pub force: f64,
}

impl PathPoint {
    /// Linear interpolation between two points (normal renormalised); the result is a fallback
    /// point if either end is.
    pub fn lerp(&self, other: &PathPoint, u: f64) -> PathPoint {
        PathPoint {
            point: self.point + (other.point - self.point) * u,
            normal: self
                .normal
                .lerp(&other.normal, u)
                .try_normalize(1e-12)
                .unwrap_or(self.normal),
            fallback: self.fallback || other.fallback,
            tau: self.tau + (other.tau - self.tau) * u,
            force: self.force + (other.force - self.force) * u,
        }
    }
}

/// Casts guide rays on a primary surface with a fallback surface for its holes.
pub struct Projector<'a> {
    /// The scanned surface.
    pub primary: &'a SmoothSurface,
    /// The surface used where the primary has a hole (the aligned reference).
    pub fallback: Option<&'a SmoothSurface>,
    /// The projection settings.
    pub config: &'a ProjectionConfig,
}

/// Why a walk stopped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Stop {
    /// It reached its target arc length on the scanned surface.
    Reached,
    /// The end of its parameter range.
    #[default]
    Range,
    /// A ray missed both the scan and the reference (the object's edge).
    Miss,
    /// Neighbouring hits jumped apart (an occluding contour or a step).
    Jump,
    /// The scan had a hole longer than `max_hole_m` (the reference went on).
    Hole,
}

impl Stop {
    /// What the stop means, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Stop::Reached => "the requested length was reached",
            Stop::Range => "the search range ended",
            Stop::Miss => "the object ends there",
            Stop::Jump => "the surface steps or folds away there",
            Stop::Hole => "the scan has a hole longer than projection.max_hole_m there",
        }
    }
}

/// The result of walking a line of the pattern from its centre outwards.
#[derive(Debug, Clone, Default)]
pub struct Walk {
    /// The points from the centre outwards (the centre first).
    pub points: Vec<PathPoint>,
    /// Arc length along the surface from the centre, metres, per point.
    pub arc: Vec<f64>,
    /// Index of the outermost point on the primary (scanned) surface.
    pub last_primary: Option<usize>,
    /// Why the walk stopped.
    pub stop: Stop,
}

impl Walk {
    /// Arc length of the outermost scanned point (0 when there is none beyond the centre).
    pub fn scanned_arc(&self) -> f64 {
        self.last_primary.map_or(0.0, |i| self.arc[i])
    }
}

impl Projector<'_> {
    /// Projects one guide ray; `None` when it misses both surfaces.
    pub fn cast(&self, g: &Guide, tau: f64, force: f64) -> Option<PathPoint> {
        let (surf, hit, fallback) = match self.primary.cast(&g.origin, &g.dir, g.reach) {
            Some(h) => (self.primary, h, false),
            None => {
                let f = self.fallback?;
                (f, f.cast(&g.origin, &g.dir, g.reach)?, true)
            }
        };
        let raw_normal = if hit.normal.dot(&g.dir) > 0.0 {
            -hit.normal
        } else {
            hit.normal
        };
        let (mut n, centroid) = surf.local_plane(&hit.point, &raw_normal);
        if n.dot(&g.dir) > 0.0 {
            n = -n;
        }
        let mut point = hit.point;
        if self.config.smooth_positions
            && let Some(c) = centroid
        {
            let off = (point - c).dot(&n);
            point -= n * off.clamp(-self.config.tolerance_m, self.config.tolerance_m);
        }
        Some(PathPoint {
            point,
            normal: n,
            fallback,
            tau,
            force,
        })
    }

    /// Walks the guide family from the already projected `centre` (at `centre.tau`) towards
    /// `tau_end`, one ray per `step_m` of parameter (`metric` metres per unit of `τ`), until the
    /// arc length reaches `target` metres on a scanned point, the line leaves the surface, a hole
    /// in the scan grows longer than `max_hole_m`, or `tau_end` is reached.
    pub fn walk(
        &self,
        family: &dyn Fn(f64) -> Guide,
        centre: PathPoint,
        tau_end: f64,
        metric: f64,
        target: Option<f64>,
    ) -> Walk {
        let mut w = Walk {
            points: vec![centre],
            arc: vec![0.0],
            last_primary: (!centre.fallback).then_some(0),
            stop: Stop::Range,
        };
        let span = tau_end - centre.tau;
        let steps = ((span.abs() * metric / self.config.step_m).ceil() as usize).max(1);
        let jump = JUMP_FACTOR * self.config.step_m;
        for i in 1..=steps {
            let tau = centre.tau + span * i as f64 / steps as f64;
            let Some(p) = self.cast(&family(tau), tau, centre.force) else {
                w.stop = Stop::Miss;
                break;
            };
            let Some(prev) = w.points.last() else { break };
            let d = (p.point - prev.point).norm();
            if d > jump {
                w.stop = Stop::Jump;
                break;
            }
            let arc = w.arc[w.arc.len() - 1] + d;
            w.points.push(p);
            w.arc.push(arc);
            if !p.fallback {
                w.last_primary = Some(w.points.len() - 1);
                if target.is_some_and(|t| arc >= t) {
                    w.stop = Stop::Reached;
                    break;
                }
            } else if arc - w.scanned_arc() > self.config.max_hole_m {
                w.stop = Stop::Hole;
                break;
            }
        }
        w
    }
}

/// A projected line of the pattern with arc-length coordinates.
#[derive(Debug, Clone)]
pub struct Line {
    /// The points in order.
    pub points: Vec<PathPoint>,
    /// Arc length of each point, metres (0 at the line's centre, negative before it).
    pub arc: Vec<f64>,
    /// Arc range covered by the scanned surface (outermost primary hits on either side).
    pub scanned: (f64, f64),
    /// Why the walks towards smaller and larger parameters stopped.
    pub stops: (Stop, Stop),
}

impl Line {
    /// Joins the walks towards smaller (`back`) and larger (`ahead`) parameters from the same
    /// centre.
    pub fn from_walks(back: Walk, ahead: Walk) -> Line {
        let mut points: Vec<PathPoint> = back.points[1..].iter().rev().copied().collect();
        let mut arc: Vec<f64> = back.arc[1..].iter().rev().map(|a| -a).collect();
        points.extend(ahead.points.iter().copied());
        arc.extend(ahead.arc.iter().copied());
        Line {
            points,
            arc,
            scanned: (-back.scanned_arc(), ahead.scanned_arc()),
            stops: (back.stop, ahead.stop),
        }
    }

    /// The point at arc length `s` (clamped to the line), interpolated.
    pub fn at(&self, s: f64) -> PathPoint {
        let i = self.arc.partition_point(|&a| a < s);
        if i == 0 {
            return self.points[0];
        }
        if i >= self.arc.len() {
            return self.points[self.points.len() - 1];
        }
        let (a0, a1) = (self.arc[i - 1], self.arc[i]);
        let u = if a1 > a0 { (s - a0) / (a1 - a0) } else { 0.0 };
        self.points[i - 1].lerp(&self.points[i], u)
    }

    /// The arc length where the parameter reaches `tau` (τ is monotone along the line).
    pub fn arc_at_tau(&self, tau: f64) -> f64 {
        let increasing = self.points.last().map(|p| p.tau) >= self.points.first().map(|p| p.tau);
        let i = self
            .points
            .partition_point(|p| if increasing { p.tau < tau } else { p.tau > tau });
        if i == 0 {
            return self.arc[0];
        }
        if i >= self.points.len() {
            return self.arc[self.arc.len() - 1];
        }
        let (t0, t1) = (self.points[i - 1].tau, self.points[i].tau);
        let u = if t1 != t0 { (tau - t0) / (t1 - t0) } else { 0.0 };
        self.arc[i - 1] + (self.arc[i] - self.arc[i - 1]) * u
    }

    /// The sub-line between arc lengths `a < b`, with interpolated ends.
    pub fn between(&self, a: f64, b: f64) -> Vec<PathPoint> {
        let mut out = vec![self.at(a)];
        out.extend(
            self.arc
                .iter()
                .zip(&self.points)
                .filter(|(s, _)| **s > a && **s < b)
                .map(|(_, p)| *p),
        );
        out.push(self.at(b));
        out
    }
}

/// Moves the points that lie on the fallback surface (holes in the scan) by the offset between
/// the scan and the fallback surface at the hole's borders, interpolated along the path, so the
/// path stays continuous across a hole: the fallback surface gives the shape, the scan around
/// the hole the level (fouling, deformation, residual misalignment). A run touching one end of
/// the path takes its one border's offset; a path without scanned points is left as it is.
pub fn bridge_holes(points: &mut [PathPoint], fallback: &SmoothSurface) {
    let offset = |p: &PathPoint| {
        let q = fallback.project(&p.point);
        let (n, _) = fallback.local_plane(&q.point, &q.normal);
        (p.point - q.point).dot(&n)
    };
    let n = points.len();
    let mut i = 0;
    while i < n {
        if !points[i].fallback {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && points[i].fallback {
            i += 1;
        }
        let before = start.checked_sub(1).map(|k| offset(&points[k]));
        let after = (i < n).then(|| offset(&points[i]));
        // Arc length across the run, from the border before it to the border after it.
        let first = start.saturating_sub(1);
        let last = i.min(n - 1);
        let mut arc = vec![0.0; last - first + 1];
        for k in first + 1..=last {
            arc[k - first] = arc[k - first - 1] + (points[k].point - points[k - 1].point).norm();
        }
        let total = arc[arc.len() - 1];
        for k in start..i {
            let d = match (before, after) {
                (Some(a), Some(b)) if total > 0.0 => a + (b - a) * arc[k - first] / total,
                (Some(a), _) => a,
                (None, Some(b)) => b,
                (None, None) => 0.0,
            };
            points[k].point += points[k].normal * d;
        }
    }
}

/// Projects a sequence of guide rays that must all hit (a connector between rows, a fixed
/// line); `what` names the part in the error.
///
/// # Errors
/// [`Error::Failed`] at the first ray that misses both surfaces.
pub fn project_all(
    projector: &Projector,
    guides: impl Iterator<Item = (f64, Guide)>,
    force: f64,
    what: &str,
) -> Result<Vec<PathPoint>> {
    guides
        .map(|(tau, g)| {
            projector.cast(&g, tau, force).ok_or_else(|| {
                Error::failed(
                    "plan",
                    format!(
                        "the {what} leaves the object near ({:.3}, {:.3}, {:.3}) m in the scan frame",
                        g.origin.x, g.origin.y, g.origin.z
                    ),
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::fixtures::{Cylinder, ScanSpec, Truth, with_hole};

    fn bottle() -> Cylinder {
        Cylinder::bottle()
    }

    #[test]
    fn smoothed_normals_follow_the_true_surface() {
        let c = bottle();
        let spec = ScanSpec {
            noise_sigma: 0.001,
            ..ScanSpec::default()
        };
        let scan = SmoothSurface::new(&c.scan(&spec), Facing::Toward(spec.viewpoint), 0.01).unwrap();
        let mut raw_err = Vec::new();
        let mut smooth_err = Vec::new();
        for i in 0..50 {
            let th = -1.0 + 0.04 * i as f64;
            let p = c.point(0.1 * (i as f64 * 0.7).sin(), -std::f64::consts::FRAC_PI_2 + th);
            let truth = c.normal(&p);
            let hit = scan.cast(&(p + truth * 0.05), &-truth, 0.1).unwrap();
            let raw = if hit.normal.dot(&truth) < 0.0 {
                -hit.normal
            } else {
                hit.normal
            };
            let (n, _) = scan.local_plane(&hit.point, &raw);
            raw_err.push(raw.angle(&truth).to_degrees());
            smooth_err.push(n.angle(&truth).to_degrees());
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (r, s) = (median(&mut raw_err), median(&mut smooth_err));
        // 1 mm depth noise on a 4 mm grid tilts raw triangles by ~20°; the smoothed normal is
        // within a couple of degrees.
        assert!(s < 3.0 && s < r / 3.0, "smoothed {s}°, raw {r}°");
    }

    #[test]
    fn holes_fall_back_to_the_reference() {
        let c = bottle();
        let spec = ScanSpec::default();
        let top = c.point(0.0, -std::f64::consts::FRAC_PI_2);
        let scan_mesh = with_hole(&c.scan(&spec), &top, 0.03);
        let scan = SmoothSurface::new(&scan_mesh, Facing::Toward(spec.viewpoint), 0.01).unwrap();
        let reference = SmoothSurface::new(&c.mesh(128, 4), Facing::Winding, 0.01).unwrap();
        let config = ProjectionConfig::default();
        let pj = Projector {
            primary: &scan,
            fallback: Some(&reference),
            config: &config,
        };
        let g = |x: f64| Guide {
            origin: Point3::new(x, 0.0, 0.5),
            dir: Vector3::z(),
            reach: 1.0,
        };
        let inside = pj.cast(&g(0.0), 0.0, 0.0).unwrap();
        assert!(inside.fallback && c.distance(&inside.point) < 1e-3);
        assert!(inside.normal.angle(&-Vector3::z()) < 0.05);
        let outside = pj.cast(&g(0.1), 0.1, 0.0).unwrap();
        assert!(!outside.fallback && c.distance(&outside.point) < 2e-3);
        assert!(pj.cast(&g(0.5), 0.5, 0.0).is_none());
        let line = |target| {
            let family = |t: f64| g(t);
            let centre = pj.cast(&g(0.0), 0.0, 0.0).unwrap();
            Line::from_walks(
                pj.walk(&family, centre, -0.4, 1.0, target),
                pj.walk(&family, centre, 0.4, 1.0, target),
            )
        };
        // Walking to the end: the scanned range stops short of the cylinder's ends by < 1 step.
        let full = line(None);
        assert!(
            (full.scanned.1 - 0.3).abs() < 0.002 && (full.scanned.0 + 0.3).abs() < 0.002,
            "{:?}",
            full.scanned
        );
        // With a target, the walk stops at the first scanned point beyond it.
        let part = line(Some(0.1));
        assert!(part.scanned.1 >= 0.1 && part.scanned.1 < 0.1 + 0.002);
        let sub = part.between(-0.05, 0.08);
        assert!((sub[0].point.x + 0.05).abs() < 1e-3 && (sub[sub.len() - 1].point.x - 0.08).abs() < 1e-3);
        assert!((part.arc_at_tau(0.02) - 0.02).abs() < 1e-3);
    }
}
