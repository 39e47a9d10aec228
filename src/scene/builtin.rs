//! The scene `clpt render` draws when no file is given: `scenes/smallpt.txt`, compiled into the
//! binary so the first command of the README needs no file.

use super::Scene;
use crate::error::Result;

/// The built-in scene's text.
pub const SMALLPT: &str = include_str!("../../scenes/smallpt.txt");

/// The name the built-in scene goes by in messages and default output names.
pub const NAME: &str = "smallpt";

/// The built-in scene, parsed.
pub fn scene() -> Result<Scene> {
    Ok(super::parse::parse_scene(SMALLPT, NAME)?)
}
