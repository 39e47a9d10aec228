//! The layout probe: builds `offsetof` and `sizeof` of every shared struct and field, and
//! every shared constant, on the device, and compares them with the host's declarations
//! ([`crate::contract`], which `kernels/types.h` is written from). A driver whose compiler
//! lays a struct out otherwise fails here, before any render.

use crate::contract::{ITEMS, Item};

/// The OpenCL source of the layout probe: one kernel writing, for every shared struct, its
/// `sizeof` and then each field's offset, and then every shared constant.
pub fn probe_source() -> String {
    let mut src = String::from(
        "#include \"types.h\"\n\
         #define CLPT_OFFSETOF(T, f) ((uint)(size_t)&(((T*)0)->f))\n\
         __kernel void probe_layout(__global uint* out) {\n    uint i = 0u;\n",
    );
    for (what, _) in expected() {
        src.push_str(&format!("    out[i++] = (uint){what};\n"));
    }
    src.push_str("}\n");
    src
}

/// Every value the probe reads on the device, as C text, with the host's value: each struct's
/// `sizeof`, each field's offset, each constant.
fn expected() -> Vec<(String, u64)> {
    let mut all = Vec::new();
    for item in ITEMS {
        match item {
            Item::Struct(s) => {
                all.push((format!("sizeof({})", s.name), s.size as u64));
                for f in s.fields {
                    let offset = format!("CLPT_OFFSETOF({}, {})", s.name, f.name);
                    all.push((offset, f.offset as u64));
                }
            }
            Item::Const(c) => all.push((format!("({})", c.name), u64::from(c.value))),
        }
    }
    all
}

/// Builds and runs the layout probe on `device` and compares every size, offset and shared
/// constant with Rust's.
pub fn verify(
    device: &super::Device,
    sources: &super::program::KernelSources,
) -> crate::Result<()> {
    use crate::Error;
    let expected = expected();
    let source = sources.expand_text("layout_probe.cl", &probe_source())?;
    let built = super::program::build(
        device,
        source,
        super::program::build_options(&device.description, &[]),
        None,
    )?;
    let out = ocl::Buffer::<u32>::builder()
        .queue(device.queue.clone())
        .len(expected.len())
        .fill_val(u32::MAX)
        .build()
        .map_err(|e| Error::opencl("allocating the layout probe", e))?;
    let kernel = super::kernel::NamedArgs::new(&built.program, "probe_layout", &device.queue)
        .global_work_size(1)
        .buffer("out", &out)
        .build()?;
    // SAFETY: one work-item writes expected.len() words into a buffer of that length.
    unsafe { kernel.enq() }.map_err(|e| Error::opencl("running the layout probe", e))?;
    let mut got = vec![0u32; expected.len()];
    out.read(&mut got)
        .enq()
        .map_err(|e| Error::opencl("reading the layout probe", e))?;
    let wrong: Vec<String> = expected
        .iter()
        .zip(&got)
        .filter(|((_, want), have)| *want != u64::from(**have))
        .map(|((what, want), have)| format!("{what}: host {want}, device {have}"))
        .collect();
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(Error::Layout(wrong.join("; ")))
    }
}
