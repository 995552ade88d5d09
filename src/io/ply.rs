//! PLY files: clouds (with optional colours and normals) and triangle meshes.
//!
//! Reading ([`read_cloud`], [`read_mesh`], [`read_ply`]) accepts the three encodings of the
//! format (ascii, binary little- and big-endian) and:
//! - `element vertex` with `x`, `y`, `z` as `float` or `double` (any other type is rejected);
//!   optional `red`/`green`/`blue` (`uchar` as is, `ushort` divided by 257, `float`/`double`
//!   taken as 0..1 and scaled by 255, rounded and clamped, a NaN as 0: a colour only paints) and
//!   `nx`/`ny`/`nz` (`float`/`double`);
//!   a colour or normal triple is used only when all three properties are present;
//! - `element face` with a `vertex_indices` (or `vertex_index`) list of any integer type;
//!   polygons of n > 3 vertices are fan-triangulated into n − 2 triangles `(v0, vk, vk+1)`;
//! - any other element or property is skipped (but still walked, so a truncated payload is
//!   caught).
//!
//! Vertices whose position is not finite are dropped and counted ([`PlyInfo::non_finite_dropped`]);
//! the remaining vertices keep their order and are renumbered, and a triangle that uses a
//! dropped vertex is dropped too ([`PlyInfo::triangles_dropped`]; [`read_mesh`], which reads a
//! surface, refuses such a mesh). A normal that is not finite is
//! kept as read.
//!
//! Every malformed file is an [`Error::Input`] naming the file and the problem in one line. The
//! element counts of the header are checked against the bytes that follow it **before** anything
//! is allocated, so a header claiming 10^12 vertices in a 200-byte file is rejected at once.
//! Binary records without lists are decoded straight from the bytes at a fixed stride.
//!
//! Writing: binary little-endian, `double` coordinates and normals, `uchar` colours,
//! `element face` with `list uchar int vertex_indices`; line sets ([`write_lines`]) with
//! `uchar` vertex colours and `element edge` (`int vertex1`, `int vertex2`).

use super::ply_read::{self, Faces};
use crate::cloud::PointCloud;
use crate::error::{Error, Result};
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Vector3};
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// What a PLY file held, as read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlyInfo {
    /// `ascii`, `binary_little_endian` or `binary_big_endian`.
    pub encoding: String,
    /// The vertex count the header declares.
    pub vertices_in_header: u64,
    /// Vertices read with a finite position (the points of the cloud).
    pub points: usize,
    /// Vertices dropped because a coordinate was NaN or infinite.
    pub non_finite_dropped: usize,
    /// The face count the header declares (0 without a `face` element).
    pub faces: u64,
    /// Triangles after fan triangulation, or `None` when the faces were not read
    /// ([`read_cloud`] skips them).
    pub triangles: Option<usize>,
    /// Triangles dropped because they use a dropped (non-finite) vertex.
    pub triangles_dropped: usize,
    /// The cloud carries colours.
    pub has_colors: bool,
    /// The cloud carries normals.
    pub has_normals: bool,
    /// Every element of the header, in order, with its properties as declared.
    pub elements: Vec<ElementInfo>,
    /// Smallest corner of the axis-aligned bounding box of the points, metres (`None` if empty).
    pub bbox_min: Option<[f64; 3]>,
    /// Largest corner of the axis-aligned bounding box of the points, metres (`None` if empty).
    pub bbox_max: Option<[f64; 3]>,
}

/// One element of a PLY header.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ElementInfo {
    /// Element name (`vertex`, `face`, ...).
    pub name: String,
    /// Record count the header declares.
    pub count: u64,
    /// Properties as the header declares them (`float x`, `list uchar int vertex_indices`).
    pub properties: Vec<String>,
}

/// A whole PLY file: its vertices as a cloud, its faces as triangles, and what was read.
#[derive(Debug, Clone, PartialEq)]
pub struct PlyData {
    /// The finite vertices, with colours and normals when the file has them.
    pub cloud: PointCloud,
    /// Triangles indexing `cloud.points` (empty when the file has no faces).
    pub triangles: Vec<[u32; 3]>,
    /// What was read.
    pub info: PlyInfo,
}

