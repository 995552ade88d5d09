//! # uvms
//!
//! An underwater stereo scan taken all the way to a force-controlled contact operation by an AUV
//! carrying a 6-DOF manipulator, after Konoplin et al., J. Mar. Sci. Eng. 2024, 12, 1126.
//!
//! Layers: [`cloud`] and [`mesh`] hold the data, [`io`] reads and writes it, [`frames`] names the
//! transforms; the stages and the simulation build on those. [`cli`] is the command line.
//! Conventions: f64 everywhere, SI units, transforms `t_a_b` map `b` coordinates into `a`.

pub mod accuracy;
pub mod arm;
pub mod body;
pub mod cli;
pub mod cloud;
pub mod config;
pub mod error;
pub mod frames;
pub mod integrate;
pub mod io;
pub mod mesh;
pub mod model;
pub mod multibody;
pub mod output;
pub mod perception;
pub mod plan;
pub mod plant;
pub mod plot;
pub mod register;
pub mod segment;
pub mod sim;
pub mod spatial;
pub mod spatial_algebra;
pub mod surface;
pub mod synth;
pub mod trajectory;
pub mod triangulate;
pub mod vehicle;

pub use error::{Error, Result};
