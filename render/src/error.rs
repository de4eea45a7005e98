//! Errors building a renderable scene.

/// Why a scene description could not be turned into a renderer.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The film has no pixels to render.
    #[error("the film has no pixels (check xresolution, yresolution and cropwindow)")]
    EmptyFilm,
    /// The camera transform cannot be inverted.
    #[error("the camera transform is singular")]
    SingularCamera,
    /// The camera cannot be built (a realistic camera's lens, say).
    #[error("{loc}: Camera \"{name}\": {why}")]
    Camera {
        /// Where the `Camera` directive is.
        loc: farm_common::scene::FileLoc,
        /// Its type.
        name: String,
        /// What is wrong.
        why: String,
    },
}

/// Result with a [`BuildError`].
pub type Result<T> = std::result::Result<T, BuildError>;
