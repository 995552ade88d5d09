//! Contact of the tool tip with the *true* surface (the plant side: the controllers never see
//! this module's output; they estimate the force from joint moments, see [`super::icu`]).
//!
//! - **Rigid object** (the bottle, a stone): a penalty force along the outward surface normal
//!   `n`, `F_n = k·δ + c·δ̇` for a penetration `δ > 0` (never pulling: `F_n ≥ 0`), with the seed's
//!   `k = 1e4 N/m`; Coulomb friction against the sliding velocity `v_t`, regularised at low
//!   speed: `F_t = −μ F_n v_t / √(‖v_t‖² + ε²)` (the brush).
//! - **Soil** (sampling): the same normal reaction with the sediment's own stiffness, and a
//!   resistance against the motion that grows with the immersion depth,
//!   `F_r = −r·δ·tanh(‖v_t‖/v_ε)·v_t/‖v_t‖`; `r` is calibrated so that the seed's ≈ 70 N appear
//!   at its 2 cm immersion and 0.02 m/s (`r = 70 N / (0.02 m · tanh(10)) ≈ 3500 N/m`).
//!
//! [`Contact::evaluate`] also returns the force's slope against the tool tip's velocity
//! ([`ContactState::damping`]: the normal damping, the regularised friction's or the soil
//! resistance's secant slope) for the plant's linearly implicit step: the soil's resistance at
//! 2 cm is a `r·δ/v_ε ≈ 35 000 N·s/m` damper at low speed, far too stiff to be held over a
//! 1 ms step.
//!
//! The penetration is the tool tip's distance to the closest point of the true surface mesh (a
//! parry3d BVH query through [`crate::surface::Surface`]), inside by the outward normal of the
//! triangle it lies on. The mesh stands for a smooth surface: the force acts along the normal
//! of that surface, the vertex normals blended at the closest point (`normals = "shaded"`, the
//! default; "force shading", Morgenbesser & Srinivasan 1996, after Phong), continuous across
//! the triangles' edges. Along the triangles' own normals (`normals = "facet"`) the force turns
//! by the angle between two triangles the instant the tip crosses their edge: on the bottle's
//! mesh (triangles of a few millimetres) a 60 N force turned by about 2° in one step, a 2 N·m
//! step of the external moments that no physical bottle makes. In soil the immersion is the
//! sediment straight above the tip (a ray cast up), with the normal of the surface there: 2 cm
//! deep under ripples the closest point jumped from one ripple's flank to the next's, steps of
//! 3–7 N in the soil run's force. The wrench acts at the tool tip (no moment about it).
//!
//! **A tool's footprint** (`footprint_radius_m > 0`, rigid surfaces): a brush or a pad presses
//! on a patch, not a point, and a scanned surface is rough at the scale of the point contact's
//! penetration (the stereo's noise, millimetres; 6 mm at 60 N against `k = 1e4`): the closest
//! point jumps between patches a few millimetres apart within a period, and the force turns
//! with it. With a footprint the surface under the tool is the mesh averaged over it, a
//! point-set surface of samples of the mesh (Adamson & Alexa 2003, "Approximating and
//! intersecting surfaces from points"; Amenta & Kil 2004): the plane through the samples'
//! weighted centroid `a(x)` normal to their weighted mean normal `n(x)`, the tip's signed
//! distance `n(x)·(x − a(x))`, the force along `n(x)`. The samples `pᵢ` lie within the radius
//! `h` of the tip, with the mesh's shaded normals `nᵢ` there and weights
//! `wᵢ = aᵢ φ(|x − pᵢ|/h)`: `aᵢ` the sample's share of the area (the triangles cut until their
//! edges are no longer than `h/2`, a sample at the centroid of each), so that the sums stand
//! for integrals over the surface whatever the mesh's density, and Wendland's
//! `φ(t) = (1 − t)⁴(4t + 1)`, twice continuously differentiable and zero at `t = 1`. Both the
//! centroid and the normal vary smoothly with the tip, across a scan's noise and round an
//! edge alike (a least-squares plane's normal instead, the covariance's smallest axis, flips
//! between two faces within a period where its two smallest spreads cross: PCL's milk carton
//! at `h` = 1 cm, identification peaks of 8–9 N·m); a plane is reproduced exactly, a cylinder
//! of radius `R` within its curvature over the patch (the test's bound). Samples facing away
//! from the patch's mean normal count less from 60° off it and not at all from 120° (a
//! smoothstep of the cosine): a patch that reaches the far face of a plate thinner than it
//! sees the near face only. The patch is the surface within `h` of the tip, a disc of radius
//! `√(h² − δ²)` at a penetration `δ`; deeper than `h` the mesh's closest point answers.

use crate::config::{non_negative, positive, require};
use crate::error::Result;
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use crate::spatial_algebra::Force;
use crate::surface::{Neighbourhood, Surface};
use nalgebra::{Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};

/// What the tool touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Material {
    /// A rigid object: penalty normal force and Coulomb friction.
    #[default]
    Rigid,
    /// Sediment: a soft normal reaction and a depth-dependent resistance to the motion.
    Soil,
}

/// Which normal the contact force acts along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Normals {
    /// The smooth surface's: the vertex normals blended at the closest point.
    #[default]
    Shaded,
    /// The closest triangle's own.
    Facet,
}

