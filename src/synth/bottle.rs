//! The reference model of the seed's object: a PET bottle of 0.35 m body diameter.
//!
//! The seed (Konoplin et al. 2024, Section 4, Figure 9a) names the object only as "a PET bottle with
//! a diameter of 0.35 m". Its length is not given; the default length, 0.72 m (length/diameter ≈ 2),
//! follows the proportions of large PET containers (a 19 L water-cooler bottle is 0.27 m × 0.49 m,
//! ratio 1.8, with a longer shoulder and neck here), which leaves a 0.43 m straight body for the
//! ring-shaped cleaning passes of Figure 11.
//!
//! The mesh is a surface of revolution of a profile `r(s)` (radius against axial position `s` from
//! the base): a shallow push-up base, a base fillet, the straight body, a cosine shoulder (tangent
//! to the body and to the neck), the neck with its support ring, and a cap with a rounded top edge.
//! The profile starts and ends on the axis, so the mesh is closed (one vertex per pole, rings of
//! `segments` vertices in between), and every triangle is wound counter-clockwise seen from
//! outside.
//!
//! Model frame (metres): `+x` is the longitudinal axis from the base towards the cap; the origin is
//! on the axis at the middle of the body (halfway between the base plane and the start of the
//! shoulder); `y` and `z` complete a right-handed frame. The shape is symmetric about `x`.

use crate::config::shown;
use crate::error::{Error, Result};
use crate::mesh::TriangleMesh;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Dimensions and tessellation of the bottle model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BottleConfig {
    /// Diameter of the straight body, metres (the seed's 0.35 m; at most [`MAX_SIZE_M`]).
    pub body_diameter_m: f64,
    /// Overall length from the base plane to the top of the cap, metres (at most
    /// [`MAX_SIZE_M`]).
    pub length_m: f64,
    /// Radius of the fillet between the base and the body, metres.
    pub base_fillet_m: f64,
    /// Depth of the base's concave push-up, metres.
    pub push_up_m: f64,
    /// Axial length of the shoulder (body to neck), metres.
    pub shoulder_length_m: f64,
    /// Diameter of the neck, metres.
    pub neck_diameter_m: f64,
    /// Axial length of the neck between shoulder and cap, metres.
    pub neck_length_m: f64,
    /// Diameter of the cap, metres (at least the neck's).
    pub cap_diameter_m: f64,
    /// Axial length of the cap, metres.
    pub cap_length_m: f64,
    /// Number of vertices on each ring (angular resolution).
    pub segments: u32,
    /// Largest spacing of the profile samples, metres (axial/radial resolution).
    pub profile_step_m: f64,
}

impl Default for BottleConfig {
    fn default() -> Self {
        BottleConfig {
            body_diameter_m: 0.35,
            length_m: 0.72,
            base_fillet_m: 0.03,
            push_up_m: 0.012,
            shoulder_length_m: 0.17,
            neck_diameter_m: 0.09,
            neck_length_m: 0.045,
            cap_diameter_m: 0.1,
            cap_length_m: 0.05,
            segments: 128,
            profile_step_m: 0.008,
        }
    }
}

/// Largest overall length and body diameter, metres: a reference file may be up to 20 m
/// across too (see [`super::scene::reference_mesh`]).
pub const MAX_SIZE_M: f64 = 20.0;

/// Most mesh vertices (profile samples × `segments`).
const MAX_VERTICES: f64 = 2.0e7;

/// Height of the neck's support ring above the neck surface, metres.
const SUPPORT_RING_M: f64 = 0.01;
/// Axial thickness of the support ring, metres.
const SUPPORT_RING_THICKNESS_M: f64 = 0.005;
/// Radius of the rounded top edge of the cap, metres.
const CAP_FILLET_M: f64 = 0.006;

impl BottleConfig {
    /// Axial position (from the base plane) where the straight body ends and the shoulder starts.
    pub fn body_end_m(&self) -> f64 {
        self.length_m - self.cap_length_m - self.neck_length_m - self.shoulder_length_m
    }

