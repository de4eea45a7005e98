//! Accepted tiles, appended to one log file per active job rather than
//! stored as SQLite rows.
//!
//! A tile is 8 KB of sums, and an active job's tiles are only ever read
//! back whole, at start-up. As rows of a B-tree they cost the coordinator
//! more CPU than the rest of a tile's handling together: each was written
//! to the WAL, read back and written again at checkpoint, and deleted row
//! by row when the job ended. Appended to a file, a tile is written once,
//! and an ended job's tiles go with one unlink.
//!
//! A log is `FARMTLG1` then records ([`super::records`]) whose key is
//! pass × tiles + tile and whose bytes are the postcard-encoded tile.
//! Reading cuts the file at the first record that is short or fails its
//! check (a write the process died in), so records appended later stay
//! readable. A key written twice keeps its last record, as the rows'
//! `INSERT OR REPLACE` did.
//!
//! Logs are written to the OS at the end of every batch the journal
//! commits, so they survive the process being killed, as the WAL's
//! commits do, and synced to the disk at most once a second.
//!
//! A new log is written past the page cache where the OS allows it
//! (`direct.rs`): every batch's records go straight to the disk, the last
//! partial block padded with zeros and written again with the next batch.
//! So a log can end in fewer than a block of zeros, which reading takes
//! for its end. A log opened again after a restart is appended to through
//! the cache, as is every log where `O_DIRECT` is refused, and one whose
//! write past the cache failed (from then on).
//!
//! Measured against the cache (2048² jobs, 8 KB tiles):
//! - `cargo bench -p farm-coordinator --bench journal`: the journal
//!   thread's CPU 1.8 and 2.4 → 0.6 µs a tile, for more wall time, 7.8 →
//!   10.5 µs a tile (the writes wait for this machine's disk, about
//!   800 MB/s; through the cache they waited for nothing);
//! - the capacity bench at one worker, perf samples of the coordinator's
//!   journal thread over six jobs: 695 → 431 (about 44 ms a job); the
//!   coordinator's CPU a tile between 10% and 90% of a job, four turns of
//!   each binary: 16.8–17.5 → 14.5–16.0 µs.

use super::direct::{Direct, ALIGN};
use super::records::{self, Found};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tracing::{debug, error, warn};

const MAGIC: &[u8; 8] = b"FARMTLG1";
/// How often written logs are synced to the disk.
const SYNC_EVERY: Duration = Duration::from_secs(1);
/// Bytes a log written past the cache writes at once: about 128 tiles,
/// more than a batch gathers in its 2 ms at 50,000 tiles a second.
const DIRECT_CHUNK: usize = 1 << 20;

/// An open log: past the page cache, or through it.
enum Log {
    Direct(Box<Direct>, PathBuf),
    Cached(BufWriter<File>),
}

impl Log {
    /// A writer for the log at `path`: past the cache if the log is new
    /// and the OS allows it, else appending through the cache.
    fn open(path: &Path) -> std::io::Result<Log> {
        let new = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
        if new {
            match Direct::with_chunk(path, DIRECT_CHUNK) {
                Ok(mut d) => {
                    d.write_all(MAGIC)?;
                    return Ok(Log::Direct(Box::new(d), path.to_path_buf()));
                }
                Err(e) => {
                    debug!(path = %path.display(), error = %e, "the tile log is written through the page cache")
                }
            }
        }
        Ok(Log::Cached(cached(open_for_append(path)?)))
    }

    /// Hands what was appended to the OS.
    fn write_out(&mut self) -> std::io::Result<()> {
        match self {
            Log::Cached(w) => w.flush(),
            Log::Direct(d, _) => match d.write_out() {
                Ok(()) => Ok(()),
                Err(e) => self.fall_back(e)?.flush(),
            },
        }
    }

    /// After a write past the cache failed with `e` (a file system that
    /// took the flag and not the writes, or a disk error): the log
    /// reopened through the cache, cut at what was surely written and
    /// given the rest again, so nothing appended is lost.
    fn fall_back(&mut self, e: std::io::Error) -> std::io::Result<&mut BufWriter<File>> {
        let Log::Direct(d, path) = self else {
            unreachable!("only a log past the cache falls back")
        };
        warn!(path = %path.display(), error = %e, "cannot write the tile log past the page cache: writing it through the cache");
        let (surely, rest) = d.unwritten();
        let f = File::options().append(true).open(&*path)?;
        f.set_len(surely)?;
        let mut w = cached(f);
        w.write_all(rest)?;
        *self = Log::Cached(w);
        let Log::Cached(w) = self else { unreachable!() };
        Ok(w)
    }

