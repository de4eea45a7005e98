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
mod write;

#[cfg(test)]
mod directive_tests;
#[cfg(test)]
mod tests;

pub use assets::is_outside;
pub use error::{Result, SceneError};
use farm_common::scene::{FileLoc, SceneDescription, Warning};
pub use overrides::{Overrides, SAMPLER_NAMES};
use std::path::Path;
pub use write::{write_scene, Meshes};

/// Parses a scene file and the files it includes: the first scene it
/// describes (see [`parse_files`] for inputs that describe several).
pub fn parse_file(path: &Path) -> Result<(SceneDescription, Vec<Warning>)> {
    let mut scenes = parse_files(&[path])?;
    let (scene, mut warnings) = scenes.remove(0);
    if !scenes.is_empty() {
        let loc = FileLoc { file: path.to_string_lossy().into_owned(), line: 1, column: 1 };
        warnings.push(Warning::at(
            &loc,
            format!("the file describes {} scenes; only the first is used here", scenes.len() + 1),
        ));
    }
    Ok((scene, warnings))
}

/// Parses scene files as pbrt-v3's command line reads them: one stream,
/// file after file, each `WorldEnd` finishing a scene and the next
/// starting from fresh options. `-` is standard input; a name ending in
/// `.gz` is gzip-compressed (as pbrt-v4 reads it). Files a scene names
/// resolve against the directory of the file being read (pbrt-v3 sets its
/// search directory for each file it is given); asset keys are relative to
/// the first file's directory. There is always at least one scene.
pub fn parse_files<P: AsRef<Path>>(paths: &[P]) -> Result<Vec<(SceneDescription, Vec<Warning>)>> {
    SceneStream::new(paths).map(|r| r.map(|s| (s.desc, s.warnings))).collect()
}

/// One scene of a [`SceneStream`].
pub struct StreamedScene {
    /// The scene.
    pub desc: SceneDescription,
    /// The parser's warnings about it.
    pub warnings: Vec<Warning>,
    /// Which of the stream's files its `WorldEnd` (or the input's end) is in.
    pub file: usize,
}

/// Scene files read as [`parse_files`] reads them, a file at a time: each
/// scene is handed out once the file it ends in has been read, so a shot
/// of many frames holds one frame's scenes at a time, not all of them.
/// After an error it yields nothing more.
pub struct SceneStream {
    paths: Vec<std::path::PathBuf>,
    next: usize,
    parser: parser::Parser,
    ready: std::collections::VecDeque<StreamedScene>,
    handed: usize,
    done: bool,
}

impl SceneStream {
    /// A stream over `paths` (`-` is standard input; `.gz` is read
    /// compressed); asset keys are relative to the first file's directory.
    pub fn new<P: AsRef<Path>>(paths: &[P]) -> SceneStream {
        let paths: Vec<std::path::PathBuf> =
            paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
        let first = paths.first().map(|p| p.as_path()).unwrap_or(Path::new("-"));
        let mut parser = parser::Parser::new(&scene_name(first));
        let base = dir_of(first);
        parser.builder.root = std::fs::canonicalize(&base).unwrap_or_else(|_| base.clone());
        SceneStream { paths, next: 0, parser, ready: Default::default(), handed: 0, done: false }
    }

    /// Reads the next file, queueing the scenes it finished.
    fn read_next(&mut self) -> Result<()> {
        let i = self.next;
        self.next += 1;
        let path = self.paths[i].clone();
        let file = if path == Path::new("-") {
            "<stdin>".to_string()
        } else {
            path.to_string_lossy().into_owned()
        };
        let start = FileLoc { file: file.clone(), line: 1, column: 1 };
        let text = read_scene_text(&path, &start)?;
        let dir = dir_of(&path);
        self.parser.builder.search_dir.clone_from(&dir);
        self.parser.parse_text(&text, &file, &dir)?;
        self.parser.close_ended();
        for (desc, warnings) in self.parser.finished.drain(..) {
            self.ready.push_back(StreamedScene { desc, warnings, file: i });
        }
        Ok(())
    }
}

impl Iterator for SceneStream {
    type Item = Result<StreamedScene>;

    fn next(&mut self) -> Option<Self::Item> {
        while self.ready.is_empty() && !self.done {
            if self.next < self.paths.len() {
                if let Err(e) = self.read_next() {
                    self.done = true;
                    return Some(Err(e));
                }
            } else {
                self.done = true;
                // Input after the last WorldEnd, or no WorldEnd at all.
                if self.parser.started || self.handed == 0 {
                    let (desc, warnings) = self.parser.finish_rest();
                    let file = self.paths.len().saturating_sub(1);
                    self.ready.push_back(StreamedScene { desc, warnings, file });
                }
            }
        }
        let s = self.ready.pop_front()?;
        self.handed += 1;
        Some(Ok(s))
    }
}

/// The directory a scene file's relative paths resolve against.
fn dir_of(p: &Path) -> std::path::PathBuf {
    let d = if p == Path::new("-") { Path::new("") } else { p.parent().unwrap_or(Path::new("")) };
    if d.as_os_str().is_empty() {
        Path::new(".").to_path_buf()
    } else {
        d.to_path_buf()
    }
}

/// The scene's name: its file's stem (`scene` for standard input).
fn scene_name(path: &Path) -> String {
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let stem = name.strip_suffix(".pbrt").unwrap_or(name);
    if stem.is_empty() || stem == "-" {
        "scene".to_string()
    } else {
        Path::new(stem).file_stem().map_or(stem.to_string(), |s| s.to_string_lossy().into_owned())
    }
}

/// The text of a scene file: `-` is standard input, `.gz` is decompressed.
pub(crate) fn read_scene_text(path: &Path, loc: &FileLoc) -> Result<String> {
    use std::io::Read;
    let shown = path.to_string_lossy().into_owned();
    let io =
        |source: std::io::Error| SceneError::File { loc: loc.clone(), path: shown.clone(), source };
    let mut bytes = Vec::new();
    if path == Path::new("-") {
        std::io::stdin().read_to_end(&mut bytes).map_err(io)?;
    } else {
        bytes = std::fs::read(path).map_err(io)?;
    }
    if path.extension().is_some_and(|e| e == "gz") {
        let mut text = Vec::new();
        flate2::read::GzDecoder::new(bytes.as_slice()).read_to_end(&mut text).map_err(io)?;
        bytes = text;
    }
    String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))
    })
}

/// Parses scene text; `file_name` is used in locations and for the scene's
/// name, `base_dir` resolves relative paths. The first scene it describes.
pub fn parse_str(
    source: &str,
    file_name: &str,
    base_dir: &Path,
) -> Result<(SceneDescription, Vec<Warning>)> {
    let mut p = parser::Parser::new(&scene_name(Path::new(file_name)));
    let base = if base_dir.as_os_str().is_empty() { Path::new(".") } else { base_dir };
    p.builder.root = std::fs::canonicalize(base).unwrap_or_else(|_| base.to_path_buf());
    p.builder.search_dir = base_dir.to_path_buf();
    p.parse_text(source, file_name, base_dir)?;
    let mut scenes = std::mem::take(&mut p.finished);
    if p.started || scenes.is_empty() {
        let end = std::mem::take(&mut p.end);
        scenes.push(p.builder.finish(&end));
    }
    let (scene, mut warnings) = scenes.remove(0);
    if !scenes.is_empty() {
        let loc = FileLoc { file: file_name.to_string(), line: 1, column: 1 };
        warnings.push(Warning::at(
            &loc,
            format!("the text describes {} scenes; only the first is used here", scenes.len() + 1),
        ));
    }
    Ok((scene, warnings))
}
