//! The journal: every change to a job, committed to SQLite as it happens by
//! one writer thread, and read back when the coordinator starts again.
//!
//! The event loop never waits for the disk: it sends [`Command`]s down a
//! channel, and the writer commits whatever has queued up in one
//! transaction (WAL, `synchronous = NORMAL`: a commit survives the process
//! being killed; only the OS losing power can lose the last few). A batch
//! that starts with a merged tile or a hand-out waits until
//! [`writer::GATHER`] has passed since the last commit, so under load a
//! transaction holds a run of them rather than one or two. Reads
//! that must see earlier writes (a finished job's image) go down the same
//! channel, so they are answered in order. Accepted tiles are the bulk of
//! what is written; they go to a log file per active job beside the
//! database ([`tiles`]), handed to the OS before the batch's commit. A
//! finished job's image goes to a file of its own ([`images`]), synced
//! before the commit that ends the job.

mod direct;
mod images;
mod records;
mod restore;
mod tiles;
mod writer;

use images::Images;
use tiles::TileLogs;
use writer::{writer, Files};

use super::StateError;
use crate::scheduler::{FinishedJob, JobSpec, JobState, Record};
use farm_common::film::FilmTile;
use farm_common::stats::RayStats;
use farm_proto::convert::Hash;
use rusqlite::Connection;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{SystemTime, UNIX_EPOCH};
use tokio::sync::oneshot;
use tracing::error;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS jobs (
    id INTEGER PRIMARY KEY,
    spec BLOB NOT NULL,
    state TEXT NOT NULL,
    reason TEXT,
    detach INTEGER NOT NULL,
    submitted_at INTEGER NOT NULL,
    ended_at INTEGER
);
CREATE TABLE IF NOT EXISTS tiles (
    job INTEGER NOT NULL, tile INTEGER NOT NULL, data BLOB NOT NULL,
    PRIMARY KEY (job, tile)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS attempts (
    job INTEGER NOT NULL, tile INTEGER NOT NULL, n INTEGER NOT NULL,
    PRIMARY KEY (job, tile)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS images (
    job INTEGER NOT NULL, seq INTEGER NOT NULL, event BLOB NOT NULL,
    PRIMARY KEY (job, seq)
);
CREATE TABLE IF NOT EXISTS job_blobs (
    job INTEGER NOT NULL, hash BLOB NOT NULL,
    PRIMARY KEY (job, hash)
) WITHOUT ROWID;
CREATE INDEX IF NOT EXISTS job_blobs_hash ON job_blobs (hash);
CREATE TABLE IF NOT EXISTS frames (
    job INTEGER PRIMARY KEY, shot INTEGER NOT NULL, frame INTEGER NOT NULL, frames INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS passes (job INTEGER PRIMARY KEY, plan BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS parallel_tiles (job INTEGER PRIMARY KEY);
CREATE TABLE IF NOT EXISTS blobs (
    hash BLOB PRIMARY KEY, size INTEGER NOT NULL, owner TEXT NOT NULL, stored_at INTEGER NOT NULL
) WITHOUT ROWID;
";

/// Seconds since the Unix epoch.
pub fn unix_now() -> i64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0)
}

/// How a job ended, as stored.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Ending {
    /// Its image is in the journal.
    Done,
    /// It failed, with the reason.
    Failed(String),
    /// A client cancelled it.
    Cancelled,
}

/// One change for the writer.
pub enum Command {
    /// A job was accepted.
    Submitted {
        /// Its id.
        id: u64,
        /// Its spec.
        spec: Box<JobSpec>,
        /// Whether it runs on with no client attached.
        detach: bool,
        /// The blobs it needs (manifest and assets).
        blobs: Vec<Hash>,
    },
    /// A tile was handed out for the `n`th time.
    HandedOut {
        /// The job.
        job: u64,
        /// The tile.
        tile: u32,
        /// Hand-outs so far.
        n: u32,
    },
    /// A tile's result was accepted: the film's own tile, shared, so the
    /// event loop neither copies nor encodes it; the writer frames its
    /// record straight from its pixels ([`encode_tile_parts`]).
    Merged {
        /// The job.
        job: u64,
        /// The tile.
        tile: u32,
        /// Its sums.
        film_tile: Arc<FilmTile>,
        /// Its rays.
        stats: RayStats,
    },
    /// A job ended; for a finished one, with its image, stored as the
    /// very `JobEvent`s a watcher is sent. Its tiles are no longer needed.
    Ended {
        /// The job.
        job: u64,
        /// How.
        ending: Ending,
        /// The image of a finished job, shared with its watchers.
        image: Option<Arc<FinishedJob>>,
    },
    /// Jobs purged after their retention period.
    Purge {
        /// The jobs.
        jobs: Vec<u64>,
        /// Blobs stored before this time that no job needs any more are
        /// reported on `reply` (and forgotten here).
        unreferenced_before: i64,
        /// Where to send them.
        reply: oneshot::Sender<Vec<Hash>>,
    },
    /// A blob was stored (or stored again).
    BlobStored {
        /// Its hash.
        hash: Hash,
        /// Its size.
        size: u64,
        /// The token that first stored it.
        owner: String,
    },
    /// The image events of a finished job.
    ReadImage {
        /// The job.
        job: u64,
        /// Where to send them.
        reply: oneshot::Sender<Vec<Vec<u8>>>,
    },
    /// Answered once everything sent before it is committed.
    Flush(oneshot::Sender<()>),
}

/// A job read back from the journal.
#[derive(Debug)]
pub struct SavedJob {
    /// Its id.
    pub id: u64,
    /// Its spec.
    pub spec: JobSpec,
    /// `None` while active.
    pub ending: Option<Ending>,
    /// When it ended (seconds since the epoch).
    pub ended_at: Option<i64>,
    /// Whether it runs on with no client attached.
    pub detach: bool,
    /// Accepted tiles of an active job, in tile order.
    pub tiles: Vec<(u32, FilmTile, RayStats)>,
    /// Hand-outs per tile.
    pub attempts: Vec<(u32, u32)>,
}

/// A stored blob's record.
#[derive(Clone, Debug)]
pub struct SavedBlob {
    /// Its hash.
    pub hash: Hash,
    /// Its size.
    pub size: u64,
    /// The token that first stored it.
    pub owner: String,
}

/// What the journal held at start.
#[derive(Debug, Default)]
pub struct Restored {
    /// The id the next job gets.
    pub next_job: u64,
    /// Every job not yet purged.
    pub jobs: Vec<SavedJob>,
    /// Every stored blob.
    pub blobs: Vec<SavedBlob>,
}

/// The sending end of the journal; cheap to clone.
#[derive(Clone)]
pub struct Journal {
    tx: mpsc::Sender<Command>,
    /// Transactions the writer has committed.
    commits: Arc<AtomicUsize>,
}

impl std::fmt::Debug for Journal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Journal")
    }
}

