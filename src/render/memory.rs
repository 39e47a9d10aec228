//! Whether a film fits before it is allocated: on the device (every buffer of
//! `render_pass`) and on the host (what reading it back and writing the image take). A film
//! too large for either was allocated lazily and then aborted the process after the whole
//! render, while reading it back; now it is an error before any work, with the figures.

use crate::device::DeviceDescription;
use crate::error::{Error, Result};
use crate::input::gib;

/// Device bytes a pixel holds: five float4 sums (value and its compensation, squares, the
/// odd half and its compensation) and two u32 counters (kernels/pathtracer.cl `render_pass`).
pub const DEVICE_BYTES_PER_PIXEL: u64 = 5 * 16 + 2 * 4;

/// The largest single device buffer a film needs, a pixel's float4 sum.
const LARGEST_BUFFER_BYTES_PER_PIXEL: u64 = 16;

/// Host bytes a pixel needs at the peak of reading the film back and writing outputs: the
/// device's buffers read back (88), one of them twice while it is converted (16), the mean
/// image and its squares (32) and an output image in f32 (12), rounded up.
pub const HOST_BYTES_PER_PIXEL: u64 = 160;

/// Checks a `width` x `height` film against `device` and, where the system says,
/// `host_available` bytes of host memory.
pub fn check_film_fits(
    device: &DeviceDescription,
    width: u32,
    height: u32,
    host_available: Option<u64>,
) -> Result<()> {
    let pixels = u64::from(width) * u64::from(height);
    let device_name = device.name.as_str();
    // (bytes needed, of what, bytes there (0: not reported), whose): the first that does not fit.
    let checks = [
        (
            pixels * DEVICE_BYTES_PER_PIXEL,
            "of device memory",
            device.global_mem_bytes,
            device_name,
        ),
        (
            pixels * LARGEST_BUFFER_BYTES_PER_PIXEL,
            "in one device buffer",
            device.max_alloc_bytes,
            device_name,
        ),
        (
            pixels * HOST_BYTES_PER_PIXEL,
            "of host memory",
            host_available.unwrap_or(0),
            "this machine",
        ),
    ];
    match checks
        .iter()
        .find(|&&(need, _, have, _)| have > 0 && need > have)
    {
        Some(&(need, what, have, whose)) => Err(Error::Invalid(format!(
            "a {width}x{height} film needs {} {what}, more than the {} {whose} has; \
             render fewer pixels (--width, --height)",
            gib(need),
            gib(have)
        ))),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device(global: u64, max_alloc: u64) -> DeviceDescription {
        DeviceDescription {
            global_mem_bytes: global,
            max_alloc_bytes: max_alloc,
            ..crate::device::test_description("CPU", "the test device")
        }
    }

    #[test]
    fn films_that_do_not_fit_are_errors_with_the_figures() {
        let gib4 = 4u64 << 30;
        let d = device(gib4, 1 << 30);
        assert!(check_film_fits(&d, 1920, 1080, Some(gib4)).is_ok());
        // 16384 x 8192 needs 11 GiB of a 4 GiB device.
        let err = check_film_fits(&d, 16384, 8192, None)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("16384x8192") && err.contains("11.0 GiB") && err.contains("4.0 GiB"),
            "{err}"
        );
        assert!(
            err.contains("the test device") && err.contains("--width"),
            "{err}"
        );
        // Fits the device's memory but not its largest buffer (a 2 GiB sum, 1 GiB at most).
        let err = check_film_fits(&device(64 << 30, 1 << 30), 16384, 8192, None)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("one device buffer") && err.contains("2.0 GiB"),
            "{err}"
        );
        // Fits the device, not the host.
        let err = check_film_fits(&device(64 << 30, 0), 16384, 8192, Some(gib4))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("host memory") && err.contains("this machine"),
            "{err}"
        );
        // A device that reports nothing is not refused on its account.
        assert!(check_film_fits(&device(0, 0), 65536, 65536, None).is_ok());
    }
}
