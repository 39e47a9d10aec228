//! The one kernel loader: reads kernel sources (embedded in the binary, or from `--kernels DIR`),
//! resolves `#include "file"` once per file, emits `#line` so the compiler's messages name the
//! kernel file and line, drops the text of `#if CLPT_X` blocks whose program switch is off
//! (kernels/features.h), takes every build option from [`build_options`], caches built
//! programs ([`super::cache`]), and puts the build log into the error when a build fails. Compilers that ignore `#line` (NVIDIA's reports
//! `<kernel>:LINE:COL`) have their messages mapped back to file and line through the line map
//! of [`ExpandedSource`].

use super::Device;
use crate::error::{Error, Result};
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Every file of `kernels/` (`.h`, `.cl`), compiled into the binary so an installed clpt needs no
/// sources; `build.rs` lists the folder.
const EMBEDDED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/embedded_kernels.rs"));

/// Where kernel sources come from.
#[derive(Clone, Debug, Default)]
pub enum KernelSources {
    /// The copies compiled into the binary.
    #[default]
    Embedded,
    /// A directory (`--kernels DIR`), read at run time: edit kernels without rebuilding.
    Dir(PathBuf),
}

/// A complete program source with, for every line of it, the kernel file and line it came from.
#[derive(Clone, Debug, Default)]
pub struct ExpandedSource {
    pub text: String,
    /// (file, 1-based line) of each line of `text`; `#line` markers map to the line they name.
    lines: Vec<(String, usize)>,
    /// Program switches known to be on or off while expanding.
    switches: Vec<(String, bool)>,
}

/// An open conditional block while expanding a file: one on a known program switch (its text
/// is kept or dropped here), or any other, passed to the compiler.
enum Block {
    Switch { on: bool, in_else: bool },
    Other,
}

impl ExpandedSource {
    /// Whether the program switch `name` is on, if expanding knows it.
    fn switch(&self, name: &str) -> Option<bool> {
        self.switches
            .iter()
            .find(|(k, _)| k == name)
            .map(|&(_, on)| on)
    }

    fn push(&mut self, line: &str, file: &str, number: usize) {
        self.text.push_str(line);
        self.text.push('\n');
        self.lines.push((file.to_string(), number));
    }

    /// The kernel file and line of line `n` (1-based) of the expanded text.
    pub fn origin(&self, n: usize) -> Option<(&str, usize)> {
        self.lines
            .get(n.checked_sub(1)?)
            .map(|(f, l)| (f.as_str(), *l))
    }

    /// Rewrites compiler messages that name a line of the expanded text (`<kernel>:9:36:` from
    /// compilers that ignore `#line`, such as NVIDIA's) to name the kernel file and line.
    pub fn annotate(&self, log: &str) -> String {
        log.lines()
            .map(|line| self.annotate_line(line).unwrap_or_else(|| line.to_string()))
            .collect::<Vec<_>>()
            .join("\n")
    }

    fn annotate_line(&self, line: &str) -> Option<String> {
        let mut parts = line.splitn(3, ':');
        let (unit, number, rest) = (parts.next()?, parts.next()?, parts.next()?);
        let known = self.lines.iter().any(|(f, _)| f == unit);
        if known || unit.is_empty() || unit.contains(char::is_whitespace) {
            return None;
        }
        let (file, at) = self.origin(number.trim().parse().ok()?)?;
        Some(format!("{file}:{at}:{rest}"))
    }
}

