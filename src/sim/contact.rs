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
//! The penetration is measured against the closest point of the true surface mesh (a parry3d
//! BVH query through [`crate::surface::Surface`]), with the outward normal of the triangle it
//! lies on; the wrench acts at the tool tip (no moment about it).

use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::mesh::TriangleMesh;
use crate::spatial_algebra::Force;
use crate::surface::Surface;
use nalgebra::{Point3, Vector3};
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
    /// The closest triangle of the last query, which starts the next one's search.
    last_triangle: Option<usize>,
}

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
            last_triangle: None,
        })
    }

    /// The contact force on a tool tip at `tip` moving with velocity `v` (world). The search
    /// for the closest point starts from the last query's closest triangle.
    pub fn evaluate(&mut self, tip: &Point3<f64>, v: &Vector3<f64>) -> ContactState {
        let proj = match self.last_triangle {
            Some(t) => self.surface.project_near(tip, t),
            None => self.surface.project(tip),
        };
        self.last_triangle = Some(proj.triangle);
        let n = proj.normal;
        let depth = (proj.point - tip).dot(&n);
        if depth <= 0.0 {
            return ContactState {
                wrench: Force::ZERO,
                depth,
                normal: n,
            };
        }
        let c = &self.cfg;
        // δ̇ = −v·n: the tip moving against the normal goes deeper.
        let fn_mag = (c.stiffness_n_m * depth - c.damping_n_s_m * v.dot(&n)).max(0.0);
        let vt = v - n * v.dot(&n);
        let speed = vt.norm();
        let tangential = match c.material {
            Material::Rigid => {
                -vt * (c.friction * fn_mag / (speed * speed + c.velocity_epsilon_m_s.powi(2)).sqrt())
            }
            Material::Soil if speed > 0.0 => {
                -vt / speed * (c.soil_resistance_n_m * depth * (speed / c.velocity_epsilon_m_s).tanh())
            }
            Material::Soil => Vector3::zeros(),
        };
        ContactState {
            wrench: Force::new(n * fn_mag + tangential, Vector3::zeros()),
            depth,
            normal: n,
        }
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

    #[test]
    fn soil_resistance_is_calibrated_to_the_seed() {
        let cfg = ContactConfig {
            material: Material::Soil,
            stiffness_n_m: 2000.0,
            ..ContactConfig::default()
        };
        let mut c = Contact::new(&floor(), &cfg).unwrap();
        let s = c.evaluate(&Point3::new(0.0, 0.0, 0.02), &Vector3::new(0.0, 0.02, 0.0));
        assert!((s.wrench.lin.y + 70.0).abs() < 0.1, "{}", s.wrench.lin.y);
        assert!((s.wrench.lin.z + 40.0).abs() < 1e-9);
        // Twice as deep, twice the resistance.
        let d = c.evaluate(&Point3::new(0.0, 0.0, 0.04), &Vector3::new(0.0, 0.02, 0.0));
        assert!((d.wrench.lin.y / s.wrench.lin.y - 2.0).abs() < 1e-9);
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