    /// Axial position of the model origin, measured from the base plane (the middle of the body).
    pub fn origin_from_base_m(&self) -> f64 {
        0.5 * self.body_end_m()
    }

    /// Checks the dimensions; `prefix` names the configuration section in errors.
    ///
    /// # Errors
    /// [`Error::Input`] naming the key when a dimension is not positive or the parts do not fit.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let key = |k: &str| format!("{prefix}.{k}");
        let positive = [
            ("body_diameter_m", self.body_diameter_m),
            ("length_m", self.length_m),
            ("base_fillet_m", self.base_fillet_m),
            ("shoulder_length_m", self.shoulder_length_m),
            ("neck_diameter_m", self.neck_diameter_m),
            ("neck_length_m", self.neck_length_m),
            ("cap_diameter_m", self.cap_diameter_m),
            ("cap_length_m", self.cap_length_m),
            ("profile_step_m", self.profile_step_m),
        ];
        for (k, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::input(
                    key(k),
                    format!("must be a positive number of metres (got {})", shown(v)),
                ));
            }
        }
        for (k, v) in [
            ("length_m", self.length_m),
            ("body_diameter_m", self.body_diameter_m),
        ] {
            if v > MAX_SIZE_M {
                return Err(Error::input(
                    key(k),
                    format!("must be at most {MAX_SIZE_M} m (got {})", shown(v)),
                ));
            }
        }
        if !(self.push_up_m.is_finite() && self.push_up_m >= 0.0) {
            return Err(Error::input(
                key("push_up_m"),
                format!("must be zero or positive (got {})", shown(self.push_up_m)),
            ));
        }
        let r = 0.5 * self.body_diameter_m;
        if self.neck_diameter_m + 2.0 * SUPPORT_RING_M >= self.body_diameter_m {
            return Err(Error::input(
                key("neck_diameter_m"),
                "neck (with its 10 mm support ring) must be narrower than the body",
            ));
        }
        if self.cap_diameter_m < self.neck_diameter_m || self.cap_diameter_m >= self.body_diameter_m {
            return Err(Error::input(
                key("cap_diameter_m"),
                "must be at least the neck's diameter and less than the body's",
            ));
        }
        if self.base_fillet_m >= 0.5 * r {
            return Err(Error::input(
                key("base_fillet_m"),
                "must be less than a quarter of the body diameter",
            ));
        }
        if self.body_end_m() <= self.base_fillet_m {
            return Err(Error::input(
                key("length_m"),
                "too short for the base fillet, shoulder, neck and cap",
            ));
        }
        if self.push_up_m >= self.body_end_m() {
            return Err(Error::input(
                key("push_up_m"),
                format!(
                    "must be less than the straight body's end, {:.3} m from the base (got {})",
                    self.body_end_m(),
                    shown(self.push_up_m)
                ),
            ));
        }
        if self.neck_length_m <= SUPPORT_RING_THICKNESS_M * 3.0 {
            return Err(Error::input(
                key("neck_length_m"),
                "must exceed 15 mm (room for the support ring)",
            ));
        }
        if self.cap_length_m <= 2.0 * CAP_FILLET_M || self.cap_diameter_m <= 4.0 * CAP_FILLET_M {
            return Err(Error::input(
                key("cap_length_m"),
                "cap too small for its 6 mm edge fillet",
            ));
        }
        if !(3..=100_000).contains(&self.segments) {
            return Err(Error::input(key("segments"), "must be between 3 and 100000"));
        }
        if self.profile_samples_bound() * self.segments as f64 > MAX_VERTICES {
            return Err(Error::input(
                key("profile_step_m"),
                "too fine for the bottle's size and segments: the mesh would exceed 20 million vertices",
            ));
        }
        Ok(())
    }

    /// An upper bound of the number of samples of [`Self::profile`] for dimensions that passed
    /// the other checks of [`Self::validate`]: its path (the base across the body's radius, the
    /// body, the shoulder, the neck with its ring and the cap across their radii) is shorter than
    /// `1.2 length + 2.6 diameter + 35 mm`, so than `2 length + 4 diameter` (the neck and cap
    /// need 27 mm of the length, and the cap 24 mm of the diameter), sampled every
    /// `profile_step_m`, plus at most two samples for each of its 13 pieces and the first.
    fn profile_samples_bound(&self) -> f64 {
        (2.0 * self.length_m + 4.0 * self.body_diameter_m) / self.profile_step_m + 32.0
    }

    /// The profile `(s, r)` from the base pole to the cap pole, `s` measured from the base plane.
    /// Consecutive samples are distinct; the first and last have `r = 0`.
    pub fn profile(&self) -> Vec<(f64, f64)> {
        let step = self.profile_step_m;
        let r_body = 0.5 * self.body_diameter_m;
        let r_neck = 0.5 * self.neck_diameter_m;
        let r_cap = 0.5 * self.cap_diameter_m;
        let f = self.base_fillet_m;
        let s_body = self.body_end_m();
        let s_neck = s_body + self.shoulder_length_m;
        let s_cap = s_neck + self.neck_length_m;
        let len = self.length_m;
        let mut p = Profile {
            pts: vec![(self.push_up_m, 0.0)],
            step,
        };
        // Push-up base: s(r) = push_up (1 - (r/r0)^2) from the pole to the standing ring.
        let r0 = r_body - f;
        let pu = self.push_up_m;
        p.curve(r0 * 1.05, |t| (pu * (1.0 - t * t), r0 * t));
        // Base fillet: quarter circle centred at (f, r0).
        p.curve(f * PI / 2.0, |t| {
            let a = -PI / 2.0 + t * PI / 2.0;
            (f + f * a.sin(), r0 + f * a.cos())
        });
        p.line((s_body, r_body));
        // Shoulder: cosine blend, tangent to body and neck.
        let ls = self.shoulder_length_m;
        p.curve(ls.hypot(r_body - r_neck) * 1.2, |t| {
            (
                s_body + ls * t,
                r_neck + (r_body - r_neck) * 0.5 * (1.0 + (PI * t).cos()),
            )
        });
        // Neck with the support ring in its middle.
        let ring0 = s_neck + 0.5 * (self.neck_length_m - SUPPORT_RING_THICKNESS_M);
        let ring1 = ring0 + SUPPORT_RING_THICKNESS_M;
        p.line((ring0, r_neck));
        p.line((ring0, r_neck + SUPPORT_RING_M));
        p.line((ring1, r_neck + SUPPORT_RING_M));
        p.line((ring1, r_neck));
        p.line((s_cap, r_neck));
        // Cap: annular step out, side wall, rounded top edge, flat top to the pole.
        p.line((s_cap, r_cap));
        p.line((len - CAP_FILLET_M, r_cap));
        p.curve(CAP_FILLET_M * PI / 2.0, |t| {
            let a = t * PI / 2.0;
            (
                len - CAP_FILLET_M + CAP_FILLET_M * a.sin(),
                r_cap - CAP_FILLET_M + CAP_FILLET_M * a.cos(),
            )
        });
        p.line((len, 0.0));
        p.pts
    }
}