impl KernelSources {
    fn read(&self, name: &str) -> Result<String> {
        match self {
            KernelSources::Embedded => EMBEDDED
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, text)| text.to_string())
                .ok_or_else(|| Error::KernelSource(format!("no embedded kernel file `{name}`"))),
            KernelSources::Dir(dir) => {
                let path = dir.join(name);
                std::fs::read_to_string(&path).map_err(|source| Error::Read { path, source })
            }
        }
    }

    /// The complete program source for `entry`: includes resolved, `#line` markers emitted,
    /// and the blocks of switches that `defines` turns off (`#if CLPT_X` with `CLPT_X=0`)
    /// left out, includes in them too.
    pub fn expand(&self, entry: &str, defines: &[(&str, String)]) -> Result<ExpandedSource> {
        let mut out = ExpandedSource {
            switches: defines
                .iter()
                .filter_map(|(k, v)| match v.as_str() {
                    "0" => Some((k.to_string(), false)),
                    "1" => Some((k.to_string(), true)),
                    _ => None,
                })
                .collect(),
            ..ExpandedSource::default()
        };
        self.expand_into(entry, &mut out, &mut Vec::new(), &mut Vec::new())?;
        Ok(out)
    }

    /// A generated program (the layout probe) whose own `#include`s resolve here.
    pub fn expand_text(&self, name: &str, text: &str) -> Result<ExpandedSource> {
        let mut out = ExpandedSource::default();
        let mut stack = vec![name.to_string()];
        self.expand_lines(
            name,
            text,
            &mut out,
            &mut vec![name.to_string()],
            &mut stack,
        )?;
        Ok(out)
    }

    fn expand_into(
        &self,
        name: &str,
        out: &mut ExpandedSource,
        done: &mut Vec<String>,
        stack: &mut Vec<String>,
    ) -> Result<()> {
        if stack.iter().any(|s| s == name) {
            return Err(Error::KernelSource(format!(
                "#include cycle: {} -> {name}",
                stack.join(" -> ")
            )));
        }
        if done.iter().any(|d| d == name) {
            return Ok(()); // each file once, like a header guard
        }
        done.push(name.to_string());
        let text = self.read(name)?;
        stack.push(name.to_string());
        self.expand_lines(name, &text, out, done, stack)?;
        stack.pop();
        Ok(())
    }

    fn expand_lines(
        &self,
        name: &str,
        text: &str,
        out: &mut ExpandedSource,
        done: &mut Vec<String>,
        stack: &mut Vec<String>,
    ) -> Result<()> {
        out.push(&format!("#line 1 \"{name}\""), name, 1);
        let mut blocks: Vec<Block> = Vec::new();
        let mut resync = false; // lines were dropped: the next kept one needs a #line
        for (i, line) in text.lines().enumerate() {
            let kept = |blocks: &[Block]| {
                blocks.iter().all(|b| match b {
                    Block::Switch { on, in_else } => on != in_else,
                    Block::Other => true,
                })
            };
            let was_kept = kept(&blocks);
            match directive(line) {
                Some(("if", cond)) if out.switch(cond).is_some() => {
                    let on = out.switch(cond).unwrap_or(true);
                    blocks.push(Block::Switch { on, in_else: false });
                    resync = true;
                    continue;
                }
                Some(("if" | "ifdef" | "ifndef", _)) => blocks.push(Block::Other),
                Some(("else", _)) => {
                    if let Some(Block::Switch { in_else, .. }) = blocks.last_mut() {
                        *in_else = true;
                        resync = true;
                        continue;
                    }
                }
                Some(("elif", _)) if matches!(blocks.last(), Some(Block::Switch { .. })) => {
                    return Err(Error::KernelSource(format!(
                        "{name}:{}: `#elif` after a program switch's `#if`: use `#else` and \
                         a nested `#if`",
                        i + 1
                    )));
                }
                Some(("endif", _)) => {
                    if let Some(Block::Switch { .. }) = blocks.pop() {
                        resync = true;
                        continue;
                    }
                }
                _ => {}
            }
            if !was_kept {
                resync = true;
                continue;
            }
            if resync {
                out.push(&format!("#line {} \"{name}\"", i + 1), name, i + 1);
                resync = false;
            }
            match include_target(line) {
                Some(Ok(target)) => {
                    self.expand_into(target, out, done, stack)
                        .map_err(|e| match e {
                            Error::Read { path, source } => Error::KernelSource(format!(
                                "{name}:{}: cannot include `{}`: {source}",
                                i + 1,
                                path.display()
                            )),
                            Error::KernelSource(m) if !m.starts_with("#include cycle") => {
                                Error::KernelSource(format!("{name}:{}: {m}", i + 1))
                            }
                            other => other,
                        })?;
                    out.push(&format!("#line {} \"{name}\"", i + 2), name, i + 2);
                }
                Some(Err(())) => {
                    return Err(Error::KernelSource(format!(
                        "{name}:{}: only `#include \"file\"` is supported, found `{}`",
                        i + 1,
                        line.trim()
                    )));
                }
                None => out.push(line, name, i + 1),
            }
        }
        Ok(())
    }
}

