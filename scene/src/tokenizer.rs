//! Splits a pbrt-v3 scene file into tokens (pbrt-v3 `Tokenizer::Next`):
//! quoted strings with `\` escapes, `[`, `]`, and bare words (directives and
//! numbers); `#` starts a comment that runs to the end of the line. Every
//! token carries its 1-based line and column. Strings without escapes and
//! bare words borrow from the source, so tokenizing does not allocate.

use crate::error::{Result, SceneError};
use farm_common::scene::FileLoc;
use std::borrow::Cow;

/// What sort of token it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TokenKind {
    /// A quoted string; the text is without quotes, escapes decoded.
    Str,
    /// A bare word: a directive name or a number.
    Bare,
    /// `[`
    Open,
    /// `]`
    Close,
}

/// One token and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Token<'a> {
    /// Its kind.
    pub kind: TokenKind,
    /// Its text (for strings, the decoded contents).
    pub text: Cow<'a, str>,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1 (in characters).
    pub column: u32,
}

impl Token<'_> {
    /// The token as it would be quoted in a message.
    pub fn describe(&self) -> String {
        match self.kind {
            TokenKind::Str => format!("string \"{}\"", self.text),
            TokenKind::Bare => format!("\"{}\"", self.text),
            TokenKind::Open => "'['".to_string(),
            TokenKind::Close => "']'".to_string(),
        }
    }
}

/// A tokenizer over one file's text, with one token of look-ahead.
pub struct Tokenizer<'a> {
    text: &'a str,
    file: &'a str,
    pos: usize,
    line: u32,
    column: u32,
    peeked: Option<Token<'a>>,
}

impl<'a> Tokenizer<'a> {
    /// A tokenizer over `text`, which came from `file` (for locations).
    pub fn new(text: &'a str, file: &'a str) -> Self {
        Tokenizer { text, file, pos: 0, line: 1, column: 1, peeked: None }
    }

