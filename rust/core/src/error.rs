//! One error type for everything that can go wrong with user data.
//! Messages name the object and the problem, because they reach artists verbatim.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene object (mesh, material, light, camera...) is invalid.
    #[error("{kind} '{name}': {problem}")]
    InvalidObject { kind: &'static str, name: String, problem: String },
    /// A render setting is out of range or inconsistent.
    #[error("setting '{setting}': {problem}")]
    InvalidSetting { setting: &'static str, problem: String },
    /// The scene description could not be parsed.
    #[error("scene description: {0}")]
    Description(String),
    /// The render was cancelled by the caller.
    #[error("render cancelled")]
    Cancelled,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn object(kind: &'static str, name: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::InvalidObject { kind, name: name.into(), problem: problem.into() }
    }
    pub fn setting(setting: &'static str, problem: impl Into<String>) -> Self {
        Error::InvalidSetting { setting, problem: problem.into() }
    }
}
