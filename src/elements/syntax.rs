//! The scene file's syntax, below any one block's grammar: whitespace-separated tokens with
//! their lines and columns (`Tokenizer`), and the parser's position in them with the readers
//! of fields and values every block uses (`Cursor`: numbers the device can hold, vectors,
//! directions, counts, paths, profile curves), each refusing what it cannot read with a
//! [`ParseError`] at file:line:column. The grammar of the file's blocks is
//! `crate::scene::parse`'s; each kind of object reads its own block (`crate::shapes`).

use super::MaterialKind;
use super::curve::{Curve, CurveKind};
use crate::error::{Location, ParseError, Warning, quote};
use glam::{DMat4, DVec2, DVec3};
use std::num::IntErrorKind;
use std::path::PathBuf;

pub(crate) type Result<T> = std::result::Result<T, ParseError>;

/// A field's value with the token of its name, so a repeat can point back at the first one.
pub(crate) type Slot<'a, T> = Option<(T, Token<'a>)>;

/// Blocks may nest at most this deep (`Group`, each `Transform`, the object, a `Rotate` or curve
/// in it): 10,000 nested `Transform` blocks overflowed the stack. The original's scenes nest 4
/// deep, and nested transforms compose into one matrix per object, so depth buys nothing on the
/// device. Each `Transform` level takes about 2 KiB of the parser's stack (254 levels needed
/// between 384 and 512 KiB, in release and debug builds alike), so 256 levels use a quarter of
/// the 2 MiB a spawned thread gets.
pub const MAX_NESTING: usize = 256;

/// Whether the device can hold `value` as an f32: finite there, and not 0 unless it is 0 (a
/// radius of 1e-50 would be none at all).
pub(crate) fn fits_f32(value: f64) -> bool {
    let single = value as f32;
    single.is_finite() && (single != 0.0 || value == 0.0)
}

/// f32's range as messages state it.
pub(crate) fn f32_range() -> String {
    format!(
        "f32's range (0, or a magnitude from {:?} to {:?}, as the device computes in f32)",
        f32::from_bits(1),
        f32::MAX
    )
}

/// "`a`, `b` or `c`".
pub(crate) fn one_of(words: &[&str]) -> String {
    listed(words, "or")
}

pub(crate) fn listed(words: &[&str], conjunction: &str) -> String {
    let quoted: Vec<String> = words.iter().map(|w| format!("`{w}`")).collect();
    match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} {conjunction} {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// A word of the scene file and where it starts (1-based; the column counts characters).
#[derive(Clone, Copy)]
pub(crate) struct Token<'a> {
    pub(crate) text: &'a str,
    pub(crate) line: usize,
    pub(crate) column: usize,
}

pub(crate) fn is_bracket(c: char) -> bool {
    matches!(c, '{' | '}' | '[' | ']')
}

/// Splits a scene's text into tokens, skipping whitespace and `#` comments.
pub(crate) struct Tokenizer<'a> {
    pub(crate) rest: &'a str,
    pub(crate) line: usize,
    pub(crate) column: usize,
}

impl<'a> Tokenizer<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        Tokenizer {
            rest: text,
            line: 1,
            column: 1,
        }
    }

    /// Consumes the next `len` bytes (always a whole number of characters), keeping the line and
    /// column in step.
    pub(crate) fn advance(&mut self, len: usize) -> &'a str {
        let (taken, rest) = self.rest.split_at_checked(len).unwrap_or((self.rest, ""));
        for c in taken.chars() {
            if c == '\n' {
                self.line += 1;
                self.column = 1;
            } else {
                self.column += 1;
            }
        }
        self.rest = rest;
        taken
    }
}

impl<'a> Iterator for Tokenizer<'a> {
    type Item = Token<'a>;

    fn next(&mut self) -> Option<Token<'a>> {
        let first = loop {
            let c = self.rest.chars().next()?;
            if c == '#' {
                let comment = self.rest.find('\n').unwrap_or(self.rest.len());
                self.advance(comment);
            } else if c.is_whitespace() {
                self.advance(c.len_utf8());
            } else {
                break c;
            }
        };
        let (line, column) = (self.line, self.column);
        let len = if is_bracket(first) {
            first.len_utf8()
        } else {
            self.rest
                .find(|c: char| c.is_whitespace() || c == '#' || is_bracket(c))
                .unwrap_or(self.rest.len())
        };
        Some(Token {
            text: self.advance(len),
            line,
            column,
        })
    }
}

