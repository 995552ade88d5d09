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

use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::mesh::TriangleMesh;
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
        }
    }
}

impl ContactConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("sim.contact.stiffness_n_m", self.stiffness_n_m)?;
        positive("sim.contact.velocity_epsilon_m_s", self.velocity_epsilon_m_s)?;
        non_negative("sim.contact.damping_n_s_m", self.damping_n_s_m)?;
        non_negative("sim.contact.friction", self.friction)?;
        non_negative("sim.contact.soil_resistance_n_m", self.soil_resistance_n_m)
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
    /// [`Error::Input`] for a bad configuration or an empty mesh.
    pub fn new(mesh: &TriangleMesh, cfg: &ContactConfig) -> Result<Self> {
        cfg.validate()?;
        Ok(Contact {
            surface: Surface::new(mesh)?,
            cfg: *cfg,
            near: Neighbourhood::new(NEIGHBOURHOOD_REACH_M),
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
    fn depth_and_normal(&mut self, tip: &Point3<f64>) -> (f64, Vector3<f64>) {
        let proj = self.surface.project_tracked(tip, &mut self.near);
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
    /// pushes as usual.
    #[test]
    fn beyond_an_open_meshs_rim_is_outside() {
        let mut c = Contact::new(&floor(), &ContactConfig::default()).unwrap();
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
        let ring = |x: f64| {
            (0..n).map(move |k| {
                let phi = 2.0 * std::f64::consts::PI * f64::from(k) / f64::from(n);
                Point3::new(x, 0.1 * phi.cos(), 0.1 * phi.sin())
            })
        };
        let vertices = ring(-0.5).chain(ring(0.5)).collect();
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
