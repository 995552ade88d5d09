//! Composition of the scene: camera pose, seabed, the object lying partly buried in silt with its
//! fouling, stones; everything built in the world frame `W` and handed to the renderer in the
//! scan frame `S`.
//!
//! Frames. `W` is NED (x north, y east, z down) with its origin on the mean seabed plane
//! vertically below the camera, so the camera sits at `(0, 0, −altitude)`. The camera looks
//! north and down: its optical axis `z_S = (sin τ, 0, cos τ)` (tilt `τ` from the vertical),
//! `x_S` = east (image right), `y_S = z_S × x_S` (image down; south when looking straight down).
//! The target (the centre of the object model's bounding box, or the seabed point for the
//! sediment scene) lies on the optical axis at `camera.distance_m`.
//!
//! Placement. The object's model `+x` axis lies in the mean seabed plane at heading
//! `object.yaw_deg`, its model `+z` along the plane's up normal (then rolled by
//! `object.roll_deg` about `+x`), and its lowest point `object.burial_m` below the plane. The
//! silt drifted against it raises the seabed by `silt_height·exp(−(g/silt_width)²)`, `g` the
//! distance in the plane to the object's footprint (its vertices at or below the plane).

use super::camera::Pinhole;
use super::config::{SceneKind, SynthConfig, streams};
use super::fouling::{self, FoulingFeature};
use super::random::{WaveField, stream, uniform};
use super::seabed::Seabed;
use super::{bottle, stones};
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use crate::surface::Surface;
use nalgebra::{Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;

/// What a triangle of the scene (and so a scan point) belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceKind {
    /// The seabed height field.
    Seabed,
    /// The object (its true, fouled surface).
    Object,
    /// A stone.
    Stone,
}

/// The scene as the renderer sees it, in the scan frame `S`.
#[derive(Debug, Clone)]
pub struct SceneGeometry {
    /// All true surfaces: seabed, object, stones.
    pub mesh: TriangleMesh,
    /// What each triangle belongs to.
    pub kinds: Vec<SurfaceKind>,
    /// Diffuse reflectance of each vertex, red/green/blue in `[0, 1]`.
    pub albedo: Vec<[f64; 3]>,
    /// Fouling displacement of each vertex along its normal, metres (0 off the object).
    pub fouling: Vec<f64>,
}

impl SceneGeometry {
    /// Appends `mesh` (already in the scene's frame) as surfaces of `kind`.
    pub fn push(
        &mut self,
        mesh: &TriangleMesh,
        kind: SurfaceKind,
        albedo: &[[f64; 3]],
        fouling: Option<&[f64]>,
    ) {
        let base = self.mesh.vertices.len() as u32;
        self.mesh.vertices.extend_from_slice(&mesh.vertices);
        self.mesh
            .triangles
            .extend(mesh.triangles.iter().map(|t| t.map(|i| i + base)));
        self.kinds.extend(std::iter::repeat_n(kind, mesh.triangles.len()));
        self.albedo.extend_from_slice(albedo);
        match fouling {
            Some(f) => self.fouling.extend_from_slice(f),
            None => self.fouling.extend(std::iter::repeat_n(0.0, mesh.vertices.len())),
        }
    }
}

/// The object as placed.
#[derive(Debug, Clone)]
pub struct PlacedObject {
    /// The reference model, model frame.
    pub reference: TriangleMesh,
    /// Model frame → world.
    pub t_world_reference: Pose,
    /// Fouling features, model frame.
    pub features: Vec<FoulingFeature>,
}

/// A stone as placed.
#[derive(Debug, Clone, Copy)]
pub struct PlacedStone {
    /// Centre of the stone's (roughened) ellipsoid, world frame, metres.
    pub centre: Point3<f64>,
    /// Longest diameter, metres.
    pub size_m: f64,
}

