//! The worker crate's one error type.

use std::net::SocketAddr;

/// Everything that can go wrong in a worker.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    // Reaching the coordinator.
    /// The coordinator's URL is wrong for its token, or nothing answers.
    #[error(transparent)]
    Connect(#[from] farm_proto::connect::ConnectError),
    /// The coordinator refused this worker (a protocol version mismatch,
    /// or a token that is missing, unknown, revoked or not a worker's).
    #[error("the coordinator refused this worker: {message}")]
    Refused {
        /// The coordinator's explanation.
        message: String,
    },
    /// Registration failed for another reason.
    #[error("registering with the coordinator failed: {message}")]
    Register {
        /// The gRPC status.
        message: String,
    },
    /// The work stream failed or the coordinator closed it.
    #[error("the work stream ended: {message}")]
    Stream {
        /// What happened.
        message: String,
    },
    /// The render pool could not start.
    #[error("cannot start the render pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    /// The metrics address could not be bound.
    #[error("cannot serve metrics on {address}: {source}")]
    Metrics {
        /// The address asked for.
        address: SocketAddr,
        /// The bind error.
        #[source]
        source: std::io::Error,
    },
    /// The health address could not be bound.
    #[error("cannot serve health checks on {address}: {source}")]
    Health {
        /// The address asked for.
        address: SocketAddr,
        /// The bind error.
        #[source]
        source: std::io::Error,
    },
    // Blobs.
    /// The coordinator refused or the connection failed.
    #[error("fetching blob {hash}: {status}")]
    BlobStatus {
        /// Hex hash of the blob.
        hash: String,
        /// The gRPC status.
        status: tonic::Status,
    },
    /// The chunks did not fit together.
    #[error("blob {hash} arrived malformed: {reason}")]
    BlobMalformed {
        /// Hex hash of the blob.
        hash: String,
        /// What was wrong.
        reason: String,
    },
    /// The bytes do not hash to the blob's name.
    #[error("blob {expected} arrived with hash {got}")]
    BlobHashMismatch {
        /// The hash asked for.
        expected: String,
        /// The hash of the bytes received.
        got: String,
    },
    // The render pool.
    /// The closure panicked; the message is the panic's payload.
    #[error("render thread panicked: {0}")]
    Panicked(String),
    /// The pool dropped the closure without running it.
    #[error("the render pool shut down")]
    PoolDropped,
    // Building a scene's renderer.
    /// The scene cannot be decoded or built: no worker will do better.
    #[error("{0}")]
    BadScene(String),
    /// The build was dropped before it finished.
    #[error("the scene build was abandoned")]
    BuildAbandoned,
}

impl Error {
    /// Whether another attempt could succeed: not for a scene that cannot
    /// be built, nor a blob the coordinator does not have.
    pub fn retryable(&self) -> bool {
        match self {
            Error::BadScene(_) => false,
            Error::BlobStatus { status, .. } => status.code() != tonic::Code::NotFound,
            _ => true,
        }
    }
}

/// Results of the worker.
pub type Result<T> = std::result::Result<T, Error>;
