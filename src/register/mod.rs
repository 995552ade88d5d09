//! Registration of the reference model to the scanned object: hidden-point removal, a global
//! initial guess that the object's symmetries cannot fool, and point-to-plane ICP.

pub mod hidden_points;
pub mod icp;