/// Reads a PLY file's vertices as a point cloud (faces, if any, are skipped).
///
/// # Errors
/// [`Error::Input`] naming `path` and the problem: missing file, directory, malformed header,
/// counts the file cannot hold, truncated payload, `x`/`y`/`z` missing or not float/double, ...
pub fn read_cloud(path: &Path) -> Result<(PointCloud, PlyInfo)> {
    let p = ply_read::read(path, Faces::Skip)?;
    Ok((p.cloud, p.info))
}

/// Reads a PLY mesh: its finite vertices and its faces, fan-triangulated. A vertex that is not
/// finite and that no face uses is dropped; one that a face uses is an error (the surface would
/// have a hole there: a tool would fall through it, a model would lose part of its shape).
///
/// # Errors
/// As [`read_cloud`], plus: no `face` element, a face without a `vertex_indices`/`vertex_index`
/// integer list, a face with fewer than 3 indices, an index out of range, or a face using a
/// vertex that is not finite.
pub fn read_mesh(path: &Path) -> Result<TriangleMesh> {
    let p = ply_read::read(path, Faces::Read)?;
    if !p.has_face_element {
        return Err(Error::input(
            path.display(),
            "the header declares no 'face' element: a point cloud, not a mesh",
        ));
    }
    refuse_holes(path, &p.info)?;
    Ok(TriangleMesh {
        vertices: p.cloud.points,
        triangles: p.triangles,
    })
}

/// Refuses the faces of `path` if any uses a vertex whose position is not finite (`info` from
/// reading it): the surface would have a hole there.
///
/// # Errors
/// [`Error::Input`] naming the file and the count.
pub fn refuse_holes(path: &Path, info: &PlyInfo) -> Result<()> {
    if info.triangles_dropped > 0 {
        return Err(Error::input(
            path.display(),
            format!(
                "{} triangles use a vertex whose position is not finite (NaN or infinite; {} such vertices): the surface would have holes there",
                info.triangles_dropped, info.non_finite_dropped
            ),
        ));
    }
    Ok(())
}

/// Reads everything: vertices (with colours and normals), faces (validated and triangulated when
/// the file has them; a face using a vertex that is not finite is dropped and counted in the
/// [`PlyInfo`], for [`refuse_holes`]) and the [`PlyInfo`].
///
/// # Errors
/// As [`read_cloud`], plus a face element [`read_mesh`] refuses on its own terms (not the
/// vertices that are not finite).
pub fn read_ply(path: &Path) -> Result<PlyData> {
    let p = ply_read::read(path, Faces::Read)?;
    Ok(PlyData {
        cloud: p.cloud,
        triangles: p.triangles,
        info: p.info,
    })
}

fn header(
    w: &mut dyn Write,
    vertices: usize,
    colors: bool,
    normals: bool,
    faces: Option<usize>,
) -> std::io::Result<()> {
    writeln!(w, "ply\nformat binary_little_endian 1.0\ncomment written by uvms")?;
    writeln!(w, "element vertex {vertices}")?;
    writeln!(w, "property double x\nproperty double y\nproperty double z")?;
    if normals {
        writeln!(w, "property double nx\nproperty double ny\nproperty double nz")?;
    }
    if colors {
        writeln!(w, "property uchar red\nproperty uchar green\nproperty uchar blue")?;
    }
    if let Some(f) = faces {
        writeln!(w, "element face {f}\nproperty list uchar int vertex_indices")?;
    }
    writeln!(w, "end_header")
}

