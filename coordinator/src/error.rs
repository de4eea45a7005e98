//! The coordinator's one error type, and how each error reaches a gRPC
//! client: `From<Error> for tonic::Status` picks the status code, so the
//! service's handlers only say what went wrong.

use farm_proto::PROTOCOL_VERSION;
use tonic::Status;

/// Everything that can go wrong in the coordinator.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A worker or client speaks another protocol version.
    #[error(
        "protocol version {0} is not supported: this coordinator speaks version {PROTOCOL_VERSION}"
    )]
    ProtocolVersion(u32),
    /// The event loop has stopped.
    #[error("the coordinator is shutting down")]
    ShuttingDown,
    /// A Work stream closed before its first message.
    #[error("empty Work stream")]
    EmptyWorkStream,
    /// A Work stream whose first message is not `Hello`.
    #[error("the first message on a Work stream must be Hello")]
    NoHello,
    /// A Work stream for a worker id never registered.
    #[error("unknown worker id or session key: call RegisterWorker first")]
    UnknownWorker,
    /// A second Work stream for a worker whose session is open.
    #[error("this worker's session is already open")]
    SessionOpen,
    /// The system's random source failed.
    #[error("no random numbers: {0}")]
    Random(String),
    /// A worker stopped sending heartbeats.
    #[error("no heartbeat from this worker in time")]
    WorkerSilent,
    /// A blob that was never uploaded.
    #[error("no blob with that hash")]
    NoBlob,
    /// Upload chunks that do not form a blob.
    #[error("upload refused: chunks are inconsistent: {0}")]
    Chunks(#[from] farm_proto::Error),
    /// Uploaded bytes that do not hash to the declared hash.
    #[error("upload refused: the data does not match its hash")]
    HashMismatch,
    /// A job submitted before its manifest was uploaded.
    #[error("upload the scene manifest before submitting")]
    NoManifest,
    /// A manifest that does not decode.
    #[error("{0}")]
    BadManifest(String),
    /// A job whose manifest names an asset not uploaded.
    #[error("asset {0} has not been uploaded")]
    MissingAsset(String),
    /// A job whose film has no pixels, or whose film or samples are over the coordinator's limits.
    #[error(transparent)]
    Film(#[from] farm_common::film::FilmError),
    /// A job whose film has no pixels.
    #[error("the film has no pixels")]
    EmptyFilm,
    /// A job's passes ask for something that cannot be (a target error
    /// that is not a number, a negative time limit).
    #[error("passes: {0}")]
    BadPasses(String),
    /// A frame names a shot that is not the client's, or is not a shot.
    #[error("{0}")]
    BadShot(String),
    /// A job id the coordinator does not know.
    #[error("no job {0}")]
    NoJob(u64),
    /// A client acting on a job another token submitted.
    #[error("job {0} belongs to another client")]
    NotYourJob(u64),
    /// A tile id outside the job's film.
    #[error("tile {0} is outside the film's {1} tiles")]
    UnknownTile(u32, u32),
    /// A film tile whose bounds or pixel count disagree with its tile's.
    #[error("tile {0} has the wrong dimensions")]
    WrongDimensions(u32),
    /// A film tile whose sums no render could produce.
    #[error("tile {0} is refused: {1}")]
    BadPixels(u32, String),
    /// An upload over a client's quota or the store's limit.
    #[error("upload refused: {0}")]
    QuotaExceeded(String),
    /// A client with too many WatchJob streams open.
    #[error("this client already has {0} job watches open: close one first")]
    TooManyWatches(u32),
    /// The blob store's disk failed.
    #[error("the blob store failed: {0}")]
    Store(String),
    /// The state directory could not be opened.
    #[error(transparent)]
    State(#[from] crate::state::StateError),
    /// The gRPC transport failed.
    #[error("gRPC server: {0}")]
    Transport(#[from] tonic::transport::Error),
    /// The scheduler's event loop failed.
    #[error("the scheduler failed: {0}")]
    Scheduler(String),
}

/// Results of the coordinator.
pub type Result<T> = std::result::Result<T, Error>;

impl From<Error> for Status {
    fn from(e: Error) -> Status {
        let message = e.to_string();
        match e {
            Error::ProtocolVersion(_)
            | Error::UnknownWorker
            | Error::NoManifest
            | Error::MissingAsset(_) => Status::failed_precondition(message),
            Error::ShuttingDown => Status::unavailable(message),
            Error::SessionOpen => Status::already_exists(message),
            Error::NotYourJob(_) => Status::permission_denied(message),
            Error::WorkerSilent => Status::deadline_exceeded(message),
            Error::NoBlob | Error::NoJob(_) => Status::not_found(message),
            Error::EmptyWorkStream
            | Error::NoHello
            | Error::Chunks(_)
            | Error::HashMismatch
            | Error::BadManifest(_)
            | Error::EmptyFilm
            | Error::BadShot(_)
            | Error::BadPasses(_)
            | Error::Film(_)
            | Error::UnknownTile(..)
            | Error::WrongDimensions(_)
            | Error::BadPixels(..) => Status::invalid_argument(message),
            Error::QuotaExceeded(_) | Error::TooManyWatches(_) => {
                Status::resource_exhausted(message)
            }
            Error::Transport(_)
            | Error::Scheduler(_)
            | Error::Random(_)
            | Error::Store(_)
            | Error::State(_) => Status::internal(message),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tonic::Code;

    #[test]
    fn each_error_has_its_status_code_and_message() {
        let s = Status::from(Error::ProtocolVersion(9));
        assert_eq!(s.code(), Code::FailedPrecondition);
        assert!(s.message().contains("protocol version 9"), "{}", s.message());
        assert_eq!(Status::from(Error::ShuttingDown).code(), Code::Unavailable);
        assert_eq!(Status::from(Error::NoJob(4)).message(), "no job 4");
        assert_eq!(Status::from(Error::NoJob(4)).code(), Code::NotFound);
        assert_eq!(Status::from(Error::HashMismatch).code(), Code::InvalidArgument);
        assert_eq!(Status::from(Error::WorkerSilent).code(), Code::DeadlineExceeded);
    }
}
