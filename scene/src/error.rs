//! Errors of the coordinator's scene parser. Every message is one line that
//! starts with `file:line:column: `, says what was wrong and what was
//! expected, e.g. `scenes/a.pbrt:12:7: unterminated string (expected a
//! closing '"')`.

use farm_common::scene::FileLoc;

/// A fatal problem in a scene file or a file it refers to.
#[derive(thiserror::Error, Debug)]
pub enum SceneError {
    /// A token that does not fit the grammar.
    #[error("{loc}: unexpected {found} (expected {expected})")]
    Syntax {
        /// Where the token starts.
        loc: FileLoc,
        /// The token as found (or a description of it).
        found: String,
        /// What would have been accepted there.
        expected: String,
    },
    /// A quoted string that runs into a newline or the end of the file.
    #[error("{loc}: unterminated string (expected a closing '\"')")]
    UnterminatedString {
        /// Where the opening quote is.
        loc: FileLoc,
    },
    /// A directive pbrt-v3 does not know (fatal in pbrt-v3 as well).
    #[error("{loc}: unknown directive \"{name}\" (expected a pbrt-v3 directive such as Shape, Material or AttributeBegin)")]
    UnknownDirective {
        /// Where the directive is.
        loc: FileLoc,
        /// The word found.
        name: String,
    },
    /// A `"type name"` declaration that cannot be decoded.
    #[error("{loc}: bad parameter declaration \"{decl}\": {problem} (expected \"type name\" with type one of integer, float, point2, vector2, point3, vector3, normal, rgb, color, xyz, spectrum, blackbody, bool, string, texture)")]
    BadDeclaration {
        /// Where the declaration is.
        loc: FileLoc,
        /// The declaration as written.
        decl: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A value that does not fit its parameter's declared type.
    #[error("{loc}: value {found} for parameter \"{decl}\" (expected {expected})")]
    BadValue {
        /// Where the value is.
        loc: FileLoc,
        /// The parameter's declaration.
        decl: String,
        /// The value as found.
        found: String,
        /// What the type needs.
        expected: String,
    },
    /// A parameter whose number of values does not fit its type.
    #[error("{loc}: parameter \"{decl}\" has {count} values (expected {expected})")]
    ValueCount {
        /// Where the declaration is.
        loc: FileLoc,
        /// The parameter's declaration.
        decl: String,
        /// How many values were given.
        count: usize,
        /// What the type needs.
        expected: String,
    },
    /// The file ended where more was required.
    #[error("{loc}: unexpected end of file {context} (expected {expected})")]
    UnexpectedEof {
        /// Where the unfinished construct starts.
        loc: FileLoc,
        /// What was being read.
        context: String,
        /// What was still needed.
        expected: String,
    },
    /// A file named by the scene (`Include`, `plymesh`, image map, spectrum
    /// file) that cannot be read.
    #[error("{loc}: cannot read \"{path}\": {source} (expected a readable file)")]
    File {
        /// Where the file is named.
        loc: FileLoc,
        /// The path tried.
        path: String,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// A PLY or spectrum file that is truncated or malformed.
    #[error("{loc}: malformed {kind} file \"{path}\": {what}")]
    BadFile {
        /// Where the file is named.
        loc: FileLoc,
        /// `"PLY"` or `"spectrum"`.
        kind: &'static str,
        /// The path read.
        path: String,
        /// What was wrong, and what was expected.
        what: String,
    },
}

impl SceneError {
    /// Where in the scene the error is.
    pub fn loc(&self) -> &FileLoc {
        match self {
            SceneError::Syntax { loc, .. }
            | SceneError::UnterminatedString { loc }
            | SceneError::UnknownDirective { loc, .. }
            | SceneError::BadDeclaration { loc, .. }
            | SceneError::BadValue { loc, .. }
            | SceneError::ValueCount { loc, .. }
            | SceneError::UnexpectedEof { loc, .. }
            | SceneError::File { loc, .. }
            | SceneError::BadFile { loc, .. } => loc,
        }
    }
}

/// Results of scene parsing.
pub type Result<T> = std::result::Result<T, SceneError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_one_line_with_location_prefix() {
        let loc = FileLoc { file: "scenes/a.pbrt".into(), line: 12, column: 7 };
        let e = SceneError::UnterminatedString { loc };
        assert_eq!(
            e.to_string(),
            "scenes/a.pbrt:12:7: unterminated string (expected a closing '\"')"
        );
        let e = SceneError::File {
            loc: e.loc().clone(),
            path: "x.ply".into(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "gone"),
        };
        assert!(e.to_string().starts_with("scenes/a.pbrt:12:7: cannot read \"x.ply\""));
        assert!(!e.to_string().contains('\n'));
    }
}