/// A profile polyline under construction, sampled no coarser than `step`.
struct Profile {
    pts: Vec<(f64, f64)>,
    step: f64,
}

impl Profile {
    fn push(&mut self, q: (f64, f64)) {
        let last = *self.pts.last().unwrap_or(&(f64::NAN, f64::NAN));
        if (q.0 - last.0).hypot(q.1 - last.1) > 1e-9 {
            self.pts.push(q);
        }
    }
    /// A straight segment from the last point to `q`.
    fn line(&mut self, q: (f64, f64)) {
        let Some(&a) = self.pts.last() else {
            self.pts.push(q);
            return;
        };
        let n = ((q.0 - a.0).hypot(q.1 - a.1) / self.step).ceil().max(1.0) as usize;
        for i in 1..=n {
            let t = i as f64 / n as f64;
            self.push((a.0 + t * (q.0 - a.0), a.1 + t * (q.1 - a.1)));
        }
    }
    /// A curve `c(t)`, `t ∈ (0, 1]`, of about `length` metres, from the last point.
    fn curve(&mut self, length: f64, c: impl Fn(f64) -> (f64, f64)) {
        let n = (length / self.step).ceil().max(2.0) as usize;
        for i in 1..=n {
            self.push(c(i as f64 / n as f64));
        }
    }
}

