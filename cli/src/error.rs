//! The CLI crate's one error type, and the exit code each error gives.

use crate::EXIT_BAD_INPUT;
use farm_common::image::ImageError;
use farm_render::BuildError;
use farm_scene::SceneError;
use std::process::ExitCode;

/// Everything that can stop a `farm` command.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    // Rendering.
    /// The scene file is malformed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The scene could not be built.
    #[error("{0}")]
    Build(#[from] BuildError),
    /// The film has no pixels, or it or its samples are over the limits.
    #[error(transparent)]
    Film(#[from] farm_common::film::FilmError),
    /// The image could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// The thread pool could not start.
    #[error("cannot start render threads: {0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
    // Talking to a coordinator.
    /// The scene names files outside its folder, which are not uploaded
    /// unless asked for.
    #[error("the scene names files outside its folder {folder}, which are not uploaded without --allow-assets-outside: {}", .paths.join(", "))]
    AssetsOutside {
        /// The scene's folder.
        folder: String,
        /// The files, relative to the folder.
        paths: Vec<String>,
    },
    /// The URL, the token or the connection is wrong.
    #[error(transparent)]
    Connect(#[from] farm_proto::connect::ConnectError),
    /// A token file that cannot be read or holds no token.
    #[error("{0}")]
    Token(String),
    /// The command line asks for something that cannot be done.
    #[error("{0}")]
    Usage(String),
    /// The coordinator refused or failed a call.
    #[error("the coordinator says: {}", .0.message())]
    Rpc(#[from] tonic::Status),
    /// The coordinator refused to open a watch of the job because the
    /// token has as many open as it may (`MAX_WATCHES_PER_TOKEN`).
    #[error("the coordinator says: {}", .0.message())]
    NoWatchSlot(tonic::Status),
    /// The job failed on the farm.
    #[error("the job failed: {0}")]
    JobFailed(String),
    /// The coordinator's answer made no sense.
    #[error("bad answer from the coordinator: {0}")]
    Protocol(String),
    // `farm converge`.
    /// The reference could not be read.
    #[error(transparent)]
    Reference(ImageError),
    /// The reference's size is not the render's.
    #[error("the reference {path} is {rw}×{rh} but the render is {w}×{h}")]
    SizeMismatch {
        /// The reference.
        path: String,
        /// Reference width.
        rw: usize,
        /// Reference height.
        rh: usize,
        /// Render width.
        w: usize,
        /// Render height.
        h: usize,
    },
}

/// Results of the CLI.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// The process exit code: 2 for bad input (the scene, the reference),
    /// 1 for everything else.
    pub fn exit_code(&self) -> ExitCode {
        match self {
            Error::Scene(_)
            | Error::Build(_)
            | Error::Film(_)
            | Error::AssetsOutside { .. }
            | Error::Usage(_)
            | Error::Reference(_)
            | Error::SizeMismatch { .. } => ExitCode::from(EXIT_BAD_INPUT),
            _ => ExitCode::FAILURE,
        }
    }
}
