//! Property tests of the planner on random cylinders and random pattern settings: every tool
//! frame orthonormal and right-handed (after the CSV round trip), `k = z_G`, no orientation
//! change faster than the configured rate, never faster than the configured speed, and no
//! scanned path point farther from the scanned surface than the tolerance.

use nalgebra::{Matrix3, Point3, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use uvms::frames::Pose;
use uvms::plan::fixtures::{Cylinder, ScanSpec};
use uvms::plan::patterns::{PatternKind, RowDirection};
use uvms::plan::{ObjectAxes, ObjectInput, PlanConfig, PlanInput, plan};
use uvms::surface::Surface;
use uvms::trajectory::{Phase, Trajectory};

#[derive(Debug, Clone)]
struct Case {
    cylinder: Cylinder,
    spec: ScanSpec,
    config: PlanConfig,
}

fn case() -> impl Strategy<Value = Case> {
    (
        (
            0.06..0.22f64,
            0.15..0.35f64,
            0.8..1.3f64,
            -0.15..0.15f64,
            0.0..std::f64::consts::PI,
            -0.4..0.4f64,
        ),
        (0.0..0.0015f64, 0.003..0.006f64, any::<u64>()),
        (
            any::<bool>(),
            any::<bool>(),
            0.0..1.0f64,
            0.0..1.0f64,
            0.0..1.0f64,
            0.005..0.02f64,
        ),
        (
            -20.0..20.0f64,
            5.0..60.0f64,
            0.008..0.025f64,
            0.002..0.006f64,
            0.01..0.04f64,
        ),
    )
        .prop_map(|(geo, scan, pat, tool)| {
            let (radius, half_length, depth, lateral, heading, tilt) = geo;
            // The axis lies across the line of sight, turned by `heading` and tilted by `tilt`.
            let axis = Vector3::new(heading.cos(), heading.sin(), tilt).normalize();
            let cylinder = Cylinder {
                centre: Point3::new(lateral, -lateral / 2.0, depth),
                axis,
                radius,
                half_length,
            };
            let spec = ScanSpec {
                noise_sigma: scan.0,
                spacing: scan.1,
                seed: scan.2,
                ..ScanSpec::default()
            };
            let (ring, along, a, b, c, spacing) = pat;
            let mut config = PlanConfig {
                pattern: if ring {
                    PatternKind::Ring
                } else {
                    PatternKind::Raster
                },
                ..PlanConfig::default()
            };
            config.projection.clip = true;
            config.ring.station_m = (a - 0.5) * half_length;
            config.ring.width_m = if b < 0.5 { 0.0 } else { b * 0.5 * half_length };
            config.ring.arc_deg = if c < 0.3 { 0.0 } else { 40.0 + 100.0 * c };
            config.ring.spacing_m = spacing;
            config.raster.rows = if along {
                RowDirection::Along
            } else {
                RowDirection::Across
            };
            config.raster.width_m = 0.04 + 0.2 * a;
            config.raster.height_m = 0.02 + 0.1 * b;
            config.raster.spacing_m = spacing;
            let (service, rate, smoothing, tolerance, standoff) = tool;
            config.tool.service_angle_deg = service;
            config.tool.max_rate_deg_s = rate;
            config.projection.smoothing_radius_m = smoothing;
            config.projection.tolerance_m = tolerance;
            config.timing.standoff_m = standoff;
            Case {
                cylinder,
                spec,
                config,
            }
        })
}

fn round_trip(t: &Trajectory) -> Trajectory {
    let mut buf = Vec::new();
    t.write_csv(&mut buf).unwrap();
    Trajectory::from_csv_str(std::str::from_utf8(&buf).unwrap(), "t.csv").unwrap()
}

proptest! {
    #![proptest_config(Config { cases: 32, rng_seed: RngSeed::Fixed(20240611), failure_persistence: None, ..Config::default() })]

    #[test]
    fn planned_trajectories_keep_their_invariants(case in case()) {
        let scan = case.cylinder.scan(&case.spec);
        prop_assume!(scan.triangles.len() > 100);
        let reference = case.cylinder.mesh(96, 6);
        let input = PlanInput {
            object: Some(ObjectInput {
                scan_surface: &scan,
                reference: &reference,
                t_scan_reference: Pose::identity(),
                axes: ObjectAxes::from_mesh(&reference).unwrap(),
            }),
            viewpoint: Point3::origin(),
            seabed_plane: None,
            seabed_surface: None,
        };
        let cfg = &case.config;
        let p = match plan(&input, cfg) {
            Ok(p) => p,
            // Settings that do not fit the object (passes shorter than their spacing, a region
            // off the scan) are reported as a failed run, never a panic or bad output.
            Err(e) => {
                eprintln!("failed run: {e}");
                prop_assert_eq!(e.exit_code(), 1, "{}", e);
                return Ok(());
            }
        };
        let t = &p.trajectory;
        prop_assert!(t.samples.windows(2).all(|w| w[1].t > w[0].t));
        // Orthonormal, right-handed tool frames with k = z_G, as a reader of the file sees them.
        for s in &round_trip(t).samples {
            let m: Matrix3<f64> = s.orientation.to_rotation_matrix().into_inner();
            prop_assert!((m.transpose() * m - Matrix3::identity()).abs().max() < 1e-9);
            prop_assert!((m.determinant() - 1.0).abs() < 1e-9);
            let [x, y, z] = s.axes();
            prop_assert!((x.cross(&y) - z).norm() < 1e-9);
            prop_assert!((s.k - z).norm() < 1e-6);
        }
        // No orientation change faster than the rate; never faster than the speed in contact.
        let max_rate = cfg.tool.max_rate_deg_s.to_radians();
        for w in t.samples.windows(2) {
            let rate = w[0].orientation.angle_to(&w[1].orientation) / (w[1].t - w[0].t);
            prop_assert!(rate <= max_rate * (1.0 + 1e-9), "rate {} deg/s", rate.to_degrees());
            if w[0].phase == Phase::Contact && w[1].phase == Phase::Contact {
                let v = (w[1].position - w[0].position).norm() / (w[1].t - w[0].t);
                prop_assert!(v <= cfg.timing.speed_m_s * (1.0 + 1e-9));
            }
        }
        // Scanned points stay within the tolerance of the scanned surface.
        let surface = Surface::new(&scan).unwrap();
        let to_scan = cfg.frames.t_world_scan().inverse();
        for s in t.phase(Phase::Contact).filter(|s| !s.fallback) {
            let d = surface.project(&(to_scan * s.position)).distance;
            prop_assert!(d <= cfg.projection.tolerance_m + 1e-5, "{} m off the scan", d);
        }
        // The approach starts `standoff` outside the first contact point, against k.
        let first = t.phase(Phase::Contact).next().unwrap();
        let a0 = &t.samples[0];
        prop_assert_eq!(a0.phase, Phase::Approach);
        prop_assert!((first.position - a0.position - first.k * cfg.timing.standoff_m).norm() < 1e-9);
    }
}
