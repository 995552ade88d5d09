//! The configuration of `uvms synth` (TOML; every key optional, units in the field docs).
//!
//! Keys left out take their defaults. A few keys are drawn from the seed when absent
//! (`seabed.slope_azimuth_deg`, `seabed.ripple_azimuth_deg`, `object.yaw_deg`, `stones.count`):
//! [`SynthConfig::resolved`] fills them, each from its own random stream, so the resolved
//! configuration (written as `config.toml`) reproduces the same scene when read back.

use super::bottle::BottleConfig;
use super::random::stream;
use crate::config::shown;
use crate::error::{Error, Result};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// Which scene to synthesise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum SceneKind {
    /// The seed's PET bottle lying on a rippled seabed, partly buried, fouled, among stones.
    #[default]
    Bottle,
    /// A sediment patch with no object (rippled seabed only, by default no stones): soil sampling.
    Sediment,
}

/// Everything `uvms synth` needs; see the module docs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthConfig {
    /// Seed of every random choice (0 ..= 2^63 - 1).
    pub seed: u64,
    /// The scene.
    pub scene: SceneKind,
    /// Stereo camera: intrinsics, baseline and where it looks from.
    pub camera: CameraConfig,
    /// Depth noise and the stereo artefacts.
    pub sensor: SensorConfig,
    /// The seabed height field.
    pub seabed: SeabedConfig,
    /// The object's placement (bottle scene only).
    pub object: ObjectConfig,
    /// Fouling bumps and dents on the object (bottle scene only).
    pub fouling: FoulingConfig,
    /// Stones on the seabed.
    pub stones: StonesConfig,
}

/// The left camera of a ZED2-class stereo pair (the scan frame `S` is the left camera's).
///
/// Defaults: 1280 × 720 (ZED2 HD720); focal length 700 px, the ZED2's in-air HD720 focal length
/// (about 528 px, 100° horizontal field of view) times the refractive index of water 1.33 for a
/// camera behind a flat port, calibrated in water as in the seed; baseline 0.12 m (ZED2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Focal length, pixels (square pixels; the principal point is the image centre).
    pub focal_px: f64,
    /// Stereo baseline, metres: the right camera is this far along the left camera's `+x`.
    pub baseline_m: f64,
    /// Keep one pixel in `pixel_stride` along rows and columns (depth-map decimation; 3 keeps the
    /// 1280 × 720 scan near 100 000 points, about 2.8 MB of PLY).
    pub pixel_stride: u32,
    /// Distance from the camera to the target along the optical axis, metres: to the centre of
    /// the object model's bounding box (bottle) or to the mean seabed plane (sediment).
    pub distance_m: f64,
    /// Angle of the optical axis from the vertical, degrees (0 looks straight down; positive looks
    /// ahead, towards north in the world frame).
    pub tilt_deg: f64,
    /// Nearest depth the stereo matcher reports, metres.
    pub min_depth_m: f64,
    /// Farthest depth reported, metres (turbidity and the disparity range limit it).
    pub max_depth_m: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            width_px: 1280,
            height_px: 720,
            focal_px: 700.0,
            baseline_m: 0.12,
            pixel_stride: 3,
            distance_m: 1.0,
            tilt_deg: 30.0,
            min_depth_m: 0.3,
            max_depth_m: 3.0,
        }
    }
}

/// Depth noise and artefacts of a stereo depth map.
///
/// The default disparity noise, 0.15 px, is the usual sub-pixel accuracy of semi-global matching
/// on textured scenes (0.1–0.2 px); with the default camera it gives σ_z = z²·σ_d/(f·b) = 1.8 mm at
/// 1 m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Standard deviation of the disparity error, pixels.
    pub disparity_sigma_px: f64,
    /// Fraction of the seabed's (and stones') area too poor in texture to match (0..1).
    pub textureless_seabed: f64,
    /// Fraction of the object's area too poor in texture to match (0..1; smooth PET).
    pub textureless_object: f64,
    /// Typical size of a textureless patch, metres.
    pub texture_patch_m: f64,
    /// Surfaces seen more obliquely than this angle of incidence are not matched, degrees.
    pub max_incidence_deg: f64,
    /// Fraction of matched pixels that are false matches (speckle: a random disparity).
    pub speckle_fraction: f64,
    /// Fraction of pixels next to a depth edge that take a mixed depth (flying pixels).
    pub flying_fraction: f64,
    /// A depth step larger than this between neighbouring kept pixels is a depth edge, metres.
    pub edge_jump_m: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            disparity_sigma_px: 0.15,
            textureless_seabed: 0.02,
            textureless_object: 0.06,
            texture_patch_m: 0.08,
            max_incidence_deg: 80.0,
            speckle_fraction: 0.002,
            flying_fraction: 0.5,
            edge_jump_m: 0.02,
        }
    }
}