/// The parser's position in the scene's tokens, read one at a time as the parser asks for them
/// (a token list held 32 bytes a token before any was parsed), the blocks open around it, and the
/// warnings so far.
pub(crate) struct Cursor<'a> {
    file: &'a str,
    tokens: Tokenizer<'a>,
    /// The token after the last one taken, once `peek` has read it.
    ahead: Option<Token<'a>>,
    /// The last token taken: end-of-file errors, which come once every token is taken, point
    /// just after it.
    last: Option<Token<'a>>,
    /// Keywords of the blocks opened and not yet closed, innermost last.
    open: Vec<Token<'a>>,
    pub(crate) warnings: Vec<Warning>,
}

impl<'a> Cursor<'a> {
    pub(crate) fn new(text: &'a str, file: &'a str) -> Self {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Cursor {
            file,
            tokens: Tokenizer::new(text),
            ahead: None,
            last: None,
            open: Vec::new(),
            warnings: Vec::new(),
        }
    }

    pub(crate) fn peek(&mut self) -> Option<Token<'a>> {
        if self.ahead.is_none() {
            self.ahead = self.tokens.next();
        }
        self.ahead
    }

    pub(crate) fn next(&mut self) -> Option<Token<'a>> {
        let token = self.ahead.take().or_else(|| self.tokens.next())?;
        self.last = Some(token);
        Some(token)
    }

    /// Just after the last token (1:1 when there is none): where end-of-file errors point.
    pub(crate) fn end(&self) -> Location {
        let (line, column) = self
            .last
            .map_or((1, 1), |t| (t.line, t.column + t.text.chars().count()));
        Location {
            file: self.file.to_string(),
            line,
            column,
        }
    }

    pub(crate) fn at(&self, token: Token) -> Location {
        Location {
            file: self.file.to_string(),
            line: token.line,
            column: token.column,
        }
    }

    pub(crate) fn error_at(&self, token: Token, message: String) -> ParseError {
        ParseError {
            location: self.at(token),
            message,
        }
    }

    pub(crate) fn warn(&mut self, token: Token, message: impl Into<String>) {
        self.warnings.push(Warning {
            location: self.at(token),
            message: message.into(),
        });
    }

    /// `value` clamped to [0, `most`] component by component, with a warning at its field `key`
    /// saying `why` when that changed it.
    pub(crate) fn clamped(&mut self, value: DVec3, most: DVec3, key: Token, why: &str) -> DVec3 {
        let clamped = value.clamp(DVec3::ZERO, most);
        if clamped != value {
            let v = |v: DVec3| format!("{} {} {}", v.x, v.y, v.z);
            self.warn(
                key,
                format!(
                    "`{} {}` {why}: clamped to {}",
                    key.text,
                    v(value),
                    v(clamped)
                ),
            );
        }
        clamped
    }

    /// "expected {what}, found `{token}`", or at the end of the file, naming the innermost block
    /// left open.
    pub(crate) fn expected(&self, found: Option<Token>, what: &str) -> ParseError {
        match found {
            Some(token) => self.error_at(
                token,
                format!("expected {what}, found {}", quote(token.text)),
            ),
            None => ParseError {
                location: self.end(),
                message: match self.open.last() {
                    Some(block) => format!(
                        "expected {what}, found end of file inside {} opened at {}:{}",
                        quote(block.text),
                        block.line,
                        block.column
                    ),
                    None => format!("expected {what}, found end of file"),
                },
            },
        }
    }

    pub(crate) fn unknown_field(&self, key: Token, block: Token, fields: &[&str]) -> ParseError {
        self.expected(
            Some(key),
            &format!("{} in {}", one_of(fields), quote(block.text)),
        )
    }

    /// "expected a `X` block" (or "`X` and `Y` blocks") at the end of the file, for each of
    /// `blocks` that is `missing`.
    pub(crate) fn missing_blocks(&self, blocks: &[&str], missing: &[bool]) -> ParseError {
        let names: Vec<&str> = blocks
            .iter()
            .zip(missing)
            .filter_map(|(name, absent)| absent.then_some(*name))
            .collect();
        let what = match names.as_slice() {
            [one] => format!("a `{one}` block"),
            _ => format!("{} blocks", listed(&names, "and")),
        };
        ParseError {
            location: self.end(),
            message: format!("expected {what}, found end of file"),
        }
    }

    /// `BezierCurve { controls [ x y z ] ... }` or `BsplineCurve { ... }`, checked: the points
    /// must lie in the xy-plane (z = 0) and be enough for the curve's kind.
    pub(crate) fn curve(&mut self) -> Result<Curve> {
        let kind_token = match self.next() {
            Some(t) if t.text == "BezierCurve" || t.text == "BsplineCurve" => t,
            found => return Err(self.expected(found, "`BezierCurve` or `BsplineCurve`")),
        };
        let kind = if kind_token.text == "BezierCurve" {
            CurveKind::Bezier
        } else {
            CurveKind::BSpline
        };
        self.open_block(kind_token)?;
        match self.next() {
            Some(t) if t.text == "controls" => {}
            found => return Err(self.expected(found, "`controls`")),
        }
        let mut points = Vec::new();
        loop {
            match self.next() {
                Some(t) if t.text == "}" => {
                    self.open.pop();
                    break;
                }
                Some(t) if t.text == "[" => {
                    let x = self.number("controls")?.0;
                    let y = self.number("controls")?.0;
                    let (z, z_token) = self.number("controls")?;
                    if z != 0.0 {
                        return Err(self.error_at(
                            z_token,
                            format!(
                                "control point {} of the profile has z = {z}: a profile lies in \
                                 the xy-plane (z = 0) and is revolved about the y axis",
                                points.len() + 1
                            ),
                        ));
                    }
                    match self.next() {
                        Some(t) if t.text == "]" => {}
                        found => return Err(self.expected(found, "`]` after a control point")),
                    }
                    points.push(DVec2::new(x, y));
                }
                found => return Err(self.expected(found, "`[` (a control point) or `}`")),
            }
        }
        Curve::new(kind, points).map_err(|message| self.error_at(kind_token, message))
    }

    /// Consumes the `}` that closes a block of fixed contents (`Rotate { .. }`, `Matrix4f`).
    pub(crate) fn close_block(&mut self, keyword: Token<'a>) -> Result<()> {
        match self.next() {
            Some(token) if token.text == "}" => {
                self.open.pop();
                Ok(())
            }
            found => Err(self.expected(found, &format!("`}}` to close {}", quote(keyword.text)))),
        }
    }

    /// Consumes the `{` after a block's keyword and marks the block open, at most
    /// [`MAX_NESTING`] deep.
    pub(crate) fn open_block(&mut self, keyword: Token<'a>) -> Result<()> {
        if self.open.len() >= MAX_NESTING {
            return Err(self.error_at(
                keyword,
                format!(
                    "expected blocks nested at most {MAX_NESTING} deep, found {} {} deep",
                    quote(keyword.text),
                    self.open.len() + 1
                ),
            ));
        }
        match self.next() {
            Some(token) if token.text == "{" => {
                self.open.push(keyword);
                Ok(())
            }
            found => Err(self.expected(found, &format!("`{{` after {}", quote(keyword.text)))),
        }
    }

    /// The next token in the innermost open block: a field name, or the `}` that closes it.
    pub(crate) fn field(&mut self) -> Result<Token<'a>> {
        match self.next() {
            Some(token) => {
                if token.text == "}" {
                    self.open.pop();
                }
                Ok(token)
            }
            None => Err(match self.open.last() {
                Some(block) => ParseError {
                    location: self.end(),
                    message: format!(
                        "expected `}}` to close {} opened at {}:{}, found end of file",
                        quote(block.text),
                        block.line,
                        block.column
                    ),
                },
                None => self.expected(None, "`}`"),
            }),
        }
    }

    /// Reads a field's value into its slot, refusing a field given twice.
    pub(crate) fn once<T>(
        &mut self,
        slot: &mut Slot<'a, T>,
        key: Token<'a>,
        value: impl FnOnce(&mut Self) -> Result<T>,
    ) -> Result<()> {
        if let Some((_, first)) = slot {
            return Err(self.error_at(
                key,
                format!(
                    "expected {} only once, found it again (first at {}:{})",
                    quote(key.text),
                    first.line,
                    first.column
                ),
            ));
        }
        *slot = Some((value(self)?, key));
        Ok(())
    }

    /// A required field's value, or an error at the `}` that closed its block without it.
    pub(crate) fn required<T>(
        &self,
        slot: Slot<T>,
        field: &str,
        block: Token,
        close: Token,
    ) -> Result<T> {
        slot.map(|(value, _)| value).ok_or_else(|| {
            self.error_at(
                close,
                format!(
                    "expected `{field}` in {} opened at {}:{}, found `}}`",
                    quote(block.text),
                    block.line,
                    block.column
                ),
            )
        })
    }

    /// A number the device reads as an f32, and its token.
    pub(crate) fn number(&mut self, field: &str) -> Result<(f64, Token<'a>)> {
        let (value, token) = self.finite_number(&format!("`{field}`"))?;
        Ok((self.device_value(field, value, token)?, token))
    }

    /// A finite number of any size (`what` names it: "`field`").
    pub(crate) fn finite_number(&mut self, what: &str) -> Result<(f64, Token<'a>)> {
        let found = self.next();
        match found.map(|t| (t.text.parse::<f64>(), t)) {
            Some((Ok(value), token)) if value.is_finite() => Ok((value, token)),
            Some((Ok(_), token)) => {
                Err(self.expected(Some(token), &format!("a finite number for {what}")))
            }
            _ => Err(self.expected(found, &format!("a number for {what}"))),
        }
    }

    /// `value`, read from `token` for `field`, if the device can hold it as an f32.
    pub(crate) fn device_value(&self, field: &str, value: f64, token: Token) -> Result<f64> {
        if fits_f32(value) {
            Ok(value)
        } else {
            Err(self.expected(Some(token), &format!("`{field}` within {}", f32_range())))
        }
    }

    /// A number that must satisfy `ok`; `rule` says how, after "expected `field` ".
    pub(crate) fn number_where(
        &mut self,
        field: &str,
        ok: impl Fn(f64) -> bool,
        rule: &str,
    ) -> Result<f64> {
        let (value, token) = self.number(field)?;
        if ok(value) {
            Ok(value)
        } else {
            Err(self.error_at(
                token,
                format!("expected `{field}` {rule}, found {}", quote(token.text)),
            ))
        }
    }

    pub(crate) fn positive(&mut self, field: &str) -> Result<f64> {
        self.number_where(field, |v| v > 0.0, "greater than 0")
    }

    pub(crate) fn non_negative(&mut self, field: &str) -> Result<f64> {
        self.number_where(field, |v| v >= 0.0, "of at least 0")
    }

    /// Three finite numbers of any size, with their tokens.
    pub(crate) fn components(&mut self, field: &str) -> Result<[(f64, Token<'a>); 3]> {
        let what = format!("`{field}`, which takes three");
        Ok([
            self.finite_number(&what)?,
            self.finite_number(&what)?,
            self.finite_number(&what)?,
        ])
    }

    /// Three numbers the device reads as f32s, and the token of the first.
    pub(crate) fn vector(&mut self, field: &str) -> Result<(DVec3, Token<'a>)> {
        let components = self.components(field)?;
        for (value, token) in components {
            self.device_value(field, value, token)?;
        }
        let [(x, first), (y, _), (z, _)] = components;
        Ok((DVec3::new(x, y, z), first))
    }

    /// A direction: three finite numbers of any size, not all 0, as written and as a unit
    /// vector (normalised without overflow or underflow), and the token of the first.
    pub(crate) fn direction(&mut self, field: &str) -> Result<(DVec3, DVec3, Token<'a>)> {
        let [(x, first), (y, _), (z, _)] = self.components(field)?;
        let written = DVec3::new(x, y, z);
        match super::unit_vector(written) {
            Some(unit) => Ok((written, unit, first)),
            None => Err(self.error_at(
                first,
                format!("expected a nonzero vector for `{field}`, found the zero vector"),
            )),
        }
    }

    /// The camera's `direction` as written, checked as the camera's basis needs it.
    pub(crate) fn camera_direction(&mut self) -> Result<DVec3> {
        let (written, _, first) = self.direction("direction")?;
        super::camera::forward(written)
            .map(|_| written)
            .map_err(|message| self.error_at(first, message))
    }

    /// `Matrix4f`'s 16 numbers, column by column, as the course framework reads them. Its
    /// bottom row (numbers 4, 8, 12, 16) must be 0 0 0 1: the device keeps the top three rows
    /// of an affine matrix, and a projective row was dropped silently.
    pub(crate) fn affine_matrix(&mut self) -> Result<DMat4> {
        let mut columns = [0.0; 16];
        for (i, value) in columns.iter_mut().enumerate() {
            let (number, token) = self.number("Matrix4f")?;
            let bottom = [0.0, 0.0, 0.0, 1.0][i / 4];
            if i % 4 == 3 && number != bottom {
                return Err(self.error_at(
                    token,
                    format!(
                        "expected `{bottom}` as number {} of `Matrix4f`, found {}: read column \
                         by column, its bottom row must be 0 0 0 1, as clpt's transforms are \
                         affine (the device keeps the top three rows; a projective row would be \
                         dropped)",
                        i + 1,
                        quote(token.text)
                    ),
                ));
            }
            *value = number;
        }
        Ok(DMat4::from_cols_array(&columns))
    }

    pub(crate) fn integer(&mut self, field: &str) -> Result<(i64, Token<'a>)> {
        let found = self.next();
        match found.map(|t| (t.text.parse::<i64>(), t)) {
            Some((Ok(integer), token)) => Ok((integer, token)),
            Some((Err(e), token))
                if matches!(
                    e.kind(),
                    IntErrorKind::PosOverflow | IntErrorKind::NegOverflow
                ) =>
            {
                Err(self.expected(
                    Some(token),
                    &format!(
                        "an integer of at most {} in magnitude for `{field}`",
                        i64::MAX
                    ),
                ))
            }
            _ => Err(self.expected(found, &format!("an integer for `{field}`"))),
        }
    }

    pub(crate) fn count(&mut self, field: &str) -> Result<(usize, Token<'a>)> {
        let (value, token) = self.integer(field)?;
        match usize::try_from(value) {
            Ok(count) => Ok((count, token)),
            Err(_) => Err(self.expected(
                Some(token),
                &format!("a non-negative integer for `{field}`"),
            )),
        }
    }

    /// The `numMaterials N` / `numObjects N` that opens a list block, and the token of `N`.
    pub(crate) fn count_field(&mut self, key: &str) -> Result<(usize, Token<'a>)> {
        match self.next() {
            Some(token) if token.text == key => self.count(key),
            found => Err(self.expected(found, &format!("`{key}`"))),
        }
    }

    pub(crate) fn image_size(&mut self, field: &str) -> Result<u32> {
        let (value, token) = self.integer(field)?;
        u32::try_from(value)
            .ok()
            .filter(|v| (1..=65536).contains(v))
            .ok_or_else(|| {
                self.error_at(
                    token,
                    format!(
                        "expected `{field}` between 1 and 65536, found {}",
                        quote(token.text)
                    ),
                )
            })
    }

    pub(crate) fn check_index(&self, index: usize, token: Token, count: usize) -> Result<()> {
        if index < count {
            return Ok(());
        }
        let what = match count {
            0 => "no `MaterialIndex`, as `Materials` lists no material".to_string(),
            _ => format!("a material index from 0 to {}", count - 1),
        };
        Err(self.expected(Some(token), &what))
    }

    pub(crate) fn material_kind(&mut self) -> Result<MaterialKind> {
        let found = self.next();
        match found.map(|t| t.text) {
            Some("diff") => Ok(MaterialKind::Diffuse),
            Some("spec") => Ok(MaterialKind::Specular),
            Some("refr") => Ok(MaterialKind::Refractive),
            _ => Err(self.expected(
                found,
                &format!("{} for `type`", one_of(&["diff", "spec", "refr"])),
            )),
        }
    }

    pub(crate) fn path(&mut self, field: &str) -> Result<PathBuf> {
        match self.next() {
            Some(token) if !token.text.starts_with(is_bracket) => Ok(PathBuf::from(token.text)),
            found => Err(self.expected(found, &format!("a file path for `{field}`"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tokens(text: &str) -> Vec<(&str, usize, usize)> {
        Tokenizer::new(text)
            .map(|t| (t.text, t.line, t.column))
            .collect()
    }

    #[test]
    fn tokens_carry_line_and_character_column() {
        assert_eq!(
            tokens("Sphere {\n\tcenter 1 -2 3.5\n  radius  é9 }"),
            [
                ("Sphere", 1, 1),
                ("{", 1, 8),
                ("center", 2, 2),
                ("1", 2, 9),
                ("-2", 2, 11),
                ("3.5", 2, 14),
                ("radius", 3, 3),
                ("é9", 3, 11),
                ("}", 3, 14),
            ]
        );
    }

    #[test]
    fn brackets_split_from_words_and_comments_are_skipped() {
        assert_eq!(
            tokens("a{b}[c]# x { y\n#\nd#e\n"),
            [
                ("a", 1, 1),
                ("{", 1, 2),
                ("b", 1, 3),
                ("}", 1, 4),
                ("[", 1, 5),
                ("c", 1, 6),
                ("]", 1, 7),
                ("d", 3, 1),
            ]
        );
    }

    #[test]
    fn end_of_file_is_just_after_the_last_token() {
        let end = |text| {
            let mut cur = Cursor::new(text, "f");
            while cur.next().is_some() {}
            let end = cur.end();
            (end.line, end.column)
        };
        assert_eq!(end("a\n  bé # c\n\n"), (2, 5));
        assert_eq!(end(" \n# only a comment\n"), (1, 1));
    }

    #[test]
    fn lists_read_as_english() {
        assert_eq!(one_of(&["a"]), "`a`");
        assert_eq!(one_of(&["a", "b", "c"]), "`a`, `b` or `c`");
        assert_eq!(listed(&["a", "b"], "and"), "`a` and `b`");
    }
}
