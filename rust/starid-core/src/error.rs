//! The one error type of the crate.
//!
//! Errors are for input that cannot be processed (a malformed catalogue, a NaN centroid,
//! an absurd field of view). A frame that simply cannot be identified is *not* an error:
//! it is an [`crate::Status`] in the [`crate::Identification`].

use std::fmt;

/// What went wrong, without the message.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// An argument is out of its domain (NaN coordinates, too few stars, a bad field of view...).
    InvalidInput,
    /// A catalogue file or table is malformed. `line` is 1-based when known.
    Catalog {
        /// 1-based line of the offending record, when the error comes from a file.
        line: Option<usize>,
    },
    /// Reading a file failed.
    Io(std::io::ErrorKind),
    /// A batch was cancelled through its flag before it finished.
    Cancelled,
}

/// An error of starid-core: a kind plus a human-readable message.
#[derive(Debug, thiserror::Error)]
pub struct Error {
    kind: ErrorKind,
    message: String,
}

impl Error {
    /// Invalid argument with a message saying what is wrong.
    ///
    /// # Example
    /// ```
    /// let e = starid_core::Error::invalid_input("fov_deg must be positive");
    /// assert_eq!(e.kind(), &starid_core::ErrorKind::InvalidInput);
    /// ```
    pub fn invalid_input(message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::InvalidInput,
            message: message.into(),
        }
    }

    /// Malformed catalogue, optionally at a 1-based line.
    ///
    /// # Example
    /// ```
    /// let e = starid_core::Error::catalog(Some(3), "mag is not a number");
    /// assert_eq!(e.to_string(), "line 3: mag is not a number");
    /// ```
    pub fn catalog(line: Option<usize>, message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::Catalog { line },
            message: message.into(),
        }
    }

    /// A batch stopped by its cancel flag.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Error::cancelled().kind(), &starid_core::ErrorKind::Cancelled);
    /// ```
    pub fn cancelled() -> Self {
        Self {
            kind: ErrorKind::Cancelled,
            message: "cancelled".into(),
        }
    }

    /// The kind of error.
    ///
    /// # Example
    /// ```
    /// let e = starid_core::Catalog::from_table("1,0,95,1\n".as_bytes()).unwrap_err();
    /// assert_eq!(e.kind(), &starid_core::ErrorKind::Catalog { line: Some(1) });
    /// ```
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// The message, without the kind.
    ///
    /// # Example
    /// ```
    /// let e = starid_core::Error::catalog(Some(3), "mag is not a number");
    /// assert_eq!(e.message(), "mag is not a number");
    /// ```
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.kind {
            ErrorKind::Catalog { line: Some(line) } => write!(f, "line {line}: {}", self.message),
            _ => f.write_str(&self.message),
        }
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Self {
            kind: ErrorKind::Io(e.kind()),
            message: e.to_string(),
        }
    }
}

/// `Result` with the crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
