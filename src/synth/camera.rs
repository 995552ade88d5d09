//! The stereo camera: a pinhole left camera (the scan frame `S`: z optical axis, x right, y down)
//! and a right camera `baseline_m` along `+x`, and the depth map they measure.
//!
//! One ray per kept pixel (through the pixel's centre; pixel `(i, j)` spans `[i, i+1) × [j, j+1)`,
//! the principal point is the image centre) is cast on the scene's true surfaces. A hit is
//! measured only if
//! - its depth lies in `[min_depth_m, max_depth_m]`;
//! - the right camera sees it too: it projects inside the right image and the segment from the
//!   right camera's centre to it crosses no surface (otherwise it is in the stereo shadow);
//! - the surface is not seen more obliquely than `max_incidence_deg`;
//! - the surface has texture there: a smooth random 3-D field (patches of about
//!   `texture_patch_m`) thresholded at the quantile that leaves the configured fraction of the
//!   seabed's or the object's area textureless.
//!
//! Depth error: the matcher's disparity `d = f·b/z` is off by a Gaussian error of
//! `disparity_sigma_px`, so `z' = f·b/(d + ε)`, whose standard deviation is, to first order,
//! `σ_z = z²·σ_d/(f·b)`; the point moves along its pixel ray (`p' = p·z'/z`). Artefacts: a fraction
//! of matches are false (speckle: a uniformly random disparity within the depth range), and
//! pixels next to a depth step larger than `edge_jump_m` take, with probability
//! `flying_fraction`, a depth (and colour) mixed between the two sides (flying pixels).
//!
//! Colour: the vertex albedo at the hit, lit by lamps at the camera (Lambert), attenuated along
//! the two-way path through water per channel (red most) with back-scatter added, white-balanced
//! for a 1 m range, then sRGB-like gamma; plus 1 % sensor noise.
//!
//! Every random number of a pixel comes from its own stream `(seed, pixel index)`, so the result
//! does not depend on threads or on which other pixels are kept.

use super::config::{CameraConfig, SensorConfig, streams};
use super::random::{WaveField, gaussian, stream};
use super::scene::{SceneGeometry, SurfaceKind};
use crate::cloud::PointCloud;
use crate::error::{Error, Result};
use crate::mesh::barycentric;
use crate::surface::Surface;
use nalgebra::{Point3, Vector3};
use rand::RngExt;
use rayon::prelude::*;
use serde::Serialize;

/// A pinhole camera with square pixels and the principal point at the image centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels.
    pub focal: f64,
}

impl Pinhole {
    /// The camera of a configuration.
    pub fn new(cfg: &CameraConfig) -> Self {
        Pinhole {
            width: cfg.width_px,
            height: cfg.height_px,
            focal: cfg.focal_px,
        }
    }

    /// The ray through image point `(u, v)` (pixels), scaled to unit depth (`z = 1`).
    pub fn ray(&self, u: f64, v: f64) -> Vector3<f64> {
        Vector3::new(
            (u - 0.5 * self.width as f64) / self.focal,
            (v - 0.5 * self.height as f64) / self.focal,
            1.0,
        )
    }

    /// The image point `(u, v)` of `p` (camera frame), if it is in front of the camera and inside
    /// the image.
    pub fn project(&self, p: &Point3<f64>) -> Option<(f64, f64)> {
        if p.z <= 0.0 {
            return None;
        }
        let u = self.focal * p.x / p.z + 0.5 * self.width as f64;
        let v = self.focal * p.y / p.z + 0.5 * self.height as f64;
        (u >= 0.0 && u < self.width as f64 && v >= 0.0 && v < self.height as f64).then_some((u, v))
    }
}

/// Why a scan point is not a plain measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Artefact {
    /// A regular measurement: the true point plus depth noise.
    None,
    /// A false match: a random depth along the pixel's ray.
    Speckle,
    /// A flying pixel: a depth mixed between the two sides of a depth edge.
    Flying,
}