/// The seabed: a sloped mean plane, sand ripples and roughness, as a height field (vertical in
/// the world frame).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SeabedConfig {
    /// Slope of the mean plane, degrees.
    pub slope_deg: f64,
    /// Downhill direction, degrees from north towards east; drawn from the seed when absent.
    pub slope_azimuth_deg: Option<f64>,
    /// Ripple wavelength (crest to crest), metres.
    pub ripple_wavelength_m: f64,
    /// Ripple amplitude (half the crest-to-trough height), metres.
    pub ripple_amplitude_m: f64,
    /// Direction across the crests, degrees from north towards east; drawn when absent.
    pub ripple_azimuth_deg: Option<f64>,
    /// RMS height of the random roughness (wavelengths 3 cm to 30 cm), metres.
    pub roughness_m: f64,
    /// Grid spacing of the height-field mesh, metres.
    pub cell_m: f64,
}

impl Default for SeabedConfig {
    fn default() -> Self {
        SeabedConfig {
            slope_deg: 3.0,
            slope_azimuth_deg: None,
            ripple_wavelength_m: 0.12,
            ripple_amplitude_m: 0.008,
            ripple_azimuth_deg: None,
            roughness_m: 0.002,
            cell_m: 0.01,
        }
    }
}

/// Which object, and where and how it lies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectConfig {
    /// A reference mesh (PLY) to use instead of the generated bottle, in its own model frame,
    /// metres; it is laid with its `+z` up and its `+x` at `yaw_deg`. A relative path is taken
    /// from the current folder (the resolved configuration names it by absolute path). When
    /// absent, the bottle of `[object.bottle]` is generated.
    pub reference: Option<std::path::PathBuf>,
    /// Heading of the model's `+x` axis (base to cap), degrees from north towards east; drawn
    /// from the seed when absent.
    pub yaw_deg: Option<f64>,
    /// Rotation about the model's `+x` axis, degrees (the bottle is symmetric about it).
    pub roll_deg: f64,
    /// How deep the object's lowest point lies below the mean seabed plane, metres.
    pub burial_m: f64,
    /// Height of the silt drifted against the object at its waterline, metres.
    pub silt_height_m: f64,
    /// Width over which that silt falls off (Gaussian), metres.
    pub silt_width_m: f64,
    /// The generated reference model.
    pub bottle: BottleConfig,
}

impl Default for ObjectConfig {
    fn default() -> Self {
        ObjectConfig {
            reference: None,
            yaw_deg: None,
            roll_deg: 0.0,
            burial_m: 0.04,
            silt_height_m: 0.012,
            silt_width_m: 0.05,
            bottle: BottleConfig::default(),
        }
    }
}

/// Fouling bumps (growth) and dents (deformation) on the object's upward-facing surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoulingConfig {
    /// Number of bumps.
    pub bumps: u32,
    /// Range of bump heights, metres.
    pub bump_height_m: [f64; 2],
    /// Range of bump radii (support), metres.
    pub bump_radius_m: [f64; 2],
    /// Number of dents.
    pub dents: u32,
    /// Range of dent depths, metres.
    pub dent_depth_m: [f64; 2],
    /// Range of dent radii (support), metres.
    pub dent_radius_m: [f64; 2],
}

impl Default for FoulingConfig {
    fn default() -> Self {
        FoulingConfig {
            bumps: 8,
            bump_height_m: [0.003, 0.008],
            bump_radius_m: [0.015, 0.04],
            dents: 2,
            dent_depth_m: [0.004, 0.01],
            dent_radius_m: [0.04, 0.07],
        }
    }
}

