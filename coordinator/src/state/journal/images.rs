//! Finished jobs' images, one file per job beside the database rather
//! than rows of it.
//!
//! An image is the bulk of what a job leaves (66 MB of events for a
//! 2048² film). As rows it went through the WAL, was checksummed there,
//! written again at checkpoint, and its pages stayed in the database file
//! as free pages once the job was purged: about 90 ms of the coordinator's
//! CPU for a 2048² job, a fifth of the job's own cost (`cargo bench -p
//! farm-tests --bench farm`, capacity table). As a file it is written
//! once and purged with one unlink.
//!
//! A file is `FARMIMG1` then one record ([`super::records`]) per event,
//! its key the event's place. It is written past the page cache where the
//! OS allows it ([`super::direct`]), whole and synced, with its
//! directory, before the commit that ends its job: a job the database
//! calls done has its image on disk, as when the rows shared its commit.
//! A file whose job is not (yet) done in the database is a leftover of a
//! crash before that commit, swept when the journal opens.
//!
//! Without a directory (an in-memory journal) images are held in memory.
//! Jobs that ended before images had files keep their rows, which are
//! still read.

use super::direct::Direct;
use super::records::{self, Found};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use tracing::{debug, error, warn};

const MAGIC: &[u8; 8] = b"FARMIMG1";

/// Where finished images are kept.
pub(super) enum Images {
    /// One file per job in this directory.
    Files(PathBuf),
    /// In memory, each job's encoded events.
    Memory(HashMap<u64, Vec<Vec<u8>>>),
}

impl Images {
    /// Images in `dir`, created if missing; in memory without one.
    pub fn open(dir: Option<PathBuf>) -> std::io::Result<Images> {
        match dir {
            Some(d) => {
                if !d.is_dir() {
                    std::fs::create_dir_all(&d)?;
                    // Its name must outlive a power cut, as its files' do.
                    #[cfg(unix)]
                    if let Some(parent) = d.parent().filter(|p| !p.as_os_str().is_empty()) {
                        File::open(parent)?.sync_all()?;
                    }
                }
                Ok(Images::Files(d))
            }
            None => Ok(Images::Memory(HashMap::new())),
        }
    }

    fn path(dir: &Path, job: u64) -> PathBuf {
        dir.join(format!("{job}.img"))
    }

    /// Stores `job`'s image as `events`, each encoded by `encode` into the
    /// buffer it is given; on disk and synced when this returns `Ok`, and
    /// no file left when it returns an error (the caller keeps the image
    /// another way, and a file cut short would hide it).
    pub fn store<E>(
        &mut self,
        job: u64,
        events: &[E],
        encode: impl Fn(&E, &mut Vec<u8>),
    ) -> std::io::Result<()> {
        let dir = match self {
            Images::Memory(m) => {
                let encoded = events
                    .iter()
                    .map(|e| {
                        let mut buf = Vec::new();
                        encode(e, &mut buf);
                        buf
                    })
                    .collect();
                m.insert(job, encoded);
                return Ok(());
            }
            Images::Files(dir) => dir,
        };
        let path = Self::path(dir, job);
        // Past the page cache where the OS allows it (`direct.rs`), else
        // through it; synced either way.
        let direct = || {
            let mut w = Direct::create(&path)?;
            let written = write_events(&mut w, events, &encode).and_then(|()| w.finish());
            // Opened but not written: a disk error or a file system that
            // takes the flag and not the writes; worth a look either way.
            if let Err(e) = &written {
                warn!(job, error = %e, "cannot write the image past the page cache");
            }
            written
        };
        let cached = || {
            let mut w = BufWriter::with_capacity(1 << 20, File::create(&path)?);
            write_events(&mut w, events, &encode)?;
            w.into_inner().map_err(|e| e.into_error())?.sync_data()
        };
        let written = direct()
            .or_else(|e| {
                debug!(job, error = %e, "the image is written through the page cache");
                cached()
            })
            .and_then(|()| {
                // The file's name must outlive a power cut as well as its
                // bytes (a folder is synced through a handle on Unix only).
                #[cfg(unix)]
                File::open(&*dir)?.sync_all()?;
                Ok(())
            });
        if written.is_err() {
            let _ = std::fs::remove_file(&path);
        }
        written
    }

