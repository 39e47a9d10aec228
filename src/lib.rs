//! clpt: a Monte Carlo path tracer with a Rust host and OpenCL C kernels, a port of a CUDA
//! course path tracer (see README.md for the map from the original's files to these).
//!
//! The layers, each using only those before it: [`contract`] (the structs and constants shared
//! with the kernels, which `kernels/types.h` is written from), [`accel`] (trees), [`elements`]
//! (what a scene is made of below its objects, and the scene file's syntax), [`pack`] (the
//! device's arrays, the light list), [`shapes`] (each kind of object: its block in a scene
//! file, its packing), [`scene`] (a whole scene file, and its packing), [`device`] (upload, the
//! one kernel loader [`device::program`]), [`render`] (passes of launches, [`render::film`]'s
//! image files). A scene file takes that road: parsed by [`scene`] and the kinds' blocks,
//! packed into [`pack`]'s arrays by the kinds, uploaded, rendered.

pub mod accel;
pub mod contract;
pub mod device;
pub mod elements;
pub mod error;
pub mod input;
pub mod output;
pub mod pack;
pub mod render;
pub mod scene;
pub mod shapes;

pub use error::{Error, Result};
