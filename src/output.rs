//! Files clpt writes, written so that none is ever lost or left half-written: each goes to a
//! temporary name in its own folder, is flushed and synced to disk, and only then renamed over
//! the destination (a rename within one file system is atomic on POSIX). A crash, `kill -9` or a
//! full disk leaves the earlier file untouched and no partial one; a failed write is an error.
//! Outputs are checked before any work (the folder exists and takes a file, the format is one
//! clpt writes), so a long render is never lost to a typo in `-o`.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// The extension of `path`, lower-cased ("" if none).
pub fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default()
}

fn write_error(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Write {
        path: path.to_path_buf(),
        message: message.to_string(),
    }
}

/// The error for a format clpt does not write: `wanted` lists those it does (".png or .pfm").
pub fn unknown_format(path: &Path, wanted: &str) -> Error {
    let ext = extension(path);
    let what = if ext.is_empty() {
        "no extension to name the format".to_string()
    } else {
        format!("unknown format `.{ext}`")
    };
    write_error(path, format!("{what}: use {wanted}"))
}

/// The folder `path` will be written in ("." for a bare file name).
fn folder(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A temporary name beside `path`, unique in this process and apart from other processes': a
/// hidden file that names what it will become.
fn temporary_name(path: &Path) -> PathBuf {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    folder(path).join(format!(
        ".{name}.{}-{}.clpt-tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Writes `path` through `fill`, atomically: into a temporary file beside it, flushed, synced,
/// then renamed over `path`. On any failure the temporary file is removed, `path` is as it was,
/// and the error names `path`.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> Result<()> {
    if path.is_dir() {
        return Err(write_error(path, "is a folder"));
    }
    let tmp = temporary_name(path);
    let result = (|| -> std::result::Result<(), String> {
        let file = File::create(&tmp).map_err(|e| e.to_string())?;
        let mut out = BufWriter::new(file);
        fill(&mut out)?;
        let file = out.into_inner().map_err(|e| e.error().to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        drop(file);
        std::fs::rename(&tmp, path).map_err(|e| e.to_string())?;
        // The rename itself reaches the disk when the folder is synced (POSIX); a file system
        // that cannot sync a folder has still renamed it.
        if let Ok(dir) = File::open(folder(path)) {
            let _ = dir.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(|message| write_error(path, message))
}

/// `bytes` written to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |out| out.write_all(bytes).map_err(|e| e.to_string()))
}

/// Checks, before any work, that `path` can be written later: its extension is one of
/// `formats` (lower case, without the dot; empty to accept any), it is not a folder, and its
/// folder exists and takes a new file (one is created there and removed).
pub fn check_writable(path: &Path, formats: &[&str]) -> Result<()> {
    if path.is_dir() {
        return Err(write_error(path, "is a folder"));
    }
    if !formats.is_empty() && !formats.contains(&extension(path).as_str()) {
        let listed: Vec<String> = formats.iter().map(|f| format!(".{f}")).collect();
        return Err(unknown_format(path, &listed.join(", ")));
    }
    let dir = folder(path);
    if !dir.is_dir() {
        return Err(write_error(
            path,
            format!("the folder {} does not exist", dir.display()),
        ));
    }
    let probe = temporary_name(path);
    File::create(&probe)
        .map_err(|e| write_error(path, format!("cannot write in {}: {e}", dir.display())))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}
