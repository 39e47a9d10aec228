//! clpt: a Monte Carlo path tracer with a Rust host and OpenCL C kernels, a port of a CUDA
//! course path tracer (see README.md for the map from the original's files to these).
//!
//! The data takes one road: scene file → [`scene`] → [`device::upload`] (packed f32 structs of
//! [`contract`], which `kernels/types.h` is written from) → [`device::program`] (the one
//! kernel loader) → [`render`] (passes of launches) → [`render::film`] (image files).

pub mod accel;
pub mod contract;
pub mod device;
pub mod error;
pub mod input;
pub mod output;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