/// Stones: rough ellipsoids half sunk in the sediment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StonesConfig {
    /// Number of stones; when absent, 4 in the bottle scene and 0 in the sediment scene.
    pub count: Option<u32>,
    /// Range of stone sizes (longest diameter), metres.
    pub size_m: [f64; 2],
    /// Range of the sunk fraction of a stone's height (0..1).
    pub embed: [f64; 2],
    /// Least gap between a stone and the object's footprint, metres.
    pub clearance_m: f64,
}

impl Default for StonesConfig {
    fn default() -> Self {
        StonesConfig {
            count: None,
            size_m: [0.03, 0.1],
            embed: [0.2, 0.5],
            clearance_m: 0.08,
        }
    }
}

/// Random streams (one per concept, so fixing one drawn value changes nothing else).
pub(crate) mod streams {
    pub const RESOLVE: u64 = 1;
    pub const SEABED: u64 = 2;
    pub const FOULING: u64 = 3;
    pub const STONES: u64 = 4;
    pub const TEXTURE: u64 = 5;
    pub const PIXELS: u64 = 6;
}

fn check(ok: bool, key: &str, reason: impl std::fmt::Display) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::input(format!("config {key}"), reason))
    }
}

fn positive(v: f64, key: &str) -> Result<()> {
    check(
        v.is_finite() && v > 0.0,
        key,
        format!("must be positive (got {})", shown(v)),
    )
}

fn non_negative(v: f64, key: &str) -> Result<()> {
    check(
        v.is_finite() && v >= 0.0,
        key,
        format!("must be zero or positive (got {})", shown(v)),
    )
}

fn fraction(v: f64, key: &str) -> Result<()> {
    check(
        v.is_finite() && (0.0..=1.0).contains(&v),
        key,
        format!("must be between 0 and 1 (got {})", shown(v)),
    )
}

fn range(r: [f64; 2], key: &str, lowest: f64, highest: f64) -> Result<()> {
    check(
        r.iter().all(|v| v.is_finite()) && lowest <= r[0] && r[0] <= r[1] && r[1] <= highest,
        key,
        format!(
            "must be [low, high] with {lowest} <= low <= high <= {highest} (got [{}, {}])",
            shown(r[0]),
            shown(r[1])
        ),
    )
}

