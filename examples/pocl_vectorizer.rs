//! What PoCL's work-group vectoriser makes of three small kernels, for BENCHMARKS.md ("Speed on
//! the CPU"): the question is which kernel code runs several work-items in one SIMD register on
//! a CPU, as Mitsuba 3's LLVM variant runs 8 or 16 lanes, and which runs one at a time.
//!
//! ```sh
//! cargo run --release --example pocl_vectorizer
//! POCL_VECTORIZER_REMARKS=1 cargo run --release --example pocl_vectorizer   # and why
//! ```
//!
//! Each kernel is timed (the least of 5 launches computing 2^24 values, after a warm-up) under
//! PoCL's vectorising work-group method (`loopvec`, its default) and its plain loops (`loops`),
//! each in a child process of this example, since PoCL reads `POCL_WORK_GROUP_METHOD` when it
//! starts. Where both take the same time, the kernel ran scalar. On other OpenCL platforms the
//! variable does nothing and both columns agree.
//!
//! - `scalar`: arithmetic and `sqrt` on scalar floats, a select;
//! - `builtin`: the same with `atan2pi`, `cospi` and `sinpi` (the rectangle-light sampler's);
//! - `float3_ops`: `dot`, `cross` and `length` of `float3` values (every kernel routine's types);
//! - `polynomial`: atan2 / pi from a polynomial and selects, scalar floats only;
//! - `polynomial_x8`: the same code on `float8`, eight values a work-item.

use std::process::Command;
use std::time::Instant;

const SOURCE: &str = r#"
__kernel void scalar(__global float* out) {
    const uint i = get_global_id(0);
    const float x = (float)(i & 1023u) * 0.19f - 97.0f, y = (float)((i >> 10) & 255u) * 0.6f + 1.0f;
    const float a = sqrt(x * x + y * y + 1.0f);
    const float c = (y * a) / (x + a) + a * x;
    out[i] = c > 0.0f ? c : -c * 0.5f;
}
__kernel void builtin(__global float* out) {
    const uint i = get_global_id(0);
    const float x = (float)(i & 1023u) * 0.19f - 97.0f, y = (float)((i >> 10) & 255u) * 0.6f + 1.0f;
    const float a = sqrt(x * x + y * y + 1.0f);
    const float b = atan2pi(y * a, x + a);
    const float c = cospi(b) * a + sinpi(b) * x;
    out[i] = c > 0.0f ? c : -c * 0.5f;
}
/* atan2(y, x) / pi without builtins (an odd polynomial on [0, 1], Abramowitz and Stegun 4.4.49's
 * form, and selects), once on float and once on float8: the same code a work-item does for one
 * value or for eight. */
#define ATAN2PI(T, M, greater, less)                                                          \
    inline T atan2pi_##T(T y, T x) {                                                          \
        const T ax = fabs(x), ay = fabs(y);                                                   \
        const M swap = greater(ay, ax);                                                       \
        const T a = select(ay, ax, swap) / fmax(select(ax, ay, swap), (T)1e-30f);             \
        const T s = a * a;                                                                    \
        T r = a * (0.9998660f + s * (-0.3302995f + s * (0.1801410f + s * (-0.0851330f +       \
                                                                        s * 0.0208351f)))); \
        r *= 0.31830988f;                                                                     \
        r = select(r, 0.5f - r, swap);                                                        \
        r = select(r, 1.0f - r, less(x, (T)0.0f));                                            \
        return select(r, -r, less(y, (T)0.0f));                                               \
    }
