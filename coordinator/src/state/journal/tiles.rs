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

use super::records::{self, Found};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tracing::{error, warn};

const MAGIC: &[u8; 8] = b"FARMTLG1";
/// How often written logs are synced to the disk.
const SYNC_EVERY: Duration = Duration::from_secs(1);

/// The logs of the active jobs, in `dir` (none kept without one).
pub(super) struct TileLogs {
    dir: Option<PathBuf>,
    open: HashMap<u64, BufWriter<File>>,
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

    /// Appends tile `key` of `job` (buffered until [`TileLogs::flush`]).
    pub fn append(&mut self, job: u64, key: u32, data: &[u8]) {
        let Some(dir) = &self.dir else { return };
        let w = match self.open.entry(job) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(v) => {
                match open_for_append(&Self::path(dir, job)) {
                    Ok(f) => v.insert(BufWriter::with_capacity(256 << 10, f)),
                    Err(e) => {
                        error!(job, error = %e, "cannot open the job's tile log: its tiles are not durable");
                        return;
                    }
                }
            }
        };
        let written = records::write(w, key, data);
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
            if let Err(e) = w.flush() {
                error!(job, error = %e, "cannot write the job's tile log: its last tiles are not durable");
            }
        }
        if self.unsynced.is_empty() || self.synced_at.elapsed() < SYNC_EVERY {
            return;
        }
        for job in self.unsynced.drain(..) {
            if let Some(w) = self.open.get(&job) {
                if let Err(e) = w.get_ref().sync_data() {
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
        warn!(
            path = %path.display(),
            bytes = size - end,
            "a tile log ends in an incomplete record (the process died writing it): cut off"
        );
        f.set_len(end)?;
    }
    Ok(records.into_iter().collect())
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
        l.append(7, 3, b"three");
        l.append(7, 1, b"one");
        l.append(8, 1, b"other job");
        l.append(7, 3, b"three again");
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
        l.append(1, 0, &[5; 100]);
        l.append(1, 1, &[6; 100]);
        l.flush();
        drop(l);
        let path = dir.join("1.log");
        let full = std::fs::read(&path).unwrap();
        // Died halfway through the second record.
        std::fs::write(&path, &full[..full.len() - 50]).unwrap();
        let mut l = logs(dir);
        assert_eq!(l.read(1).keys().copied().collect::<Vec<_>>(), [0]);
        l.append(1, 2, &[7; 10]);
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

    #[test]
    fn ended_jobs_lose_their_logs_and_strays_are_swept() {
        let tmp = scratch("swept");
        let dir = tmp.path();
        let mut l = logs(dir);
        for job in [1, 2, 3] {
            l.append(job, 0, b"x");
        }
        l.flush();
        l.remove(2);
        assert!(!dir.join("2.log").exists());
        l.remove_all_but(&[3]);
        assert!(!dir.join("1.log").exists());
        assert_eq!(l.read(3).len(), 1);
        // In memory, nothing is kept and nothing fails.
        let mut m = TileLogs::open(None).unwrap();
        m.append(1, 0, b"x");
        m.flush();
        assert!(m.read(1).is_empty());
    }
}
