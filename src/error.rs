//! The one error type of the core. The Python layer maps it to `nlos_rs.SceneError`
//! (bad input, a `ValueError`), `FileNotFoundError` and `KeyboardInterrupt`.

use std::path::PathBuf;

/// Everything that can go wrong in nlos_rs.
#[derive(Debug, thiserror::Error)]
pub enum NlosError {
    /// A scene description is wrong: the plugin and key are named, as Mitsuba does.
    #[error("plugin '{plugin}': key '{key}': {msg}")]
    Property {
        /// Plugin type, e.g. `transient_hdr_film`.
        plugin: String,
        /// Offending key.
        key: String,
        /// What is wrong with it.
        msg: String,
    },
    /// A scene is structurally wrong (missing laser, several relay walls, ...).
    #[error("{0}")]
    Scene(String),
    /// A mesh file could not be read or is malformed.
    #[error("mesh '{path}': {msg}")]
    Mesh {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// A Mitsuba XML file could not be parsed.
    #[error("XML '{path}': {msg}")]
    Xml {
        /// The file.
        path: PathBuf,
        /// What is wrong with it (with line number where known).
        msg: String,
    },
    /// A file does not exist.
    #[error("file not found: '{0}'")]
    NotFound(PathBuf),
    /// The render was cancelled (Ctrl-C).
    #[error("render interrupted")]
    Interrupted,
}

/// Result alias for the core.
pub type Result<T> = std::result::Result<T, NlosError>;

impl NlosError {
    /// Shorthand for a [`NlosError::Property`].
    pub fn prop(plugin: &str, key: &str, msg: impl Into<String>) -> Self {
        NlosError::Property {
            plugin: plugin.to_string(),
            key: key.to_string(),
            msg: msg.into(),
        }
    }
}