/// The composed scene with the poses that define it.
#[derive(Debug, Clone)]
pub struct Composed {
    /// Surfaces in the scan frame.
    pub geometry: SceneGeometry,
    /// Scan (left camera) → world.
    pub t_world_scan: Pose,
    /// Mean seabed plane's unit up normal, world frame.
    pub up_world: Vector3<f64>,
    /// Point the camera looks at, world frame.
    pub target_world: Point3<f64>,
    /// The object (bottle scene).
    pub object: Option<PlacedObject>,
    /// The stones.
    pub stones: Vec<PlacedStone>,
    /// Seabed extent in `W`: `[x_min, y_min]`, `[x_max, y_max]`, metres.
    pub seabed_extent: ([f64; 2], [f64; 2]),
}

/// The silt against the object ends this many `silt_width_m` from its footprint.
const SILT_CUTOFF: f64 = 4.0;

// Diffuse reflectances (linear RGB).
const SAND: [f64; 3] = [0.74, 0.66, 0.48];
const SILT: [f64; 3] = [0.55, 0.52, 0.43];
const STONE: [f64; 3] = [0.42, 0.41, 0.38];
const PET: [f64; 3] = [0.30, 0.52, 0.40];
const GROWTH: [f64; 3] = [0.40, 0.36, 0.18];

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * t)
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|v| (v * s).clamp(0.0, 1.0))
}

/// The camera's pose in `W` and the target point, given the target's height above the mean
/// plane (`up` the plane's unit up normal).
fn camera_pose(cfg: &SynthConfig, up: &Vector3<f64>, target_height: f64) -> Result<(Pose, Point3<f64>)> {
    let tau = cfg.camera.tilt_deg.to_radians();
    let z_s = Vector3::new(tau.sin(), 0.0, tau.cos());
    let x_s = Vector3::y();
    let y_s = z_s.cross(&x_s);
    let down_view = -up.dot(&z_s);
    if down_view < 0.2 {
        return Err(Error::input(
            "config camera.tilt_deg",
            "with this seabed slope the camera would not look down on the seabed",
        ));
    }
    let d = cfg.camera.distance_m;
    // The camera is at (0, 0, zc) and up·(camera + d z_s) = target_height (plane through 0).
    let zc = (target_height - d * up.dot(&z_s)) / up.z;
    let camera = Point3::new(0.0, 0.0, zc);
    let rot = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x_s, y_s, z_s]));
    let pose = Pose::from_parts(
        Translation3::from(camera.coords),
        UnitQuaternion::from_rotation_matrix(&rot),
    );
    Ok((pose, camera + z_s * d))
}

/// The object's orientation in `W`: model `+x` along the heading projected into the plane, `+z`
/// along `up`, then the roll about `+x`.
fn object_rotation(cfg: &SynthConfig, up: &Vector3<f64>) -> UnitQuaternion<f64> {
    let yaw = cfg.object.yaw_deg.unwrap_or(0.0).to_radians();
    let heading = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
    let x = (heading - up * heading.dot(up)).normalize();
    let y = up.cross(&x);
    let base = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, *up]));
    let roll = Rotation3::from_axis_angle(&Vector3::x_axis(), cfg.object.roll_deg.to_radians());
    UnitQuaternion::from_rotation_matrix(&(base * roll))
}

/// The part of the seabed the camera can see (mean plane lowered by `margin`, depths up to
/// `max_depth_m`), as an `xy` box in `W` grown by `grow`.
fn footprint(
    cfg: &SynthConfig,
    t_world_scan: &Pose,
    up: &Vector3<f64>,
    margin: f64,
    grow: f64,
) -> ([f64; 2], [f64; 2]) {
    let c = &cfg.camera;
    let (w, h) = (c.width_px as f64, c.height_px as f64);
    let origin = t_world_scan.translation.vector;
    let (mut lo, mut hi) = ([origin.x, origin.y], [origin.x, origin.y]);
    let n = 48;
    for i in 0..=n {
        for j in 0..=n {
            let ray = Vector3::new(
                (w * i as f64 / n as f64 - 0.5 * w) / c.focal_px,
                (h * j as f64 / n as f64 - 0.5 * h) / c.focal_px,
                1.0,
            );
            let dir = t_world_scan.rotation * ray;
            let rate = up.dot(&dir);
            let depth = if rate < 0.0 {
                (-margin - up.dot(&origin)) / rate
            } else {
                f64::INFINITY
            };
            let p = origin + dir * depth.clamp(0.0, c.max_depth_m);
            lo = [lo[0].min(p.x), lo[1].min(p.y)];
            hi = [hi[0].max(p.x), hi[1].max(p.y)];
        }
    }
    ([lo[0] - grow, lo[1] - grow], [hi[0] + grow, hi[1] + grow])
}

