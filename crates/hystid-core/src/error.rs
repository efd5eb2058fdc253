//! The library's error type.
//!
//! Every error names *where* the problem is (a file, a configuration key, a
//! channel, a stage) and *what was expected*, so the command-line tool can
//! print it as is. Numerical stages that can fail point by point (a harmonic
//! balance solve, a dwell that never settles) report the failure as data in
//! their results instead of an `Err`, so one bad point does not stop a sweep.

use std::path::Path;

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A structural model (linear part or element) has an invalid parameter.
    #[error("invalid model: `{field}`: {message}")]
    InvalidModel {
        /// The parameter, e.g. `system.mass` or `joint.kd`.
        field: String,
        /// What was expected.
        message: String,
    },
    /// A test definition (stepped-sine plan, fit or analysis option) is invalid.
    #[error("invalid test definition: `{field}`: {message}")]
    InvalidPlan {
        /// The key, e.g. `test.levels_n[2]`.
        field: String,
        /// What was expected.
        message: String,
    },
    /// A command's option is out of range, or does not go with the others
    /// (see `analysis::request`). `option` is the request's field; each front
    /// end names it as its users write it (`--each-alone`, `each_alone`).
    /// An empty `option`: the message names the options itself.
    #[error("{}", option_message(option, message))]
    InvalidOption {
        /// The request's field, e.g. `starts`.
        option: String,
        /// What was expected.
        message: String,
    },
    /// An option of the time-domain fit given to a fit of the FRFs alone.
    /// Each front end says how its users ask for the time domain
    /// (`--domain time`, or the time histories as `recordings=`).
    #[error("{option}: {why}; it applies to the time domain only")]
    TimeDomainOnly {
        /// The request's field, e.g. `starts`.
        option: String,
        /// What the option does there.
        why: String,
    },
    /// Input data (a signal, a recording's content) is unusable.
    #[error("invalid input: {what}: {message}")]
    InvalidInput {
        /// The signal or channel, e.g. `force[1234]`.
        what: String,
        /// What was expected.
        message: String,
    },
    /// A reference holds no stepped-sine dwell: no stretch of constant
    /// frequency and amplitude long enough to reduce. Its own kind, as the
    /// caller may then take the drive for broadband rather than fail.
    #[error("invalid input: reference: {message}")]
    NoDwell {
        /// The tolerances and windows searched.
        message: String,
    },
    /// A file's content does not follow its format.
    #[error("{path}: `{field}`: {message}")]
    Format {
        /// The file.
        path: String,
        /// The field, variable, column or header part.
        field: String,
        /// What was expected.
        message: String,
    },
    /// A numerical solve did not converge.
    #[error("{stage} did not converge: {reason}")]
    NotConverged {
        /// The stage, e.g. `implicit sample solve`.
        stage: &'static str,
        /// Why, with the figures (residual, iterations).
        reason: String,
    },
    /// A step over one of several inputs failed (e.g. `reducing
    /// run.mcap`); the source says why. The message names the step only:
    /// print the error's source chain for the whole story.
    #[error("{what}")]
    Context {
        /// The step and its input.
        what: String,
        /// Why it failed.
        #[source]
        source: Box<Error>,
    },
    /// The caller asked the work to stop ([`crate::observe::Observer::cancelled`]).
    #[error("cancelled by the caller")]
    Cancelled,
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// An [`Error::InvalidModel`].
    pub fn model(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidModel {
            field: field.into(),
            message: message.into(),
        }
    }
    /// An [`Error::InvalidPlan`].
    pub fn plan(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidPlan {
            field: field.into(),
            message: message.into(),
        }
    }
    /// An [`Error::InvalidOption`].
    pub fn option(option: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidOption {
            option: option.into(),
            message: message.into(),
        }
    }
    /// An [`Error::InvalidInput`].
    pub fn input(what: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidInput {
            what: what.into(),
            message: message.into(),
        }
    }
    /// An [`Error::Format`] for a file.
    pub fn format(
        path: impl AsRef<Path>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Format {
            path: path.as_ref().display().to_string(),
            field: field.into(),
            message: message.into(),
        }
    }
    /// An [`Error::Context`]: `source` while doing `what`.
    pub fn context(what: impl Into<String>, source: Error) -> Self {
        Error::Context {
            what: what.into(),
            source: Box::new(source),
        }
    }
    /// The error under its [`Error::Context`] wrappers: what failed.
    pub fn root(&self) -> &Error {
        match self {
            Error::Context { source, .. } => source.root(),
            e => e,
        }
    }
    /// An [`Error::Io`] for a file.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().display().to_string(),
            source,
        }
    }
}

fn option_message(option: &str, message: &str) -> String {
    if option.is_empty() {
        message.to_string()
    } else {
        format!("{option}: {message}")
    }
}

/// An error and its causes on one line, each said once, as the command line
/// prints them: a cause whose text its parent already ends with (a file
/// error that prints its own cause) is not repeated, nor a path the parent
/// has just named ("reducing X" then "X: why" reads "reducing X: why").
pub fn one_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut out = String::new();
    let mut cause = Some(e);
    while let Some(c) = cause {
        cause = c.source();
        let text = c.to_string();
        if out.ends_with(&text) {
            continue;
        }
        let text = match out.rsplit_once(' ') {
            Some((_, last)) if !last.is_empty() => text
                .strip_prefix(last)
                .and_then(|t| t.strip_prefix(": "))
                .map(str::to_string)
                .unwrap_or(text),
            _ => text,
        };
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// Checks that a parameter is finite and strictly positive.
pub(crate) fn require_positive(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::model(
            field,
            format!("must be a finite number > 0, got {value}"),
        ))
    }
}

/// Checks that a parameter is finite and not negative.
pub(crate) fn require_non_negative(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(Error::model(
            field,
            format!("must be a finite number >= 0, got {value}"),
        ))
    }
}

/// Checks that a parameter is finite.
pub(crate) fn require_finite(field: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Error::model(
            field,
            format!("must be a finite number, got {value}"),
        ))
    }
}
