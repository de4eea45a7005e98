use serde::{Deserialize, Serialize};
use std::fmt;

/// A place in a scene file: `file:line:column`, 1-based.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FileLoc {
    /// The file as it was named (relative to the working directory or absolute).
    pub file: String,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
}

impl fmt::Display for FileLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// Something ignored or adjusted in a scene, reported to the user with
/// pbrt-v3's wording where pbrt-v3 has one; rendering goes on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Warning {
    /// Where in the scene, when known.
    pub loc: Option<FileLoc>,
    /// What was ignored or adjusted.
    pub message: String,
}

impl Warning {
    /// A warning at `loc`.
    pub fn at(loc: &FileLoc, message: impl Into<String>) -> Self {
        Warning { loc: Some(loc.clone()), message: message.into() }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(loc) => write!(f, "{loc}: warning: {}", self.message),
            None => write!(f, "warning: {}", self.message),
        }
    }
}
