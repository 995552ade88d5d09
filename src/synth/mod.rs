//! `uvms synth`: a synthetic underwater stereo scan with its ground truth, deterministic per seed.
//!
//! The scene (module [`scene`]): a seabed height field ([`seabed`]: slope, sand ripples,
//! roughness), the seed's PET bottle ([`bottle`], 0.35 m body diameter) lying on it partly buried
//! in silt with fouling bumps and dents ([`fouling`]), and stones ([`stones`]); or, for soil
//! sampling, a sediment patch with no object. The camera ([`camera`]): a ZED2-class stereo pair
//! (1280 × 720, 0.12 m baseline) casting one ray per pixel on the true surfaces, with the stereo
//! shadows, depth noise σ_z = z²·σ_d/(f·b), textureless dropouts, speckle and flying pixels.
//!
//! Frames: the scan frame `S` is the left camera's (z optical axis, x right, y down); the world
//! frame `W` is NED with its origin on the mean seabed plane below the camera; the reference
//! model's frame is described in [`bottle`]. [`Truth`] holds the transforms between them.
//!
//! Every random choice comes from [`SynthConfig::seed`] through independent streams, so the same
//! configuration gives the same bytes, on any number of threads.

pub mod bottle;
pub mod camera;
pub mod config;
pub mod fouling;
pub mod random;
pub mod scene;
pub mod seabed;
pub mod stones;

pub use bottle::{BottleConfig, bottle_mesh};
pub use camera::{Artefact, PointTruth, RenderCounts};
pub use config::{
    CameraConfig, FoulingConfig, ObjectConfig, SceneKind, SeabedConfig, SensorConfig, StonesConfig,
    SynthConfig,
};
pub use scene::SurfaceKind;

use crate::cloud::PointCloud;
use crate::error::Result;
use crate::frames::{Pose, pose_to_rows};
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Vector3};
use serde::{Serialize, Serializer};

/// What the frames in [`Truth`] are (written into `truth.json`).
#[derive(Debug, Clone, Serialize)]
pub struct FrameNotes {
    /// The scan frame.
    pub scan: &'static str,
    /// The world frame.
    pub world: &'static str,
    /// The reference model's frame.
    pub reference: &'static str,
}

/// The camera as synthesised.
#[derive(Debug, Clone, Serialize)]
pub struct CameraTruth {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Focal length, pixels.
    pub focal_px: f64,
    /// Principal point, pixels (column, row).
    pub principal_point_px: [f64; 2],
    /// Stereo baseline, metres.
    pub baseline_m: f64,
    /// Pixel stride of the depth map.
    pub pixel_stride: u32,
    /// Distance to the target along the optical axis, metres.
    pub distance_m: f64,
    /// Tilt of the optical axis from the vertical, degrees.
    pub tilt_deg: f64,
    /// Height of the camera above the mean seabed plane, metres.
    pub altitude_m: f64,
    /// Disparity noise, pixels.
    pub disparity_sigma_px: f64,
    /// Depth noise at 1 m, z²·σ_d/(f·b), metres.
    pub depth_sigma_at_1m_m: f64,
}

/// One fouling feature.
#[derive(Debug, Clone, Serialize)]
pub struct FoulingTruth {
    /// `bump` or `dent`.
    pub kind: &'static str,
    /// Centre on the reference surface, scan frame, metres.
    pub centre_in_scan: Point3<f64>,
    /// Centre, reference model frame, metres.
    pub centre_in_reference: Point3<f64>,
    /// Radius of the affected area, metres.
    pub radius_m: f64,
    /// Displacement at the centre along the outward normal, metres (negative for a dent).
    pub height_m: f64,
}

/// The object as synthesised.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectTruth {
    /// Which model: `bottle` (generated) or the reference file's path.
    pub model: String,
    /// Size of the model's bounding box along its x, y, z, metres.
    pub extent_m: [f64; 3],
    /// Body diameter of the generated bottle, metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_diameter_m: Option<f64>,
    /// Depth of the lowest point below the mean seabed plane, metres.
    pub burial_m: f64,
    /// Heading of the model's `+x`, degrees from north towards east.
    pub yaw_deg: f64,
    /// Rotation about the model's `+x`, degrees.
    pub roll_deg: f64,
    /// The model's symmetry (a rotation about it leaves the shape unchanged), when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub symmetry: Option<&'static str>,
    /// Fouling bumps and dents.
    pub fouling: Vec<FoulingTruth>,
}

/// The seabed as synthesised.
#[derive(Debug, Clone, Serialize)]
pub struct SeabedTruth {
    /// Slope of the mean plane, degrees.
    pub slope_deg: f64,
    /// Downhill direction, degrees from north towards east.
    pub slope_azimuth_deg: f64,
    /// Ripple wavelength, metres.
    pub ripple_wavelength_m: f64,
    /// Ripple amplitude, metres.
    pub ripple_amplitude_m: f64,
    /// Direction across the ripple crests, degrees from north towards east.
    pub ripple_azimuth_deg: f64,
    /// RMS roughness, metres.
    pub roughness_m: f64,
    /// Extent of the height field in the world frame, `[[x_min, y_min], [x_max, y_max]]`, metres.
    pub extent_in_world_m: [[f64; 2]; 2],
}

