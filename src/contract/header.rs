//! `kernels/types.h`, written from the Rust declarations (`types.rs`, `buffers.rs`):
//! the kernels' copy of every shared constant, struct and the scene buffer list. The file is in
//! the tree for readers and for `--kernels DIR`; `tests/layout.rs` fails when it differs from
//! [`text`] and rewrites it with `CLPT_WRITE_TYPES_H=1`.

use super::{ITEMS, Item, OBJECT_KINDS, SCENE_BUFFERS};

const WIDTH: usize = 100;

const PREAMBLE: &str = "\
/* types.h: every struct, constant and buffer shared between host and device.
 *
 * WRITTEN BY THE HOST from src/contract/types.rs and buffers.rs, its one definition: edit those
 * and run `CLPT_WRITE_TYPES_H=1 cargo test --release --test layout` (the test fails while this
 * file differs). Reads: nothing. Writes: nothing. Why: both sides must agree to the byte; the
 * layout probe (tests/layout.rs) also compiles offsetof() for every field and every constant on
 * the device and compares them with Rust's. Rules: only 4-byte scalars and arrays of them (no
 * float3: it is 16 bytes with 16-byte alignment), so no implicit padding can differ between
 * compilers.
 */
#ifndef CLPT_TYPES_H
#define CLPT_TYPES_H

#include \"features.h\"

/* Compile-time size check that works in OpenCL C 1.2 (C99 has no _Static_assert). */
#define CLPT_ASSERT_SIZE(T, n) typedef char clpt_size_check_##T[(sizeof(T) == (n)) ? 1 : -1]
";

/// The text of `kernels/types.h`.
pub fn text() -> String {
    let mut out = String::from(PREAMBLE);
    let mut previous_const = false;
    for item in ITEMS {
        match item {
            Item::Const(c) => {
                // A constant with a sentence above it opens a group; the rest of the group
                // follows it.
                if !previous_const || !(c.doc.is_empty() || inline(c.doc)) {
                    out.push('\n');
                }
                let value = if c.value >= 0x10000 {
                    format!("0x{:X}u", c.value)
                } else {
                    format!("{}u", c.value)
                };
                let line = format!("#define {} {value}", c.name);
                push_commented(&mut out, "", &line, c.doc);
                previous_const = true;
            }
            Item::Struct(s) => {
                out.push('\n');
                push_block_comment(&mut out, "", s.doc);
                out.push_str(&format!("typedef struct {} {{\n", s.name));
                for f in s.fields {
                    let dims = if f.len > 0 {
                        format!("[{}]", f.len)
                    } else {
                        String::new()
                    };
                    let line = format!("{} {}{dims};", f.c_type, f.name);
                    push_commented(&mut out, "    ", &line, f.doc);
                }
                out.push_str(&format!("}} {};\n", s.name));
                out.push_str(&format!("CLPT_ASSERT_SIZE({}, {});\n", s.name, s.size));
                previous_const = false;
            }
        }
    }
    push_kinds(&mut out);
    out.push('\n');
    push_block_comment(
        &mut out,
        "",
        &[
            "Every scene buffer, X(element type, parameter name), in the order kernels take them \
           (src/contract/buffers.rs; scene.h builds the Scene struct and the kernels' \
           parameter list from it).",
        ],
    );
    out.push_str("#define SCENE_BUFFERS(X)");
    for (name, c_type) in SCENE_BUFFERS {
        out.push_str(&format!(" \\\n    X({c_type}, {name})"));
    }
    out.push_str("\n\n#endif\n");
    out
}

/// Each kind of object's program switch, on unless the host's `-D` turns it off, and the
/// `SHAPES(X)` list of the kinds the program has ([`OBJECT_KINDS`]).
fn push_kinds(out: &mut String) {
    out.push('\n');
    push_block_comment(
        out,
        "",
        &[
            "Every kind of object, in the order rays meet them without the object BVH \
             (src/contract/types.rs, OBJECT_KINDS): its program switch CLPT_KINDS (on unless \
             the host's -D turns it off: src/render/features.rs) and SHAPES(X), X(OBJECT_KIND, \
             kind) for each kind the program has. kernels/shapes.h says what each kind defines.",
        ],
    );
    let mut list = String::from("#define SHAPES(X)");
    for kind in &OBJECT_KINDS {
        let switch = kind.switch;
        let entry = format!("SHAPE_{}", kind.name.to_uppercase());
        let constant = format!("OBJECT_{}", kind.name.to_uppercase());
        out.push_str(&format!(
            "#ifndef {switch}\n#define {switch} 1\n#endif\n#if {switch}\n\
             #define {entry}(X) X({constant}, {name})\n#else\n#define {entry}(X)\n#endif\n",
            name = kind.name
        ));
        list.push_str(&format!(" {entry}(X)"));
    }
    out.push_str(&list);
    out.push('\n');
}

/// Whether a doc comment goes on its declaration's line: one phrase, not a sentence.
fn inline(doc: &[&str]) -> bool {
    matches!(doc, [one] if !one.trim().ends_with('.'))
}

/// `line` with its comment: on the same line when it is a phrase that fits, else a block above.
fn push_commented(out: &mut String, indent: &str, line: &str, doc: &[&str]) {
    if inline(doc) {
        let text = format!("{indent}{line:<22} /* {} */", doc[0].trim());
        if text.len() <= WIDTH {
            out.push_str(&text);
            out.push('\n');
            return;
        }
    }
    push_block_comment(out, indent, doc);
    out.push_str(&format!("{indent}{line}\n"));
}

/// A `/* ... */` comment of the doc lines, re-wrapped at [`WIDTH`] columns, except lines that
/// open with spaces (a table or a formula keeps its lines).
fn push_block_comment(out: &mut String, indent: &str, doc: &[&str]) {
    if doc.is_empty() {
        return;
    }
    let mut lines: Vec<String> = Vec::new();
    let mut paragraph: Vec<&str> = Vec::new();
    let first = format!("{indent}/* ");
    let rest = format!("{indent} * ");
    let flush = |paragraph: &mut Vec<&str>, lines: &mut Vec<String>| {
        let mut current = String::new();
        for word in paragraph.drain(..) {
            let lead = if lines.is_empty() { &first } else { &rest };
            if !current.is_empty() && lead.len() + current.len() + 1 + word.len() + 3 > WIDTH {
                lines.push(std::mem::take(&mut current));
            }
            if !current.is_empty() {
                current.push(' ');
            }
            current.push_str(word);
        }
        if !current.is_empty() {
            lines.push(current);
        }
    };
    for d in doc {
        let d = d.strip_prefix(' ').unwrap_or(d);
        if d.starts_with(' ') {
            flush(&mut paragraph, &mut lines);
            lines.push(d.to_string());
        } else {
            paragraph.extend(d.split_whitespace());
        }
    }
    flush(&mut paragraph, &mut lines);
    let n = lines.len();
    for (i, l) in lines.into_iter().enumerate() {
        out.push_str(if i == 0 { &first } else { &rest });
        out.push_str(&l);
        out.push_str(if i + 1 == n { " */\n" } else { "\n" });
    }
}
