//! The host–kernel contract, declared once: every shared constant and struct (`types.rs`) and
//! the scene buffer list (`buffers.rs`). `kernels/types.h` is written from them ([`header`]);
//! the device's layout probe (`device::layout`) checks every size, offset and constant on the
//! device against them. A leaf module: it uses nothing else of the crate.

#[macro_use]
mod describe;
mod buffers;
pub mod header;
mod types;

pub use buffers::*;
pub use describe::{CType, ConstDef, Field, Item, StructDef};
pub use types::*;
