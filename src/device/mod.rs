//! OpenCL platforms and devices: discovery, choice (`--device`, `CLPT_DEVICE`), and the
//! context and queue a render runs on. Kernel building lives in [`program`] (its on-disk cache in
//! [`cache`]), binding kernel arguments by name in [`kernel`], the device probe of the shared
//! layouts ([`crate::contract`]) in [`layout`], uploading the packed scene ([`crate::pack`]) in
//! [`upload`].

pub mod cache;
pub mod kernel;
pub mod layout;
pub mod program;
pub mod upload;

use crate::error::{Error, Result};
use ocl::enums::{DeviceInfo as Info, DeviceInfoResult as InfoResult};
use std::fmt;

/// The environment variable that picks a device when `--device` is not given.
pub const DEVICE_ENV: &str = "CLPT_DEVICE";

/// Whether `wanted` names device `d`: it begins a word (a run of letters and digits) of the
/// device's or the platform's name, ignoring case, and has at least two characters.
pub fn names_device(wanted: &str, d: &DeviceDescription) -> bool {
    let wanted = wanted.trim().to_lowercase();
    wanted.chars().count() >= 2
        && [&d.name, &d.platform].iter().any(|name| {
            let name = name.to_lowercase();
            name.char_indices().any(|(i, c)| {
                c.is_alphanumeric()
                    && name[..i]
                        .chars()
                        .next_back()
                        .is_none_or(|p| !p.is_alphanumeric())
                    && name[i..].starts_with(&wanted)
            })
        })
}

/// What `clpt devices` shows about one device.
#[derive(Clone, Debug)]
pub struct DeviceDescription {
    /// Position in the list of all devices of all platforms, as `--device` takes it.
    pub index: usize,
    pub platform: String,
    /// The platform's version string (part of the program cache's key).
    pub platform_version: String,
    pub name: String,
    pub kind: String,
    pub compute_units: u32,
    pub global_mem_bytes: u64,
    /// The largest single buffer the device allocates (CL_DEVICE_MAX_MEM_ALLOC_SIZE).
    pub max_alloc_bytes: u64,
    pub opencl_c_version: String,
    pub driver_version: String,
    pub is_gpu: bool,
    /// CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT: the floats one SIMD instruction takes (a CPU's
    /// 8 with AVX2, 16 with AVX-512; 1 on GPUs), the lanes a work-item carries there
    /// (render/features.rs `wide_lanes`).
    pub native_float_width: u32,
    /// Whether the driver stops a kernel that runs too long (a display's watchdog): NVIDIA's
    /// CL_DEVICE_KERNEL_EXEC_TIMEOUT_NV (cl_nv_device_attribute_query); `None` where the
    /// device does not say.
    pub watchdog: Option<bool>,
    /// Whether the compiler takes NVIDIA's `-cl-nv-*` build options (cl_nv_compiler_options):
    /// the register cap of [`program::build_options`].
    pub nv_compiler_options: bool,
}

impl fmt::Display for DeviceDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "[{}] {} ({}, {}): {} compute units, {:.1} GiB, {}, driver {}{}",
            self.index,
            self.name,
            self.kind,
            self.platform,
            self.compute_units,
            self.global_mem_bytes as f64 / (1u64 << 30) as f64,
            self.opencl_c_version,
            self.driver_version,
            match self.watchdog {
                Some(true) => ", kernel watchdog",
                Some(false) => ", no kernel watchdog",
                None => "",
            }
        )
    }
}

/// A chosen device with its context and in-order queue.
pub struct Device {
    pub description: DeviceDescription,
    pub device: ocl::Device,
    pub context: ocl::Context,
    pub queue: ocl::Queue,
}

fn info_string(device: &ocl::Device, what: Info) -> String {
    device
        .info(what)
        .map(|r| r.to_string().trim().to_string())
        .unwrap_or_else(|e| format!("<unknown: {e}>"))
}