/// The triangles of `mesh` (world frame) that may matter to the stereo pair: those with a vertex
/// in front of the camera and within the left image grown by 10 % on each side and, to the right,
/// by the vertex's disparity (occluders of the right camera's view). Unused vertices are dropped.
fn crop_to_view(mesh: &TriangleMesh, cfg: &SynthConfig, t_scan_world: &Pose) -> TriangleMesh {
    let c = &cfg.camera;
    let (w, h) = (c.width_px as f64, c.height_px as f64);
    let near: Vec<bool> = mesh
        .vertices
        .iter()
        .map(|p| {
            let q = t_scan_world * p;
            if q.z <= 0.0 {
                return false;
            }
            let u = c.focal_px * q.x / q.z + 0.5 * w;
            let v = c.focal_px * q.y / q.z + 0.5 * h;
            let disparity = c.focal_px * c.baseline_m / q.z;
            u >= -0.1 * w && u <= 1.1 * w + disparity && v >= -0.1 * h && v <= 1.1 * h
        })
        .collect();
    let mut index = vec![u32::MAX; mesh.vertices.len()];
    let mut out = TriangleMesh::default();
    for t in &mesh.triangles {
        if t.iter().any(|&i| near[i as usize]) {
            let t = t.map(|i| {
                if index[i as usize] == u32::MAX {
                    index[i as usize] = out.vertices.len() as u32;
                    out.vertices.push(mesh.vertices[i as usize]);
                }
                index[i as usize]
            });
            out.triangles.push(t);
        }
    }
    out
}

/// The reference model: the configured PLY file, or the generated bottle.
///
/// # Errors
/// [`Error::Input`] if the file cannot be read, has no triangles or no area, is not sized like
/// an object ([`crate::cloud::object_size`]), or would be buried past 90 % of its height.
pub fn reference_mesh(cfg: &SynthConfig) -> Result<TriangleMesh> {
    let o = &cfg.object;
    let Some(path) = &o.reference else {
        return bottle::bottle_mesh(&o.bottle);
    };
    let what = format!("config object.reference {}", path.display());
    let mesh = crate::io::ply::read_mesh(path).map_err(|e| Error::input("config object.reference", e))?;
    if mesh.triangles.is_empty() {
        return Err(Error::input(what, "the mesh has no triangles"));
    }
    if mesh.area() <= 0.0 {
        return Err(Error::input(what, "the mesh has no surface area"));
    }
    let (lo, hi) = crate::cloud::object_size(&what, &mesh.vertices)?;
    if o.burial_m >= 0.9 * (hi.z - lo.z) {
        return Err(Error::input(
            "config object.burial_m",
            format!(
                "must be less than 90 % of the model's height along z ({:.3} m)",
                hi.z - lo.z
            ),
        ));
    }
    Ok(mesh)
}

