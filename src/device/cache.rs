//! The on-disk cache of built programs. A program binary is only valid for the platform,
//! device and driver that built it, and for exactly the source and options it came from, so
//! all of these go into its key (LuxCore's cache left the driver version out, and its users got
//! stale binaries after driver updates). The key is a 128-bit FNV-1a hash, stable across Rust
//! releases; files are written to a temporary name and renamed, so a crash leaves no half file
//! and concurrent renders never read one. A binary the driver refuses is rebuilt from source.
//! Kernel counterpart: none (the loader, [`super::program`], calls it).

use super::Device;
use std::path::{Path, PathBuf};

/// Overrides the cache folder (`--cache-dir` overrides this in turn).
pub const CACHE_ENV: &str = "CLPT_CACHE_DIR";

/// The default cache folder: `$CLPT_CACHE_DIR`, else `$XDG_CACHE_HOME/clpt/programs`, else
/// `$HOME/.cache/clpt/programs`; `None` when none of these is set.
pub fn default_dir() -> Option<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if let Some(dir) = var(CACHE_ENV) {
        return Some(PathBuf::from(dir));
    }
    let base = var("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("clpt").join("programs"))
}

/// The file name for the program built from `source` with `options` on `device`.
pub fn key(device: &Device, source: &str, options: &str) -> String {
    let d = &device.description;
    let parts = [
        d.platform.as_str(),
        d.platform_version.as_str(),
        d.name.as_str(),
        d.driver_version.as_str(),
        d.opencl_c_version.as_str(),
        options,
        source,
    ];
    format!("{}.bin", fingerprint(&parts.map(str::as_bytes)))
}

/// A 128-bit fingerprint of `parts`, as 32 hex digits: two FNV-1a hashes from different
/// offsets, each part followed by its length so that moving bytes from one part to the next
/// changes it. Not cryptographic: it tells files and settings apart, it does not guard them.
pub fn fingerprint(parts: &[&[u8]]) -> String {
    let hash = |offset: u64| {
        let mut h = offset;
        for part in parts {
            for &byte in part.iter().chain(&(part.len() as u64).to_le_bytes()) {
                h ^= byte as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
        h
    };
    format!(
        "{:016x}{:016x}",
        hash(0xcbf2_9ce4_8422_2325),
        hash(0x6c62_272e_07bb_0142)
    )
}

/// The cached binary under `dir` for `key`, if there is one.
pub fn load(dir: &Path, key: &str) -> Option<Vec<u8>> {
    std::fs::read(dir.join(key)).ok().filter(|b| !b.is_empty())
}

/// Stores `binary` under `dir` for `key`, atomically (crate::output): a crash never leaves a
/// cut binary for a later run to load.
pub fn store(dir: &Path, key: &str, binary: &[u8]) -> crate::error::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| crate::error::Error::Write {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    crate::output::write_bytes(&dir.join(key), binary)
}