/// The ground truth of one scan point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointTruth {
    /// Its pixel `(column, row)` in the full-resolution image.
    pub pixel: [u32; 2],
    /// The true surface point the pixel's ray meets (noise-free), scan frame, metres.
    pub true_point: Point3<f64>,
    /// What that surface is.
    pub surface: SurfaceKind,
    /// Whether the measured point is an artefact.
    pub artefact: Artefact,
    /// Largest fouling displacement at the hit triangle's vertices, metres (0: the surface there
    /// is exactly the reference's).
    pub fouling_m: f64,
}

/// How many pixels went where.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RenderCounts {
    /// Pixels cast (after the stride).
    pub pixels: usize,
    /// Rays that met no surface within the depth range's reach.
    pub no_return: usize,
    /// Hits (or noisy depths) outside `[min_depth_m, max_depth_m]`.
    pub out_of_range: usize,
    /// Hits outside the right camera's image.
    pub outside_right_image: usize,
    /// Hits hidden from the right camera by another surface.
    pub stereo_shadow: usize,
    /// Hits seen too obliquely.
    pub grazing: usize,
    /// Hits on textureless patches.
    pub textureless: usize,
    /// Noisy disparities that came out non-positive.
    pub invalid_disparity: usize,
    /// Speckle outliers in the scan.
    pub speckle: usize,
    /// Flying pixels in the scan.
    pub flying: usize,
    /// Points in the scan.
    pub points: usize,
}

impl RenderCounts {
    fn add(&mut self, o: &RenderCounts) {
        self.pixels += o.pixels;
        self.no_return += o.no_return;
        self.out_of_range += o.out_of_range;
        self.outside_right_image += o.outside_right_image;
        self.stereo_shadow += o.stereo_shadow;
        self.grazing += o.grazing;
        self.textureless += o.textureless;
        self.invalid_disparity += o.invalid_disparity;
        self.speckle += o.speckle;
        self.flying += o.flying;
        self.points += o.points;
    }
}

/// The measured scan and its ground truth.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The scan in the camera frame, with colours.
    pub scan: PointCloud,
    /// The truth of each scan point, in the same order.
    pub points: Vec<PointTruth>,
    /// Where the pixels went.
    pub counts: RenderCounts,
}

/// A noise-free hit of a pixel's ray.
#[derive(Debug, Clone, Copy)]
struct Hit {
    point: Point3<f64>,
    triangle: usize,
    normal: Vector3<f64>,
    colour: [f64; 3],
}

/// One measured point: position (scan frame), colour, truth.
type Measured = (Point3<f64>, [u8; 3], PointTruth);

// Water: two-way attenuation per metre (red, green, blue) and back-scatter colour (linear RGB).
const ATTENUATION: [f64; 3] = [0.30, 0.06, 0.035];
const BACKSCATTER: [f64; 3] = [0.03, 0.10, 0.12];
/// Range at which the camera's white balance makes the water neutral, metres.
const WHITE_BALANCE_RANGE_M: f64 = 1.0;

/// Linear RGB reaching the camera from a surface of albedo `albedo` at `range` metres seen at
/// incidence cosine `cos_inc`.
fn shade(albedo: [f64; 3], cos_inc: f64, range: f64) -> [f64; 3] {
    let light = 0.2 + 0.8 * cos_inc;
    std::array::from_fn(|k| {
        let t = (-2.0 * ATTENUATION[k] * range).exp();
        let balance = (2.0 * ATTENUATION[k] * WHITE_BALANCE_RANGE_M).exp();
        (albedo[k] * light * t + BACKSCATTER[k] * (1.0 - t)) * balance
    })
}

fn to_srgb(c: [f64; 3]) -> [u8; 3] {
    c.map(|v| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8)
}

