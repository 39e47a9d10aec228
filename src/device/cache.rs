//! The on-disk cache of built programs. A program binary is only valid for the platform,
//! device and driver that built it, and for exactly the source and options it came from, so
//! all of these go into its key (LuxCore's cache left the driver version out, and its users got
//! stale binaries after driver updates). The key is a 128-bit FNV-1a hash, stable across Rust
//! releases; files are written to a temporary name and renamed, so a crash leaves no half file
//! and concurrent renders never read one. Each file frames its binary with a length and a
//! checksum that are checked before the driver sees it ([`load`]); a file that fails them, or a
//! binary the driver refuses, is rebuilt from source and replaced.
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

/// What a cache file starts with, before the binary's length (u64, little-endian) and its
/// [`fingerprint`] (32 hex digits): a driver handed a cut or damaged binary may crash (PoCL
/// asserted on a header-only file, and every later run of that scene died with it), so the
/// cache checks its own frame before the driver sees a byte.
const MAGIC: &[u8; 10] = b"clpt-bin1\n";

/// The binary in a cache file's bytes, when the frame is whole and the checksum agrees.
fn unframe(bytes: &[u8]) -> Option<&[u8]> {
    let rest = bytes.strip_prefix(MAGIC.as_slice())?;
    let (length, rest) = rest.split_at_checked(8)?;
    let length = u64::from_le_bytes(length.try_into().ok()?);
    let (sum, binary) = rest.split_at_checked(32)?;
    (binary.len() as u64 == length
        && !binary.is_empty()
        && sum == fingerprint(&[binary]).as_bytes())
    .then_some(binary)
}

/// The cached binary under `dir` for `key`, if there is a whole one. A file that is cut,
/// damaged or of an older format reads as none: the program is rebuilt and the file replaced.
pub fn load(dir: &Path, key: &str) -> Option<Vec<u8>> {
    let bytes = std::fs::read(dir.join(key)).ok()?;
    unframe(&bytes).map(<[u8]>::to_vec)
}

/// Stores `binary` under `dir` for `key` in its frame, atomically (crate::output): a crash
/// never leaves a cut file, and one cut any other way is caught by [`load`].
pub fn store(dir: &Path, key: &str, binary: &[u8]) -> crate::error::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| crate::error::Error::Write {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut framed = MAGIC.to_vec();
    framed.extend((binary.len() as u64).to_le_bytes());
    framed.extend(fingerprint(&[binary]).as_bytes());
    framed.extend(binary);
    crate::output::write_bytes(&dir.join(key), &framed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_whole_frames_with_their_checksum_load() {
        let dir = std::env::temp_dir().join(format!("clpt-cache-frame-{}", std::process::id()));
        let binary: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        store(&dir, "k.bin", &binary).unwrap();
        assert_eq!(load(&dir, "k.bin"), Some(binary.clone()));
        let whole = std::fs::read(dir.join("k.bin")).unwrap();
        for cut in [0, 5, MAGIC.len() + 8, whole.len() / 2, whole.len() - 1] {
            std::fs::write(dir.join("k.bin"), &whole[..cut]).unwrap();
            assert_eq!(load(&dir, "k.bin"), None, "cut to {cut} bytes");
        }
        let mut flipped = whole.clone();
        flipped[whole.len() - 10] ^= 1;
        std::fs::write(dir.join("k.bin"), &flipped).unwrap();
        assert_eq!(load(&dir, "k.bin"), None, "a flipped bit");
        std::fs::write(dir.join("k.bin"), &binary).unwrap();
        assert_eq!(load(&dir, "k.bin"), None, "an unframed (older) file");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