/// A preprocessor line's directive and the rest: `("if", "CLPT_MESHES")` for `#if CLPT_MESHES`.
fn directive(line: &str) -> Option<(&str, &str)> {
    let rest = line.trim_start().strip_prefix('#')?.trim_start();
    let end = rest
        .find(|c: char| !c.is_ascii_alphabetic())
        .unwrap_or(rest.len());
    Some((&rest[..end], rest[end..].trim()))
}

/// `Some(Ok(file))` for `#include "file"`, `Some(Err)` for another `#include` form.
fn include_target(line: &str) -> Option<std::result::Result<&str, ()>> {
    let rest = line.trim_start().strip_prefix('#')?.trim_start();
    let rest = rest.strip_prefix("include")?.trim();
    Some(
        rest.strip_prefix('"')
            .and_then(|r| r.strip_suffix('"'))
            .filter(|f| !f.is_empty() && !f.contains('"'))
            .ok_or(()),
    )
}

/// The registers a work-item may use where the compiler takes NVIDIA's options
/// (`-cl-nv-maxrregcount`). Left alone, NVIDIA's compiler gave the path tracer 126 registers
/// (case1's program) to 196 (the dragon room's with light sampling), so that an SM kept 12 to
/// 16 warps of its 64 to hide memory behind. Capped at 64 it keeps 32, and spills a few
/// hundred bytes to the L1 cache. On an H100, light sampling off unless named, seconds at
/// none / 128 / 96 / 80 / 64 / 56 / 48 / 40 / 32 registers (BENCHMARKS.md, "A register cap"):
/// - case1 (160 spp): 5.08 / 5.05 / 4.74 / 4.46 / 4.04 / 3.96 / 4.05 / 4.08 / 5.87;
/// - case3 (250): 3.90 / 3.71 / 3.55 / 3.43 / 2.94 / 2.81 / 2.85 / 3.20 / 3.97;
/// - case0 (200): 1.61 / 1.59 / 1.50 / 1.47 / 1.50 / 1.62 / 1.96 / 2.63 / 4.16;
/// - the dragon room with light sampling (256): 2.23 / 1.91 / 1.85 / 1.79 / 1.68 / 1.64 /
///   1.61 / 1.55 / 1.73;
/// - scenes/lights.txt with light sampling (256): 3.19 / 2.86 / 2.79 / 2.56 / 2.35 / 2.25 /
///   2.25 / 2.12 / 2.11.
///
/// 64 is 7 to 27% faster than no cap everywhere, and within 5% of the best cap without light
/// sampling; lower caps lose up to 2.6 times on case0. The programs with light sampling ran
/// 8 and 11% faster still at 40, on the two scenes measured. The images are the same bits at
/// every cap: registers change where values live, not the arithmetic.
pub const NV_MAX_REGISTERS: u32 = 64;

