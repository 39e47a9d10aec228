//! clpt: a Monte Carlo path tracer with a Rust host and OpenCL C kernels, a port of a CUDA
//! course path tracer (see README.md for the map from the original's files to these).
//!
//! The data takes one road: scene file → [`scene`] (and [`accel`], its trees) → [`pack`] (the
//! f32 structs of [`contract`], which `kernels/types.h` is written from) → [`device`] (upload,
//! the one kernel loader [`device::program`]) → [`render`] (passes of launches) →
//! [`render::film`] (image files). Each layer uses only those before it.

pub mod accel;
pub mod contract;
pub mod device;
pub mod error;
pub mod input;
pub mod output;
pub mod pack;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