    /// The file name given to [`Tokenizer::new`].
    pub fn file(&self) -> &'a str {
        self.file
    }

    /// The location of a token of this file.
    pub fn loc(&self, t: &Token<'_>) -> FileLoc {
        self.loc_at(t.line, t.column)
    }

    /// A location in this file.
    pub fn loc_at(&self, line: u32, column: u32) -> FileLoc {
        FileLoc { file: self.file.to_string(), line, column }
    }

    /// The location just past the last token read (for end-of-file errors).
    pub fn end_loc(&self) -> FileLoc {
        self.loc_at(self.line, self.column)
    }

    /// The next token without consuming it.
    pub fn peek(&mut self) -> Result<Option<&Token<'a>>> {
        if self.peeked.is_none() {
            self.peeked = self.scan()?;
        }
        Ok(self.peeked.as_ref())
    }

    /// The next token, or `None` at the end of the file.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Result<Option<Token<'a>>> {
        match self.peeked.take() {
            Some(t) => Ok(Some(t)),
            None => self.scan(),
        }
    }

    /// Advances over one byte, keeping line and column.
    #[inline]
    fn bump(&mut self, b: u8) {
        self.pos += 1;
        if b == b'\n' {
            self.line += 1;
            self.column = 1;
        } else if b & 0xC0 != 0x80 {
            // Count characters, not UTF-8 continuation bytes.
            self.column += 1;
        }
    }

    fn scan(&mut self) -> Result<Option<Token<'a>>> {
        let bytes = self.text.as_bytes();
        loop {
            let Some(&b) = bytes.get(self.pos) else {
                return Ok(None);
            };
            let (line, column) = (self.line, self.column);
            match b {
                b' ' | b'\t' | b'\r' | b'\n' => self.bump(b),
                b'#' => {
                    while let Some(&c) = bytes.get(self.pos) {
                        if c == b'\n' || c == b'\r' {
                            break;
                        }
                        self.bump(c);
                    }
                }
                b'[' | b']' => {
                    self.bump(b);
                    let kind = if b == b'[' { TokenKind::Open } else { TokenKind::Close };
                    let text = Cow::Borrowed(&self.text[self.pos - 1..self.pos]);
                    return Ok(Some(Token { kind, text, line, column }));
                }
                b'"' => return self.scan_string(line, column).map(Some),
                _ => {
                    let start = self.pos;
                    while let Some(&c) = bytes.get(self.pos) {
                        if matches!(c, b' ' | b'\n' | b'\t' | b'\r' | b'"' | b'[' | b']') {
                            break;
                        }
                        self.bump(c);
                    }
                    let text = Cow::Borrowed(&self.text[start..self.pos]);
                    return Ok(Some(Token { kind: TokenKind::Bare, text, line, column }));
                }
            }
        }
    }

    fn scan_string(&mut self, line: u32, column: u32) -> Result<Token<'a>> {
        let bytes = self.text.as_bytes();
        self.bump(b'"');
        let start = self.pos;
        let mut escaped = false;
        loop {
            match bytes.get(self.pos) {
                None | Some(b'\n') => {
                    return Err(SceneError::UnterminatedString { loc: self.loc_at(line, column) })
                }
                Some(b'"') => break,
                Some(b'\\') => {
                    escaped = true;
                    self.bump(b'\\');
                    match bytes.get(self.pos) {
                        None | Some(b'\n') => {
                            let loc = self.loc_at(line, column);
                            return Err(SceneError::UnterminatedString { loc });
                        }
                        Some(&c) => self.bump(c),
                    }
                }
                Some(&c) => self.bump(c),
            }
        }
        let raw = &self.text[start..self.pos];
        self.bump(b'"');
        let text = if escaped {
            Cow::Owned(self.unescape(raw, line, column)?)
        } else {
            Cow::Borrowed(raw)
        };
        Ok(Token { kind: TokenKind::Str, text, line, column })
    }

    fn unescape(&self, raw: &str, line: u32, column: u32) -> Result<String> {
        let mut out = String::with_capacity(raw.len());
        let mut chars = raw.chars();
        while let Some(c) = chars.next() {
            if c != '\\' {
                out.push(c);
                continue;
            }
            let e = chars.next().unwrap_or('\\');
            out.push(match e {
                'b' => '\u{8}',
                'f' => '\u{c}',
                'n' => '\n',
                'r' => '\r',
                't' => '\t',
                '\\' | '\'' | '"' => e,
                _ => {
                    return Err(SceneError::Syntax {
                        loc: self.loc_at(line, column),
                        found: format!("escape \"\\{e}\" in a string"),
                        expected: "one of \\b \\f \\n \\r \\t \\\\ \\' \\\"".into(),
                    })
                }
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(text: &str) -> Vec<(TokenKind, String, u32, u32)> {
        let mut t = Tokenizer::new(text, "t.pbrt");
        let mut v = Vec::new();
        while let Some(tok) = t.next().unwrap() {
            v.push((tok.kind, tok.text.into_owned(), tok.line, tok.column));
        }
        v
    }

    #[test]
    fn tokens_with_locations() {
        let v = all("Shape \"sphere\" # comment\n  \"float radius\"[2.5]\n");
        use TokenKind::*;
        assert_eq!(
            v,
            vec![
                (Bare, "Shape".into(), 1, 1),
                (Str, "sphere".into(), 1, 7),
                (Str, "float radius".into(), 2, 3),
                (Open, "[".into(), 2, 17),
                (Bare, "2.5".into(), 2, 18),
                (Close, "]".into(), 2, 21),
            ]
        );
    }

    #[test]
    fn escapes_are_decoded() {
        let v = all(r#""a\"b\\c\n\td""#);
        assert_eq!(v[0].1, "a\"b\\c\n\td");
    }

    #[test]
    fn unterminated_string_reports_opening_quote() {
        let mut t = Tokenizer::new("Shape\n   \"sphere\n", "a.pbrt");
        t.next().unwrap();
        let e = t.next().unwrap_err();
        assert!(e.to_string().starts_with("a.pbrt:2:4: unterminated string"), "{e}");
        let mut t = Tokenizer::new("\"abc", "a.pbrt");
        assert!(t.next().is_err());
    }

    #[test]
    fn peek_does_not_consume() {
        let mut t = Tokenizer::new("a b", "x");
        assert_eq!(t.peek().unwrap().unwrap().text, "a");
        assert_eq!(t.next().unwrap().unwrap().text, "a");
        assert_eq!(t.next().unwrap().unwrap().text, "b");
        assert!(t.next().unwrap().is_none());
    }

    #[test]
    fn columns_count_characters() {
        let v = all("# é\n\"é\" x");
        assert_eq!((v[1].2, v[1].3), (2, 5));
    }
}