/// One stone.
#[derive(Debug, Clone, Serialize)]
pub struct StoneTruth {
    /// Centre, scan frame, metres.
    pub centre_in_scan: Point3<f64>,
    /// Longest diameter, metres.
    pub size_m: f64,
}

fn rows<S: Serializer>(p: &Pose, s: S) -> Result<S::Ok, S::Error> {
    pose_to_rows(p).serialize(s)
}

fn rows_opt<S: Serializer>(p: &Option<Pose>, s: S) -> Result<S::Ok, S::Error> {
    p.as_ref().map(pose_to_rows).serialize(s)
}

/// The ground truth of a synthetic scan (`truth.json`). Poses are 4×4 row-major matrices in the
/// file; `t_a_b` maps `b` coordinates into `a`.
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// The scene.
    pub scene: SceneKind,
    /// The seed.
    pub seed: u64,
    /// What the frames are.
    pub frames: FrameNotes,
    /// Reference model → scan (absent for the sediment scene).
    #[serde(serialize_with = "rows_opt", skip_serializing_if = "Option::is_none")]
    pub t_scan_reference: Option<Pose>,
    /// Scan (left camera) → world.
    #[serde(serialize_with = "rows")]
    pub t_world_scan: Pose,
    /// Reference model → world (absent for the sediment scene).
    #[serde(serialize_with = "rows_opt", skip_serializing_if = "Option::is_none")]
    pub t_world_reference: Option<Pose>,
    /// Unit vector opposite to gravity, scan frame (it differs from the seabed plane's normal by
    /// the seabed's slope).
    pub up_in_scan: Vector3<f64>,
    /// Mean seabed plane `[a, b, c, d]`, scan frame: unit normal towards the camera,
    /// `a x + b y + c z + d = 0`, `d > 0`.
    pub seabed_plane: [f64; 4],
    /// The point the camera looks at (the centre of the object model's bounding box, or on the
    /// mean seabed plane), scan frame.
    pub target_in_scan: Point3<f64>,
    /// The camera.
    pub camera: CameraTruth,
    /// The object (absent for the sediment scene).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub object: Option<ObjectTruth>,
    /// The seabed.
    pub seabed: SeabedTruth,
    /// The stones.
    pub stones: Vec<StoneTruth>,
}

/// A synthetic scan, its ground truth and the true scene.
#[derive(Debug, Clone)]
pub struct SynthScene {
    /// The resolved configuration (every seed-drawn key filled in).
    pub config: SynthConfig,
    /// The scan, scan frame, with colours.
    pub scan: PointCloud,
    /// The truth of each scan point (same order as `scan.points`).
    pub points: Vec<PointTruth>,
    /// Poses and scene parameters.
    pub truth: Truth,
    /// The true surfaces (seabed, fouled object, stones), scan frame.
    pub scene_mesh: TriangleMesh,
    /// What each triangle of `scene_mesh` belongs to.
    pub triangle_kinds: Vec<SurfaceKind>,
    /// The reference model in its own frame (absent for the sediment scene).
    pub reference: Option<TriangleMesh>,
    /// Where the pixels went.
    pub counts: RenderCounts,
}

impl SynthScene {
    /// The noise-free true points of the regular measurements (no speckle, no flying pixels) on
    /// surfaces of `kind`, scan frame.
    pub fn noise_free(&self, kind: SurfaceKind) -> Vec<Point3<f64>> {
        self.points
            .iter()
            .filter(|t| t.surface == kind && t.artefact == Artefact::None)
            .map(|t| t.true_point)
            .collect()
    }

    /// The run's summary (`summary.json`): counts, poses and noise level; no timings, so that it
    /// is reproducible too.
    pub fn summary(&self) -> serde_json::Value {
        let by = |k: SurfaceKind| self.points.iter().filter(|t| t.surface == k).count();
        serde_json::json!({
            "scene": self.truth.scene,
            "seed": self.truth.seed,
            "points": self.scan.len(),
            "points_by_surface": {
                "seabed": by(SurfaceKind::Seabed),
                "object": by(SurfaceKind::Object),
                "stone": by(SurfaceKind::Stone),
            },
            "pixels": self.counts,
            "depth_sigma_at_1m_m": self.truth.camera.depth_sigma_at_1m_m,
            "t_scan_reference": self.truth.t_scan_reference.as_ref().map(pose_to_rows),
            "up_in_scan": self.truth.up_in_scan,
            "seabed_plane": self.truth.seabed_plane,
            "scene_mesh": {
                "vertices": self.scene_mesh.vertices.len(),
                "triangles": self.scene_mesh.triangles.len(),
            },
            "fouling_features": self.truth.object.as_ref().map_or(0, |o| o.fouling.len()),
            "stones": self.truth.stones.len(),
        })
    }
}