/// Builds the scene of a resolved, validated configuration.
///
/// # Errors
/// [`Error::Input`] when the configuration cannot make a scene (the camera would not look down
/// on the seabed, or the seabed grid would be too large).
pub fn compose(cfg: &SynthConfig) -> Result<Composed> {
    let seabed = Seabed::new(&cfg.seabed, &mut stream(cfg.seed, streams::SEABED, 0));
    let up = seabed.up();
    let ocfg = &cfg.object;

    // The object in its model frame and its orientation; the target height follows from burial.
    // The camera aims at the centre of the model's bounding box (so the whole object fits the
    // view at any heading), `centre` in the model frame.
    let (object_rot, reference, centre, target_height) = match cfg.scene {
        SceneKind::Sediment => (UnitQuaternion::identity(), None, Vector3::zeros(), 0.0),
        SceneKind::Bottle => {
            let mesh = reference_mesh(cfg)?;
            let rot = object_rotation(cfg, &up);
            let (lo, hi) = crate::cloud::bbox(&mesh.vertices).unwrap_or_default();
            let centre = 0.5 * (lo.coords + hi.coords);
            let lowest = mesh
                .vertices
                .iter()
                .map(|v| (rot * (v.coords - centre)).dot(&up))
                .fold(f64::MAX, f64::min);
            (rot, Some(mesh), centre, -lowest - ocfg.burial_m)
        }
    };
    let (t_world_scan, target) = camera_pose(cfg, &up, target_height)?;
    let t_world_reference = Pose::from_parts(
        Translation3::from(target.coords - object_rot * centre),
        object_rot,
    );

    // Fouling, in the model frame.
    let placed = reference.map(|reference| {
        let up_model = object_rot.inverse() * up;
        let height = |p: &Point3<f64>| up.dot(&(t_world_reference * p).coords);
        let mut rng = stream(cfg.seed, streams::FOULING, 0);
        let min_height = ocfg.silt_height_m + cfg.seabed.ripple_amplitude_m * 1.25 + 0.01;
        let features = fouling::place(&reference, &up_model, height, min_height, &cfg.fouling, &mut rng);
        PlacedObject {
            reference,
            t_world_reference,
            features,
        }
    });
    let deformed = placed
        .as_ref()
        .map(|o| fouling::deform(&o.reference, &o.features));
    let object_world = deformed.as_ref().map(|(m, _)| m.transformed(&t_world_reference));
    let camera = Point3::from(t_world_scan.translation.vector);
    if let Some(obj) = &object_world
        && Surface::new(obj)?.contains(&camera)
    {
        return Err(Error::input(
            "config camera.distance_m",
            "the camera would be inside the object; increase the distance or reduce the tilt",
        ));
    }

    // Footprint of the object (its vertices at or below the plane, projected into the plane).
    let in_plane = |p: &Point3<f64>| p - up * up.dot(&p.coords);
    let footprint_pts: Vec<Point3<f64>> = object_world
        .iter()
        .flat_map(|m| m.vertices.iter())
        .filter(|p| up.dot(&p.coords) <= 0.0)
        .map(in_plane)
        .collect();
    let footprint_index = KdIndex::new(&footprint_pts)?;
    let footprint_distance = |p: &Point3<f64>| {
        footprint_index
            .nearest(&in_plane(p))
            .map_or(f64::INFINITY, |n| n.distance)
    };
    // The object's whole outline projected into the plane (stones stay clear of it, including
    // under the raised neck).
    let outline: Vec<Point3<f64>> = object_world
        .iter()
        .flat_map(|m| m.vertices.iter())
        .map(in_plane)
        .collect();
    let outline_index = KdIndex::new(&outline)?;
    // The silt is cut off beyond SILT_CUTOFF widths; points farther than that from every
    // footprint point (checked first against the footprint's bounding circle) get none.
    let footprint_centre = in_plane(&target);
    let footprint_radius = footprint_pts
        .iter()
        .map(|p| (p - footprint_centre).norm())
        .fold(0.0, f64::max);
    let silt_reach = SILT_CUTOFF * ocfg.silt_width_m;
    let silt = |x: f64, y: f64| {
        let p = in_plane(&Point3::new(x, y, seabed.plane_depth(x, y)));
        if footprint_pts.is_empty() || (p - footprint_centre).norm() > footprint_radius + silt_reach {
            return 0.0;
        }
        let g = footprint_distance(&p);
        if g > silt_reach {
            0.0
        } else {
            ocfg.silt_height_m * (-(g / ocfg.silt_width_m).powi(2)).exp()
        }
    };

    // The seabed over the visible footprint.
    let relief = 1.25 * cfg.seabed.ripple_amplitude_m + 4.0 * cfg.seabed.roughness_m + 0.02;
    let (lo, hi) = footprint(cfg, &t_world_scan, &up, relief, 0.1 + 5.0 * cfg.seabed.cell_m);
    let cells = ((hi[0] - lo[0]) / cfg.seabed.cell_m).ceil() * ((hi[1] - lo[1]) / cfg.seabed.cell_m).ceil();
    if cells > 2.0e7 {
        return Err(Error::input(
            "config seabed.cell_m",
            format!(
                "the seabed grid would have {cells:.0} cells; use a larger cell or a shorter camera.max_depth_m"
            ),
        ));
    }
    let t_scan_world = t_world_scan.inverse();
    let seabed_mesh = crop_to_view(&seabed.mesh(lo, hi, cfg.seabed.cell_m, silt), cfg, &t_scan_world);
    let seabed_depth = |x: f64, y: f64| seabed.plane_depth(x, y) - seabed.relief(x, y) - silt(x, y);
    if seabed_depth(camera.x, camera.y) - camera.z < 0.05 {
        return Err(Error::input(
            "config camera.distance_m",
            "the camera would be less than 5 cm above the seabed; increase the distance or reduce the tilt",
        ));
    }

    // Colour texture: a fine 3-D field modulating every albedo.
    let tint = WaveField::new(
        &mut stream(cfg.seed, streams::TEXTURE, 0),
        24,
        [0.01, 0.12],
        1.0,
        false,
    );
    let mut geometry = SceneGeometry {
        mesh: TriangleMesh::default(),
        kinds: Vec::new(),
        albedo: Vec::new(),
        fouling: Vec::new(),
    };
    let sand: Vec<[f64; 3]> = seabed_mesh
        .vertices
        .iter()
        .map(|p| {
            let trough = 0.5 * (1.25 - seabed.ripple_shape(p.x, p.y)); // 0 at crests, 1 in troughs
            let s = silt(p.x, p.y) / ocfg.silt_height_m.max(1e-9);
            let base = mix(SAND, SILT, s.clamp(0.0, 1.0));
            scale(base, (1.0 + 0.12 * tint.at(p)) * (1.0 - 0.08 * trough))
        })
        .collect();
    geometry.push(
        &seabed_mesh.transformed(&t_scan_world),
        SurfaceKind::Seabed,
        &sand,
        None,
    );

    if let (Some(obj), Some((_, shift))) = (&object_world, &deformed) {
        let growth_scale = cfg.fouling.bump_height_m[1].max(1e-3) * 0.4;
        let albedo: Vec<[f64; 3]> = obj
            .vertices
            .iter()
            .zip(shift)
            .map(|(p, &d)| {
                let base = mix(PET, GROWTH, (d.max(0.0) / growth_scale).min(1.0));
                scale(base, 1.0 + 0.1 * tint.at(p))
            })
            .collect();
        geometry.push(
            &obj.transformed(&t_scan_world),
            SurfaceKind::Object,
            &albedo,
            Some(shift),
        );
    }

    // Stones, clear of the object and of each other.
    let mut stones_placed = Vec::new();
    let mut rng = stream(cfg.seed, streams::STONES, 0);
    let count = cfg.stones.count.unwrap_or(0);
    let inner = 0.1 + 5.0 * cfg.seabed.cell_m;
    for _ in 0..count {
        let size = uniform(&mut rng, cfg.stones.size_m);
        let embed = uniform(&mut rng, cfg.stones.embed);
        let (mesh, low, high) = stones::stone(size, &up, &mut rng);
        for _ in 0..200 {
            let x = uniform(&mut rng, [lo[0] + inner, hi[0] - inner]);
            let y = uniform(&mut rng, [lo[1] + inner, hi[1] - inner]);
            let ground = Point3::new(x, y, seabed_depth(x, y));
            let clear_object = outline_index
                .nearest(&in_plane(&ground))
                .is_none_or(|n| n.distance > cfg.stones.clearance_m + 0.5 * size);
            let clear_stones = stones_placed.iter().all(|s: &PlacedStone| {
                (in_plane(&s.centre) - in_plane(&ground)).norm() > 0.5 * (s.size_m + size)
            });
            // Only where the camera can see it (in the image, within the depth range).
            let seen = t_scan_world * ground;
            let visible = Pinhole::new(&cfg.camera).project(&seen).is_some()
                && seen.z > cfg.camera.min_depth_m
                && seen.z < cfg.camera.max_depth_m;
            if clear_object && clear_stones && visible {
                let centre = ground + up * (-embed * (high - low) - low);
                let world = mesh.transformed(&Pose::from_parts(
                    Translation3::from(centre.coords),
                    UnitQuaternion::identity(),
                ));
                let grey = uniform(&mut rng, [0.7, 1.25]);
                let albedo: Vec<[f64; 3]> = world
                    .vertices
                    .iter()
                    .map(|p| scale(STONE, grey * (1.0 + 0.15 * tint.at(p))))
                    .collect();
                geometry.push(
                    &world.transformed(&t_scan_world),
                    SurfaceKind::Stone,
                    &albedo,
                    None,
                );
                stones_placed.push(PlacedStone { centre, size_m: size });
                break;
            }
        }
    }

    Ok(Composed {
        geometry,
        t_world_scan,
        up_world: up,
        target_world: target,
        object: placed,
        stones: stones_placed,
        seabed_extent: (lo, hi),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_looks_at_the_target_from_the_distance() {
        let cfg = SynthConfig {
            seed: 2,
            ..Default::default()
        }
        .resolved();
        let c = compose(&cfg).unwrap();
        let cam = Point3::from(c.t_world_scan.translation.vector);
        // Camera straight above the world origin, target on the optical axis at the distance.
        assert!(cam.x.abs() < 1e-12 && cam.y.abs() < 1e-12 && cam.z < -0.5);
        let target_in_scan = c.t_world_scan.inverse() * c.target_world;
        assert!((target_in_scan - Point3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
        // x_S is east, the optical axis is tilted 30° from the vertical towards north.
        let rot = c.t_world_scan.rotation;
        assert!((rot * Vector3::x() - Vector3::y()).norm() < 1e-12);
        let z = rot * Vector3::z();
        assert!((z.z - 30f64.to_radians().cos()).abs() < 1e-12 && z.x > 0.0);
        // The camera aims at the centre of the bottle's bounding box, 0.1325 m from the origin
        // towards the cap.
        let o = c.object.as_ref().unwrap();
        let aim = o.t_world_reference.inverse() * c.target_world;
        assert!((aim - Point3::new(0.1325, 0.0, 0.0)).norm() < 1e-9, "{aim:?}");
        // The object's lowest point is burial_m below the mean plane.
        let o = c.object.as_ref().unwrap();
        let lowest = o
            .reference
            .vertices
            .iter()
            .map(|v| c.up_world.dot(&(o.t_world_reference * v).coords))
            .fold(f64::MAX, f64::min);
        assert!((lowest + cfg.object.burial_m).abs() < 1e-12, "{lowest}");
        // Its model z is the seabed's up, its x lies in the plane.
        let r = o.t_world_reference.rotation;
        assert!((r * Vector3::z() - c.up_world).norm() < 1e-12);
        assert!((r * Vector3::x()).dot(&c.up_world).abs() < 1e-12);
        // The scene has seabed, object and stones.
        let k = &c.geometry.kinds;
        assert!(
            k.contains(&SurfaceKind::Seabed)
                && k.contains(&SurfaceKind::Object)
                && k.contains(&SurfaceKind::Stone)
        );
        assert_eq!(c.geometry.albedo.len(), c.geometry.mesh.vertices.len());
        assert_eq!(c.geometry.fouling.len(), c.geometry.mesh.vertices.len());
    }

    #[test]
    fn stones_clear_of_the_object() {
        let cfg = SynthConfig {
            seed: 3,
            stones: crate::synth::StonesConfig {
                count: Some(12),
                ..Default::default()
            },
            ..Default::default()
        }
        .resolved();
        let c = compose(&cfg).unwrap();
        let o = c.object.unwrap();
        let up = c.up_world;
        let flat = |p: Point3<f64>| p - up * up.dot(&p.coords);
        for s in &c.stones {
            let gap = o
                .reference
                .vertices
                .iter()
                .map(|v| (flat(o.t_world_reference * v) - flat(s.centre)).norm())
                .fold(f64::MAX, f64::min);
            assert!(gap > cfg.stones.clearance_m + 0.5 * s.size_m - 1e-9, "{gap}");
        }
        assert!(!c.stones.is_empty());
    }
}