/// The contact model's parameters (`[sim.contact]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContactConfig {
    /// What the surface is made of.
    pub material: Material,
    /// Normal stiffness, N/m (the seed's 1e4 for the bottle).
    pub stiffness_n_m: f64,
    /// Normal damping, N·s/m.
    pub damping_n_s_m: f64,
    /// Coulomb friction coefficient (rigid).
    pub friction: f64,
    /// Sliding speed below which friction and soil resistance are regularised, m/s.
    pub velocity_epsilon_m_s: f64,
    /// Soil resistance per metre of immersion, N/m (soil).
    pub soil_resistance_n_m: f64,
    /// The normal the force acts along.
    pub normals: Normals,
    /// The radius of the patch the tool presses on, m (rigid surfaces; 0: a point; at most
    /// 0.1 m): the surface under the tool is the mesh averaged over it (see the module's
    /// documentation).
    pub footprint_radius_m: f64,
}

impl Default for ContactConfig {
    fn default() -> Self {
        ContactConfig {
            material: Material::Rigid,
            stiffness_n_m: 1e4,
            damping_n_s_m: 50.0,
            friction: 0.3,
            velocity_epsilon_m_s: 0.002,
            soil_resistance_n_m: 3500.0,
            normals: Normals::Shaded,
            footprint_radius_m: 0.0,
        }
    }
}

impl ContactConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("sim.contact.stiffness_n_m", self.stiffness_n_m)?;
        positive("sim.contact.velocity_epsilon_m_s", self.velocity_epsilon_m_s)?;
        non_negative("sim.contact.damping_n_s_m", self.damping_n_s_m)?;
        non_negative("sim.contact.friction", self.friction)?;
        non_negative("sim.contact.soil_resistance_n_m", self.soil_resistance_n_m)?;
        non_negative("sim.contact.footprint_radius_m", self.footprint_radius_m)?;
        require(
            self.footprint_radius_m <= FOOTPRINT_MAX_RADIUS_M,
            "sim.contact.footprint_radius_m",
            format!(
                "{} m is wider than a tool's footprint (at most {FOOTPRINT_MAX_RADIUS_M} m): the force acts at the tip with no moment, which a pad that wide would feel, and the contact would sum over a patch the size of the object every period",
                crate::config::shown(self.footprint_radius_m)
            ),
        )?;
        require(
            self.material == Material::Rigid || self.footprint_radius_m == 0.0,
            "sim.contact.footprint_radius_m",
            "applies to a rigid surface (the soil's immersion is the sediment straight above the tip)",
        )
    }
}

/// The contact state at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// The environment's wrench on the tool (world axes, about the tool tip).
    pub wrench: Force,
    /// Penetration depth, m (≤ 0: no contact).
    pub depth: f64,
    /// Outward unit normal of the surface at the closest point (world).
    pub normal: Vector3<f64>,
    /// `D`, the contact force's (world axes) slope against the tool tip's velocity (world) for
    /// the plant's linearly implicit step, N·s/m; zero out of contact. Along the normal the
    /// damping `c` (`−∂F/∂v`), in the tangent plane the secant slope `C` of the friction or the
    /// soil's resistance, `F_t = −C·v_t`: equal to `−∂F/∂v` across the sliding direction,
    /// larger along it (`tanh` is concave). With the secant the force of a step, `F − D·Δv`,
    /// is `−C·v_t` at the step's end velocity: it never drives the tool, whatever the step.
    /// (The tangent slope along the sliding direction vanishes at speeds of a few `ε`: a tool
    /// braking from there overshot zero speed and made the force swing, 14 N·m of moment
    /// identification error in the soil run's retreat against 8.7 with the secant.) The
    /// friction's growth with the normal damping is left explicit. Symmetric, positive
    /// semi-definite.
    pub damping: Matrix3<f64>,
}

impl ContactState {
    /// Whether the tool touches the surface.
    pub fn in_contact(&self) -> bool {
        self.depth > 0.0
    }
}

/// The true surface and its contact law.
pub struct Contact {
    surface: Surface,
    cfg: ContactConfig,
    /// The triangles around the tool tip, for the next query's closest point.
    near: Neighbourhood,
    /// The tool's footprint, when it has one.
    footprint: Option<Footprint>,
}

/// The mesh averaged over a tool's footprint: samples of the surface (points, their normals
/// and shares of the area), indexed.
struct Footprint {
    radius: f64,
    index: KdIndex,
    points: Vec<Point3<f64>>,
    normals: Vec<Vector3<f64>>,
    areas: Vec<f64>,
    /// The samples within `radius + reach` of `centre`, for the queries within `reach` of it
    /// (a quarter of the radius: some hundred control periods at the tool's speed) without a
    /// walk down the tree each period; empty until the first query.
    centre: Point3<f64>,
    near: Vec<u32>,
    /// The samples within the radius of the last query, with their weights (kept for its
    /// allocation).
    weighed: Vec<(u32, f64)>,
}

/// The widest footprint, m: a brush's or a pad's radius.
const FOOTPRINT_MAX_RADIUS_M: f64 = 0.1;

/// The most samples a footprint takes of a mesh: some 300 MB.
const FOOTPRINT_MAX_SAMPLES: usize = 5_000_000;

/// How many pieces a side the triangle `a b c` is cut into for a footprint of `radius`: the
/// least that makes their edges no longer than half the radius (clamped where the count would
/// pass [`FOOTPRINT_MAX_SAMPLES`] anyway, to keep it in range).
fn footprint_cuts([a, b, c]: [Point3<f64>; 3], radius: f64) -> usize {
    let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
    ((2.0 * longest / radius).ceil() as usize).clamp(1, 1 << 12)
}

