//! Planning on analytic surfaces with known truth (the "Must show" of issue 4 before the
//! synthetic scenes): distance of every path point to the true surface, tool axis against the
//! true normal, uniform spacing, exact speed; the error cases and their exit codes.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use uvms::frames::Pose;
use uvms::mesh::TriangleMesh;
use uvms::plan::fixtures::{Cylinder, RippledPlane, ScanSpec, Truth, with_hole};
use uvms::plan::patterns::{PatternKind, PolylineFrame, RowDirection};
use uvms::plan::{ObjectAxes, ObjectInput, Plan, PlanConfig, PlanInput, plan};
use uvms::trajectory::{Phase, Sample, Trajectory};

/// A bottle-sized cylinder lying across the view 1 m in front of the camera.
fn bottle() -> Cylinder {
    Cylinder::bottle()
}

struct Scene {
    scan: TriangleMesh,
    reference: TriangleMesh,
    t_scan_reference: Pose,
    seabed_plane: Option<[f64; 4]>,
    seabed: Option<TriangleMesh>,
}

impl Scene {
    fn cylinder(c: &Cylinder, sigma: f64) -> Scene {
        let spec = ScanSpec {
            noise_sigma: sigma,
            ..ScanSpec::default()
        };
        Scene {
            scan: c.scan(&spec),
            reference: c.mesh(128, 8),
            t_scan_reference: Pose::identity(),
            seabed_plane: None,
            seabed: None,
        }
    }

    fn input(&self) -> PlanInput<'_> {
        PlanInput {
            object: Some(ObjectInput {
                scan_surface: &self.scan,
                reference: &self.reference,
                t_scan_reference: self.t_scan_reference,
                axes: ObjectAxes::from_mesh(&self.reference).unwrap(),
            }),
            viewpoint: Point3::origin(),
            seabed_plane: self.seabed_plane,
            seabed_surface: self.seabed.as_ref(),
        }
    }
}

fn config(pattern: PatternKind) -> PlanConfig {
    PlanConfig {
        pattern,
        ..PlanConfig::default()
    }
}

