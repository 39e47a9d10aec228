//! The library's error type: every failure a user can cause or meet, with enough context to act
//! on it (file:line:column for scene files, device and build log for kernel builds).

use std::fmt;
use std::path::PathBuf;

/// A place in a scene file: 1-based line and column (columns count characters).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub file: String,
    pub line: usize,
    pub column: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// A scene file that cannot be read as a scene: where, and what was expected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{location}: {message}")]
pub struct ParseError {
    pub location: Location,
    pub message: String,
}

/// Something worth telling the user about a scene that still loads (the original's own files
/// have slips such as a wrong object count).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    pub location: Location,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: warning: {}", self.location, self.message)
    }
}

/// Every error the clpt library returns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Parse(#[from] ParseError),

    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("cannot write {}: {message}", path.display())]
    Write { path: PathBuf, message: String },

    #[error("OpenCL: {context}: {message}")]
    OpenCl { context: String, message: String },

    #[error(
        "no OpenCL device matches `{wanted}` (from {from}: an index, or the start of a word \
         of a device or platform name, 2 characters or more); available:\n{available}"
    )]
    NoSuchDevice {
        wanted: String,
        /// Where `wanted` came from: `--device` or `CLPT_DEVICE`.
        from: &'static str,
        available: String,
    },

    #[error(
        "no OpenCL platform found. Install one (on Debian/Ubuntu: \
         `apt-get install pocl-opencl-icd ocl-icd-opencl-dev`, or your GPU vendor's driver)"
    )]
    NoPlatform,

    #[error("texture {}: {message}", path.display())]
    Texture { path: PathBuf, message: String },

    #[error(
        "{location}: {what} file {} not found; tried:\n{}",
        quote(written),
        tried.iter().map(|p| format!("  {}", p.display())).collect::<Vec<_>>().join("\n")
    )]
    FileNotFound {
        what: &'static str,
        location: Location,
        written: String,
        tried: Vec<PathBuf>,
    },

    /// A file larger than clpt reads of its kind (`what`: "scene"), checked while reading, so
    /// an endless source (`/dev/zero`, a pipe) ends too.
    #[error("{what} {}: {}", path.display(), over_limit(*size, *limit, flag))]
    FileTooLarge {
        what: &'static str,
        path: PathBuf,
        /// The file's size, where it has one (not a pipe's or a device's).
        size: Option<u64>,
        limit: u64,
        /// The option that raises the limit.
        flag: &'static str,
    },

    /// A name a scene gives (a texture, a mesh) that is there but is no file to read: a
    /// directory, a device or a pipe.
    #[error(
        "{location}: {what} file {} is {kind} ({})",
        quote(written),
        path.display()
    )]
    NotAFile {
        what: &'static str,
        location: Location,
        written: String,
        path: PathBuf,
        kind: &'static str,
    },

    #[error("image {}: {message}", path.display())]
    Image { path: PathBuf, message: String },

    #[error("mesh {}: {message}", path.display())]
    Mesh { path: PathBuf, message: String },

    /// Something wrong on one line of an OBJ file (and column, where one is known).
    #[error("mesh {}:{}: {message}", path.display(), line_and_column(*line, *column))]
    MeshLine {
        path: PathBuf,
        line: usize,
        column: Option<usize>,
        message: String,
    },

    #[error("kernel source: {0}")]
    KernelSource(String),

    #[error("kernel build failed on {device} (options: {options}):\n{log}")]
    Build {
        device: String,
        options: String,
        log: String,
    },

    #[error("device layout check failed: {0}")]
    Layout(String),

    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// Wraps an OpenCL failure with what clpt was doing at the time.
    pub fn opencl(context: impl Into<String>, err: impl fmt::Display) -> Self {
        Error::OpenCl {
            context: context.into(),
            message: concise_opencl_message(&err.to_string()),
        }
    }
}

/// What a file over its limit gets: its size where known, the limit, and the option (`flag`)
/// that raises it.
pub fn over_limit(size: Option<u64>, limit: u64, flag: &str) -> String {
    let size = size.map_or(String::new(), |s| format!("the file is {}, ", bytes(s)));
    format!(
        "{size}larger than the limit of {}; a larger file can be read with {flag} N",
        bytes(limit)
    )
}