/// Encodes a tile result for its log record: the bytes of postcard's
/// encoding of `(tile, stats)`, which restoring decodes.
///
/// postcard writes a struct as its fields in order, a sequence as its
/// length (a varint) and then its items, and an `f32` as its four
/// little-endian bytes, so the pixels are written here as their sums'
/// bytes in field order ([`farm_common::film::Pixel::to_array`]). Through serde, one call per
/// float that pushed one byte at a time, this was 8% of the coordinator's
/// CPU while tiles came in.
pub fn encode_tile(tile: &FilmTile, stats: &RayStats) -> Vec<u8> {
    let mut out = Vec::new();
    encode_tile_into(&mut out, tile, stats);
    out
}

/// [`encode_tile`] as the pieces that follow each other, so that the
/// writer frames a tile's record straight from its pixels: `head` and
/// `tail` (cleared first) hold the pixels' bounds and count and the stats,
/// and the pixels are their own bytes ([`Pixel::wire_bytes`]; on a
/// big-endian host `head` holds the whole encoding and the rest are empty).
/// A tile's 8 KB then goes to its log in one copy, not two.
///
/// [`Pixel::wire_bytes`]: farm_common::film::Pixel::wire_bytes
pub fn encode_tile_parts<'a>(
    tile: &'a FilmTile,
    stats: &RayStats,
    head: &'a mut Vec<u8>,
    tail: &'a mut Vec<u8>,
) -> [&'a [u8]; 3] {
    let Some(pixels) = farm_common::film::Pixel::wire_bytes(&tile.pixels) else {
        encode_tile_into(head, tile, stats);
        return [head.as_slice(), &[], &[]];
    };
    head.clear();
    tail.clear();
    let counted = (&tile.pixel_bounds, tile.pixels.len() as u64);
    *head = postcard::to_extend(&counted, std::mem::take(head)).unwrap_or_default();
    *tail = postcard::to_extend(stats, std::mem::take(tail)).unwrap_or_default();
    [head.as_slice(), pixels, tail.as_slice()]
}