/// A contact sample brought back to the scan frame: position and tool axis `z_G`.
fn in_scan(cfg: &PlanConfig, s: &Sample) -> (Point3<f64>, Vector3<f64>) {
    let t = cfg.frames.t_world_scan();
    (t.inverse() * s.position, t.inverse_transform_vector(&s.k))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

struct Stats {
    dist_median_mm: f64,
    dist_max_mm: f64,
    angle_median_deg: f64,
    spacing_dev: f64,
    speed_dev: f64,
}

/// Distances to the truth, tool axis against the true normal, spacing and speed of the contact
/// samples (speed only over steps the orientation-rate limit did not slow down).
fn stats(p: &Plan, cfg: &PlanConfig, truth: &dyn Truth) -> Stats {
    let contact: Vec<&Sample> = p.trajectory.phase(Phase::Contact).collect();
    assert!(contact.len() > 10);
    let mut dist = Vec::new();
    let mut angle = Vec::new();
    for s in &contact {
        let (pos, k) = in_scan(cfg, s);
        dist.push(truth.distance(&pos) * 1e3);
        angle.push(k.angle(&-truth.normal(&pos)).to_degrees());
    }
    let h = p.report.spacing_m;
    let dt = h / cfg.timing.speed_m_s;
    let (mut spacing_dev, mut speed_dev) = (0.0f64, 0.0f64);
    for w in contact.windows(2) {
        let d = (w[1].position - w[0].position).norm();
        spacing_dev = spacing_dev.max((d / h - 1.0).abs());
        if (w[1].t - w[0].t - dt).abs() < 1e-9 {
            speed_dev = speed_dev.max((d / (w[1].t - w[0].t) / cfg.timing.speed_m_s - 1.0).abs());
        }
    }
    let dist_max_mm = dist.iter().copied().fold(0.0, f64::max);
    Stats {
        dist_median_mm: median(dist),
        dist_max_mm,
        angle_median_deg: median(angle),
        spacing_dev,
        speed_dev,
    }
}

fn assert_must_show(name: &str, s: &Stats, sigma: f64) {
    eprintln!(
        "{name}: distance to the true surface median {:.3} mm, max {:.3} mm; tool axis to true normal median {:.2}°; spacing within {:.3} %, speed within {:.3} %",
        s.dist_median_mm,
        s.dist_max_mm,
        s.angle_median_deg,
        s.spacing_dev * 100.0,
        s.speed_dev * 100.0
    );
    assert!(
        s.dist_max_mm <= 1.0 + sigma * 1e3,
        "{name}: max distance {} mm",
        s.dist_max_mm
    );
    assert!(
        s.angle_median_deg <= 3.0,
        "{name}: median angle {}°",
        s.angle_median_deg
    );
    // The issue asks for 1 %; chord resampling makes both exact.
    assert!(s.spacing_dev <= 1e-6, "{name}: spacing off by {}", s.spacing_dev);
    assert!(s.speed_dev <= 1e-6, "{name}: speed off by {}", s.speed_dev);
}

#[test]
fn ring_on_a_noisy_cylinder() {
    let c = bottle();
    for sigma in [0.0005, 0.001] {
        let scene = Scene::cylinder(&c, sigma);
        let cfg = PlanConfig::default();
        let p = plan(&scene.input(), &cfg).unwrap();
        assert_must_show(&format!("ring, noise {sigma} m"), &stats(&p, &cfg, &c), sigma);
        // The ring lies in the plane perpendicular to the axis at the station.
        for s in p.trajectory.phase(Phase::Contact) {
            assert!(in_scan(&cfg, s).0.x.abs() < 1e-3);
        }
        // The arc the camera saw: the scan's incidence limit of 75° from the viewing rays, less
        // 1 cm at each end. A point at angle φ from the top sees the camera at incidence
        // φ + asin(R sin φ / |ray|); solve for 75°.
        let phi = (0..=9000)
            .map(|i| (i as f64 / 100.0).to_radians())
            .find(|&phi| {
                let ray = (1.0 - c.radius * phi.cos(), c.radius * phi.sin());
                let inc = phi + (ray.1 / (ray.0 * ray.0 + ray.1 * ray.1).sqrt()).asin();
                inc >= 75f64.to_radians()
            })
            .unwrap();
        let expect = 2.0 * (phi - 0.01 / c.radius).to_degrees();
        let arc = p.report.arc_deg.unwrap();
        assert!((arc - expect).abs() < 2.0, "arc {arc}° expected {expect}°");
        assert!((p.report.length_m - arc.to_radians() * c.radius).abs() < 0.005);
        assert!((p.report.speed_m_s - 0.02).abs() < 1e-15);
    }
}

#[test]
fn ring_band_and_explicit_arc() {
    let c = bottle();
    let scene = Scene::cylinder(&c, 0.0005);
    let mut cfg = PlanConfig::default();
    cfg.ring.width_m = 0.05;
    cfg.ring.spacing_m = 0.02;
    cfg.ring.arc_deg = 90.0;
    cfg.ring.station_m = 0.1;
    let p = plan(&scene.input(), &cfg).unwrap();
    assert_eq!(p.report.rows, 4);
    assert!((p.report.row_spacing_m - 0.05 / 3.0).abs() < 1e-12);
    assert!((p.report.arc_deg.unwrap() - 90.0).abs() < 1e-6);
    // 4 passes of 90°, shortened by ρ = 1/120 m at each end next to one of the 3 U-turns of
    // radius ρ.
    let rho = 0.05 / 6.0;
    let expect = 4.0 * std::f64::consts::FRAC_PI_2 * c.radius - 6.0 * rho + 3.0 * std::f64::consts::PI * rho;
    assert!(
        (p.report.length_m - expect).abs() < 0.004,
        "{} vs {expect}",
        p.report.length_m
    );
    let xs: Vec<f64> = p
        .trajectory
        .phase(Phase::Contact)
        .map(|s| in_scan(&cfg, s).0.x)
        .collect();
    assert!(xs.iter().all(|x| (0.075 - 1e-3..=0.125 + 1e-3).contains(x)));
    assert_must_show("ring band", &stats(&p, &cfg, &c), 0.0005);
}

#[test]
fn raster_on_a_cylinder_and_on_a_rippled_plane() {
    let c = bottle();
    let scene = Scene::cylinder(&c, 0.0005);
    for rows in [RowDirection::Along, RowDirection::Across] {
        let mut cfg = config(PatternKind::Raster);
        cfg.raster.rows = rows;
        let p = plan(&scene.input(), &cfg).unwrap();
        assert_eq!(p.report.rows, 11);
        // 11 rows of 0.15 m on the surface, shortened by ρ = 5 mm next to each of the 10
        // U-turns of radius ρ (in the plane perpendicular to the line of sight).
        let expect = 11.0 * 0.15 - 20.0 * 0.005 + 10.0 * std::f64::consts::PI * 0.005;
        assert!(
            (p.report.length_m - expect).abs() < 0.015,
            "{} vs {expect}",
            p.report.length_m
        );
        assert_must_show(
            &format!("raster {rows:?} on the cylinder"),
            &stats(&p, &cfg, &c),
            0.0005,
        );
    }
    let ripple = RippledPlane {
        origin: Point3::new(0.0, 0.0, 1.0),
        normal: -Vector3::z(),
        amplitude: 0.01,
        wavelength: 0.25,
        half_size: 0.25,
    };
    let sigma = 0.0005;
    let scene = Scene {
        scan: ripple.scan(&ScanSpec {
            noise_sigma: sigma,
            ..ScanSpec::default()
        }),
        reference: ripple.mesh(100),
        t_scan_reference: Pose::identity(),
        seabed_plane: None,
        seabed: None,
    };
    let mut cfg = config(PatternKind::Raster);
    cfg.raster.width_m = 0.3;
    cfg.raster.height_m = 0.2;
    let p = plan(&scene.input(), &cfg).unwrap();
    assert_eq!(p.report.fallback_points, 0);
    assert_must_show("raster on the rippled plane", &stats(&p, &cfg, &ripple), sigma);
}

#[test]
fn holes_fall_back_to_the_reference_and_are_flagged() {
    let c = bottle();
    let mut scene = Scene::cylinder(&c, 0.0005);
    let top = c.point(0.0, -std::f64::consts::FRAC_PI_2);
    scene.scan = with_hole(&scene.scan, &top, 0.02);
    // The reference is misaligned by 3 mm along the view. Fallback points take the reference's
    // shape at the scan's level around the hole (no 3 mm step into the hole), and are flagged.
    scene.t_scan_reference =
        Isometry3::from_parts(Translation3::new(0.0, 0.0, -0.003), UnitQuaternion::identity());
    scene.reference = c.mesh(128, 8).transformed(&scene.t_scan_reference);
    let cfg = PlanConfig::default();
    let p = plan(&scene.input(), &cfg).unwrap();
    let fallback: Vec<&Sample> = p
        .trajectory
        .phase(Phase::Contact)
        .filter(|s| s.fallback)
        .collect();
    // The hole is 4 cm across.
    assert!((fallback.len() as f64 - 40.0).abs() < 8.0, "{}", fallback.len());
    assert_eq!(p.report.fallback_points, fallback.len());
    for s in &fallback {
        let (pos, _) = in_scan(&cfg, s);
        assert!(c.distance(&pos) < 0.0015, "{}", c.distance(&pos));
    }
    assert_must_show("ring over a hole", &stats(&p, &cfg, &c), 0.0005);
    // A hole longer than max_hole_m ends the ring's arc there.
    let mut cfg = PlanConfig::default();
    cfg.projection.max_hole_m = 0.01;
    cfg.ring.station_m = 0.015;
    let p = plan(&scene.input(), &cfg).unwrap_err();
    assert_eq!(p.exit_code(), 1, "{p}");
}

#[test]
fn line_along_the_seabed_at_depth() {
    let c = bottle();
    let mut scene = Scene::cylinder(&c, 0.0005);
    let seabed = RippledPlane {
        origin: Point3::new(0.0, 0.0, 1.175),
        normal: -Vector3::z(),
        amplitude: 0.005,
        wavelength: 0.3,
        half_size: 0.6,
    };
    let sigma = 0.0005;
    let with_object_gap = seabed.scan(&ScanSpec {
        noise_sigma: sigma,
        spacing: 0.006,
        ..ScanSpec::default()
    });
    scene.seabed = Some(with_hole(&with_object_gap, &Point3::new(0.0, 0.0, 1.175), 0.2));
    scene.seabed_plane = Some([0.0, 0.0, -1.0, 1.175]);
    let mut cfg = config(PatternKind::Line);
    let p = plan(&scene.input(), &cfg).unwrap();
    assert_eq!(p.report.force_max_n, 0.0);
    assert!((p.report.length_m - 0.3).abs() < 0.002, "{}", p.report.length_m);
    for s in p.trajectory.phase(Phase::Contact) {
        let (pos, k) = in_scan(&cfg, s);
        // Beside the bottle (0.175 m half-width + 0.1 m clearance), 2 cm into the seabed.
        // (The depth is along the rippled seabed's normal, tilted by up to 6°.)
        assert!((pos.y.abs() - 0.275).abs() < 3e-3, "{pos}");
        assert!(
            (seabed.distance(&pos) - 0.02).abs() < 1e-3 + sigma,
            "{}",
            seabed.distance(&pos)
        );
        assert!(k.angle(&-seabed.normal(&pos)).to_degrees() < 3.0);
        // Moving along the object's axis.
        assert!(
            (s.orientation * Vector3::x())
                .dot(&(cfg.frames.t_world_scan().rotation * Vector3::x()))
                .abs()
                > 0.99
        );
    }
    // Moved under the bottle, it crosses the object: a failed run.
    cfg.line.offset_m = [0.0, -0.275];
    let e = plan(&scene.input(), &cfg).unwrap_err();
    assert!(
        e.exit_code() == 1 && e.to_string().contains("crosses the object"),
        "{e}"
    );
    // Without the triangulated seabed it runs on the plane.
    scene.seabed = None;
    cfg.line.offset_m = [0.0, 0.0];
    let p = plan(&scene.input(), &cfg).unwrap();
    for s in p.trajectory.phase(Phase::Contact) {
        assert!((in_scan(&cfg, s).0.z - 1.195).abs() < 1e-9);
    }
    // Without an object (a sediment patch), the line is centred where the optical axis meets the
    // seabed and runs along the image's x axis, here turned by 90°.
    cfg.line.heading_deg = 90.0;
    let input = PlanInput {
        object: None,
        ..scene.input()
    };
    let p = plan(&input, &cfg).unwrap();
    let pts: Vec<Point3<f64>> = p
        .trajectory
        .phase(Phase::Contact)
        .map(|s| in_scan(&cfg, s).0)
        .collect();
    assert!(pts.iter().all(|q| q.x.abs() < 1e-9 && (q.z - 1.195).abs() < 1e-9));
    assert!((pts[0].y - pts[pts.len() - 1].y).abs() > 0.299);
    assert!(p.report.object_axes.is_none());
    // The ring needs the object: a usage error.
    assert_eq!(plan(&input, &PlanConfig::default()).unwrap_err().exit_code(), 2);
}

#[test]
fn polyline_from_a_csv_in_the_reference_frame() {
    let c = bottle();
    let mut scene = Scene::cylinder(&c, 0.0005);
    // The reference model lives in its own frame; the scan sees it moved and turned.
    let t = Isometry3::new(Vector3::new(0.02, -0.01, 0.005), Vector3::new(0.0, 0.0, 0.02));
    let model = c.mesh(128, 8);
    scene.reference = model.transformed(&t);
    scene.t_scan_reference = t;
    let true_c = Cylinder {
        centre: t * c.centre,
        axis: t * c.axis,
        ..c
    };
    let spec = ScanSpec {
        noise_sigma: 0.0005,
        ..ScanSpec::default()
    };
    scene.scan = true_c.scan(&spec);
    // A zig-zag over the top of the model, in model coordinates, with a force per point.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("path.csv");
    let mut text = String::from("# a zig-zag\nx_m,y_m,z_m,force_n\n");
    for (i, (s, th)) in [(-0.1, -0.3), (0.0, 0.3), (0.1, -0.3)].iter().enumerate() {
        let p = c.point(*s, -std::f64::consts::FRAC_PI_2 + th);
        text += &format!("{},{},{},{}\n", p.x, p.y, p.z, 40.0 + 10.0 * i as f64);
    }
    std::fs::write(&file, text).unwrap();
    let mut cfg = config(PatternKind::Polyline);
    cfg.polyline.file = Some(file.clone());
    assert_eq!(cfg.polyline.frame, PolylineFrame::Reference);
    let p = plan(&scene.input(), &cfg).unwrap();
    assert_must_show("polyline", &stats(&p, &cfg, &true_c), 0.0005);
    let f: Vec<f64> = p.trajectory.phase(Phase::Contact).map(|s| s.force).collect();
    assert!((f[0] - 40.0).abs() < 0.1 && (f[f.len() - 1] - 60.0).abs() < 0.1);
    assert!(f.windows(2).all(|w| w[1] >= w[0] - 1e-9));
    // Bad polyline files are bad input (exit 2), naming line and column.
    for (bad, needle) in [
        ("x_m,y_m\n0,0\n", "line 1"),
        ("x_m,y_m,z_m\n0,0,1\n0,zz,1\n", "line 3 column 2"),
        ("x_m,y_m,z_m\n0,0,1\n", "at least two"),
        ("x_m,y_m,z_m,force_n\n0,0,1,-4\n0,0,1,2\n", "line 2 column 4"),
    ] {
        std::fs::write(&file, bad).unwrap();
        let e = plan(&scene.input(), &cfg).unwrap_err();
        assert!(e.exit_code() == 2 && e.to_string().contains(needle), "{e}");
    }
    cfg.polyline.file = Some(dir.path().join("missing.csv"));
    assert_eq!(plan(&scene.input(), &cfg).unwrap_err().exit_code(), 2);
}

#[test]
fn clear_errors() {
    let c = bottle();
    let scene = Scene::cylinder(&c, 0.0005);
    let fails = |cfg: &PlanConfig, input: &PlanInput, needle: &str| {
        let e = plan(input, cfg).unwrap_err();
        assert_eq!(e.exit_code(), 1, "{e}");
        assert!(e.to_string().contains(needle), "{e}");
        assert!(!e.to_string().contains('\n'));
    };
    // A pattern that misses the object.
    let mut cfg = config(PatternKind::Raster);
    cfg.raster.offset_m = [2.0, 0.0];
    fails(&cfg, &scene.input(), "misses the object");
    let mut cfg = PlanConfig::default();
    cfg.ring.station_m = 0.5;
    fails(&cfg, &scene.input(), "misses the object");
    // A scan with no object.
    let empty = TriangleMesh::default();
    let mut input = scene.input();
    if let Some(o) = input.object.as_mut() {
        o.scan_surface = &empty;
    }
    fails(&PlanConfig::default(), &input, "no object surface");
    // A band wider than the surface: the camera saw ~140° of the ring, a raster row longer than
    // the scanned width, a ring band longer than the bottle.
    let mut cfg = PlanConfig::default();
    cfg.ring.arc_deg = 200.0;
    fails(&cfg, &scene.input(), "band wider than the surface");
    let mut cfg = config(PatternKind::Raster);
    cfg.raster.rows = RowDirection::Across;
    cfg.raster.width_m = 0.5;
    fails(&cfg, &scene.input(), "band wider than the surface");
    let mut cfg = PlanConfig::default();
    cfg.ring.width_m = 0.8;
    fails(&cfg, &scene.input(), "band wider than the surface");
    // ... which clipping trims to the scan instead.
    let mut cfg = PlanConfig::default();
    cfg.ring.arc_deg = 200.0;
    cfg.projection.clip = true;
    let p = plan(&scene.input(), &cfg).unwrap();
    assert!(p.report.clipped && p.report.arc_deg.unwrap() < 160.0);
    // The line needs a seabed plane; bad configuration values are bad input.
    let cfg = config(PatternKind::Line);
    fails(&cfg, &scene.input(), "seabed plane");
    let mut cfg = PlanConfig::default();
    cfg.timing.speed_m_s = -1.0;
    assert_eq!(plan(&scene.input(), &cfg).unwrap_err().exit_code(), 2);
    // Settings that would need absurd numbers of samples are refused before anything is
    // allocated.
    for set in [
        (|c: &mut PlanConfig| c.projection.step_m = 1e-9) as fn(&mut PlanConfig),
        |c| c.timing.sample_period_s = 1e-12,
        |c| c.timing.standoff_m = 1e9,
        |c| c.ring.width_m = 1e9,
        |c| c.timing.dwell_s = f64::INFINITY,
    ] {
        let mut cfg = PlanConfig::default();
        set(&mut cfg);
        assert_eq!(plan(&scene.input(), &cfg).unwrap_err().exit_code(), 2);
    }
    // Both of a count's factors are named: the step is as likely the mistake as the extent.
    let mut cfg = PlanConfig::default();
    (cfg.ring.width_m, cfg.ring.spacing_m) = (0.1, 1e-9);
    let e = plan(&scene.input(), &cfg).unwrap_err().to_string();
    assert!(
        e.starts_with("ring.width_m: at a spacing_m of 1e-9 m would need"),
        "{e}"
    );
    // A value that is no number, named by its own key (they were named together as "pattern").
    for (set, key) in [
        (
            (|c: &mut PlanConfig| c.ring.station_m = f64::NAN) as fn(&mut PlanConfig),
            "ring.station_m",
        ),
        (|c| c.line.offset_m[1] = f64::INFINITY, "line.offset_m[2]"),
    ] {
        let mut cfg = PlanConfig::default();
        set(&mut cfg);
        let e = plan(&scene.input(), &cfg).unwrap_err().to_string();
        assert_eq!(e, format!("{key}: must be a finite number"));
    }
}

#[test]
fn trajectory_file_round_trip_in_the_world_frame() {
    let c = bottle();
    let scene = Scene::cylinder(&c, 0.0005);
    let mut cfg = PlanConfig::default();
    cfg.timing.dwell_s = 2.0;
    let p = plan(&scene.input(), &cfg).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = uvms::output::OutDir::create(dir.path(), &[], &uvms::cli::plan::products()).unwrap();
    out.write_with("trajectory.csv", |w| p.trajectory.write_csv(w))
        .unwrap();
    let back = Trajectory::read_csv(&dir.path().join("trajectory.csv")).unwrap();
    assert_eq!(back.samples.len(), p.trajectory.samples.len());
    let phases: Vec<Phase> = back.samples.iter().map(|s| s.phase).collect();
    let firsts: Vec<Phase> = phases.iter().copied().fold(Vec::new(), |mut v, ph| {
        if v.last() != Some(&ph) {
            v.push(ph);
        }
        v
    });
    assert_eq!(
        firsts,
        [Phase::Approach, Phase::Dwell, Phase::Contact, Phase::Retreat]
    );
    assert!((back.phase(Phase::Dwell).count() as f64 - 40.0).abs() < 1.0);
    // World frame: with the default mounting the camera looks forward and down, so the bottle's
    // top (facing the camera) is pressed roughly along the optical axis: k has a component
    // forward (north) and down.
    let k = back
        .phase(Phase::Contact)
        .map(|s| s.k)
        .sum::<Vector3<f64>>()
        .normalize();
    let optical = cfg.frames.t_world_scan().rotation * Vector3::z();
    assert!(k.angle(&optical).to_degrees() < 5.0, "{k} vs {optical}");
    let text = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
    assert!(text.contains("# frame W: world, NED") && text.contains("# pattern: ring"));
}
