//! The journal's writer thread: it commits what has queued up, a batch to
//! a transaction, and writes the tile logs and image files beside it.

use super::images::Images;
use super::tiles::TileLogs;
use super::{encode_tile_parts, unix_now, Command, Ending};
use crate::scheduler::JobUpdate;
use crate::server::events::job_events;
use farm_proto::convert::Hash;
use prost::Message;
use rusqlite::{params, Connection};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};
use tracing::{debug, error};

/// What the writer keeps beside the database.
pub(super) struct Files {
    pub(super) logs: TileLogs,
    pub(super) images: Images,
    /// A tile's record is framed from the bytes before its pixels, the
    /// pixels' own and the bytes after them ([`encode_tile_parts`]): the
    /// first and last are made here, in these two buffers.
    pub(super) around: (Vec<u8>, Vec<u8>),
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
pub(super) const GATHER: Duration = Duration::from_millis(2);

pub(super) fn writer(
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
                // An ended job's tiles go once its ending is committed: a
                // crash in between leaves a log that the next start
                // deletes. So do a purged job's tiles and image. A batch
                // that did not commit leaves them all: the database still
                // has those jobs as they were.
                for job in after.ended {
                    files.logs.remove(job);
                }
                for job in after.purged {
                    files.images.remove(job);
                }
            }
            Err(e) => {
                error!(error = %e, changes = n, "the journal could not commit: these changes are not durable")
            }
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
    let Files { logs, images, around } = files;
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
            let (head, tail) = around;
            logs.append(job, tile, &encode_tile_parts(&film_tile, &stats, head, tail));
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
            // Purged earlier in this batch: its file goes after the commit.
            if after.purged.contains(&job) {
                let _ = reply.send(Vec::new());
                return Ok(());
            }
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