/// Writes vertices (with optional colours and normals, one per point) and optional triangles.
fn write_binary(
    w: &mut dyn Write,
    points: &[Point3<f64>],
    colors: Option<&[[u8; 3]]>,
    normals: Option<&[Vector3<f64>]>,
    triangles: Option<&[[u32; 3]]>,
) -> Result<()> {
    let io = |e: std::io::Error| Error::failed("write PLY", e);
    if colors.is_some_and(|c| c.len() != points.len()) || normals.is_some_and(|n| n.len() != points.len()) {
        return Err(Error::failed(
            "write PLY",
            "colours or normals do not match the points",
        ));
    }
    header(
        w,
        points.len(),
        colors.is_some(),
        normals.is_some(),
        triangles.map(<[_]>::len),
    )
    .map_err(io)?;
    let n_tri = triangles.map_or(0, <[_]>::len);
    let mut buf = Vec::with_capacity(points.len() * 51 + n_tri * 13);
    for (i, p) in points.iter().enumerate() {
        for v in p.coords.iter() {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(n) = normals.and_then(|n| n.get(i)) {
            for v in n.iter() {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        if let Some(c) = colors.and_then(|c| c.get(i)) {
            buf.extend_from_slice(c);
        }
    }
    for t in triangles.unwrap_or_default() {
        buf.push(3);
        for &i in t {
            let i = i32::try_from(i).map_err(|_| Error::failed("write PLY", "vertex index exceeds int"))?;
            buf.extend_from_slice(&i.to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io)
}

/// Writes a cloud as binary little-endian PLY (with its colours and normals when present).
///
/// # Errors
/// [`Error::Failed`] if the writer fails.
pub fn write_cloud(w: &mut dyn Write, cloud: &PointCloud) -> Result<()> {
    write_binary(
        w,
        &cloud.points,
        cloud.colors.as_deref(),
        cloud.normals.as_deref(),
        None,
    )
}

/// Writes a triangle mesh as binary little-endian PLY.
///
/// # Errors
/// [`Error::Failed`] if the writer fails or an index does not fit a PLY `int`.
pub fn write_mesh(w: &mut dyn Write, mesh: &TriangleMesh) -> Result<()> {
    write_binary(w, &mesh.vertices, None, None, Some(&mesh.triangles))
}

/// Writes a cloud (with its colours and normals) and triangles over its points as binary
/// little-endian PLY: what [`read_ply`] reads back, exactly (`double` positions and normals).
///
/// # Errors
/// [`Error::Failed`] if the writer fails or an index does not fit a PLY `int`.
pub fn write_ply(w: &mut dyn Write, cloud: &PointCloud, triangles: &[[u32; 3]]) -> Result<()> {
    write_binary(
        w,
        &cloud.points,
        cloud.colors.as_deref(),
        cloud.normals.as_deref(),
        Some(triangles),
    )
}

/// Writes a line set as binary little-endian PLY: coloured vertices and an `edge` element
/// (`vertex1`, `vertex2`), which CloudCompare, MeshLab and Open3D's `read_line_set` display.
///
/// # Errors
/// [`Error::Failed`] if the writer fails, `colors` does not have one entry per point, or an
/// edge index is out of range.
pub fn write_lines(
    w: &mut dyn Write,
    points: &[Point3<f64>],
    colors: &[[u8; 3]],
    edges: &[[u32; 2]],
) -> Result<()> {
    let io = |e: std::io::Error| Error::failed("write PLY", e);
    if colors.len() != points.len() {
        return Err(Error::failed("write PLY", "one colour per line vertex is needed"));
    }
    if edges
        .iter()
        .flatten()
        .any(|&i| i as usize >= points.len() || i > i32::MAX as u32)
    {
        return Err(Error::failed("write PLY", "an edge index is out of range"));
    }
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment written by uvms\nelement vertex {}\n\
         property double x\nproperty double y\nproperty double z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element edge {}\nproperty int vertex1\nproperty int vertex2\nend_header\n",
        points.len(),
        edges.len()
    )
    .map_err(io)?;
    let mut buf = Vec::with_capacity(points.len() * 27 + edges.len() * 8);
    for (p, c) in points.iter().zip(colors) {
        for v in p.coords.iter() {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(c);
    }
    for e in edges {
        for &i in e {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh whose triangle uses a vertex that is not finite is refused (a hole in the
    /// surface), naming the file; a non-finite vertex no face uses is dropped.
    #[test]
    fn a_mesh_with_a_non_finite_vertex_in_a_face_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = |name: &str, faces: &str| {
            let path = dir.path().join(name);
            std::fs::write(
                &path,
                format!(
                    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                     property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                     end_header\n0 0 0\n1 0 0\n0 1 0\nnan 0 0\n{faces}\n"
                ),
            )
            .unwrap();
            path
        };
        let unused = read_mesh(&mesh("unused.ply", "3 0 1 2")).unwrap();
        assert_eq!((unused.vertices.len(), unused.triangles.len()), (3, 1));
        let path = mesh("used.ply", "3 0 1 3");
        let e = read_mesh(&path).unwrap_err().to_string();
        assert!(
            e.contains("used.ply") && e.contains("1 triangles use a vertex whose position is not finite"),
            "{e}"
        );
    }
}