/// Synthesises the scan of `config` (validated, then resolved; see [`SynthConfig::resolved`]).
///
/// # Errors
/// [`Error::Input`](crate::Error::Input) naming the key of an invalid configuration value.
pub fn synthesize(config: &SynthConfig) -> Result<SynthScene> {
    config.validate()?;
    let cfg = config.resolved();
    let composed = scene::compose(&cfg)?;
    let rendered = camera::render(&composed.geometry, &cfg.camera, &cfg.sensor, cfg.seed)?;

    let t_world_scan = composed.t_world_scan;
    let t_scan_world = t_world_scan.inverse();
    // Gravity points along +z in NED.
    let up_in_scan = t_scan_world.rotation * Vector3::new(0.0, 0.0, -1.0);
    let normal = t_scan_world.rotation * composed.up_world;
    let origin_in_scan = t_scan_world * Point3::origin();
    let d = -normal.dot(&origin_in_scan.coords);
    let seabed_plane = [normal.x, normal.y, normal.z, d];
    let altitude = composed.up_world.dot(&t_world_scan.translation.vector);
    let c = &cfg.camera;
    let object = composed.object.as_ref().map(|o| {
        let t_scan_reference = t_scan_world * o.t_world_reference;
        let (lo, hi) = crate::cloud::bbox(&o.reference.vertices).unwrap_or_default();
        let generated = cfg.object.reference.is_none();
        ObjectTruth {
            model: cfg
                .object
                .reference
                .as_ref()
                .map_or("bottle".into(), |p| p.display().to_string()),
            extent_m: (hi - lo).into(),
            body_diameter_m: generated.then_some(cfg.object.bottle.body_diameter_m),
            burial_m: cfg.object.burial_m,
            yaw_deg: cfg.object.yaw_deg.unwrap_or(0.0),
            roll_deg: cfg.object.roll_deg,
            symmetry: generated.then_some("rotation about the reference's x axis"),
            fouling: o
                .features
                .iter()
                .map(|f| FoulingTruth {
                    kind: if f.height_m >= 0.0 { "bump" } else { "dent" },
                    centre_in_scan: t_scan_reference * f.centre,
                    centre_in_reference: f.centre,
                    radius_m: f.radius_m,
                    height_m: f.height_m,
                })
                .collect(),
        }
    });
    let (lo, hi) = composed.seabed_extent;
    let truth = Truth {
        scene: cfg.scene,
        seed: cfg.seed,
        frames: FrameNotes {
            scan: "S, the left camera: z along the optical axis, x right, y down in the image; metres",
            world: "W, NED (x north, y east, z down); origin on the mean seabed plane vertically below the camera; the camera looks north and down",
            reference: if cfg.object.reference.is_some() {
                "the reference file's own frame, laid with its +z up"
            } else {
                "the bottle model: +x along the axis from base to cap, origin on the axis midway between the base plane and the shoulder"
            },
        },
        t_scan_reference: composed
            .object
            .as_ref()
            .map(|o| t_scan_world * o.t_world_reference),
        t_world_scan,
        t_world_reference: composed.object.as_ref().map(|o| o.t_world_reference),
        up_in_scan,
        seabed_plane,
        target_in_scan: t_scan_world * composed.target_world,
        camera: CameraTruth {
            width_px: c.width_px,
            height_px: c.height_px,
            focal_px: c.focal_px,
            principal_point_px: [0.5 * c.width_px as f64, 0.5 * c.height_px as f64],
            baseline_m: c.baseline_m,
            pixel_stride: c.pixel_stride,
            distance_m: c.distance_m,
            tilt_deg: c.tilt_deg,
            altitude_m: altitude,
            disparity_sigma_px: cfg.sensor.disparity_sigma_px,
            depth_sigma_at_1m_m: cfg.sensor.disparity_sigma_px / (c.focal_px * c.baseline_m),
        },
        object,
        seabed: SeabedTruth {
            slope_deg: cfg.seabed.slope_deg,
            slope_azimuth_deg: cfg.seabed.slope_azimuth_deg.unwrap_or(0.0),
            ripple_wavelength_m: cfg.seabed.ripple_wavelength_m,
            ripple_amplitude_m: cfg.seabed.ripple_amplitude_m,
            ripple_azimuth_deg: cfg.seabed.ripple_azimuth_deg.unwrap_or(0.0),
            roughness_m: cfg.seabed.roughness_m,
            extent_in_world_m: [lo, hi],
        },
        stones: composed
            .stones
            .iter()
            .map(|s| StoneTruth {
                centre_in_scan: t_scan_world * s.centre,
                size_m: s.size_m,
            })
            .collect(),
    };
    Ok(SynthScene {
        config: cfg,
        scan: rendered.scan,
        points: rendered.points,
        truth,
        scene_mesh: composed.geometry.mesh,
        triangle_kinds: composed.geometry.kinds,
        reference: composed.object.map(|o| o.reference),
        counts: rendered.counts,
    })
}
