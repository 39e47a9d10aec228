//! Kernels whose arguments are given by name: each is bound under its parameter's name (ocl's
//! named arguments, so a launch sets it by that name too), and where the driver reports the
//! program's parameter names (OpenCL 1.2 argument info: PoCL always, others for programs built
//! from source with it) they are checked against them, so an argument bound out of order or
//! under a wrong name is an error when the kernel is made, not a wrong image.

use crate::contract::SceneBuffers;
use crate::error::{Error, Result};
use ocl::enums::{KernelArgInfo, KernelArgInfoResult};
use ocl::{Buffer, OclPrm};

/// A kernel being given its arguments, each by name, in the kernel's order.
pub struct NamedArgs<'b> {
    builder: ocl::builders::KernelBuilder<'b>,
    kernel: String,
    names: Vec<&'static str>,
}

impl<'b> NamedArgs<'b> {
    /// Kernel `kernel` of `program`, launched on `queue`.
    pub fn new(program: &'b ocl::Program, kernel: &str, queue: &ocl::Queue) -> Self {
        let mut builder = ocl::Kernel::builder();
        builder.program(program).name(kernel).queue(queue.clone());
        // SAFETY: this only turns off ocl's check of each argument's element type, which would
        // refuse the scene's buffers: they are bytes on the host (packed `contract` structs,
        // whose layout the device probe checks) and typed pointers in the kernels. Names are
        // checked in `build` instead.
        unsafe { builder.disable_arg_type_check() };
        NamedArgs {
            builder,
            kernel: kernel.to_string(),
            names: Vec::new(),
        }
    }

    pub fn global_work_size(&mut self, size: impl Into<ocl::SpatialDims>) -> &mut Self {
        self.builder.global_work_size(size);
        self
    }

    pub fn buffer<T: OclPrm>(&mut self, name: &'static str, buffer: &'b Buffer<T>) -> &mut Self {
        self.builder.arg_named(name, buffer);
        self.names.push(name);
        self
    }

    /// A buffer argument set by name before each launch (`Kernel::set_arg`).
    pub fn buffer_later<T: OclPrm>(&mut self, name: &'static str) -> &mut Self {
        self.builder.arg_named(name, None::<&Buffer<T>>);
        self.names.push(name);
        self
    }

    pub fn scalar<T: OclPrm>(&mut self, name: &'static str, value: T) -> &mut Self {
        self.builder.arg_named(name, value);
        self.names.push(name);
        self
    }

    /// Every scene buffer, under its name in `SCENE_BUFFERS` (src/contract/buffers.rs).
    pub fn scene(&mut self, buffers: &'b SceneBuffers<Buffer<u8>>) -> &mut Self {
        for (name, buffer) in buffers.named() {
            self.buffer(name, buffer);
        }
        self
    }

    /// The kernel, its argument names checked against the program's where the driver reports
    /// them.
    pub fn build(&mut self) -> Result<ocl::Kernel> {
        let what = format!("creating kernel {}", self.kernel);
        let kernel = self.builder.build().map_err(|e| Error::opencl(&what, e))?;
        for (i, want) in self.names.iter().enumerate() {
            match kernel.arg_info(i as u32, KernelArgInfo::Name) {
                Ok(KernelArgInfoResult::Name(have)) if have == *want => {}
                Ok(KernelArgInfoResult::Name(have)) => {
                    return Err(Error::opencl(
                        what,
                        format!("argument {i} is `{have}` in the kernel, `{want}` on the host"),
                    ));
                }
                // No argument information from this driver for this program: nothing to check.
                _ => break,
            }
        }
        Ok(kernel)
    }
}