impl SynthConfig {
    /// Checks every value; errors name the key (`config camera.focal_px: must be positive ...`).
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad key.
    pub fn validate(&self) -> Result<()> {
        check(
            self.seed <= i64::MAX as u64,
            "seed",
            "must be at most 2^63 - 1 (TOML integers are signed)",
        )?;
        let c = &self.camera;
        check(
            (16..=20_000).contains(&c.width_px),
            "camera.width_px",
            "must be 16 ..= 20000",
        )?;
        check(
            (16..=20_000).contains(&c.height_px),
            "camera.height_px",
            "must be 16 ..= 20000",
        )?;
        positive(c.focal_px, "camera.focal_px")?;
        positive(c.baseline_m, "camera.baseline_m")?;
        check(
            (1..=64).contains(&c.pixel_stride),
            "camera.pixel_stride",
            format!("must be 1 ..= 64 (got {})", c.pixel_stride),
        )?;
        let kept = (c.width_px.div_ceil(c.pixel_stride.max(1)) as u64)
            * (c.height_px.div_ceil(c.pixel_stride.max(1)) as u64);
        check(
            kept <= 20_000_000,
            "camera.pixel_stride",
            format!("{kept} kept pixels is more than 20 million; raise the stride or lower the resolution"),
        )?;
        positive(c.distance_m, "camera.distance_m")?;
        check(
            c.tilt_deg.is_finite() && (0.0..=75.0).contains(&c.tilt_deg),
            "camera.tilt_deg",
            format!(
                "must be 0 ..= 75 degrees from the vertical (got {})",
                shown(c.tilt_deg)
            ),
        )?;
        positive(c.min_depth_m, "camera.min_depth_m")?;
        check(
            c.max_depth_m.is_finite() && c.max_depth_m > c.min_depth_m && c.max_depth_m <= 100.0,
            "camera.max_depth_m",
            "must exceed camera.min_depth_m and be at most 100 m",
        )?;
        check(
            c.distance_m > c.min_depth_m && c.distance_m < c.max_depth_m,
            "camera.distance_m",
            "must lie between camera.min_depth_m and camera.max_depth_m",
        )?;
        let s = &self.sensor;
        non_negative(s.disparity_sigma_px, "sensor.disparity_sigma_px")?;
        check(
            s.disparity_sigma_px <= 10.0,
            "sensor.disparity_sigma_px",
            "must be at most 10 px",
        )?;
        fraction(s.textureless_seabed, "sensor.textureless_seabed")?;
        fraction(s.textureless_object, "sensor.textureless_object")?;
        positive(s.texture_patch_m, "sensor.texture_patch_m")?;
        check(
            s.max_incidence_deg.is_finite() && (0.0..=90.0).contains(&s.max_incidence_deg),
            "sensor.max_incidence_deg",
            "must be 0 ..= 90 degrees",
        )?;
        fraction(s.speckle_fraction, "sensor.speckle_fraction")?;
        fraction(s.flying_fraction, "sensor.flying_fraction")?;
        positive(s.edge_jump_m, "sensor.edge_jump_m")?;
        let b = &self.seabed;
        check(
            b.slope_deg.is_finite() && (0.0..=45.0).contains(&b.slope_deg),
            "seabed.slope_deg",
            "must be 0 ..= 45 degrees",
        )?;
        for (k, v) in [
            ("seabed.slope_azimuth_deg", b.slope_azimuth_deg),
            ("seabed.ripple_azimuth_deg", b.ripple_azimuth_deg),
        ] {
            check(
                v.is_none_or(f64::is_finite),
                k,
                "must be a finite number of degrees",
            )?;
        }
        positive(b.ripple_wavelength_m, "seabed.ripple_wavelength_m")?;
        non_negative(b.ripple_amplitude_m, "seabed.ripple_amplitude_m")?;
        check(
            b.ripple_amplitude_m <= 0.5,
            "seabed.ripple_amplitude_m",
            "must be at most 0.5 m",
        )?;
        non_negative(b.roughness_m, "seabed.roughness_m")?;
        check(
            b.roughness_m <= 0.2,
            "seabed.roughness_m",
            "must be at most 0.2 m",
        )?;
        positive(b.cell_m, "seabed.cell_m")?;
        check(b.cell_m >= 0.001, "seabed.cell_m", "must be at least 1 mm")?;
        let o = &self.object;
        check(
            o.yaw_deg.is_none_or(f64::is_finite),
            "object.yaw_deg",
            "must be a finite number of degrees",
        )?;
        check(
            o.roll_deg.is_finite(),
            "object.roll_deg",
            "must be a finite number of degrees",
        )?;
        o.bottle.validate("config object.bottle")?;
        non_negative(o.burial_m, "object.burial_m")?;
        // With a reference file the model's height is known only once it is read (scene.rs).
        check(
            o.reference.is_some() || o.burial_m < 0.9 * o.bottle.body_diameter_m,
            "object.burial_m",
            "must be less than 90 % of the body diameter (the object must show)",
        )?;
        check(
            o.reference.as_ref().is_none_or(|p| !p.as_os_str().is_empty()),
            "object.reference",
            "is empty; leave it out to use the generated bottle",
        )?;
        non_negative(o.silt_height_m, "object.silt_height_m")?;
        check(
            o.silt_height_m <= 0.5 * o.bottle.body_diameter_m,
            "object.silt_height_m",
            "must be at most half the body diameter",
        )?;
        positive(o.silt_width_m, "object.silt_width_m")?;
        let f = &self.fouling;
        check(f.bumps <= 1000, "fouling.bumps", "must be at most 1000")?;
        check(f.dents <= 1000, "fouling.dents", "must be at most 1000")?;
        range(f.bump_height_m, "fouling.bump_height_m", 0.0, 0.1)?;
        range(f.bump_radius_m, "fouling.bump_radius_m", 1e-3, 0.5)?;
        range(f.dent_depth_m, "fouling.dent_depth_m", 0.0, 0.1)?;
        range(f.dent_radius_m, "fouling.dent_radius_m", 1e-3, 0.5)?;
        let st = &self.stones;
        check(
            st.count.is_none_or(|n| n <= 1000),
            "stones.count",
            "must be at most 1000",
        )?;
        range(st.size_m, "stones.size_m", 0.005, 1.0)?;
        range(st.embed, "stones.embed", 0.0, 0.9)?;
        non_negative(st.clearance_m, "stones.clearance_m")?;
        // What the checks above leave unbounded (a cell size, a clearance...).
        crate::config::within_range(self, "config ")
    }