/// Checks that `count` samples (the sum of the triangles' squared [`footprint_cuts`]) are
/// within [`FOOTPRINT_MAX_SAMPLES`].
///
/// # Errors
/// [`Error::Input`](crate::error::Error::Input) naming `sim.contact.footprint_radius_m`
/// when they are not.
fn check_samples(count: usize, radius: f64) -> Result<()> {
    require(
        count <= FOOTPRINT_MAX_SAMPLES,
        "sim.contact.footprint_radius_m",
        format!(
            "{radius} m would need at least {count} samples of the surface mesh (at most \
             {FOOTPRINT_MAX_SAMPLES}): give a larger radius or a mesh of the part the tool touches"
        ),
    )
}

/// Checks that a footprint of `cfg` can sample `mesh` (see [`Contact::new`]), before a run
/// writes anything.
///
/// # Errors
/// [`Error::Input`](crate::error::Error::Input) naming `sim.contact.footprint_radius_m`
/// when it would take too many samples.
pub fn check_footprint(cfg: &ContactConfig, mesh: &TriangleMesh) -> Result<()> {
    let radius = cfg.footprint_radius_m;
    if radius <= 0.0 {
        return Ok(());
    }
    let count = mesh
        .triangles
        .iter()
        .map(|t| footprint_cuts(t.map(|i| mesh.vertices[i as usize]), radius).pow(2))
        .sum();
    check_samples(count, radius)
}

impl Footprint {
    /// Samples the surface: each triangle is cut into `m²` equal triangles
    /// ([`footprint_cuts`]), each a sample at its centroid with its area and the surface's
    /// shaded normal there ([`Surface::shaded_normal_in`]), so that a footprint on the surface
    /// holds several samples wherever it stands.
    ///
    /// # Errors
    /// As [`check_samples`].
    fn new(surface: &Surface, radius: f64) -> Result<Self> {
        let triangles: Vec<_> = (0..surface.triangle_count())
            .filter_map(|t| Some((t, surface.corners(t)?)))
            .map(|(t, corners)| (t, corners, footprint_cuts(corners, radius)))
            .collect();
        let count = triangles.iter().map(|(_, _, m)| m * m).sum();
        check_samples(count, radius)?;
        let (mut points, mut normals, mut areas) = (
            Vec::with_capacity(count),
            Vec::with_capacity(count),
            Vec::with_capacity(count),
        );
        for (t, [a, b, c], m) in triangles {
            let area = 0.5 * (b - a).cross(&(c - a)).norm() / (m * m) as f64;
            let mf = m as f64;
            // The centroids of the small triangles pointing like the triangle (offset 1/3) and
            // of those pointing the other way (2/3), in the weights (u, v) of `b` and `c`.
            let mut sample = |u: f64, v: f64| {
                let w = 1.0 - u - v;
                points.push(Point3::from(a.coords * w + b.coords * u + c.coords * v));
                normals.push(surface.shaded_normal_in(t, [w, u, v]));
                areas.push(area);
            };
            for i in 0..m {
                for j in 0..m - i {
                    sample((i as f64 + 1.0 / 3.0) / mf, (j as f64 + 1.0 / 3.0) / mf);
                    if i + j + 2 <= m {
                        sample((i as f64 + 2.0 / 3.0) / mf, (j as f64 + 2.0 / 3.0) / mf);
                    }
                }
            }
        }
        Ok(Footprint {
            radius,
            index: KdIndex::new(&points)?,
            points,
            normals,
            areas,
            centre: Point3::new(f64::INFINITY, 0.0, 0.0),
            near: Vec::new(),
            weighed: Vec::new(),
        })
    }

    /// The averaged surface's signed distance from `x` (positive outside) and its outward unit
    /// normal there; `None` when no sample lies within the radius.
    fn at(&mut self, x: &Point3<f64>) -> Option<(f64, Vector3<f64>)> {
        let reach = 0.25 * self.radius;
        // (False for a point that is not finite: listed anew, nothing found.)
        let covered = (x - self.centre).norm() <= reach;
        if !covered {
            self.centre = *x;
            self.near.clear();
            let near = &mut self.near;
            self.index
                .within_visit(x, self.radius + reach, |nb| near.push(nb.index as u32));
        }
        // The samples within the radius, their weights, and their mean normal.
        let h2 = self.radius * self.radius;
        self.weighed.clear();
        let mut mean = Vector3::zeros();
        for &i in &self.near {
            let d2 = (self.points[i as usize] - x).norm_squared();
            if d2 < h2 {
                let t = d2.sqrt() / self.radius;
                let w = self.areas[i as usize] * (1.0 - t).powi(4) * (4.0 * t + 1.0);
                mean += w * self.normals[i as usize];
                self.weighed.push((i, w));
            }
        }
        let facing = mean.try_normalize(1e-12)?;
        // Sums over the samples' offsets from `x` (at most the radius: no cancellation), of
        // the samples facing the mean's side: those turned from it by more than 60° count
        // less, by more than 120° (the far side of a thin object) not at all, smoothly.
        let (mut sw, mut sd, mut sn) = (0.0, Vector3::zeros(), Vector3::zeros());
        for &(i, w) in &self.weighed {
            let n = self.normals[i as usize];
            let t = (n.dot(&facing) + 0.5).clamp(0.0, 1.0);
            let w = w * t * t * (3.0 - 2.0 * t);
            sw += w;
            sd += w * (self.points[i as usize] - x);
            sn += w * n;
        }
        if sw <= 0.0 {
            return None;
        }
        let n = sn.try_normalize(1e-12)?;
        // `n·(x − a)`, `a = x + sd/sw` the weighted centroid.
        Some((-n.dot(&sd) / sw, n))
    }
}

/// How far the tool tip may move before the triangles around it are listed anew, m: a few
/// hundred control periods at the tool's centimetres per second, and a list of a few triangles
/// of the bottle's mesh.
const NEIGHBOURHOOD_REACH_M: f64 = 0.0005;

