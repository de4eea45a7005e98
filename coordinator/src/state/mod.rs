//! What the coordinator keeps across restarts, all in its state directory:
//! the journal of jobs, tiles and images in `farm.db` (SQLite, beside the
//! tokens), and the blobs in `blobs/`. Without a state directory (tests,
//! embedded use) the journal is in memory and the blobs in a temporary
//! directory.

mod blobs;
mod journal;

pub use blobs::{bytes, hex, BlobLimits, BlobStore, Upload};
pub use journal::{encode_tile, unix_now, Command, Ending, Journal, Restored, SavedBlob, SavedJob};

use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where and how long the coordinator keeps things.
#[derive(Clone, Debug)]
pub struct StateConfig {
    /// The state directory; `None` keeps nothing across restarts.
    pub dir: Option<PathBuf>,
    /// How long a finished, failed or cancelled job is kept.
    pub keep_finished: Duration,
    /// How many bytes blobs may take.
    pub blobs: BlobLimits,
}

impl Default for StateConfig {
    fn default() -> Self {
        StateConfig {
            dir: None,
            keep_finished: Duration::from_secs(24 * 3600),
            blobs: BlobLimits::default(),
        }
    }
}

/// Why the state could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    /// The database failed.
    #[error("the coordinator's database: {0}")]
    Db(String),
    /// A file or directory failed.
    #[error("{0}: {1}")]
    Io(String, #[source] std::io::Error),
    /// Another coordinator has the directory.
    #[error("another coordinator is using the state directory {0}")]
    Locked(PathBuf),
}

impl StateError {
    pub(crate) fn db(e: rusqlite::Error) -> StateError {
        StateError::Db(e.to_string())
    }
}

/// The opened state: the journal, the blobs, what was restored, and the
/// lock that keeps a second coordinator out of the directory.
#[derive(Debug)]
pub struct State {
    /// The journal's sending end.
    pub journal: Journal,
    /// The blob store.
    pub blobs: BlobStore,
    /// Jobs as they were at the last commit.
    pub jobs: Vec<SavedJob>,
    /// The next job's id.
    pub next_job: u64,
    /// The directory's lock, held while the coordinator runs.
    pub lock: Option<File>,
}

impl State {
    /// Opens the state in `config.dir` (creating it), or an empty one.
    pub fn open(config: &StateConfig) -> Result<State, StateError> {
        let lock = match &config.dir {
            Some(d) => Some(lock(d)?),
            None => None,
        };
        let db = config.dir.as_ref().map(|d| d.join("farm.db"));
        let (journal, restored) = Journal::open(db.as_deref())?;
        let blob_dir = config.dir.as_ref().map(|d| d.join("blobs"));
        let blobs =
            BlobStore::open(blob_dir.as_deref(), config.blobs, journal.clone(), restored.blobs)?;
        Ok(State { journal, blobs, jobs: restored.jobs, next_job: restored.next_job, lock })
    }
}

/// Takes the directory's lock file, so two coordinators never share state.
fn lock(dir: &Path) -> Result<File, StateError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| StateError::Io(format!("cannot create {}", dir.display()), e))?;
    let path = dir.join("coordinator.lock");
    let f = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|e| StateError::Io(format!("cannot open {}", path.display()), e))?;
    match f.try_lock() {
        Ok(()) => Ok(f),
        Err(std::fs::TryLockError::WouldBlock) => Err(StateError::Locked(dir.to_path_buf())),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(StateError::Io(format!("cannot lock {}", path.display()), e))
        }
    }
}