fn describe(index: usize, platform: &ocl::Platform, device: &ocl::Device) -> DeviceDescription {
    let (kind, is_gpu) = match device.info(Info::Type) {
        Ok(InfoResult::Type(t)) if t.contains(ocl::flags::DEVICE_TYPE_GPU) => ("GPU", true),
        Ok(InfoResult::Type(t)) if t.contains(ocl::flags::DEVICE_TYPE_CPU) => ("CPU", false),
        Ok(InfoResult::Type(t)) if t.contains(ocl::flags::DEVICE_TYPE_ACCELERATOR) => {
            ("accelerator", false)
        }
        _ => ("other", false),
    };
    let compute_units = match device.info(Info::MaxComputeUnits) {
        Ok(InfoResult::MaxComputeUnits(n)) => n,
        _ => 0,
    };
    let global_mem_bytes = match device.info(Info::GlobalMemSize) {
        Ok(InfoResult::GlobalMemSize(n)) => n,
        _ => 0,
    };
    let max_alloc_bytes = match device.info(Info::MaxMemAllocSize) {
        Ok(InfoResult::MaxMemAllocSize(n)) => n,
        _ => 0,
    };
    let extensions = info_string(device, Info::Extensions);
    DeviceDescription {
        index,
        platform: platform
            .name()
            .unwrap_or_else(|_| "<unknown platform>".into()),
        platform_version: platform.version().unwrap_or_default(),
        name: device.name().unwrap_or_else(|_| "<unknown device>".into()),
        kind: kind.into(),
        compute_units,
        global_mem_bytes,
        max_alloc_bytes,
        opencl_c_version: info_string(device, Info::OpenclCVersion),
        driver_version: info_string(device, Info::DriverVersion),
        is_gpu,
        native_float_width: match device.info(Info::NativeVectorWidthFloat) {
            Ok(InfoResult::NativeVectorWidthFloat(n)) => n,
            _ => 1,
        },
        watchdog: watchdog(device, &extensions),
        nv_compiler_options: extensions
            .split_whitespace()
            .any(|e| e == "cl_nv_compiler_options"),
    }
}

/// CL_DEVICE_KERNEL_EXEC_TIMEOUT_NV of cl_nv_device_attribute_query ([`DeviceDescription::watchdog`]).
const KERNEL_EXEC_TIMEOUT_NV: u32 = 0x4005;

fn watchdog(device: &ocl::Device, extensions: &str) -> Option<bool> {
    if !extensions.contains("cl_nv_device_attribute_query") {
        return None;
    }
    // A cl_bool: 4 bytes.
    let raw = ocl::core::get_device_info_raw(device.as_core(), KERNEL_EXEC_TIMEOUT_NV).ok()?;
    let bytes: [u8; 4] = raw.get(..4)?.try_into().ok()?;
    Some(u32::from_ne_bytes(bytes) != 0)
}

/// Every device of every platform, in the order `--device` indexes them.
pub fn list() -> Result<Vec<(ocl::Platform, ocl::Device, DeviceDescription)>> {
    // ocl's Platform::list panics when the ICD loader finds no platform; ask the core API.
    // Enumeration is not thread-safe everywhere (PoCL 3.1 reported no devices to concurrent
    // first callers), so enumerations are serialised.
    static ENUMERATION: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = ENUMERATION
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let ids = ocl::core::get_platform_ids();
    let platforms = match ids {
        Ok(ids) if !ids.is_empty() => ids.into_iter().map(ocl::Platform::new),
        _ => return Err(Error::NoPlatform),
    };
    let mut all = Vec::new();
    for platform in platforms {
        let devices = ocl::Device::list_all(platform)
            .map_err(|e| Error::opencl("listing the devices of a platform", e))?;
        for device in devices {
            let description = describe(all.len(), &platform, &device);
            all.push((platform, device, description));
        }
    }
    if all.is_empty() {
        return Err(Error::NoPlatform);
    }
    Ok(all)
}

/// Picks a device: `wanted` (or `$CLPT_DEVICE`) as an index into [`list`] or the start of a
/// word of the device or platform name, case-insensitive, at least two characters (`nvidia`,
/// `portable`, `xeon`; a lone `x` once picked a Xeon by a letter inside a word); by default the
/// first GPU, else the first CPU, else the first device. An error says where the wanted name
/// came from.
pub fn select(wanted: Option<&str>) -> Result<Device> {
    select_reserving(wanted, 0)
}