    fn sync_data(&self) -> std::io::Result<()> {
        match self {
            Log::Direct(d, _) => d.sync_data(),
            Log::Cached(w) => w.get_ref().sync_data(),
        }
    }
}

impl Write for Log {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        match self {
            Log::Cached(w) => w.write(data),
            // A failed write of a full chunk took none of `data`.
            Log::Direct(d, _) => match d.write(data) {
                Ok(n) => Ok(n),
                Err(e) => self.fall_back(e)?.write(data),
            },
        }
    }

    /// Only the cache's buffer: [`Log::write_out`] hands everything over.
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Log::Direct(..) => Ok(()),
            Log::Cached(w) => w.flush(),
        }
    }
}

fn cached(f: File) -> BufWriter<File> {
    BufWriter::with_capacity(256 << 10, f)
}

/// The logs of the active jobs, in `dir` (none kept without one).
pub(super) struct TileLogs {
    dir: Option<PathBuf>,
    open: HashMap<u64, Log>,
    /// Jobs written since the last sync.
    unsynced: Vec<u64>,
    synced_at: Instant,
}

impl TileLogs {
    /// The logs in `dir`, created if missing; `None` keeps nothing (an
    /// in-memory journal is never read back).
    pub fn open(dir: Option<PathBuf>) -> std::io::Result<TileLogs> {
        if let Some(d) = &dir {
            std::fs::create_dir_all(d)?;
        }
        Ok(TileLogs { dir, open: HashMap::new(), unsynced: Vec::new(), synced_at: Instant::now() })
    }

    fn path(dir: &Path, job: u64) -> PathBuf {
        dir.join(format!("{job}.log"))
    }

    /// Whether logs are written (there is a directory for them).
    pub fn keeps(&self) -> bool {
        self.dir.is_some()
    }

    /// Appends tile `key` of `job`, whose record's bytes are `parts` one
    /// after the other (buffered until [`TileLogs::flush`]).
    pub fn append(&mut self, job: u64, key: u32, parts: &[&[u8]]) {
        let Some(dir) = &self.dir else { return };
        let w = match self.open.entry(job) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(v) => {
                match Log::open(&Self::path(dir, job)) {
                    Ok(log) => v.insert(log),
                    Err(e) => {
                        error!(job, error = %e, "cannot open the job's tile log: its tiles are not durable");
                        return;
                    }
                }
            }
        };
        let written = records::write_parts(w, key, parts);
        if let Err(e) = written {
            error!(job, error = %e, "cannot write the job's tile log: this tile is not durable");
        }
        if !self.unsynced.contains(&job) {
            self.unsynced.push(job);
        }
    }

    /// Hands everything appended to the OS; syncs it to the disk when the
    /// last sync is a second old.
    pub fn flush(&mut self) {
        for (job, w) in &mut self.open {
            if let Err(e) = w.write_out() {
                error!(job, error = %e, "cannot write the job's tile log: its last tiles are not durable");
            }
        }
        if self.unsynced.is_empty() || self.synced_at.elapsed() < SYNC_EVERY {
            return;
        }
        for job in self.unsynced.drain(..) {
            if let Some(w) = self.open.get(&job) {
                if let Err(e) = w.sync_data() {
                    warn!(job, error = %e, "cannot sync the job's tile log");
                }
            }
        }
        self.synced_at = Instant::now();
    }

    /// Deletes the log of a job that ended or was purged.
    pub fn remove(&mut self, job: u64) {
        self.open.remove(&job);
        self.unsynced.retain(|j| *j != job);
        let Some(dir) = &self.dir else { return };
        match std::fs::remove_file(Self::path(dir, job)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                warn!(job, error = %e, "cannot delete an ended job's tile log")
            }
            _ => {}
        }
    }

    /// Reads back the tiles of `job`, by key, cutting a torn last record.
    pub fn read(&self, job: u64) -> BTreeMap<u32, Vec<u8>> {
        let Some(dir) = &self.dir else { return BTreeMap::new() };
        let path = Self::path(dir, job);
        match read_log(&path) {
            Ok(tiles) => tiles,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => BTreeMap::new(),
            Err(e) => {
                error!(job, error = %e, "cannot read the job's tile log: its tiles render again");
                BTreeMap::new()
            }
        }
    }

    /// Deletes the logs of jobs not in `active` (ended while their log's
    /// deletion was pending, or never committed).
    pub fn remove_all_but(&mut self, active: &[u64]) {
        let Some(dir) = self.dir.clone() else { return };
        let Ok(entries) = std::fs::read_dir(&dir) else { return };
        for e in entries.flatten() {
            let name = e.file_name();
            let job = name.to_str().and_then(|n| n.strip_suffix(".log")?.parse::<u64>().ok());
            if let Some(job) = job.filter(|j| !active.contains(j)) {
                self.remove(job);
            }
        }
    }
}