impl Contact {
    /// The contact with `mesh` (world frame; triangles wound so their normals point out of the
    /// material).
    ///
    /// # Errors
    /// [`Error::Input`](crate::error::Error::Input) for a bad configuration, an empty mesh,
    /// or a footprint too small for the mesh's size.
    pub fn new(mesh: &TriangleMesh, cfg: &ContactConfig) -> Result<Self> {
        cfg.validate()?;
        let surface = Surface::new(mesh)?;
        let footprint = if cfg.footprint_radius_m > 0.0 {
            Some(Footprint::new(&surface, cfg.footprint_radius_m)?)
        } else {
            None
        };
        Ok(Contact {
            surface,
            cfg: *cfg,
            near: Neighbourhood::new(NEIGHBOURHOOD_REACH_M),
            footprint,
        })
    }

    /// The contact force on a tool tip at `tip` moving with velocity `v` (world). The closest
    /// point is searched among the triangles around the last queries' tips
    /// ([`Surface::project_tracked`]).
    pub fn evaluate(&mut self, tip: &Point3<f64>, v: &Vector3<f64>) -> ContactState {
        let (depth, n) = self.depth_and_normal(tip);
        if depth <= 0.0 {
            return ContactState {
                wrench: Force::ZERO,
                depth,
                normal: n,
                damping: Matrix3::zeros(),
            };
        }
        let c = &self.cfg;
        // δ̇ = −v·n: the tip moving against the normal goes deeper.
        let fn_raw = c.stiffness_n_m * depth - c.damping_n_s_m * v.dot(&n);
        let fn_mag = fn_raw.max(0.0);
        // The normal force's slope −∂F_n/∂v = c·n (none while the tip leaves faster than the
        // spring pushes).
        let nn = n * n.transpose();
        let normal_slope = if fn_raw > 0.0 { c.damping_n_s_m } else { 0.0 };
        let vt = v - n * v.dot(&n);
        let speed = vt.norm();
        let eps = c.velocity_epsilon_m_s;
        // The tangential force is `−C·v_t` with a secant slope `C ≥ 0`.
        let (tangential, secant) = match c.material {
            Material::Rigid => {
                // F_t = −μ F_n v_t/σ, σ = √(‖v_t‖² + ε²).
                let sigma = (speed * speed + eps * eps).sqrt();
                let slope = c.friction * fn_mag / sigma;
                (-vt * slope, slope)
            }
            Material::Soil => {
                // F_r = −r δ tanh(s/ε) v_t/s (s = ‖v_t‖): C = (rδ/ε)·tanh(s/ε)/(s/ε), rδ/ε at rest.
                let x = speed / eps;
                let th = x.tanh();
                let a = if x > 1e-8 { th / x } else { 1.0 };
                let tangential = if speed > 0.0 {
                    -vt / speed * (c.soil_resistance_n_m * depth * th)
                } else {
                    Vector3::zeros()
                };
                (tangential, c.soil_resistance_n_m * depth / eps * a)
            }
        };
        let damping = nn * normal_slope + (Matrix3::identity() - nn) * secant;
        ContactState {
            wrench: Force::new(n * fn_mag + tangential, Vector3::zeros()),
            depth,
            normal: n,
            damping,
        }
    }

    /// How deep a tip at `tip` is in the material (negative outside: minus its distance from
    /// the surface), and the normal the contact force is along.
    pub(crate) fn depth_and_normal(&mut self, tip: &Point3<f64>) -> (f64, Vector3<f64>) {
        let proj = self.surface.project_tracked(tip, &mut self.near);
        // The footprint's surface ends at the mesh's rim too; where no sample lies within its
        // radius (a tip deeper than that), the mesh's own surface answers.
        if let Some(fp) = &mut self.footprint
            && !self.surface.on_rim(&proj)
            && let Some((f, n)) = fp.at(tip)
        {
            return (-f, n);
        }
        // Behind the closest point's triangle, and not beyond an open mesh's rim (whose closest
        // point is on the rim, off to the side: however far behind the rim triangle's plane,
        // no material; counted inside, metres of penetration, a runaway at once).
        let inside = (proj.point - tip).dot(&proj.normal) > 0.0 && !self.surface.on_rim(&proj);
        let immersion = match self.cfg.material {
            Material::Soil if inside => self.immersion(tip),
            _ => None,
        };
        immersion.unwrap_or_else(|| {
            let n = match self.cfg.normals {
                Normals::Shaded => self.surface.shaded_normal(&proj),
                Normals::Facet => proj.normal,
            };
            (if inside { proj.distance } else { -proj.distance }, n)
        })
    }

    /// How deep a point is in the material, m (negative outside: minus its distance from the
    /// surface), as [`Contact::evaluate`] measures a tool tip's.
    pub fn depth(&mut self, p: &Point3<f64>) -> f64 {
        self.depth_and_normal(p).0
    }