/// [`encode_tile`] into `out`, cleared first (the writer's encoding on a
/// big-endian host, [`encode_tile_parts`]).
pub fn encode_tile_into(out: &mut Vec<u8>, tile: &FilmTile, stats: &RayStats) {
    const PIXEL: usize = std::mem::size_of::<[f32; 8]>();
    out.clear();
    // Room for all of it up front, so nothing is reallocated.
    out.reserve(64 + tile.pixels.len() * PIXEL);
    let head = (&tile.pixel_bounds, tile.pixels.len() as u64);
    let mut buf = postcard::to_extend(&head, std::mem::take(out)).unwrap_or_default();
    for p in &tile.pixels {
        farm_common::le::extend_f32s(&mut buf, &p.to_array());
    }
    *out = postcard::to_extend(stats, buf).unwrap_or_default();
}

impl Journal {
    /// Opens (or creates) the journal in `db` (in memory if `None`), reads
    /// back what it holds and starts the writer thread.
    pub fn open(db: Option<&Path>) -> Result<(Journal, Restored), StateError> {
        let conn = match db {
            Some(p) => Connection::open(p),
            None => Connection::open_in_memory(),
        }
        .map_err(StateError::db)?;
        conn.busy_timeout(std::time::Duration::from_secs(10)).map_err(StateError::db)?;
        conn.pragma_update(None, "journal_mode", "WAL").map_err(StateError::db)?;
        conn.pragma_update(None, "synchronous", "NORMAL").map_err(StateError::db)?;
        conn.execute_batch(SCHEMA).map_err(StateError::db)?;
        let tile_dir = db.map(|p| p.with_extension("tiles"));
        let mut logs = TileLogs::open(tile_dir.clone()).map_err(|e| {
            let dir = tile_dir.unwrap_or_default();
            StateError::Io(format!("cannot create {}", dir.display()), e)
        })?;
        let restored = restore::restore(&conn, &logs).map_err(StateError::db)?;
        let active: Vec<u64> =
            restored.jobs.iter().filter(|j| j.ending.is_none()).map(|j| j.id).collect();
        logs.remove_all_but(&active);
        let image_dir = db.map(|p| p.with_extension("images"));
        let mut images = Images::open(image_dir.clone()).map_err(|e| {
            let dir = image_dir.unwrap_or_default();
            StateError::Io(format!("cannot create {}", dir.display()), e)
        })?;
        let ended: Vec<u64> =
            restored.jobs.iter().filter(|j| j.ending.is_some()).map(|j| j.id).collect();
        images.remove_all_but(&ended);
        let (tx, rx) = mpsc::channel();
        let files = Files { logs, images, around: (Vec::new(), Vec::new()) };
        let commits = Arc::new(AtomicUsize::new(0));
        let counted = commits.clone();
        std::thread::Builder::new()
            .name("farm-journal".into())
            .spawn(move || writer(conn, files, rx, counted))
            .map_err(|e| StateError::Io("cannot start the journal's thread".into(), e))?;
        Ok((Journal { tx, commits }, restored))
    }

    /// Queues a change (dropped, with the coordinator, if the writer died).
    pub fn send(&self, c: Command) {
        if self.tx.send(c).is_err() {
            error!("the journal's writer has stopped: this change is not durable");
        }
    }

    /// Queues a change the scheduler asks to be made durable.
    pub fn record(&self, change: Record<'_>) {
        self.send(match change {
            Record::Submitted { job, spec } => Command::Submitted {
                id: job.0,
                detach: spec.detach,
                blobs: spec.blobs.clone(),
                spec: Box::new(spec.clone()),
            },
            Record::HandedOut { job, tile, n } => {
                Command::HandedOut { job: job.0, tile: tile.0, n }
            }
            Record::Merged { job, tile, film_tile, stats } => Command::Merged {
                job: job.0,
                tile: tile.0,
                film_tile: film_tile.clone(),
                stats: *stats,
            },
            Record::Ended { job, state, image } => {
                let ending = match state {
                    JobState::Failed(m) => Ending::Failed(m.clone()),
                    JobState::Cancelled => Ending::Cancelled,
                    _ => Ending::Done,
                };
                // Encoded by the writer, off the event loop.
                let image = image.cloned();
                Command::Ended { job: job.0, ending, image }
            }
        });
    }

    /// How many transactions the writer has committed so far.
    pub fn commits(&self) -> usize {
        self.commits.load(Ordering::Relaxed)
    }

    /// Waits until everything queued so far is committed.
    pub async fn flush(&self) {
        let (reply, rx) = oneshot::channel();
        self.send(Command::Flush(reply));
        let _ = rx.await;
    }
}

#[cfg(test)]
mod tests;