fn open_for_append(path: &Path) -> std::io::Result<File> {
    let mut f = File::options().create(true).append(true).open(path)?;
    if f.metadata()?.len() == 0 {
        f.write_all(MAGIC)?;
    }
    Ok(f)
}

/// The records of the log at `path`; a torn or corrupt tail is cut off.
fn read_log(path: &Path) -> std::io::Result<BTreeMap<u32, Vec<u8>>> {
    let f = File::options().read(true).write(true).open(path)?;
    let size = f.metadata()?.len();
    let found = records::read(&mut BufReader::new(&f), MAGIC, size)?;
    let Found::Records { records, end, complete } = found else {
        warn!(path = %path.display(), "not a tile log: its tiles render again");
        f.set_len(0)?;
        return Ok(BTreeMap::new());
    };
    if !complete {
        if !is_padding(&f, end, size)? {
            warn!(
                path = %path.display(),
                bytes = size - end,
                "a tile log ends in an incomplete record (the process died writing it): cut off"
            );
        }
        f.set_len(end)?;
    }
    Ok(records.into_iter().collect())
}

/// Whether the bytes of `f` from `end` to `size` are fewer than a block of
/// zeros: the padding a log written past the cache ends in.
fn is_padding(mut f: &File, end: u64, size: u64) -> std::io::Result<bool> {
    let Some(n) = usize::try_from(size - end).ok().filter(|&n| n < ALIGN) else {
        return Ok(false);
    };
    let mut tail = vec![0u8; n];
    f.seek(SeekFrom::Start(end))?;
    f.read_exact(&mut tail)?;
    Ok(tail.iter().all(|&b| b == 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn logs(dir: &Path) -> TileLogs {
        TileLogs::open(Some(dir.to_path_buf())).unwrap()
    }

    /// An empty directory of this test's own, removed when dropped.
    fn scratch(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("farm-tile-log-{name}-")).tempdir().unwrap()
    }

    #[test]
    fn tiles_read_back_by_key_with_the_last_of_a_key_kept() {
        let tmp = scratch("kept");
        let dir = tmp.path();
        let mut l = logs(dir);
        l.append(7, 3, &[b"three"]);
        l.append(7, 1, &[b"o", b"ne"]);
        l.append(8, 1, &[b"other job"]);
        l.append(7, 3, &[b"three", b"", b" again"]);
        l.flush();
        drop(l);
        let l = logs(dir);
        let t = l.read(7);
        assert_eq!(t.keys().copied().collect::<Vec<_>>(), [1, 3]);
        assert_eq!(t[&3], b"three again");
        assert_eq!(l.read(8)[&1], b"other job");
        assert!(l.read(9).is_empty());
    }

    #[test]
    fn a_torn_or_corrupt_tail_is_cut_and_later_records_still_read() {
        let tmp = scratch("torn");
        let dir = tmp.path();
        let mut l = logs(dir);
        l.append(1, 0, &[&[5; 100]]);
        l.append(1, 1, &[&[6; 100]]);
        l.flush();
        drop(l);
        let path = dir.join("1.log");
        let full = std::fs::read(&path).unwrap();
        // Died halfway through the second record (each is 8 + 4 + 100
        // bytes, after the magic; a log past the cache has zeros after).
        std::fs::write(&path, &full[..MAGIC.len() + 112 + 62]).unwrap();
        let mut l = logs(dir);
        assert_eq!(l.read(1).keys().copied().collect::<Vec<_>>(), [0]);
        l.append(1, 2, &[&[7; 10]]);
        l.flush();
        assert_eq!(l.read(1).keys().copied().collect::<Vec<_>>(), [0, 2]);
        // A flipped bit in the payload fails the check: that record and
        // everything after it are dropped, not misread.
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[8 + 8 + 4 + 10] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(l.read(1).is_empty());
        // A length too large to be a record is not allocated.
        let mut bytes = MAGIC.to_vec();
        bytes.extend(u32::MAX.to_le_bytes());
        bytes.extend([0; 12]);
        std::fs::write(&path, &bytes).unwrap();
        assert!(l.read(1).is_empty());
        assert_eq!(std::fs::metadata(&path).unwrap().len(), MAGIC.len() as u64);
    }

    /// Records of uneven lengths (4 to 13 KB), in batches of 1 to 150
    /// (past a chunk).
    fn batches() -> Vec<Vec<(u32, Vec<u8>)>> {
        [1, 3, 150, 2, 7]
            .iter()
            .enumerate()
            .map(|(b, &n)| {
                (0..n)
                    .map(|k| {
                        let key = (b * 1000 + k) as u32;
                        (key, vec![key as u8 | 1; 4000 + key as usize * 97 % 9000])
                    })
                    .collect()
            })
            .collect()
    }

    /// After every batch, a copy of the log (what a restart would find)
    /// reads back every record so far, and what follows the last one is
    /// the padding, not taken for a torn record; after a restart the log
    /// goes on through the cache.
    #[test]
    fn a_log_past_the_cache_reads_back_after_every_batch() {
        let tmp = scratch("direct");
        let dir = tmp.path();
        let (path, copy) = (dir.join("1.log"), dir.join("2.log"));
        let mut l = logs(dir);
        let mut expect = BTreeMap::new();
        for batch in batches() {
            for (key, data) in batch {
                l.append(1, key, &[&data]);
                expect.insert(key, data);
            }
            l.flush();
            let size = std::fs::metadata(&path).unwrap().len();
            match &l.open[&1] {
                Log::Direct(..) => assert_eq!(size % ALIGN as u64, 0),
                Log::Cached(_) => {
                    eprintln!("{} takes no O_DIRECT writes: cached only", dir.display())
                }
            }
            std::fs::copy(&path, &copy).unwrap();
            let f = File::open(&copy).unwrap();
            let Ok(Found::Records { records, end, .. }) =
                records::read(&mut BufReader::new(&f), MAGIC, size)
            else {
                panic!("not read")
            };
            assert_eq!(records.len(), expect.len(), "each record once");
            assert!(is_padding(&f, end, size).unwrap(), "{} bytes after the records", size - end);
            assert_eq!(l.read(2), expect);
            assert_eq!(std::fs::metadata(&copy).unwrap().len(), end);
        }
        drop(l);
        let mut l = logs(dir);
        assert_eq!(l.read(1), expect);
        l.append(1, 7, &[b"after a restart"]);
        l.flush();
        assert!(matches!(l.open[&1], Log::Cached(_)));
        expect.insert(7, b"after a restart".to_vec());
        assert_eq!(l.read(1), expect);
    }

    /// A log past the cache whose write fails goes on through the cache
    /// with nothing lost: cut at what was surely written, the rest given
    /// again. Job 1 fails as a chunk fills (batch 2 is over 1 MiB), job 2
    /// as a batch is written out.
    #[test]
    fn a_failed_write_past_the_cache_goes_on_through_it() {
        let tmp = scratch("fallback");
        let dir = tmp.path();
        let mut l = logs(dir);
        for (job, fails_at) in [(1, 2), (2, 1)] {
            let mut expect = BTreeMap::new();
            for (i, batch) in batches().into_iter().enumerate() {
                if i == fails_at {
                    // A file the writer cannot write: its next write fails.
                    let read_only = File::open(dir.join(format!("{job}.log"))).unwrap();
                    let Some(Log::Direct(d, _)) = l.open.get_mut(&job) else {
                        eprintln!("skipped: {} takes no O_DIRECT writes", dir.display());
                        return;
                    };
                    d.replace_file(read_only);
                }
                for (key, data) in batch {
                    l.append(job, key, &[&data]);
                    expect.insert(key, data);
                }
                l.flush();
                assert_eq!(matches!(l.open[&job], Log::Cached(_)), i >= fails_at);
                let path = dir.join(format!("{job}.log"));
                let size = std::fs::metadata(&path).unwrap().len();
                let f = File::open(&path).unwrap();
                let Ok(Found::Records { records, .. }) =
                    records::read(&mut BufReader::new(&f), MAGIC, size)
                else {
                    panic!("not read")
                };
                assert_eq!(records.len(), expect.len(), "each record once: job {job}, batch {i}");
                assert_eq!(l.read(job), expect, "job {job}, batch {i}");
            }
        }
    }

    #[test]
    fn ended_jobs_lose_their_logs_and_strays_are_swept() {
        let tmp = scratch("swept");
        let dir = tmp.path();
        let mut l = logs(dir);
        for job in [1, 2, 3] {
            l.append(job, 0, &[b"x"]);
        }
        l.flush();
        l.remove(2);
        assert!(!dir.join("2.log").exists());
        l.remove_all_but(&[3]);
        assert!(!dir.join("1.log").exists());
        assert_eq!(l.read(3).len(), 1);
        // In memory, nothing is kept and nothing fails.
        let mut m = TileLogs::open(None).unwrap();
        m.append(1, 0, &[b"x"]);
        m.flush();
        assert!(m.read(1).is_empty());
    }
}
