//! pbrt-v3 scene text to a [`SceneDescription`]: the tokenizer, the
//! directive parser and the builder that turns directives into entities
//! (pbrt-v3 `core/parser.cpp` and `core/api.cpp`), with `Include`, PLY
//! meshes and the files a scene names read as they are met. Every error
//! names `file:line:column`.
//!
//! ```text
//! let (scene, warnings) = farm_scene::parse_file(Path::new("scenes/cornell-box.pbrt"))?;
//! ```
#![warn(missing_docs)]

mod assets;
mod builder;
/// Scene errors.
pub mod error;
mod overrides;
mod parser;
/// PLY mesh reader.
pub mod ply;
pub mod tokenizer;
pub mod transform;
pub mod values;
mod world;

#[cfg(test)]
mod directive_tests;
#[cfg(test)]
mod tests;

pub use assets::is_outside;
pub use error::{Result, SceneError};
use farm_common::scene::{FileLoc, SceneDescription, Warning};
pub use overrides::Overrides;
use std::path::Path;

/// Parses a scene file and the files it includes.
pub fn parse_file(path: &Path) -> Result<(SceneDescription, Vec<Warning>)> {
    let file = path.to_string_lossy().into_owned();
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::File {
        loc: FileLoc { file: file.clone(), line: 1, column: 1 },
        path: file.clone(),
        source,
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    parse(&text, &file, dir, &name)
}

/// Parses scene text; `file_name` is used in locations and for the scene's
/// name, `base_dir` resolves relative paths.
pub fn parse_str(
    source: &str,
    file_name: &str,
    base_dir: &Path,
) -> Result<(SceneDescription, Vec<Warning>)> {
    let name = Path::new(file_name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    parse(source, file_name, base_dir, &name)
}

fn parse(
    text: &str,
    file: &str,
    dir: &Path,
    name: &str,
) -> Result<(SceneDescription, Vec<Warning>)> {
    let mut p = parser::Parser::new(name);
    let base = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
    p.builder.root = std::fs::canonicalize(base).unwrap_or_else(|_| base.to_path_buf());
    p.builder.search_dir = dir.to_path_buf();
    p.parse_text(text, file, dir)?;
    Ok(p.builder.finish(&p.end))
}