/// The bottle as a closed, outward-wound triangle mesh in the model frame (see the module docs).
///
/// # Errors
/// [`Error::Input`] when the configuration is invalid (see [`BottleConfig::validate`]).
pub fn bottle_mesh(cfg: &BottleConfig) -> Result<TriangleMesh> {
    cfg.validate("bottle")?;
    Ok(revolve(
        &cfg.profile(),
        cfg.segments as usize,
        cfg.origin_from_base_m(),
    ))
}

/// Revolves a profile `(s, r)` (first and last samples on the axis) about `+x`; `x = s - origin`.
fn revolve(profile: &[(f64, f64)], segments: usize, origin: f64) -> TriangleMesh {
    let rings = profile.len() - 2;
    let mut vertices = Vec::with_capacity(rings * segments + 2);
    vertices.push(Point3::new(profile[0].0 - origin, 0.0, 0.0));
    for &(s, r) in &profile[1..profile.len() - 1] {
        for j in 0..segments {
            let th = 2.0 * PI * j as f64 / segments as f64;
            vertices.push(Point3::new(s - origin, r * th.cos(), r * th.sin()));
        }
    }
    let last = profile[profile.len() - 1];
    vertices.push(Point3::new(last.0 - origin, 0.0, 0.0));
    let top = (vertices.len() - 1) as u32;
    let at = |k: usize, j: usize| (1 + k * segments + j % segments) as u32;
    let mut triangles = Vec::with_capacity(2 * rings * segments);
    // Winding: (ring k, j) → (ring k, j+1) → (ring k+1, j) is ∂θ × ∂s, the outward normal.
    for j in 0..segments {
        triangles.push([0, at(0, j + 1), at(0, j)]);
    }
    for k in 0..rings - 1 {
        for j in 0..segments {
            triangles.push([at(k, j), at(k, j + 1), at(k + 1, j)]);
            triangles.push([at(k, j + 1), at(k + 1, j + 1), at(k + 1, j)]);
        }
    }
    for j in 0..segments {
        triangles.push([at(rings - 1, j), at(rings - 1, j + 1), top]);
    }
    TriangleMesh { vertices, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Volume of the solid of revolution of the profile (Pappus on each conical frustum).
    fn profile_volume(p: &[(f64, f64)]) -> f64 {
        p.windows(2)
            .map(|w| {
                let ((s0, r0), (s1, r1)) = (w[0], w[1]);
                PI * (s1 - s0) * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0
            })
            .sum()
    }

    #[test]
    fn closed_and_consistently_wound() {
        let m = bottle_mesh(&BottleConfig::default()).unwrap();
        // Every directed edge appears once, and its reverse once: closed and consistently oriented.
        let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}->{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
        for t in 0..m.triangles.len() {
            assert!(m.triangle_normal(t).is_some(), "degenerate triangle {t}");
        }
        // Positive signed volume = outward normals; it matches the solid of revolution of the
        // polygonal profile up to the chord error of the rings.
        let cfg = BottleConfig::default();
        let v = m.signed_volume();
        let n = cfg.segments as f64;
        let ring_factor = n * (2.0 * PI / n).sin() / (2.0 * PI); // polygon area / circle area
        let expected = profile_volume(&cfg.profile()) * ring_factor;
        assert!(
            (v - expected).abs() < 1e-9 * expected.max(1.0),
            "{v} vs {expected}"
        );
        // Body cylinder alone: π 0.175² 0.455 = 43.8 L; shoulder, neck and cap add about 8 L.
        assert!((0.048..0.056).contains(&v), "volume {v} m³");
    }

    #[test]
    fn dimensions_and_frame() {
        let cfg = BottleConfig::default();
        let m = bottle_mesh(&cfg).unwrap();
        let (lo, hi) = crate::cloud::bbox(&m.vertices).unwrap();
        assert!((hi.x - lo.x - cfg.length_m).abs() < 1e-12);
        assert!((hi.y - 0.175).abs() < 1e-12 && (lo.y + 0.175).abs() < 1e-12);
        assert!((hi.z - 0.175).abs() < 1e-3 && (lo.z + 0.175).abs() < 1e-3);
        // Origin halfway between the base plane and the shoulder's start.
        assert!((lo.x + cfg.origin_from_base_m()).abs() < 1e-12);
        assert!((hi.x - (cfg.length_m - cfg.origin_from_base_m())).abs() < 1e-12);
        // A body vertex at x = 0 sits on the 0.175 m cylinder.
        let on_body = m
            .vertices
            .iter()
            .filter(|v| v.x.abs() < 0.1)
            .all(|v| (v.y.hypot(v.z) - 0.175).abs() < 1e-12);
        assert!(on_body);
    }

    #[test]
    fn rejects_impossible_dimensions() {
        let cfg = BottleConfig {
            length_m: 0.2,
            ..Default::default()
        };
        let e = bottle_mesh(&cfg).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("bottle.length_m"), "{e}");
        let cfg = BottleConfig {
            cap_diameter_m: 0.5,
            ..Default::default()
        };
        assert!(
            bottle_mesh(&cfg)
                .unwrap_err()
                .to_string()
                .contains("cap_diameter_m")
        );
    }

    #[test]
    fn a_huge_bottle_is_rejected_before_its_mesh_is_built() {
        // 1e6 m allocated 432 GB; 1e300 m never finished sampling its profile.
        for d in [1e6, 1e300, 20.5] {
            let cfg = BottleConfig {
                body_diameter_m: d,
                ..Default::default()
            };
            crate::perception::assert_bad_input(bottle_mesh(&cfg), "bottle.body_diameter_m");
        }
        let cfg = BottleConfig {
            length_m: 1e300,
            ..Default::default()
        };
        crate::perception::assert_bad_input(bottle_mesh(&cfg), "bottle.length_m");
        let cfg = BottleConfig {
            push_up_m: 1e300,
            ..Default::default()
        };
        crate::perception::assert_bad_input(bottle_mesh(&cfg), "bottle.push_up_m");
        // Wide and fine: the vertex estimate counts the diameter too.
        let cfg = BottleConfig {
            body_diameter_m: 20.0,
            length_m: 20.0,
            profile_step_m: 0.001,
            segments: 1000,
            ..Default::default()
        };
        crate::perception::assert_bad_input(bottle_mesh(&cfg), "bottle.profile_step_m");
    }

    #[test]
    fn the_sample_bound_holds() {
        let default = BottleConfig::default();
        let tiny = BottleConfig {
            body_diameter_m: 0.045,
            length_m: 0.09,
            base_fillet_m: 0.005,
            push_up_m: 0.0,
            shoulder_length_m: 0.005,
            neck_diameter_m: 0.024,
            neck_length_m: 0.016,
            cap_diameter_m: 0.0241,
            cap_length_m: 0.0121,
            profile_step_m: 1e-4,
            segments: 3,
        };
        for cfg in [
            default.clone(),
            BottleConfig {
                body_diameter_m: 20.0,
                length_m: 20.0,
                ..default.clone()
            },
            BottleConfig {
                body_diameter_m: 2.0,
                length_m: 0.6,
                shoulder_length_m: 0.1,
                profile_step_m: 0.0005,
                ..default.clone()
            },
            BottleConfig {
                profile_step_m: 1.0,
                ..default.clone()
            },
            tiny,
        ] {
            cfg.validate("bottle").unwrap();
            let n = cfg.profile().len() as f64;
            assert!(
                n <= cfg.profile_samples_bound(),
                "{n} > {} for {cfg:?}",
                cfg.profile_samples_bound()
            );
        }
    }
}