    /// `job`'s image events, or `None` when no image of it is kept here, or
    /// its file cannot be read or is cut short or corrupt (logged as an
    /// error): the caller then looks for rows, and without them the image
    /// is lost.
    pub fn read(&self, job: u64) -> Option<Vec<Vec<u8>>> {
        let dir = match self {
            Images::Memory(m) => return m.get(&job).cloned(),
            Images::Files(dir) => dir,
        };
        let path = Self::path(dir, job);
        let read = File::open(&path).and_then(|f| {
            let size = f.metadata()?.len();
            records::read(&mut BufReader::with_capacity(1 << 20, f), MAGIC, size)
        });
        match read {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Ok(Found::Records { records, complete: true, .. })
                if records.iter().enumerate().all(|(i, (k, _))| *k as usize == i) =>
            {
                Some(records.into_iter().map(|(_, bytes)| bytes).collect())
            }
            Ok(_) => {
                error!(job, path = %path.display(), "a stored image is cut short or corrupt");
                None
            }
            Err(e) => {
                error!(job, path = %path.display(), error = %e, "cannot read a stored image");
                None
            }
        }
    }

    /// Forgets `job`'s image (purged).
    pub fn remove(&mut self, job: u64) {
        let dir = match self {
            Images::Memory(m) => {
                m.remove(&job);
                return;
            }
            Images::Files(dir) => dir,
        };
        match std::fs::remove_file(Self::path(dir, job)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                warn!(job, error = %e, "cannot delete a purged job's image")
            }
            _ => {}
        }
    }

    /// Deletes the files of jobs not in `ended` (stored just before a
    /// crash that kept their ending from being committed).
    pub fn remove_all_but(&mut self, ended: &[u64]) {
        let Images::Files(dir) = self else { return };
        let ended: std::collections::HashSet<u64> = ended.iter().copied().collect();
        let Ok(entries) = std::fs::read_dir(&*dir) else { return };
        let strays: Vec<u64> = entries
            .flatten()
            .filter_map(|e| e.file_name().to_str()?.strip_suffix(".img")?.parse().ok())
            .filter(|j| !ended.contains(j))
            .collect();
        for job in strays {
            self.remove(job);
        }
    }
}

/// The file's bytes: the magic, then `events` as records in order.
fn write_events<E>(
    w: &mut impl Write,
    events: &[E],
    encode: &impl Fn(&E, &mut Vec<u8>),
) -> std::io::Result<()> {
    w.write_all(MAGIC)?;
    let mut buf = Vec::new();
    for (seq, e) in events.iter().enumerate() {
        buf.clear();
        encode(e, &mut buf);
        records::write(w, seq as u32, &buf)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode(e: &&[u8], buf: &mut Vec<u8>) {
        buf.extend_from_slice(e);
    }

    #[test]
    fn images_read_back_whole_and_a_damaged_one_is_lost_not_misread() {
        let tmp = tempfile::Builder::new().prefix("farm-images-").tempdir().unwrap();
        let dir = tmp.path().join("farm.images");
        let events: [&[u8]; 3] = [b"head", &[7; 5000], b""];
        let want: Vec<Vec<u8>> = events.iter().map(|e| e.to_vec()).collect();
        let mut files = Images::open(Some(dir.clone())).unwrap();
        let mut memory = Images::open(None).unwrap();
        for images in [&mut files, &mut memory] {
            images.store(4, &events, encode).unwrap();
            images.store(5, &events[..1], encode).unwrap();
            assert_eq!(images.read(4), Some(want.clone()));
            assert_eq!(images.read(6), None, "no image: the caller looks for rows");
            images.remove(4);
            assert_eq!(images.read(4), None);
            assert_eq!(images.read(5), Some(want[..1].to_vec()));
        }
        files.store(4, &events, encode).unwrap();
        let path = dir.join("4.img");
        let bytes = std::fs::read(&path).unwrap();
        // Cut short, or a bit flipped in the second event (the last byte
        // before the empty third's 12): not an image, not partly read
        // (the caller then looks for rows).
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        assert_eq!(files.read(4), None);
        let mut flipped = bytes.clone();
        flipped[bytes.len() - 13] ^= 1;
        std::fs::write(&path, &flipped).unwrap();
        assert_eq!(files.read(4), None);
        std::fs::write(&path, b"FARMTLG1").unwrap();
        assert_eq!(files.read(4), None);
        // Records out of order are not an image this writer wrote.
        let mut swapped = MAGIC.to_vec();
        records::write(&mut swapped, 1, b"b").unwrap();
        records::write(&mut swapped, 0, b"a").unwrap();
        std::fs::write(&path, &swapped).unwrap();
        assert_eq!(files.read(4), None);
        // Strays (a job whose ending never committed) are swept.
        files.remove_all_but(&[5]);
        assert!(!path.exists());
        assert_eq!(files.read(5), Some(want[..1].to_vec()));
    }
}
