//! Reading and writing files: PLY clouds and meshes.

pub mod ply;
mod ply_read;