/// "100 bytes", or "67108864 bytes (64.0 MiB)" from a mebibyte on.
pub fn bytes(count: u64) -> String {
    const MIB: u64 = 1 << 20;
    if count < MIB {
        format!("{count} bytes")
    } else {
        format!("{count} bytes ({:.1} MiB)", count as f64 / MIB as f64)
    }
}

/// The most characters [`quote`] shows of a text, escapes included.
pub const QUOTE_CHARS: usize = 60;

/// `text` in backticks for a message, as its reader can act on it: control, invisible and other
/// non-printing characters escaped the way Rust writes them (`\0`, `\t`, `\u{200b}`:
/// `char::escape_debug`, which follows Unicode's printable classes), and cut after
/// [`QUOTE_CHARS`] characters with an ellipsis, so that a gigabyte-long token, or a file of NULs,
/// gives a short line that still shows what is there.
pub fn quote(text: &str) -> String {
    let mut quoted = String::from("`");
    let mut shown = 0;
    for c in text.chars() {
        let escaped = escape(c);
        shown += escaped.chars().count();
        if shown > QUOTE_CHARS {
            quoted.push('…');
            break;
        }
        quoted.push_str(&escaped);
    }
    quoted.push('`');
    quoted
}

/// One character as [`quote`] shows it. Quotes and backslashes are printable and stay as
/// written (the text is quoted in backticks; a Windows path keeps its look).
fn escape(c: char) -> String {
    match c {
        '"' | '\'' | '\\' => c.to_string(),
        _ => c.escape_debug().to_string(),
    }
}

/// The `ocl` crate wraps a failing call in a banner of several paragraphs; keep the function
/// and status lines (`clCreateBuffer`, `CL_INVALID_BUFFER_SIZE (-61)`), or the text as is.
fn concise_opencl_message(text: &str) -> String {
    let pick = |prefix: &str| {
        text.lines()
            .find_map(|l| l.trim().strip_prefix(prefix).map(|s| s.trim().to_string()))
    };
    match (
        pick("Error executing function:"),
        pick("Status error code:"),
    ) {
        (Some(function), Some(status)) => format!("{function} failed with {status}"),
        _ => text.trim().to_string(),
    }
}

/// `12` or `12:5`.
fn line_and_column(line: usize, column: Option<usize>) -> String {
    match column {
        Some(column) => format!("{line}:{column}"),
        None => line.to_string(),
    }
}

/// What a path that is not a regular file is, for messages: "a directory", "a named pipe", ...
pub fn file_kind(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a named pipe";
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return "a device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_dir() {
        "a directory"
    } else if file_type.is_file() {
        "a file"
    } else {
        "not a regular file"
    }
}

pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quote_escapes_what_cannot_be_seen_and_stays_short() {
        assert_eq!(quote("Sphere"), "`Sphere`");
        assert_eq!(quote("\u{200b}0.75"), "`\\u{200b}0.75`");
        assert_eq!(quote("a\0b\tc\r\n\u{7f}"), "`a\\0b\\tc\\r\\n\\u{7f}`");
        // Byte-order mark, no-break space, soft hyphen, right-to-left override.
        assert_eq!(
            quote("\u{feff}\u{a0}\u{ad}\u{202e}"),
            "`\\u{feff}\\u{a0}\\u{ad}\\u{202e}`"
        );
        assert_eq!(quote("é \"x\" C:\\y's"), "`é \"x\" C:\\y's`");
        let long = "7".repeat(1 << 20);
        assert_eq!(quote(&long), format!("`{}…`", "7".repeat(QUOTE_CHARS)));
        let nuls = "\0".repeat(1000);
        assert_eq!(
            quote(&nuls),
            format!("`{}…`", "\\0".repeat(QUOTE_CHARS / 2))
        );
        let exact = "x".repeat(QUOTE_CHARS);
        assert_eq!(quote(&exact), format!("`{exact}`"));
    }
}