/// Every compiler option clpt passes for `device`, from one place. No fast-math: the
/// ray-spawning error bounds (kernels/ray.h) assume IEEE rounding. `-cl-kernel-arg-info` keeps
/// the parameters' names in the program, against which the host's argument names are checked
/// ([`super::kernel::NamedArgs`]). NVIDIA's compiler also takes the register cap
/// [`NV_MAX_REGISTERS`].
pub fn build_options(device: &super::DeviceDescription, defines: &[(&str, String)]) -> String {
    std::iter::once("-cl-kernel-arg-info".to_string())
        .chain(
            device
                .nv_compiler_options
                .then(|| format!("-cl-nv-maxrregcount={NV_MAX_REGISTERS}")),
        )
        .chain(defines.iter().map(|(k, v)| format!("-D{k}={v}")))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Where a built program came from, as `-v` reports it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheUse {
    /// No cache (`--no-cache`, or no cache folder known).
    Off,
    /// Loaded from this cached binary.
    Hit(PathBuf),
    /// Built from source and stored here.
    Stored(PathBuf),
    /// Built from source; storing it failed for this reason (the render goes on).
    NotStored(String),
}

/// A built program with what went into it.
pub struct BuiltProgram {
    pub program: ocl::Program,
    pub source: ExpandedSource,
    pub options: String,
    /// Creating and building the program: from source, or from the cached binary.
    pub build_time: Duration,
    pub cache: CacheUse,
}

/// Builds a complete (already expanded) source for `device`, or loads its binary from the
/// program cache at `cache` (see [`super::cache`]) and stores it there after a build.
pub fn build(
    device: &Device,
    source: ExpandedSource,
    options: String,
    cache: Option<&Path>,
) -> Result<BuiltProgram> {
    let start = Instant::now();
    let opts = CString::new(options.clone())
        .map_err(|_| Error::KernelSource("build options contain a NUL byte".into()))?;
    let key = cache.map(|dir| (dir, super::cache::key(device, &source.text, &options)));
    if let Some((dir, key)) = &key
        && let Some(binary) = super::cache::load(dir, key)
        && let Ok(program) = from_binary(device, &binary, &opts)
    {
        return Ok(BuiltProgram {
            program,
            source,
            options,
            build_time: start.elapsed(),
            cache: CacheUse::Hit(dir.join(key)),
        });
    }
    let src = CString::new(source.text.clone())
        .map_err(|_| Error::KernelSource("kernel source contains a NUL byte".into()))?;
    let program = ocl::core::create_program_with_source(&device.context, &[src])
        .map_err(|e| Error::opencl("creating the program", e))?;
    if let Err(e) = ocl::core::build_program(&program, Some(&[device.device]), &opts, None, None) {
        let log = match ocl::core::get_program_build_info(
            &program,
            device.device,
            ocl::enums::ProgramBuildInfo::BuildLog,
        ) {
            Ok(ocl::enums::ProgramBuildInfoResult::BuildLog(log)) if !log.trim().is_empty() => log,
            _ => e.to_string(),
        };
        let log = source.annotate(&log);
        return Err(Error::Build {
            device: device.description.name.clone(),
            options,
            log,
        });
    }
    let build_time = start.elapsed();
    let cache = match &key {
        None => CacheUse::Off,
        Some((dir, key)) => {
            match ocl::core::get_program_info(&program, ocl::enums::ProgramInfo::Binaries) {
                Ok(ocl::enums::ProgramInfoResult::Binaries(b))
                    if b.len() == 1 && !b[0].is_empty() =>
                {
                    match super::cache::store(dir, key, &b[0]) {
                        Ok(()) => CacheUse::Stored(dir.join(key)),
                        Err(e) => CacheUse::NotStored(e.to_string()),
                    }
                }
                _ => CacheUse::NotStored("the driver gave no program binary".into()),
            }
        }
    };
    Ok(BuiltProgram {
        program: ocl::Program::from(program),
        source,
        options,
        build_time,
        cache,
    })
}

/// A program from a cached binary, or `Err` when the driver will not take it (it is then
/// built from source).
fn from_binary(device: &Device, binary: &[u8], options: &CString) -> Result<ocl::Program> {
    let program =
        ocl::core::create_program_with_binary(&device.context, &[device.device], &[binary])
            .map_err(|e| Error::opencl("loading a cached program", e))?;
    ocl::core::build_program(&program, Some(&[device.device]), options, None, None)
        .map_err(|e| Error::opencl("building a cached program", e))?;
    Ok(ocl::Program::from(program))
}

/// Expands and builds the kernel file `entry` of `sources` with the program switches and
/// values `defines`, through the program cache at `cache` when given.
pub fn build_entry(
    device: &Device,
    sources: &KernelSources,
    entry: &str,
    defines: &[(&str, String)],
    cache: Option<&Path>,
) -> Result<BuiltProgram> {
    build(
        device,
        sources.expand(entry, defines)?,
        build_options(&device.description, defines),
        cache,
    )
}

/// The `kernels/` folder of this checkout, for tests that edit or inspect kernel files.
pub fn checkout_kernel_dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/kernels"))
}