/// [`select`], a CPU device with `reserve` of its compute units left to the host: a run on
/// several devices keeps one host thread for each other device's driver, whose launches and
/// waits need a core (Blender's Cycles does the same for each GPU beside its CPU). Done by an
/// OpenCL 1.2 sub-device of that many units (clCreateSubDevices, partitioned by counts); where
/// the platform cannot partition, the whole device.
pub fn select_reserving(wanted: Option<&str>, reserve: u32) -> Result<Device> {
    let all = list()?;
    let env = std::env::var(DEVICE_ENV)
        .ok()
        .filter(|s| !s.trim().is_empty());
    let (wanted, from) = match (wanted, env) {
        (Some(w), _) => (Some(w.to_string()), "--device"),
        (None, Some(e)) => (Some(e), DEVICE_ENV),
        (None, None) => (None, ""),
    };
    let chosen = match wanted.as_deref().map(str::trim) {
        None => all
            .iter()
            .position(|(_, _, d)| d.is_gpu)
            .or_else(|| all.iter().position(|(_, _, d)| d.kind == "CPU"))
            .unwrap_or(0),
        Some(w) => match w.parse::<usize>() {
            Ok(i) if i < all.len() => i,
            _ => all
                .iter()
                .position(|(_, _, d)| names_device(w, d))
                .ok_or_else(|| Error::NoSuchDevice {
                    wanted: w.to_string(),
                    from,
                    available: all
                        .iter()
                        .map(|(_, _, d)| format!("  {d}"))
                        .collect::<Vec<_>>()
                        .join("\n"),
                })?,
        },
    };
    let (platform, mut device, mut description) =
        all.into_iter().nth(chosen).ok_or(Error::NoPlatform)?;
    let units = description.compute_units.saturating_sub(reserve).max(1);
    if description.kind == "CPU"
        && units < description.compute_units
        && let Some(sub) = sub_device(device, units)
    {
        (device, description.compute_units) = (sub, units);
    }
    let context = ocl::Context::builder()
        .platform(platform)
        .devices(device)
        .build()
        .map_err(|e| Error::opencl(format!("creating a context on {}", description.name), e))?;
    let queue = ocl::Queue::new(&context, device, None)
        .map_err(|e| Error::opencl(format!("creating a queue on {}", description.name), e))?;
    Ok(Device {
        description,
        device,
        context,
        queue,
    })
}

/// A sub-device of `device` with `units` of its compute units, or None where the platform
/// does not partition it so.
fn sub_device(device: ocl::Device, units: u32) -> Option<ocl::Device> {
    use ocl::core::ClDeviceIdPtr;
    use ocl::ffi::{self, cl_device_partition_property as Property};
    let properties: [Property; 4] = [
        ffi::CL_DEVICE_PARTITION_BY_COUNTS as Property,
        units as Property,
        ffi::CL_DEVICE_PARTITION_BY_COUNTS_LIST_END as Property,
        0,
    ];
    let mut sub: ffi::cl_device_id = std::ptr::null_mut();
    let mut count: ffi::cl_uint = 0;
    // SAFETY: a valid device id, a zero-terminated property list, room for one device.
    let status = unsafe {
        ffi::clCreateSubDevices(
            device.as_core().as_ptr(),
            properties.as_ptr(),
            1,
            &mut sub,
            &mut count,
        )
    };
    (status == ffi::CL_SUCCESS && count == 1 && !sub.is_null())
        // SAFETY: a device id the platform just created; it lives as long as the process.
        .then(|| ocl::Device::from(unsafe { ocl::core::DeviceId::from_raw(sub) }))
}

/// A description for the library's unit tests: a device of `kind` ("CPU" or "GPU") named
/// `name`, with no memory, one lane, no watchdog answer and no NVIDIA compiler options; tests
/// change the fields they use.
#[cfg(test)]
pub(crate) fn test_description(kind: &str, name: &str) -> DeviceDescription {
    DeviceDescription {
        index: 0,
        platform: "p".into(),
        platform_version: String::new(),
        name: name.into(),
        kind: kind.into(),
        compute_units: 1,
        global_mem_bytes: 0,
        max_alloc_bytes: 0,
        opencl_c_version: String::new(),
        driver_version: String::new(),
        is_gpu: kind == "GPU",
        native_float_width: 1,
        watchdog: None,
        nv_compiler_options: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_is_named_by_the_start_of_a_word_of_two_characters_or_more() {
        let d = DeviceDescription {
            platform: "Portable Computing Language".into(),
            ..test_description("CPU", "pthread-skylake-avx512-Intel(R) Xeon(R) Gold")
        };
        for yes in [
            "xeon",
            "XE",
            "portable",
            " Portable Computing ",
            "avx512",
            "pthread-sky",
        ] {
            assert!(names_device(yes, &d), "{yes}");
        }
        for no in ["x", "p", "", "eon", "512", "thread", "nvidia", "gold!"] {
            assert!(!names_device(no, &d), "{no}");
        }
    }
}