    /// How deep a tip inside soil is buried, and the normal of the surface above it: the
    /// sediment over the tip, straight up (`−z`, NED); `None` when the surface above does not
    /// face up there.
    fn immersion(&self, tip: &Point3<f64>) -> Option<(f64, Vector3<f64>)> {
        let up = -Vector3::z();
        let hit = self.surface.cast_ray(tip, &up, f64::MAX)?;
        if hit.normal.dot(&up) <= 0.0 {
            return None;
        }
        let n = match self.cfg.normals {
            Normals::Shaded => self.surface.shaded_normal_at_hit(&hit),
            Normals::Facet => hit.normal,
        };
        Some((hit.distance, n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 m square in the plane z = 0 with its normal along −z (up in NED).
    fn floor() -> TriangleMesh {
        TriangleMesh {
            vertices: vec![
                Point3::new(-1.0, -1.0, 0.0),
                Point3::new(1.0, -1.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(-1.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
        }
    }

    /// Beyond the floor's rim, below its plane, the closest point is on the rim: no material
    /// there, no force (counted inside by the side of the triangle alone, 1 m below and 0.5 m
    /// out was a 1.1 m penetration, 11 kN; a simulation whose surface lay off the trajectory ran
    /// away at its first step). Under the floor, just inside its rim and at its corner, it
    /// pushes as usual. The same with a triangle without area on every edge (a mesh writer's
    /// slivers), which would hide the rim.
    #[test]
    fn beyond_an_open_meshs_rim_is_outside() {
        let mut slivers = floor();
        for [a, b, c] in floor().triangles {
            slivers.triangles.extend([[a, a, b], [b, b, c], [c, c, a]]);
        }
        for mesh in [floor(), slivers] {
            beyond_the_rim(&mut Contact::new(&mesh, &ContactConfig::default()).unwrap());
        }
    }

    fn beyond_the_rim(c: &mut Contact) {
        for tip in [
            Point3::new(1.5, 0.0, 1.0),
            Point3::new(1.002, 0.0, 0.006),
            Point3::new(1.1, 1.1, 0.5),
        ] {
            let beyond = c.evaluate(&tip, &Vector3::zeros());
            assert!(!beyond.in_contact(), "{tip}: depth {}", beyond.depth);
            assert_eq!(beyond.wrench, Force::ZERO);
        }
        for tip in [
            Point3::new(0.99, 0.0, 0.006),
            Point3::new(0.999, 0.999, 0.006),
            Point3::new(0.0, 0.0, 0.006),
        ] {
            let under = c.evaluate(&tip, &Vector3::zeros());
            assert!(
                under.in_contact() && (under.depth - 0.006).abs() < 1e-12,
                "{tip}: {under:?}"
            );
        }
    }

    #[test]
    fn penalty_force_is_stiffness_times_depth() {
        let mut c = Contact::new(&floor(), &ContactConfig::default()).unwrap();
        let s = c.evaluate(&Point3::new(0.1, 0.2, 0.006), &Vector3::zeros());
        assert!((s.normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        assert!((s.depth - 0.006).abs() < 1e-12);
        assert!((s.wrench.lin - Vector3::new(0.0, 0.0, -60.0)).norm() < 1e-9);
        let above = c.evaluate(&Point3::new(0.1, 0.2, -0.01), &Vector3::new(0.0, 0.0, 1.0));
        assert!(!above.in_contact());
        assert_eq!(above.wrench, Force::ZERO);
    }

    /// A cylinder of radius 0.1 m about the x-axis, `n` flat sides, open ends, normals out.
    fn cylinder(n: u32) -> TriangleMesh {
        tube(n, 0.5)
    }

    /// [`cylinder`] from `x = −half_length` to `half_length`.
    fn tube(n: u32, half_length: f64) -> TriangleMesh {
        let ring = |x: f64| {
            (0..n).map(move |k| {
                let phi = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
                Point3::new(x, 0.1 * phi.cos(), 0.1 * phi.sin())
            })
        };
        let vertices = ring(-half_length).chain(ring(half_length)).collect();
        let triangles = (0..n)
            .flat_map(|k| {
                let (a0, a1) = (k, (k + 1) % n);
                let (b0, b1) = (a0 + n, a1 + n);
                [[a0, a1, b1], [a0, b1, b0]]
            })
            .collect();
        TriangleMesh { vertices, triangles }
    }

    /// A tip 5 mm deep in a 24-sided cylinder, carried around it: along the sides' own normals
    /// the force turns by the sides' 15° at each edge; shaded, by a twentieth of that, and it
    /// stays closer to the round cylinder's normal than the sides' normals do.
    #[test]
    fn shaded_normals_turn_the_force_smoothly_across_edges() {
        let sides = 24;
        let facet_angle = 2.0 * std::f64::consts::PI / f64::from(sides);
        let sweep = |normals: Normals| {
            let cfg = ContactConfig {
                normals,
                ..ContactConfig::default()
            };
            let mut c = Contact::new(&cylinder(sides), &cfg).unwrap();
            let steps = 1000;
            let (mut biggest_turn, mut worst_error) = (0.0_f64, 0.0_f64);
            let mut last: Option<Vector3<f64>> = None;
            for k in 0..=steps {
                let phi = 3.0 * facet_angle * f64::from(k) / f64::from(steps) + 0.01;
                let radial = Vector3::new(0.0, phi.cos(), phi.sin());
                let s = c.evaluate(&Point3::from(radial * 0.095), &Vector3::zeros());
                assert!(
                    s.in_contact() && s.depth > 0.003 && s.depth < 0.006,
                    "{}",
                    s.depth
                );
                let dir = s.wrench.lin.normalize();
                worst_error = worst_error.max(dir.angle(&radial));
                if let Some(l) = last {
                    biggest_turn = biggest_turn.max(dir.angle(&l));
                }
                last = Some(dir);
            }
            (biggest_turn, worst_error)
        };
        let (facet_turn, facet_error) = sweep(Normals::Facet);
        let (shaded_turn, shaded_error) = sweep(Normals::Shaded);
        assert!(facet_turn > 0.9 * facet_angle, "{facet_turn}");
        // Shaded, what is left is the closest point's own jump at the edge, from the foot on
        // one side to the foot on the other, `2 δ tan(θ/2)` of the 26 mm sides: 1.3 mm, 5 %
        // of the way across a side, a 0.8° turn.
        assert!(shaded_turn < facet_turn / 15.0, "{shaded_turn} vs {facet_turn}");
        assert!(facet_error > 0.45 * facet_angle, "{facet_error}");
        assert!(
            shaded_error < 0.25 * facet_angle,
            "{shaded_error} vs {facet_error}"
        );
    }

    /// A tip dragged 2 cm under rippled sediment (1 cm ripples, 5 cm long): the immersion is
    /// the sediment over it, and the force changes smoothly. The closest surface point would
    /// jump from one ripple's flank to the next's beneath each trough (the tip is deeper than
    /// the troughs' curvature radius), and the resistance with it.
    #[test]
    fn soil_immersion_is_the_sediment_above_the_tip() {
        let height = |x: f64| 0.01 * (2.0 * std::f64::consts::PI * x / 0.05).sin();
        let (nx, dx) = (401_u32, 0.001);
        let x = |i: u32| -0.2 + f64::from(i) * dx;
        let vertices = [-0.1, 0.1]
            .iter()
            .flat_map(|&y| (0..nx).map(move |i| Point3::new(x(i), y, height(x(i)))))
            .collect();
        let triangles = (0..nx - 1)
            .flat_map(|i| [[i, i + nx + 1, i + 1], [i, i + nx, i + nx + 1]])
            .collect();
        let mesh = TriangleMesh { vertices, triangles };
        let run = |material: Material, steps: u32| {
            let cfg = ContactConfig { material, ..soil() };
            let mut c = Contact::new(&mesh, &cfg).unwrap();
            let v = Vector3::new(0.02, 0.0, 0.0);
            let (mut worst_depth, mut biggest_change) = (0.0_f64, 0.0_f64);
            let mut last: Option<Vector3<f64>> = None;
            for k in 0..=steps {
                let tip = Point3::new(-0.1 + 0.2 * f64::from(k) / f64::from(steps), 0.0, 0.02);
                let s = c.evaluate(&tip, &v);
                worst_depth = worst_depth.max((s.depth - (0.02 - height(tip.x))).abs());
                if let Some(l) = last {
                    biggest_change = biggest_change.max((s.wrench.lin - l).norm());
                }
                last = Some(s.wrench.lin);
            }
            (worst_depth, biggest_change)
        };
        let (depth_error, change) = run(Material::Soil, 1000);
        // The ripple's chords sag by at most 2e-5 m under the sine.
        assert!(depth_error < 3e-5, "{depth_error}");
        // Continuous: the largest change between neighbouring points halves with the step.
        let (_, finer) = run(Material::Soil, 2000);
        assert!(finer < 0.6 * change, "{finer} vs {change} N");
        // Measured to the closest point (as against a rigid surface) the depth misses the
        // sediment above, and the force jumps: its largest change does not shrink.
        let (closest_depth_error, coarse) = run(Material::Rigid, 1000);
        let (_, fine) = run(Material::Rigid, 2000);
        assert!(closest_depth_error > 5e-3, "{closest_depth_error}");
        assert!(fine > 0.8 * coarse, "{fine} vs {coarse} N");
    }

    #[test]
    fn friction_opposes_sliding_and_is_bounded_by_mu_fn() {
        let mut c = Contact::new(&floor(), &ContactConfig::default()).unwrap();
        let v = Vector3::new(0.02, 0.0, 0.0);
        let s = c.evaluate(&Point3::new(0.0, 0.0, 0.006), &v);
        let ft = Vector3::new(s.wrench.lin.x, s.wrench.lin.y, 0.0);
        assert!(ft.x < 0.0 && ft.y.abs() < 1e-12);
        let mu_fn = 0.3 * 60.0;
        assert!(ft.norm() <= mu_fn && ft.norm() > 0.99 * mu_fn, "{}", ft.norm());
        // Regularised: no force at rest, continuous through zero speed.
        let rest = c.evaluate(&Point3::new(0.0, 0.0, 0.006), &Vector3::zeros());
        assert!(rest.wrench.lin.x.abs() < 1e-12);
    }

    /// Sediment with its own stiffness.
    fn soil() -> ContactConfig {
        ContactConfig {
            material: Material::Soil,
            stiffness_n_m: 2000.0,
            ..ContactConfig::default()
        }
    }

    #[test]
    fn soil_resistance_is_calibrated_to_the_seed() {
        let mut c = Contact::new(&floor(), &soil()).unwrap();
        let s = c.evaluate(&Point3::new(0.0, 0.0, 0.02), &Vector3::new(0.0, 0.02, 0.0));
        assert!((s.wrench.lin.y + 70.0).abs() < 0.1, "{}", s.wrench.lin.y);
        assert!((s.wrench.lin.z + 40.0).abs() < 1e-9);
        // Twice as deep, twice the resistance.
        let d = c.evaluate(&Point3::new(0.0, 0.0, 0.04), &Vector3::new(0.0, 0.02, 0.0));
        assert!((d.wrench.lin.y / s.wrench.lin.y - 2.0).abs() < 1e-9);
    }

    /// `−∂F/∂v` by central differences of [`Contact::evaluate`].
    fn slope_by_differences(c: &mut Contact, tip: &Point3<f64>, v: &Vector3<f64>) -> Matrix3<f64> {
        let h = 1e-8;
        Matrix3::from_fn(|i, j| {
            let mut dv = Vector3::zeros();
            dv[j] = h;
            let (plus, minus) = (c.evaluate(tip, &(v + dv)), c.evaluate(tip, &(v - dv)));
            -(plus.wrench.lin[i] - minus.wrench.lin[i]) / (2.0 * h)
        })
    }

    #[test]
    fn velocity_slope_is_the_derivative_across_the_sliding_and_the_secant_along_it() {
        // Soil and rigid contact, at rest, slow (inside the regularisation), fast, sliding with
        // a normal velocity, and leaving faster than the spring pushes (no force, no slope).
        let soil = soil();
        let velocities = [
            Vector3::zeros(),
            Vector3::new(0.0007, -0.0004, 0.0),
            Vector3::new(0.0015, 0.001, 0.003),
            Vector3::new(0.02, 0.005, -0.01),
            Vector3::new(-0.003, 0.0, 0.5),
            Vector3::new(-0.003, 0.0, -5.0),
        ];
        let n = Vector3::new(0.0, 0.0, -1.0);
        for cfg in [ContactConfig::default(), soil] {
            let mut c = Contact::new(&floor(), &cfg).unwrap();
            let tip = Point3::new(0.1, -0.2, 0.02);
            for v in &velocities {
                let s = c.evaluate(&tip, v);
                let d = s.damping;
                assert_eq!(d, d.transpose());
                let fd = slope_by_differences(&mut c, &tip, v);
                let tol = 1e-5 * (1.0 + fd.amax());
                let vt = Vector3::new(v.x, v.y, 0.0);
                // Along the normal (the force's response to the normal velocity and the
                // friction's to it left aside) and across the sliding direction: −∂F/∂v.
                let across = n.cross(&vt).try_normalize(0.0).unwrap_or(Vector3::x());
                let fd_normal = if s.wrench.lin.z < 0.0 {
                    cfg.damping_n_s_m
                } else {
                    0.0
                };
                assert!(
                    (n.dot(&(d * n)) - fd_normal).abs() < tol && (n.dot(&(fd * n)) - fd_normal).abs() < tol
                );
                assert!(
                    (d * across - fd * across).amax() < tol,
                    "{:?} at {v:?}: {d} vs {fd}",
                    cfg.material
                );
                // Along it: the secant, F_t = −D v_t.
                assert!((d * vt + Vector3::new(s.wrench.lin.x, s.wrench.lin.y, 0.0)).amax() < 1e-9);
            }
            // The soil's resistance at rest is a r·δ/ε damper in the tangent plane.
            if cfg.material == Material::Soil {
                let s = c.evaluate(&tip, &Vector3::zeros());
                let d = 3500.0 * 0.02 / 0.002;
                assert!((s.damping[(0, 0)] - d).abs() < 1e-6 * d && (s.damping[(2, 2)] - 50.0).abs() < 1e-9);
            }
        }
        let mut c = Contact::new(&floor(), &soil).unwrap();
        assert_eq!(
            c.evaluate(&Point3::new(0.0, 0.0, -0.01), &Vector3::zeros())
                .damping,
            Matrix3::zeros()
        );
    }

    fn with_footprint(radius: f64) -> ContactConfig {
        ContactConfig {
            footprint_radius_m: radius,
            ..ContactConfig::default()
        }
    }

    /// A footprint on a plane is the plane: the depth and the force exactly the point's, the
    /// plane's two triangles cut into 2 m / 1 cm pieces, anywhere on it.
    #[test]
    fn a_footprint_on_a_plane_is_the_plane() {
        let mut c = Contact::new(&floor(), &with_footprint(0.01)).unwrap();
        for (x, y) in [(0.1, 0.2), (-0.73, 0.41), (0.0, 0.0), (0.95, -0.95)] {
            let s = c.evaluate(&Point3::new(x, y, 0.006), &Vector3::zeros());
            assert!((s.depth - 0.006).abs() < 1e-12, "{x} {y}: {}", s.depth);
            assert!((s.normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
            assert!((s.wrench.lin - Vector3::new(0.0, 0.0, -60.0)).norm() < 1e-8);
        }
        assert!(
            !c.evaluate(&Point3::new(0.1, 0.2, -0.001), &Vector3::zeros())
                .in_contact()
        );
    }

    /// On a round surface the footprint's plane passes inside the true one by the patch's
    /// curvature: from a tip `δ` deep in a cylinder of radius `R` (at `ρ = R − δ` from its
    /// axis) the samples within `h` lie at most `θ` round, `1 − cos θ ≤ (h² − δ²)/(2Rρ)`; the
    /// mean normal is the radius's by symmetry and the centroid lies `R·cos θ` out along it
    /// on average, so the depth read is between `δ − (h² − δ²)/(2ρ)` and `δ` (0.34 mm here).
    #[test]
    fn a_footprint_on_a_cylinder_is_within_its_curvature() {
        let (h, depth, r) = (0.01, 0.006, 0.1);
        let mut c = Contact::new(&tube(400, 0.05), &with_footprint(h)).unwrap();
        let bound = (h * h - depth * depth) / (2.0 * (r - depth));
        for k in 0..50 {
            let phi = 0.1 * f64::from(k) + 0.003;
            let radial = Vector3::new(0.0, phi.cos(), phi.sin());
            let s = c.evaluate(
                &Point3::from(radial * (r - depth) + Vector3::x() * 0.01),
                &Vector3::zeros(),
            );
            assert!(
                s.depth >= depth - bound && s.depth <= depth + 1e-6,
                "at {phi}: {} against {depth} − [0, {bound}]",
                s.depth
            );
            assert!(
                s.normal.angle(&radial).to_degrees() < 0.1,
                "at {phi}: {}",
                s.normal
            );
        }
    }

    /// A plane scanned with noise (vertices 2 mm apart, 1 mm of noise across it, as the
    /// stereo's): a tip 6 mm deep carried 10 cm along it. The point contact's force turns
    /// tens of degrees between two positions 50 µm apart (its closest point passing from one
    /// bump to the next); under a 15 mm footprint it turns by hundredths of a degree, and its
    /// depth and normal are the true plane's within the noise averaged over the footprint.
    #[test]
    fn a_footprint_smooths_a_rough_surface() {
        use crate::synth::random::{gaussian, stream};
        let mut rng = stream(7, 0, 0);
        let rough = TriangleMesh::grid(101, 0.002, |_, _| 0.001 * gaussian(&mut rng));
        let sweep = |cfg: &ContactConfig| {
            let mut c = Contact::new(&rough, cfg).unwrap();
            let (mut turn, mut depth_error, mut tilt) = (0.0_f64, 0.0_f64, 0.0_f64);
            let mut last: Option<Vector3<f64>> = None;
            for k in 0..=2000 {
                let x = -0.05 + 5e-5 * f64::from(k);
                let s = c.evaluate(&Point3::new(x, 0.003, 0.006), &Vector3::zeros());
                if let Some(l) = last {
                    turn = turn.max(s.normal.angle(&l).to_degrees());
                }
                last = Some(s.normal);
                depth_error = depth_error.max((s.depth - 0.006).abs());
                tilt = tilt.max(s.normal.angle(&-Vector3::z()).to_degrees());
            }
            (turn, depth_error, tilt)
        };
        let (point_turn, point_depth_error, point_tilt) = sweep(&ContactConfig::default());
        let (turn, depth_error, tilt) = sweep(&with_footprint(0.015));
        // The samples listed around an earlier tip are those a fresh query finds.
        let mut carried = Contact::new(&rough, &with_footprint(0.015)).unwrap();
        for k in 0..=100 {
            let tip = Point3::new(-0.05 + 1e-3 * f64::from(k), 0.003, 0.006);
            let s = carried.evaluate(&tip, &Vector3::zeros());
            if k % 10 == 3 {
                let fresh = Contact::new(&rough, &with_footprint(0.015))
                    .unwrap()
                    .evaluate(&tip, &Vector3::zeros());
                assert!((s.depth - fresh.depth).abs() < 1e-15 && (s.normal - fresh.normal).norm() < 1e-14);
            }
        }
        eprintln!(
            "point: {point_turn}° {point_depth_error} m {point_tilt}°; footprint: {turn}° {depth_error} m {tilt}°"
        );
        assert!(
            point_turn > 10.0 && point_tilt > 20.0,
            "point: {point_turn}° {point_tilt}°"
        );
        // The footprint's mean normal is tilted by about σ/h (the noise over the patch's rim:
        // inside it the tilts cancel), its centroid's height off by a fraction of σ.
        assert!(turn < 0.2, "{turn}°");
        assert!(tilt.to_radians() < 2.0 * 0.001 / 0.015, "{tilt}°");
        assert!(depth_error < 0.5 * 0.001, "{depth_error} m");
    }

    /// A plate 4 mm thick, both faces meshed: a footprint wider than the plate reaches the far
    /// face too, whose samples face the other way and do not count (the near face's plane
    /// only); counted, their centroid halfway between the faces read every tip inside as
    /// outside, and the plate pushed nothing.
    #[test]
    fn a_footprint_in_a_thin_plate_sees_its_near_face() {
        let thickness = 0.004;
        // The top face's normal up (−z), the bottom's down.
        let top = TriangleMesh::grid(51, 0.002, |_, _| 0.0);
        let bottom = TriangleMesh::grid(51, 0.002, |_, _| thickness);
        let o = top.vertices.len() as u32;
        let plate = TriangleMesh {
            vertices: top.vertices.iter().chain(&bottom.vertices).copied().collect(),
            triangles: top
                .triangles
                .iter()
                .copied()
                .chain(bottom.triangles.iter().map(|&[a, b, c]| [a + o, c + o, b + o]))
                .collect(),
        };
        let mut c = Contact::new(&plate, &with_footprint(0.015)).unwrap();
        for depth in [0.0005, 0.001, 0.0019] {
            let s = c.evaluate(&Point3::new(0.001, 0.003, depth), &Vector3::zeros());
            assert!((s.depth - depth).abs() < 1e-12, "{depth}: {}", s.depth);
            assert!((s.normal + Vector3::z()).norm() < 1e-12, "{depth}: {}", s.normal);
            let from_below = c.evaluate(&Point3::new(0.001, 0.003, thickness - depth), &Vector3::zeros());
            assert!(
                (from_below.depth - depth).abs() < 1e-12,
                "{depth}: {}",
                from_below.depth
            );
            assert!((from_below.normal - Vector3::z()).norm() < 1e-12);
        }
    }

    #[test]
    fn a_footprint_is_refused_on_soil_and_where_it_needs_too_many_samples() {
        let e = Contact::new(
            &floor(),
            &ContactConfig {
                footprint_radius_m: 0.01,
                ..soil()
            },
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("footprint_radius_m") && e.contains("rigid"), "{e}");
        let e = Contact::new(&floor(), &with_footprint(0.0005))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("footprint_radius_m") && e.contains("samples"), "{e}");
        let e = Contact::new(&floor(), &with_footprint(-0.01))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("footprint_radius_m"), "{e}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let cfg = ContactConfig {
            stiffness_n_m: -1.0,
            ..ContactConfig::default()
        };
        let e = Contact::new(&floor(), &cfg).err().unwrap().to_string();
        assert!(e.contains("stiffness_n_m"), "{e}");
    }
}
