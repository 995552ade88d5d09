//! PLY files: clouds (with optional colours and normals) and triangle meshes.
//!
//! Writing: binary little-endian, `double` coordinates and normals, `uchar` colours,
//! `element face` with `list uchar int vertex_indices`.

use crate::cloud::PointCloud;
use crate::error::{Error, Result};
use crate::mesh::TriangleMesh;
use std::io::Write;

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

/// Writes a cloud as binary little-endian PLY (with its colours and normals when present).
///
/// # Errors
/// [`Error::Failed`] if the writer fails.
pub fn write_cloud(w: &mut dyn Write, cloud: &PointCloud) -> Result<()> {
    let io = |e: std::io::Error| Error::failed("write PLY", e);
    header(
        w,
        cloud.len(),
        cloud.colors.is_some(),
        cloud.normals.is_some(),
        None,
    )
    .map_err(io)?;
    let mut buf = Vec::with_capacity(cloud.len() * 51);
    for (i, p) in cloud.points.iter().enumerate() {
        for v in p.coords.iter() {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(n) = &cloud.normals {
            for v in n[i].iter() {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        if let Some(c) = &cloud.colors {
            buf.extend_from_slice(&c[i]);
        }
    }
    w.write_all(&buf).map_err(io)
}

/// Writes a triangle mesh as binary little-endian PLY.
///
/// # Errors
/// [`Error::Failed`] if the writer fails or an index does not fit a PLY `int`.
pub fn write_mesh(w: &mut dyn Write, mesh: &TriangleMesh) -> Result<()> {
    let io = |e: std::io::Error| Error::failed("write PLY", e);
    header(w, mesh.vertices.len(), false, false, Some(mesh.triangles.len())).map_err(io)?;
    let mut buf = Vec::with_capacity(mesh.vertices.len() * 24 + mesh.triangles.len() * 13);
    for p in &mesh.vertices {
        for v in p.coords.iter() {
            buf.extend_from_slice(&v.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        buf.push(3);
        for &i in t {
            let i = i32::try_from(i).map_err(|_| Error::failed("write PLY", "vertex index exceeds int"))?;
            buf.extend_from_slice(&i.to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io)
}
