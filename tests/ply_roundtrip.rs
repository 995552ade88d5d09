//! Round trip: a PLY written by an independent writer (ply-rs-bw) in ascii, binary little-endian
//! and binary big-endian is read by uvms, written back by uvms and read again; points, colours,
//! normals and faces must come back bit for bit, equal to the values the file was made from.

use nalgebra::{Point3, Vector3};
use ply_rs_bw::ply::{
    Addable, DefaultElement, ElementDef, Encoding, Ply, Property, PropertyDef, PropertyType, ScalarType,
};
use rand::{RngExt, SeedableRng};
use std::path::Path;
use uvms::io::ply::{read_cloud, read_mesh, read_ply, write_ply};

/// Ground truth: vertices (x, z as double, y as float), colours, float normals, polygons.
struct Truth {
    points: Vec<Point3<f64>>,
    colors: Vec<[u8; 3]>,
    normals: Vec<Vector3<f64>>,
    polygons: Vec<Vec<u32>>,
}

fn truth(n: usize) -> Truth {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(11);
    let points = (0..n)
        .map(|_| {
            Point3::new(
                rng.random_range(-3.0..3.0),
                f64::from(rng.random_range(-1.0f32..1.0)),
                rng.random_range(0.1..9.0),
            )
        })
        .collect();
    let colors = (0..n)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    let normals = (0..n)
        .map(|_| Vector3::new(0.0, 0.6, 0.8).map(|v: f64| f64::from(v as f32)))
        .collect();
    let polygons = (0..n / 2)
        .map(|i| {
            let len = 3 + i % 3; // triangles, quads, pentagons
            (0..len).map(|_| rng.random_range(0..n as u32)).collect()
        })
        .collect();
    Truth {
        points,
        colors,
        normals,
        polygons,
    }
}

fn write_with_ply_rs(t: &Truth, encoding: Encoding, path: &Path) {
    let mut ply = Ply::<DefaultElement>::new();
    ply.header.encoding = encoding;
    let scalar = |name: &str, ty| PropertyDef::new(name.into(), PropertyType::Scalar(ty));
    let mut vertex = ElementDef::new("vertex".into());
    vertex.properties.add(scalar("x", ScalarType::Double));
    vertex.properties.add(scalar("y", ScalarType::Float));
    vertex.properties.add(scalar("confidence", ScalarType::UShort)); // unknown: skipped
    vertex.properties.add(scalar("z", ScalarType::Double));
    vertex.properties.add(scalar("red", ScalarType::UChar));
    vertex.properties.add(scalar("green", ScalarType::UChar));
    vertex.properties.add(scalar("blue", ScalarType::UChar));
    for n in ["nx", "ny", "nz"] {
        vertex.properties.add(scalar(n, ScalarType::Float));
    }
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".into());
    face.properties.add(PropertyDef::new(
        "vertex_indices".into(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    ply.header.elements.add(face);
    let mut extra = ElementDef::new("camera".into());
    extra.properties.add(scalar("view_px", ScalarType::Float));
    ply.header.elements.add(extra);

    let vertices = (0..t.points.len())
        .map(|i| {
            let mut e = DefaultElement::new();
            let (p, c, n) = (t.points[i], t.colors[i], t.normals[i]);
            e.insert("x".into(), Property::Double(p.x));
            e.insert("y".into(), Property::Float(p.y as f32));
            e.insert("confidence".into(), Property::UShort(7));
            e.insert("z".into(), Property::Double(p.z));
            e.insert("red".into(), Property::UChar(c[0]));
            e.insert("green".into(), Property::UChar(c[1]));
            e.insert("blue".into(), Property::UChar(c[2]));
            e.insert("nx".into(), Property::Float(n.x as f32));
            e.insert("ny".into(), Property::Float(n.y as f32));
            e.insert("nz".into(), Property::Float(n.z as f32));
            e
        })
        .collect();
    let faces = t
        .polygons
        .iter()
        .map(|poly| {
            let mut e = DefaultElement::new();
            e.insert(
                "vertex_indices".into(),
                Property::ListInt(poly.iter().map(|&i| i as i32).collect()),
            );
            e
        })
        .collect();
    let mut cam = DefaultElement::new();
    cam.insert("view_px".into(), Property::Float(1.5));
    ply.payload.insert("vertex".into(), vertices);
    ply.payload.insert("face".into(), faces);
    ply.payload.insert("camera".into(), vec![cam]);
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    ply_rs_bw::writer::Writer::new()
        .write_ply(&mut out, &mut ply)
        .unwrap();
}

#[test]
fn ascii_le_and_be_round_trip_exactly() {
    let t = truth(300);
    let expected_triangles: Vec<[u32; 3]> = t
        .polygons
        .iter()
        .flat_map(|p| (1..p.len() - 1).map(move |k| [p[0], p[k], p[k + 1]]))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    for (encoding, name) in [
        (Encoding::Ascii, "ascii"),
        (Encoding::BinaryLittleEndian, "binary_little_endian"),
        (Encoding::BinaryBigEndian, "binary_big_endian"),
    ] {
        let input = dir.path().join(format!("{name}.ply"));
        write_with_ply_rs(&t, encoding, &input);
        let first = read_ply(&input).unwrap();
        assert_eq!(first.info.encoding, name);
        assert_eq!(first.cloud.points, t.points, "{name}");
        assert_eq!(first.cloud.colors.as_ref(), Some(&t.colors), "{name}");
        assert_eq!(first.cloud.normals.as_ref(), Some(&t.normals), "{name}");
        assert_eq!(first.triangles, expected_triangles, "{name}");
        assert_eq!(first.info.faces, t.polygons.len() as u64);

        let again = dir.path().join(format!("{name}.again.ply"));
        let mut f = std::fs::File::create(&again).unwrap();
        write_ply(&mut f, &first.cloud, &first.triangles).unwrap();
        drop(f);
        let second = read_ply(&again).unwrap();
        assert_eq!(second.cloud, first.cloud, "{name}");
        assert_eq!(second.triangles, first.triangles, "{name}");

        // The narrower readers agree.
        let (cloud, info) = read_cloud(&input).unwrap();
        assert_eq!(cloud, first.cloud);
        assert_eq!(info.triangles, None);
        let mesh = read_mesh(&input).unwrap();
        assert_eq!(mesh.vertices, t.points);
        assert_eq!(mesh.triangles, expected_triangles);
    }
}