    /// The configuration with every seed-drawn key filled in (see the module docs).
    pub fn resolved(&self) -> SynthConfig {
        let mut r = self.clone();
        let mut rng = stream(self.seed, streams::RESOLVE, 0);
        // Always draw all three, in this order, so one fixed value does not shift the others.
        let draws: [f64; 3] = std::array::from_fn(|_| rng.random_range(0.0..360.0));
        let round = |v: f64| (v * 1e6).round() / 1e6;
        r.seabed.slope_azimuth_deg.get_or_insert(round(draws[0]));
        r.seabed.ripple_azimuth_deg.get_or_insert(round(draws[1]));
        r.object.yaw_deg.get_or_insert(round(draws[2]));
        r.stones.count.get_or_insert(match self.scene {
            SceneKind::Bottle => 4,
            SceneKind::Sediment => 0,
        });
        // Named by absolute path, so that the written configuration finds it from any folder.
        r.object.reference = r.object.reference.map(|p| crate::config::relative_to(None, &p));
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::from_toml_str;

    #[test]
    fn defaults_validate_and_resolve_round_trip() {
        let c = SynthConfig {
            seed: 5,
            ..Default::default()
        };
        c.validate().unwrap();
        let r = c.resolved();
        assert!(r.object.yaw_deg.is_some() && r.stones.count == Some(4));
        let text = toml::to_string_pretty(&r).unwrap();
        let back: SynthConfig = from_toml_str(&text, "resolved").unwrap();
        assert_eq!(back, r);
        assert_eq!(back.resolved(), r);
        // A different seed draws a different yaw.
        let other = SynthConfig {
            seed: 6,
            ..Default::default()
        }
        .resolved();
        assert_ne!(other.object.yaw_deg, r.object.yaw_deg);
    }

    #[test]
    fn bad_values_name_the_key() {
        let c: SynthConfig = from_toml_str("[camera]\nfocal_px = -3.0\n", "x.toml").unwrap();
        let e = c.validate().unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("camera.focal_px"), "{e}");
        let c: SynthConfig = from_toml_str("[fouling]\nbump_radius_m = [0.05, 0.01]\n", "x.toml").unwrap();
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("fouling.bump_radius_m")
        );
        let c: SynthConfig = from_toml_str("[object.bottle]\nlength_m = 0.1\n", "x.toml").unwrap();
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("object.bottle.length_m")
        );
        // A value no check above bounds, past any scene (it was taken, and the seabed vanished).
        let c: SynthConfig = from_toml_str("[seabed]\ncell_m = 1e300\n", "x.toml").unwrap();
        let e = c.validate();
        assert!(format!("{e:?}").contains("1e300 is beyond"), "{e:?}");
        crate::perception::assert_bad_input(e, "config seabed.cell_m");
        let e = from_toml_str::<SynthConfig>("[sensor]\ndisparity_sigma = 0.1\n", "x.toml").unwrap_err();
        assert!(e.to_string().contains("disparity_sigma"), "{e}");
    }

    #[test]
    fn a_bottle_larger_than_a_reference_file_may_be_is_rejected() {
        for d in ["1e6", "1e300", "nan"] {
            let c: SynthConfig =
                from_toml_str(&format!("[object.bottle]\nbody_diameter_m = {d}\n"), "x.toml").unwrap();
            crate::perception::assert_bad_input(c.validate(), "config object.bottle.body_diameter_m");
        }
    }
}
