//! The reader's one error type: where (file, line, column, the element
//! path), what was found and what was expected.

use std::fmt;

/// A `.xosc` file (or a catalog or distribution it names) that cannot be
/// read: schema violations, bad parameters and expressions, missing files
/// and references.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct XoscError {
    /// The file the error is in.
    pub file: String,
    /// 1-based line (0 when the error is about the file as a whole).
    pub line: u32,
    /// 1-based column, in characters.
    pub col: u32,
    /// The element path, e.g. `OpenSCENARIO/Storyboard/Story[cut_in]/Act`.
    pub path: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for XoscError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: ", self.file)?;
        } else {
            write!(f, "{}:{}:{}: ", self.file, self.line, self.col)?;
        }
        if !self.path.is_empty() {
            write!(f, "{}: ", self.path)?;
        }
        f.write_str(&self.message)
    }
}

impl XoscError {
    /// An error about a whole file (it cannot be opened, it is too large).
    pub fn file(file: &str, message: impl Into<String>) -> Self {
        XoscError {
            file: file.to_string(),
            line: 0,
            col: 0,
            path: String::new(),
            message: message.into(),
        }
    }
}