#define GREATER1(a, b) ((a) > (b))
#define LESS1(a, b) ((a) < (b))
ATAN2PI(float, int, GREATER1, LESS1)
ATAN2PI(float8, int8, isgreater, isless)
__kernel void polynomial(__global float* out) {
    const uint i = get_global_id(0);
    const float x = (float)(i & 1023u) * 0.0019f - 0.97f, y = (float)((i >> 10) & 255u) * 0.6f + 1.0f;
    out[i] = atan2pi_float(y, x);
}
__kernel void polynomial_x8(__global float* out) {
    const uint g = get_global_id(0);
    const uint8 i = (uint8)(8u * g) + (uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u);
    const float8 x = convert_float8(i & 1023u) * 0.0019f - 0.97f;
    const float8 y = convert_float8((i >> 10) & 255u) * 0.6f + 1.0f;
    vstore8(atan2pi_float8(y, x), g, out);
}
__kernel void float3_ops(__global float* out) {
    const uint i = get_global_id(0);
    const float3 p = (float3)((float)(i & 1023u) * 0.19f - 97.0f, (float)((i >> 10) & 255u) * 0.6f + 1.0f, 2.0f);
    const float3 q = p * 0.5f + (float3)(1.0f, 2.0f, 3.0f);
    const float c = length(cross(p, q)) / sqrt(dot(p, q) + 1.0f);
    out[i] = c > 0.0f ? c : -c * 0.5f;
}
"#;

/// Each kernel and the values one work-item computes.
const KERNELS: [(&str, usize); 5] = [
    ("scalar", 1),
    ("builtin", 1),
    ("float3_ops", 1),
    ("polynomial", 1),
    ("polynomial_x8", 8),
];
const ITEMS: usize = 1 << 24;
/// Marks the child's result lines among what PoCL prints to standard output (its remarks).
const RESULT: &str = "pocl_vectorizer:";

/// In the child: ns per work-item of each kernel, one line each.
fn time_kernels() -> ocl::Result<()> {
    let pq = ocl::ProQue::builder().src(SOURCE).dims(ITEMS).build()?;
    let out = pq.create_buffer::<f32>()?;
    for (name, lanes) in KERNELS {
        let kernel = pq
            .kernel_builder(name)
            .arg_named("out", &out)
            .global_work_size(ITEMS / lanes)
            .local_work_size(64)
            .build()?;
        let mut best = f64::INFINITY;
        for launch in 0..6 {
            let start = Instant::now();
            // SAFETY: ITEMS / lanes work-items write `lanes` floats each, at lanes * id:
            // within the buffer of ITEMS floats.
            unsafe { kernel.enq()? };
            pq.finish()?;
            if launch > 0 {
                best = best.min(start.elapsed().as_secs_f64());
            }
        }
        println!("{RESULT} {name} {:.2}", best * 1e9 / ITEMS as f64);
    }
    Ok(())
}

fn main() {
    if std::env::var_os("POCL_VECTORIZER_CHILD").is_some() {
        if let Err(e) = time_kernels() {
            eprintln!("{e}");
            std::process::exit(1);
        }
        return;
    }
    let me = std::env::current_exe().expect("this example's path");
    let methods = ["loopvec", "loops"];
    let columns: Vec<Vec<String>> = methods
        .iter()
        .map(|method| {
            let out = Command::new(&me)
                .env("POCL_VECTORIZER_CHILD", "1")
                .env("POCL_WORK_GROUP_METHOD", method)
                .env("POCL_KERNEL_CACHE", "0")
                .output()
                .expect("run this example again");
            eprint!("{}", String::from_utf8_lossy(&out.stderr));
            let stdout = String::from_utf8_lossy(&out.stdout);
            // A remark may end without a newline, ahead of a result on the same line.
            stdout
                .lines()
                .filter_map(|l| match l.find(RESULT) {
                    Some(at) => {
                        if at > 0 {
                            eprintln!("{}", &l[..at]);
                        }
                        l[at..].split_whitespace().nth(2).map(str::to_string)
                    }
                    None => {
                        if !l.is_empty() {
                            eprintln!("{l}");
                        }
                        None
                    }
                })
                .collect()
        })
        .collect();
    println!("| kernel | ns a value, `loopvec` | ns a value, `loops` |");
    println!("|---|---|---|");
    for (k, (name, _)) in KERNELS.iter().enumerate() {
        let cell = |c: &Vec<String>| c.get(k).cloned().unwrap_or_else(|| "-".into());
        println!(
            "| `{name}` | {} | {} |",
            cell(&columns[0]),
            cell(&columns[1])
        );
    }
}
