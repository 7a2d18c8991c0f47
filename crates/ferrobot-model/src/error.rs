//! The error type of the model crate.

use std::fmt;

/// Where in a source document a problem was found.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SourceLocation {
    /// The file the text came from, or `<string>` for text passed in memory.
    pub source: String,
    /// 1-based line, when known.
    pub line: Option<u32>,
}

impl SourceLocation {
    /// A location in `source` at an optional 1-based line.
    pub fn new(source: impl Into<String>, line: Option<u32>) -> Self {
        Self {
            source: source.into(),
            line,
        }
    }
}

impl fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}", self.source, line),
            None => write!(f, "{}", self.source),
        }
    }
}

/// Everything that can go wrong while loading or querying a robot model.
///
/// Every variant names what was wrong (file, line, element, name, index) so
/// that the message alone tells a user what to fix.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ModelError {
    /// The URDF is not well-formed XML, or violates the URDF format.
    #[error("{location}: {message}")]
    Urdf {
        /// Where the problem is.
        location: SourceLocation,
        /// What is wrong.
        message: String,
    },
    /// The SRDF is not well-formed, or names something the URDF lacks.
    #[error("{location}: {message}")]
    Srdf {
        /// Where the problem is.
        location: SourceLocation,
        /// What is wrong.
        message: String,
    },
    /// A mesh referenced by the URDF could not be found or read.
    #[error("link '{link}': mesh '{filename}': {message}")]
    Mesh {
        /// The link whose geometry references the mesh.
        link: String,
        /// The filename as written in the URDF.
        filename: String,
        /// What went wrong (not found: the candidates tried; unreadable: why).
        message: String,
    },
    /// A name (link, joint, group, named state) that the model does not have.
    #[error("unknown {kind} '{name}'; known: {known}")]
    UnknownName {
        /// What kind of name: "link", "joint", "group", "state".
        kind: &'static str,
        /// The name asked for.
        name: String,
        /// A short list of the names the model has.
        known: String,
    },
    /// An array of the wrong shape or length.
    #[error("{what}: expected shape {expected}, got {got}")]
    Shape {
        /// The argument.
        what: String,
        /// The expected shape, e.g. `(7,)` or `(N, 7)`.
        expected: String,
        /// The shape that was passed.
        got: String,
    },
    /// A NaN or infinite value where a finite one is required.
    #[error("{what}: non-finite value {value} at index {index}")]
    NonFinite {
        /// The argument.
        what: String,
        /// Flat index of the first offending value.
        index: usize,
        /// The value (NaN or ±inf).
        value: f64,
    },
    /// Any other invalid argument.
    #[error("{0}")]
    InvalidArgument(String),
}

impl From<crate::ranges::RangeError> for ModelError {
    fn from(e: crate::ranges::RangeError) -> Self {
        ModelError::InvalidArgument(e.0)
    }
}

impl ModelError {
    /// A URDF error at `location`.
    pub fn urdf(location: SourceLocation, message: impl Into<String>) -> Self {
        Self::Urdf {
            location,
            message: message.into(),
        }
    }

    /// An SRDF error at `location`.
    pub fn srdf(location: SourceLocation, message: impl Into<String>) -> Self {
        Self::Srdf {
            location,
            message: message.into(),
        }
    }

    /// An unknown name of `kind`, listing (at most 12 of) the known ones.
    pub fn unknown<'a>(
        kind: &'static str,
        name: &str,
        known: impl IntoIterator<Item = &'a str>,
    ) -> Self {
        let all: Vec<&str> = known.into_iter().collect();
        let mut listed = all.iter().take(12).copied().collect::<Vec<_>>().join(", ");
        if all.len() > 12 {
            listed.push_str(&format!(", ... ({} in all)", all.len()));
        }
        if all.is_empty() {
            listed = "(none)".into();
        }
        Self::UnknownName {
            kind,
            name: name.to_string(),
            known: listed,
        }
    }
}

/// Result alias of the model crate.
pub type Result<T, E = ModelError> = std::result::Result<T, E>;

/// Checks that `values` holds only finite numbers.
pub fn check_finite(what: &str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(ModelError::NonFinite {
            what: what.to_string(),
            index,
            value: values[index],
        }),
    }
}
