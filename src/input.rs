//! Reading the files a user names, within limits: a scene (which may come from a pipe), and the
//! meshes and textures a scene names (regular files only). Whatever the source claims, at most
//! one byte past the limit is read, into memory reserved fallibly, so `/dev/zero`, an endless
//! pipe or a huge file ends with an error instead of filling memory. And the host memory there
//! is room in ([`host_available_bytes`]), for what a texture or a film would take.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// All of `reader`, or `None` when it holds more than `limit` bytes. `size_hint` (the file's
/// length, 0 when unknown) sizes the buffer, reserved fallibly and never past the limit.
pub fn read_at_most(
    reader: impl Read,
    size_hint: u64,
    limit: u64,
) -> std::io::Result<Option<Vec<u8>>> {
    let cap = limit.saturating_add(1);
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(usize::try_from(size_hint.min(cap)).unwrap_or(usize::MAX))
        .map_err(std::io::Error::other)?;
    reader.take(cap).read_to_end(&mut bytes)?;
    Ok((bytes.len() as u64 <= limit).then_some(bytes))
}

/// Opens `path` after checking that it is a regular file of at most `limit` bytes (`flag`:
/// what raises the limit), and returns it with its length. A directory is named as such; a
/// device or pipe is refused, since `/dev/zero` would be read forever (and opening a pipe waits
/// for a writer).
pub fn open_regular(path: &Path, limit: u64, flag: &str) -> Result<(File, u64), String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(format!(
            "this is {}, not a file",
            crate::error::file_kind(meta.file_type())
        ));
    }
    if meta.len() > limit {
        return Err(crate::error::over_limit(Some(meta.len()), limit, flag));
    }
    Ok((File::open(path).map_err(|e| e.to_string())?, meta.len()))
}

/// The whole of a regular file of at most `limit` bytes ([`open_regular`]).
pub fn read_regular(path: &Path, limit: u64, flag: &str) -> Result<Vec<u8>, String> {
    let (file, len) = open_regular(path, limit, flag)?;
    read_at_most(file, len, limit)
        .map_err(|e| format!("cannot read the file ({len} bytes): {e}"))?
        // One byte past the limit tells a file that grew since it was measured.
        .ok_or_else(|| crate::error::over_limit(None, limit, flag))
}

/// The host memory available now (Linux: MemAvailable of /proc/meminfo), if the system says.
pub fn host_available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// `bytes` in GiB with one decimal, for messages.
pub fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reading_stops_one_byte_past_the_limit() {
        let endless = std::io::repeat(0u8);
        assert_eq!(read_at_most(endless, 0, 1000).unwrap(), None);
        let ten = [7u8; 10];
        assert_eq!(read_at_most(&ten[..], 10, 10).unwrap(), Some(ten.to_vec()));
        assert_eq!(read_at_most(&ten[..], 10, 9).unwrap(), None);
        // A size hint beyond memory is capped at the limit, not reserved.
        assert_eq!(
            read_at_most(&ten[..], u64::MAX, 100).unwrap(),
            Some(ten.to_vec())
        );
        let message = crate::error::over_limit(Some(100 << 20), 64 << 20, "--max-scene-bytes");
        assert_eq!(
            message,
            "the file is 104857600 bytes (100.0 MiB), larger than the limit of 67108864 bytes \
             (64.0 MiB); a larger file can be read with --max-scene-bytes N"
        );
        assert!(
            crate::error::over_limit(None, 10, "--x")
                .starts_with("larger than the limit of 10 bytes;")
        );
    }

    #[test]
    fn this_machine_reports_its_memory() {
        if cfg!(target_os = "linux") {
            assert!(host_available_bytes().is_some_and(|b| b > 0));
        }
    }
}
