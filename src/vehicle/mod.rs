//! The vehicle: Fossen's rigid-body and hydrodynamic model ([`hydro`]) and its thrusters
//! ([`thrusters`]).

pub mod hydro;
pub mod thrusters;
