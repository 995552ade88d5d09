//! Segmentation of a scan: seabed removal, Euclidean clustering of what stands on it, and the
//! choice of the cluster that matches the reference model.

pub mod cluster;
pub mod seabed;
pub mod select;
