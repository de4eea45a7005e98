//! The journal: every change to a job, committed to SQLite as it happens by
//! one writer thread, and read back when the coordinator starts again.
//!
//! The event loop never waits for the disk: it sends [`Command`]s down a
//! channel, and the writer commits whatever has queued up in one
//! transaction (WAL, `synchronous = NORMAL`: a commit survives the process
//! being killed; only the OS losing power can lose the last few). Tiles
//! and hand-outs are committed at most every [`GATHER`], so under load a
//! transaction holds a run of them rather than one or two. Reads
//! that must see earlier writes (a finished job's image) go down the same
//! channel, so they are answered in order. Accepted tiles are the bulk of
//! what is written; they go to a log file per active job beside the
//! database ([`tiles`]), handed to the OS before the batch's commit. A
//! finished job's image goes to a file of its own ([`images`]), synced
//! before the commit that ends the job.

mod images;
mod records;
mod restore;
mod tiles;

use images::Images;
use tiles::TileLogs;

use super::StateError;
use crate::scheduler::{FinishedJob, JobSpec, JobState, JobUpdate, Record};
use crate::server::events::job_events;
use farm_common::film::FilmTile;
use farm_common::stats::RayStats;
use farm_proto::convert::Hash;
use prost::Message;
use rusqlite::{params, Connection};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tokio::sync::oneshot;
use tracing::{debug, error};

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
    /// event loop neither copies nor encodes it; the writer encodes it
    /// ([`encode_tile_into`]) straight before appending it to the log.
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

/// [`encode_tile`] into `out`, cleared first: the writer keeps one buffer
/// for every tile.
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
        let files = Files { logs, images, encoded: Vec::new() };
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

/// What the writer keeps beside the database.
struct Files {
    logs: TileLogs,
    images: Images,
    /// Each tile is encoded here, into this one buffer, then appended.
    encoded: Vec<u8>,
}

/// What a batch leaves to do once it is committed.
#[derive(Default)]
struct After {
    replies: Vec<Reply>,
    /// Jobs whose tile logs go.
    ended: Vec<u64>,
    /// Jobs whose images go.
    purged: Vec<u64>,
}

/// The least time between a commit and the next one that a merged tile or
/// a hand-out starts. Each transaction costs the writer a wake-up, SQLite's
/// locks and WAL frames and a write of the tile log: one per tile or two
/// while tiles came in as fast as the coordinator merged them. Gathering
/// 2 ms took a sixth to a quarter off the writer's CPU for a 2048² job at
/// one worker (perf samples of its thread, three alternating pairs:
/// 641/622/526 → 531/449/414), and
/// adds at most 2 ms to how long a tile waits to be durable, against the
/// seconds a tile in flight takes to render again.
const GATHER: Duration = Duration::from_millis(2);