/// Renders the scan of `scene` (in the scan frame) as the configured stereo camera measures it.
///
/// # Errors
/// [`Error::Input`] if the scene mesh is unusable; [`Error::Failed`] if the ray-casting structure
/// does not keep the triangle numbering.
pub fn render(
    scene: &SceneGeometry,
    camera: &CameraConfig,
    sensor: &SensorConfig,
    seed: u64,
) -> Result<Rendered> {
    let surface = Surface::new(&scene.mesh)?;
    if surface.triangle_count() != scene.mesh.triangles.len() {
        return Err(Error::failed(
            "synth render",
            "the ray caster dropped triangles of the scene mesh",
        ));
    }
    let cam = Pinhole::new(camera);
    let stride = camera.pixel_stride.max(1);
    let cols = camera.width_px.div_ceil(stride);
    let rows = camera.height_px.div_ceil(stride);
    let centre = |k: u32| (k * stride + stride / 2).min(k * stride + stride - 1);
    let reach = camera.max_depth_m * (1.0 + cam.ray(0.0, 0.0).norm_squared()).sqrt() * 1.01;

    // Pass 1: the noise-free hit of every kept pixel.
    let hits: Vec<Vec<Option<Hit>>> = (0..rows)
        .into_par_iter()
        .map(|r| {
            let v = centre(r) as f64 + 0.5;
            (0..cols)
                .map(|c| {
                    let u = centre(c) as f64 + 0.5;
                    let ray = cam.ray(u, v);
                    let hit = surface.cast_ray(&Point3::origin(), &ray, reach)?;
                    let [a, b, cc] = scene.mesh.triangles[hit.triangle].map(|i| i as usize);
                    let m = &scene.mesh.vertices;
                    let w = barycentric(&m[a], &m[b], &m[cc], &hit.point);
                    let albedo = std::array::from_fn(|k| {
                        w[0] * scene.albedo[a][k] + w[1] * scene.albedo[b][k] + w[2] * scene.albedo[cc][k]
                    });
                    let cos_inc = hit.normal.dot(&ray.normalize()).abs();
                    Some(Hit {
                        point: hit.point,
                        triangle: hit.triangle,
                        normal: hit.normal,
                        colour: shade(albedo, cos_inc, hit.distance),
                    })
                })
                .collect()
        })
        .collect();

    // Textureless patches: thresholds at the configured quantiles of the field's values.
    let dropout = WaveField::new(
        &mut stream(seed, streams::TEXTURE, 1),
        16,
        [0.5 * sensor.texture_patch_m, 2.0 * sensor.texture_patch_m],
        1.0,
        false,
    );
    let threshold = {
        let mut rng = stream(seed, streams::TEXTURE, 2);
        let mut values: Vec<f64> = (0..8192)
            .map(|_| {
                dropout.at(&Point3::new(
                    rng.random::<f64>() * 50.0,
                    rng.random::<f64>() * 50.0,
                    rng.random::<f64>() * 50.0,
                ))
            })
            .collect();
        values.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            if q <= 0.0 {
                f64::NEG_INFINITY
            } else if q >= 1.0 {
                f64::INFINITY
            } else {
                values[((q * values.len() as f64) as usize).min(values.len() - 1)]
            }
        };
        (
            quantile(sensor.textureless_seabed),
            quantile(sensor.textureless_object),
        )
    };

    let fb = camera.focal_px * camera.baseline_m;
    let right = Point3::new(camera.baseline_m, 0.0, 0.0);
    let cos_max = sensor.max_incidence_deg.to_radians().cos();
    let (d_min, d_max) = (fb / camera.max_depth_m, fb / camera.min_depth_m);

    // Pass 2: what the stereo pair measures.
    let per_row: Vec<(Vec<Measured>, RenderCounts)> = (0..rows as usize)
        .into_par_iter()
        .map(|r| {
            let mut out = Vec::new();
            let mut n = RenderCounts::default();
            for c in 0..cols as usize {
                n.pixels += 1;
                let (pu, pv) = (centre(c as u32), centre(r as u32));
                let Some(hit) = hits[r][c] else {
                    n.no_return += 1;
                    continue;
                };
                let z = hit.point.z;
                if z < camera.min_depth_m || z > camera.max_depth_m {
                    n.out_of_range += 1;
                    continue;
                }
                if cam.project(&(hit.point - right.coords)).is_none() {
                    n.outside_right_image += 1;
                    continue;
                }
                let to_hit = hit.point - right;
                let len = to_hit.norm();
                if surface.cast_ray(&right, &to_hit, len - 1e-5).is_some() {
                    n.stereo_shadow += 1;
                    continue;
                }
                let ray = cam.ray(pu as f64 + 0.5, pv as f64 + 0.5);
                if hit.normal.dot(&ray.normalize()).abs() < cos_max {
                    n.grazing += 1;
                    continue;
                }
                let kind = scene.kinds[hit.triangle];
                let limit = if kind == SurfaceKind::Object {
                    threshold.1
                } else {
                    threshold.0
                };
                if dropout.at(&hit.point) < limit {
                    n.textureless += 1;
                    continue;
                }
                // This pixel's random numbers, always drawn in the same order.
                let mut rng = stream(
                    seed,
                    streams::PIXELS,
                    pv as u64 * camera.width_px as u64 + pu as u64,
                );
                let (u_speckle, u_disp, u_fly, u_mix): (f64, f64, f64, f64) =
                    (rng.random(), rng.random(), rng.random(), rng.random());
                let eps = gaussian(&mut rng);
                let colour_noise: [f64; 3] = std::array::from_fn(|_| 0.01 * gaussian(&mut rng));

                let mut depth = z;
                let mut colour = hit.colour;
                let mut artefact = Artefact::None;
                if u_speckle < sensor.speckle_fraction {
                    depth = fb / (d_min + (d_max - d_min) * u_disp);
                    artefact = Artefact::Speckle;
                } else if u_fly < sensor.flying_fraction {
                    // The neighbour across the largest depth step, if any exceeds the edge jump.
                    let neighbours = [
                        (r.wrapping_sub(1), c),
                        (r + 1, c),
                        (r, c.wrapping_sub(1)),
                        (r, c + 1),
                    ];
                    let other = neighbours
                        .iter()
                        .filter_map(|&(rr, cc)| hits.get(rr).and_then(|row| row.get(cc)).copied().flatten())
                        .filter(|h| (h.point.z - z).abs() > sensor.edge_jump_m)
                        .max_by(|a, b| (a.point.z - z).abs().total_cmp(&(b.point.z - z).abs()));
                    if let Some(o) = other {
                        let t = 0.15 + 0.7 * u_mix;
                        depth = z + t * (o.point.z - z);
                        colour = std::array::from_fn(|k| colour[k] + t * (o.colour[k] - colour[k]));
                        artefact = Artefact::Flying;
                    }
                }
                let disparity = fb / depth + sensor.disparity_sigma_px * eps;
                if disparity <= 0.0 {
                    n.invalid_disparity += 1;
                    continue;
                }
                let measured = fb / disparity;
                if measured < camera.min_depth_m || measured > camera.max_depth_m {
                    n.out_of_range += 1;
                    continue;
                }
                match artefact {
                    Artefact::Speckle => n.speckle += 1,
                    Artefact::Flying => n.flying += 1,
                    Artefact::None => {}
                }
                n.points += 1;
                let fouling_m = scene.mesh.triangles[hit.triangle]
                    .iter()
                    .map(|&i| scene.fouling[i as usize].abs())
                    .fold(0.0, f64::max);
                let rgb = to_srgb(std::array::from_fn(|k| colour[k] * (1.0 + colour_noise[k])));
                out.push((
                    Point3::from(ray * measured),
                    rgb,
                    PointTruth {
                        pixel: [pu, pv],
                        true_point: hit.point,
                        surface: kind,
                        artefact,
                        fouling_m,
                    },
                ));
            }
            (out, n)
        })
        .collect();

    let mut counts = RenderCounts::default();
    let total: usize = per_row.iter().map(|(o, _)| o.len()).sum();
    let (mut points, mut colors, mut truth) = (
        Vec::with_capacity(total),
        Vec::with_capacity(total),
        Vec::with_capacity(total),
    );
    for (row, n) in per_row {
        counts.add(&n);
        for (p, c, t) in row {
            points.push(p);
            colors.push(c);
            truth.push(t);
        }
    }
    if points.is_empty() {
        return Err(Error::input(
            "config camera",
            "the stereo pair matched no point of the scene: an empty scan (camera.focal_px, baseline_m, distance_m, the image size?)",
        ));
    }
    Ok(Rendered {
        scan: PointCloud {
            points,
            colors: Some(colors),
            normals: None,
        },
        points: truth,
        counts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TriangleMesh;

    /// An axis-aligned box `[lo, hi]` with outward triangles.
    fn cuboid(lo: Point3<f64>, hi: Point3<f64>) -> TriangleMesh {
        let v = (0..8)
            .map(|i| {
                Point3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        let t = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriangleMesh {
            vertices: v,
            triangles: t,
        }
    }

    /// A floor at depth 1 m (facing the camera) with a 0.2 m cube standing on it, centred under
    /// the left camera.
    fn floor_and_cube() -> SceneGeometry {
        let mut g = SceneGeometry {
            mesh: TriangleMesh::default(),
            kinds: vec![],
            albedo: vec![],
            fouling: vec![],
        };
        let floor = TriangleMesh {
            vertices: vec![
                Point3::new(-3.0, -3.0, 1.0),
                Point3::new(3.0, -3.0, 1.0),
                Point3::new(-3.0, 3.0, 1.0),
                Point3::new(3.0, 3.0, 1.0),
            ],
            triangles: vec![[0, 2, 1], [1, 2, 3]],
        };
        g.push(&floor, SurfaceKind::Seabed, &[[0.7; 3]; 4], None);
        g.push(
            &cuboid(Point3::new(-0.1, -0.1, 0.8), Point3::new(0.1, 0.1, 1.0)),
            SurfaceKind::Object,
            &[[0.4; 3]; 8],
            None,
        );
        g
    }

    fn clean_sensor() -> SensorConfig {
        SensorConfig {
            disparity_sigma_px: 0.0,
            textureless_seabed: 0.0,
            textureless_object: 0.0,
            speckle_fraction: 0.0,
            flying_fraction: 0.0,
            max_incidence_deg: 90.0,
            ..Default::default()
        }
    }

    fn small_camera() -> CameraConfig {
        CameraConfig {
            width_px: 320,
            height_px: 240,
            focal_px: 300.0,
            pixel_stride: 1,
            ..Default::default()
        }
    }

    #[test]
    fn stereo_shadow_left_of_the_cube_only() {
        // Floor points beside the cube at y ≈ 0: the left camera (x = 0) sees x < −0.125 and
        // x > 0.125; the right camera (x = 0.12) cannot see −0.155 < x < −0.125 past the cube.
        let out = render(&floor_and_cube(), &small_camera(), &clean_sensor(), 1).unwrap();
        assert!(out.counts.stereo_shadow > 0);
        let band = |lo: f64, hi: f64| {
            out.points
                .iter()
                .filter(|t| t.surface == SurfaceKind::Seabed && t.true_point.y.abs() < 0.05)
                .filter(|t| t.true_point.x > lo && t.true_point.x < hi)
                .count()
        };
        assert_eq!(band(-0.150, -0.130), 0, "stereo shadow must be empty");
        assert!(
            band(0.130, 0.150) > 10,
            "the mirror band right of the cube is seen by both"
        );
        assert!(band(-0.25, -0.16) > 10);
        // Nothing behind the cube: no floor point whose ray from the left camera crosses the cube.
        for t in &out.points {
            if t.surface == SurfaceKind::Seabed {
                let at_top = t.true_point * 0.8; // where the ray crosses z = 0.8
                assert!(at_top.x.abs() > 0.1 || at_top.y.abs() > 0.1, "{:?}", t.true_point);
            }
        }
        // Noise-free measurements are the true points.
        for (p, t) in out.scan.points.iter().zip(&out.points) {
            assert!((p - t.true_point).norm() < 1e-9);
        }
    }

    #[test]
    fn speckle_and_flying_pixels_are_labelled() {
        let sensor = SensorConfig {
            speckle_fraction: 0.05,
            flying_fraction: 1.0,
            ..clean_sensor()
        };
        let out = render(&floor_and_cube(), &small_camera(), &sensor, 1).unwrap();
        let speckle = out
            .points
            .iter()
            .filter(|t| t.artefact == Artefact::Speckle)
            .count();
        let flying = out
            .points
            .iter()
            .filter(|t| t.artefact == Artefact::Flying)
            .count();
        assert_eq!((speckle, flying), (out.counts.speckle, out.counts.flying));
        let frac = speckle as f64 / out.counts.points as f64;
        assert!((frac - 0.05).abs() < 0.01, "{frac}");
        assert!(flying > 20);
        for (p, t) in out.scan.points.iter().zip(&out.points) {
            match t.artefact {
                // Flying pixels lie strictly between the cube's top (0.8) and the floor (1.0).
                Artefact::Flying => assert!(p.z > 0.8 + 0.02 && p.z < 1.0 - 0.02, "{p:?}"),
                Artefact::None => assert!((p - t.true_point).norm() < 1e-9),
                Artefact::Speckle => {}
            }
        }
    }

    #[test]
    fn textureless_fraction_and_grazing() {
        let sensor = SensorConfig {
            textureless_seabed: 0.3,
            texture_patch_m: 0.05,
            ..clean_sensor()
        };
        let out = render(&floor_and_cube(), &small_camera(), &sensor, 3).unwrap();
        let floor = out.counts.textureless
            + out
                .points
                .iter()
                .filter(|t| t.surface == SurfaceKind::Seabed)
                .count();
        let frac = out.counts.textureless as f64 / floor as f64;
        assert!((frac - 0.3).abs() < 0.08, "{frac}");
        // A plane turned 75° about y is seen at 48° to 90° incidence across the image.
        let a = 75f64.to_radians();
        let (t1, t2) = (Vector3::new(a.cos(), 0.0, a.sin()) * 4.0, Vector3::y() * 4.0);
        let o = Point3::new(0.0, 0.0, 2.0);
        let plane = TriangleMesh {
            vertices: vec![o - t1 - t2, o + t1 - t2, o - t1 + t2, o + t1 + t2],
            triangles: vec![[0, 2, 1], [1, 2, 3]],
        };
        let mut g = SceneGeometry {
            mesh: TriangleMesh::default(),
            kinds: vec![],
            albedo: vec![],
            fouling: vec![],
        };
        g.push(&plane, SurfaceKind::Seabed, &[[0.7; 3]; 4], None);
        let n = plane.triangle_normal(0).unwrap();
        let mut kept = Vec::new();
        for limit in [60.0, 80.0] {
            let sensor = SensorConfig {
                max_incidence_deg: limit,
                ..clean_sensor()
            };
            let out = render(&g, &small_camera(), &sensor, 3).unwrap();
            assert!(
                out.counts.grazing > 0 && out.counts.points > 0,
                "{limit}: {:?}",
                out.counts
            );
            kept.push(out.counts.points);
            let cos = limit.to_radians().cos();
            for t in &out.points {
                assert!(n.dot(&t.true_point.coords.normalize()).abs() >= cos - 1e-12);
            }
        }
        assert!(kept[1] > kept[0] + 100, "{kept:?}");
    }
}
