//! Library error type. Every variant that comes from a file names the file,
//! and the line where one is known.

use std::path::PathBuf;

/// Errors raised while loading, validating or solving a scene.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The scene TOML is malformed or has a bad value.
    #[error("{path}: {message}")]
    SceneFile {
        /// The scene file.
        path: PathBuf,
        /// What is wrong, naming the table or key.
        message: String,
    },
    /// An OBJ or MTL file could not be parsed.
    #[error("{path}: {message}")]
    Obj {
        /// The OBJ or MTL file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A glTF file (or a buffer or image it names) could not be read, is not
    /// valid glTF 2.0, or holds data linkgi cannot use; `message` says where
    /// in the file (mesh, primitive, accessor, node) and what is wrong.
    #[error("{path}: {message}")]
    Gltf {
        /// The glTF file (or the buffer or image it names).
        path: PathBuf,
        /// Where in the file and what is wrong.
        message: String,
    },
    /// An image (a sky's environment map) could not be decoded or holds bad values.
    #[error("{path}: {message}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A mesh has invalid geometry (non-finite coordinates, bad indices, ...).
    #[error("{source_name}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Geometry {
        /// File path or built-in mesh name.
        source_name: String,
        /// 1-based line in the OBJ file, where known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A scene name was neither a file nor a built-in scene.
    #[error("scene '{0}' is neither a file nor a built-in scene (built-ins: {1})")]
    UnknownScene(String, String),
    /// The scene has nothing to solve.
    #[error("{0}: the scene has no triangles")]
    EmptyScene(String),
    /// A plot could not be drawn or written.
    #[error("plot: {0}")]
    Plot(String),
    /// A setting is out of range.
    #[error("invalid setting: {0}")]
    Setting(String),
    /// The GPU path failed (no adapter, a device error, a lost device).
    #[error("GPU: {0}")]
    Gpu(String),
    /// The engine's worker thread could not be started (the system's limit
    /// on threads or memory).
    #[error("could not start the GI worker thread: {0}")]
    Thread(#[source] std::io::Error),
}

/// A `Result` whose error is [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