fn writer(
    mut conn: Connection,
    mut files: Files,
    rx: mpsc::Receiver<Command>,
    commits: Arc<AtomicUsize>,
) {
    let mut committed: Option<Instant> = None;
    while let Ok(first) = rx.recv() {
        if matches!(first, Command::Merged { .. } | Command::HandedOut { .. }) {
            if let Some(wait) = committed.and_then(|t| GATHER.checked_sub(t.elapsed())) {
                std::thread::sleep(wait);
            }
        }
        let mut batch = vec![first];
        while batch.len() < 1024 {
            match rx.try_recv() {
                Ok(c) => batch.push(c),
                Err(_) => break,
            }
        }
        let n = batch.len();
        let mut after = After::default();
        let result = (|| -> rusqlite::Result<()> {
            let tx = conn.transaction()?;
            for c in batch {
                apply(&tx, &mut files, c, &mut after)?;
            }
            // Tiles reach the OS before the commit that could end their job.
            files.logs.flush();
            tx.commit()
        })();
        committed = Some(Instant::now());
        match result {
            Ok(()) => {
                commits.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => {
                error!(error = %e, changes = n, "the journal could not commit: these changes are not durable")
            }
        }
        // An ended job's tiles go once its ending is committed: a crash in
        // between leaves a log that the next start deletes. So do a purged
        // job's tiles and image.
        for job in after.ended {
            files.logs.remove(job);
        }
        for job in after.purged {
            files.images.remove(job);
        }
        // Answers go out after the commit, so a flush means "on disk".
        for r in after.replies {
            r();
        }
    }
    debug!("journal writer stopped");
}

type Reply = Box<dyn FnOnce() + Send>;

fn apply(
    tx: &rusqlite::Transaction<'_>,
    files: &mut Files,
    c: Command,
    after: &mut After,
) -> rusqlite::Result<()> {
    let Files { logs, images, encoded } = files;
    match c {
        Command::Submitted { id, spec, detach, blobs } => {
            let bytes = postcard::to_stdvec(&*spec).unwrap_or_default();
            tx.execute(
                "INSERT OR REPLACE INTO jobs (id, spec, state, detach, submitted_at) VALUES (?1, ?2, 'active', ?3, ?4)",
                params![id as i64, bytes, detach, unix_now()],
            )?;
            tx.execute(
                "INSERT INTO meta (key, value) VALUES ('next_job', ?1)
                 ON CONFLICT (key) DO UPDATE SET value = max(value, excluded.value)",
                params![id as i64 + 1],
            )?;
            let mut st =
                tx.prepare_cached("INSERT OR IGNORE INTO job_blobs (job, hash) VALUES (?1, ?2)")?;
            for h in blobs {
                st.execute(params![id as i64, h.as_slice()])?;
            }
            if let Some(p) = &spec.passes {
                tx.execute(
                    "INSERT OR REPLACE INTO passes (job, plan) VALUES (?1, ?2)",
                    params![id as i64, postcard::to_stdvec(p).unwrap_or_default()],
                )?;
            }
            if spec.parallel_tiles {
                tx.execute(
                    "INSERT OR IGNORE INTO parallel_tiles (job) VALUES (?1)",
                    params![id as i64],
                )?;
            }
            if let Some(f) = spec.shot {
                tx.execute(
                    "INSERT OR REPLACE INTO frames (job, shot, frame, frames) VALUES (?1, ?2, ?3, ?4)",
                    params![id as i64, f.shot.0 as i64, f.frame, f.frames],
                )?;
            }
        }
        Command::HandedOut { job, tile, n } => {
            tx.prepare_cached(
                "INSERT OR REPLACE INTO attempts (job, tile, n) VALUES (?1, ?2, ?3)",
            )?
            .execute(params![job as i64, tile, n])?;
        }
        Command::Merged { job, tile, film_tile, stats } if logs.keeps() => {
            encode_tile_into(encoded, &film_tile, &stats);
            logs.append(job, tile, encoded);
        }
        Command::Merged { .. } => {}
        Command::Ended { job, ending, image } => {
            let (state, reason) = match ending {
                Ending::Done => ("done", None),
                Ending::Failed(r) => ("failed", Some(r)),
                Ending::Cancelled => ("cancelled", None),
            };
            tx.execute(
                "UPDATE jobs SET state = ?2, reason = ?3, ended_at = ?4 WHERE id = ?1",
                params![job as i64, state, reason, unix_now()],
            )?;
            // Rows of tiles journalled before the tile logs.
            tx.execute("DELETE FROM tiles WHERE job = ?1", params![job as i64])?;
            after.ended.push(job);
            let Some(image) = image else { return Ok(()) };
            let events = job_events(&JobUpdate::Finished(image));
            // A `Vec` grows to take any message: encoding it cannot fail.
            let encode = |e: &farm_proto::v1::JobEvent, buf: &mut Vec<u8>| {
                let _ = e.encode(buf);
            };
            let Err(e) = images.store(job, &events, encode) else { return Ok(()) };
            error!(job, error = %e, "cannot write a finished image's file: it goes in the database");
            let mut st = tx.prepare_cached(
                "INSERT OR REPLACE INTO images (job, seq, event) VALUES (?1, ?2, ?3)",
            )?;
            for (seq, ev) in events.iter().enumerate() {
                st.execute(params![job as i64, seq as i64, ev.encode_to_vec()])?;
            }
        }
        Command::Purge { jobs, unreferenced_before, reply } => {
            for job in jobs {
                let job = job as i64;
                for table in [
                    "tiles",
                    "attempts",
                    "images",
                    "job_blobs",
                    "frames",
                    "passes",
                    "parallel_tiles",
                ] {
                    tx.execute(&format!("DELETE FROM {table} WHERE job = ?1"), params![job])?;
                }
                tx.execute("DELETE FROM jobs WHERE id = ?1", params![job])?;
                after.ended.push(job as u64);
                after.purged.push(job as u64);
            }
            let mut st = tx.prepare(
                "SELECT hash FROM blobs WHERE stored_at < ?1
                 AND NOT EXISTS (SELECT 1 FROM job_blobs WHERE job_blobs.hash = blobs.hash)",
            )?;
            let hashes: Vec<Hash> = st
                .query_map(params![unreferenced_before], |r| r.get::<_, Vec<u8>>(0))?
                .filter_map(|h| h.ok().and_then(|h| h.try_into().ok()))
                .collect();
            for h in &hashes {
                tx.execute("DELETE FROM blobs WHERE hash = ?1", params![h.as_slice()])?;
            }
            after.replies.push(Box::new(move || {
                let _ = reply.send(hashes);
            }));
        }
        Command::BlobStored { hash, size, owner } => {
            tx.prepare_cached(
                "INSERT INTO blobs (hash, size, owner, stored_at) VALUES (?1, ?2, ?3, ?4)
                 ON CONFLICT (hash) DO UPDATE SET stored_at = excluded.stored_at",
            )?
            .execute(params![hash.as_slice(), size as i64, owner, unix_now()])?;
        }
        Command::ReadImage { job, reply } => {
            if let Some(events) = images.read(job) {
                let _ = reply.send(events);
                return Ok(());
            }
            let mut st =
                tx.prepare_cached("SELECT event FROM images WHERE job = ?1 ORDER BY seq")?;
            let events: Vec<Vec<u8>> =
                st.query_map(params![job as i64], |r| r.get(0))?.filter_map(Result::ok).collect();
            let _ = reply.send(events);
        }
        Command::Flush(reply) => after.replies.push(Box::new(move || {
            let _ = reply.send(());
        })),
    }
    Ok(())
}

#[cfg(test)]
mod tests;
