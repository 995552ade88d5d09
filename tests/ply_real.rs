//! Every PLY in the real-data folder reads with the point count and bounding box
//! `shared/data/real/SOURCES.md` gives (counts and boxes written by the people who converted the
//! files, with Open3D + plyfile, not by uvms).

mod common;

use uvms::io::ply::read_cloud;

/// (file, points, has colours, bbox min, bbox max, tolerance) as SOURCES.md lists them (boxes to
/// the digits it gives, hence the tolerance of half a unit in the last digit).
type Expected = (&'static str, usize, bool, [f64; 3], [f64; 3], f64);
const FILES: &[Expected] = &[
    (
        "table_scene_mug_stereo_textured.ply",
        209280,
        true,
        [-0.456, -0.511, 0.690],
        [0.715, 0.179, 2.593],
        5e-4,
    ),
    (
        "milk_cartoon_all_small_clorox.ply",
        241407,
        true,
        [-1.061, -0.869, 0.501],
        [1.152, 0.220, 2.063],
        5e-4,
    ),
    (
        "milk.ply",
        13704,
        true,
        [-0.140, -0.264, 0.714],
        [0.014, -0.012, 0.891],
        5e-4,
    ),
    (
        "bun000.ply",
        40256,
        false,
        [-0.0948, 0.0357, -0.0587],
        [0.0610, 0.1879, 0.0587],
        5e-5,
    ),
    (
        "bun045.ply",
        40097,
        false,
        [-0.0632, 0.0342, -0.0452],
        [0.0840, 0.1876, 0.0935],
        5e-5,
    ),
    (
        "bun090.ply",
        30379,
        false,
        [-0.0593, 0.0350, -0.0748],
        [0.0620, 0.1879, 0.0609],
        5e-5,
    ),
    (
        "bun180.ply",
        40251,
        false,
        [-0.0615, 0.0341, -0.0339],
        [0.0948, 0.1876, 0.0612],
        5e-5,
    ),
    (
        "bun270.ply",
        31701,
        false,
        [-0.0622, 0.0347, -0.0113],
        [0.0590, 0.1876, 0.0943],
        5e-5,
    ),
    (
        "bun315.ply",
        35336,
        false,
        [-0.0735, 0.0341, -0.0195],
        [0.0735, 0.1869, 0.1006],
        5e-5,
    ),
    (
        "chin.ply",
        37738,
        false,
        [-0.0712, 0.0340, -0.0152],
        [0.1035, 0.1664, 0.1448],
        5e-5,
    ),
    (
        "ear_back.ply",
        32193,
        false,
        [-0.0840, 0.0258, 0.0037],
        [0.1065, 0.1875, 0.1151],
        5e-5,
    ),
];

#[test]
fn every_real_file_reads_with_the_documented_counts() {
    for &(file, points, colours, lo, hi, tol) in FILES {
        let Some(path) = common::real_data(file) else {
            return;
        };
        let (cloud, info) = read_cloud(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(cloud.len(), points, "{file}");
        assert_eq!(info.points, points, "{file}");
        assert_eq!(info.vertices_in_header, points as u64, "{file}");
        assert_eq!(info.non_finite_dropped, 0, "{file}");
        assert_eq!(cloud.colors.is_some(), colours, "{file}");
        assert_eq!(info.encoding, "binary_little_endian", "{file}");
        let (bmin, bmax) = cloud.bbox().unwrap();
        for k in 0..3 {
            assert!(
                (bmin[k] - lo[k]).abs() <= tol,
                "{file}: bbox min {bmin} vs {lo:?}"
            );
            assert!(
                (bmax[k] - hi[k]).abs() <= tol,
                "{file}: bbox max {bmax} vs {hi:?}"
            );
        }
    }
}

/// milk.ply is an exact crop of the scene (SOURCES.md): every model point is also a scene point.
#[test]
fn milk_model_is_an_exact_crop_of_the_scene() {
    let (Some(model), Some(scene)) = (
        common::real_data("milk.ply"),
        common::real_data("milk_cartoon_all_small_clorox.ply"),
    ) else {
        return;
    };
    let (model, _) = read_cloud(&model).unwrap();
    let (scene, _) = read_cloud(&scene).unwrap();
    let key = |p: &nalgebra::Point3<f64>| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let set: std::collections::HashSet<_> = scene.points.iter().map(key).collect();
    assert!(model.points.iter().all(|p| set.contains(&key(p))));
}
