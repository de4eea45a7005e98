//! Writing a new file past the page cache (`O_DIRECT`, Linux), for the
//! journal's finished images and tile logs.
//!
//! Both are read again only after a restart, so the OS's copy of them
//! buys nothing, and making it was most of the journal thread's CPU: the
//! kernel copying every byte into fresh page-cache pages (a 2048² job
//! writes 134 MB of tiles and a 66 MB image), then freeing them when the
//! job's files were deleted, and the cache held them in place of what is
//! read again. Written past the cache, the bytes go from an aligned
//! buffer to the disk:
//! - images: the capacity bench's coordinator spent about 32 ms less a
//!   job on its journal thread (perf samples, 1,110 and 1,006 → 902 and
//!   838 over six jobs), for about 12 ms more wall time to the ending's
//!   commit (`cargo bench -p farm-coordinator --bench journal`: 51–57 →
//!   66–71 ms);
//! - tile logs: about 44 ms less a job on that thread (`tiles.rs`).
//!
//! The OS wants such writes aligned to the disk's blocks: in address,
//! length and offset. [`Direct`] gathers the bytes in an aligned buffer
//! and writes it whole, the last partial block padded with zeros. An
//! image is then cut back to the bytes given and synced; a tile log,
//! written out at every batch, writes its last partial block again with
//! the next batch. Where the OS or the file system refuses (a file system
//! without `O_DIRECT`, other systems), [`Direct::with_chunk`] or a write
//! fails and the caller writes through the cache instead.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

/// Alignment of address, length and offset that every Linux block device
/// accepts (a multiple of 512-byte and 4 KB sectors alike).
pub(super) const ALIGN: usize = 4096;
/// Bytes an image writes at once: enough that the disk is kept busy.
const CHUNK: usize = 4 << 20;

/// A new file written past the page cache.
pub(super) struct Direct {
    file: File,
    /// `chunk + ALIGN` bytes, of which `start..start + chunk` is aligned.
    buf: Vec<u8>,
    start: usize,
    chunk: usize,
    /// Bytes of the chunk filled: the file's bytes from `written` on.
    len: usize,
    /// Bytes of the file before the chunk's (a multiple of [`ALIGN`]).
    written: u64,
    /// Whether bytes were given since the chunk was last written: a log
    /// with nothing new is not written out again.
    fresh: bool,
}

impl Direct {
    /// Creates (or empties) `path` to write past the page cache; an error
    /// where the OS or the file system does not allow it.
    pub fn create(path: &Path) -> io::Result<Direct> {
        Self::with_chunk(path, CHUNK)
    }

    /// As [`Direct::create`], writing at most `chunk` bytes at once (a
    /// multiple of [`ALIGN`]).
    pub fn with_chunk(path: &Path, chunk: usize) -> io::Result<Direct> {
        debug_assert!(chunk > 0 && chunk.is_multiple_of(ALIGN));
        #[cfg(target_os = "linux")]
        {
            use std::os::unix::fs::OpenOptionsExt;
            let file = File::options()
                .write(true)
                .create(true)
                .truncate(true)
                .custom_flags(libc::O_DIRECT)
                .open(path)?;
            let buf = vec![0u8; chunk + ALIGN];
            let start = buf.as_ptr().align_offset(ALIGN);
            Ok(Direct { file, buf, start, chunk, len: 0, written: 0, fresh: false })
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = path;
            Err(io::Error::new(io::ErrorKind::Unsupported, "no O_DIRECT here"))
        }
    }

    /// Writes the chunk's first `len` bytes, padded with zeros to a whole
    /// block, at `written`; then keeps the last partial block (if any) at
    /// the chunk's start, to be written again, whole, with what follows it.
    fn write_chunk(&mut self) -> io::Result<()> {
        let padded = self.len.next_multiple_of(ALIGN);
        self.buf[self.start + self.len..self.start + padded].fill(0);
        self.file.seek(SeekFrom::Start(self.written))?;
        self.file.write_all(&self.buf[self.start..self.start + padded])?;
        let whole = self.len / ALIGN * ALIGN;
        self.buf.copy_within(self.start + whole..self.start + self.len, self.start);
        self.written += whole as u64;
        self.len -= whole;
        self.fresh = false;
        Ok(())
    }

    /// Hands every byte given so far to the disk. The file then holds them
    /// and fewer than [`ALIGN`] zeros after them, which the next bytes
    /// given overwrite: a reader must take zeros past its last record for
    /// the end. The bytes already written are written again only in the
    /// last, partial block, with the same values, so a write torn by a
    /// crash cannot damage them.
    pub fn write_out(&mut self) -> io::Result<()> {
        if !self.fresh {
            return Ok(());
        }
        self.write_chunk()
    }

    /// Writes what is left, cuts the file to the bytes given and syncs
    /// its data (and so its length) to the disk.
    pub fn finish(mut self) -> io::Result<()> {
        let total = self.written + self.len as u64;
        self.write_out()?;
        self.file.set_len(total)?;
        self.file.sync_data()
    }

    /// Syncs what was written out to the disk, with the file's length.
    pub fn sync_data(&self) -> io::Result<()> {
        self.file.sync_data()
    }

    /// For a writer through the cache to take over: the length of the
    /// file's bytes that are surely written (what follows may be partly
    /// written, or zeros), and the bytes given after them, to cut the file
    /// at the one and append the other.
    pub fn unwritten(&self) -> (u64, &[u8]) {
        (self.written, &self.buf[self.start..self.start + self.len])
    }
}

#[cfg(test)]
impl Direct {
    /// Writes from now on to `file` instead (a test's failing writes).
    pub fn replace_file(&mut self, file: File) {
        self.file = file;
    }
}

impl Write for Direct {
    /// Writes a full chunk first, so that an error takes none of `data`.
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        if self.len == self.chunk {
            self.write_chunk()?;
        }
        let n = data.len().min(self.chunk - self.len);
        let at = self.start + self.len;
        self.buf[at..at + n].copy_from_slice(&data[..n]);
        self.len += n;
        self.fresh |= n > 0;
        Ok(n)
    }

    /// Nothing: [`Direct::write_out`] and [`Direct::finish`] write the
    /// last, partial chunk.
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Files of lengths on and off the alignment and the chunk, written in
    /// uneven pieces, read back byte for byte at their own length.
    #[test]
    fn bytes_read_back_at_their_length_whatever_it_is() {
        let tmp = tempfile::Builder::new().prefix("farm-direct-").tempdir().unwrap();
        let path = tmp.path().join("f");
        match Direct::create(&path) {
            Ok(_) => {}
            Err(e) => {
                eprintln!("skipped: {} does not take O_DIRECT writes ({e})", tmp.path().display());
                return;
            }
        }
        for len in [0, 5, ALIGN, ALIGN + 1, CHUNK - 1, CHUNK, CHUNK + 1, 2 * CHUNK + ALIGN + 7] {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 31 % 251) as u8).collect();
            let mut w = Direct::create(&path).unwrap();
            for piece in bytes.chunks(ALIGN * 3 + 11) {
                w.write_all(piece).unwrap();
            }
            w.finish().unwrap();
            assert_eq!(std::fs::read(&path).unwrap(), bytes, "{len} bytes");
        }
    }

    /// Written out after pieces that end short of a block, on one, on a
    /// full chunk and past it: the file holds every byte given, then fewer
    /// than a block of zeros; and with nothing new it is not written at
    /// all (a read-only file would fail the write).
    #[test]
    fn written_out_piece_by_piece_the_file_holds_every_byte_then_zeros() {
        let tmp = tempfile::Builder::new().prefix("farm-direct-out-").tempdir().unwrap();
        let path = tmp.path().join("f");
        let chunk = 4 * ALIGN;
        let Ok(mut w) = Direct::with_chunk(&path, chunk) else {
            eprintln!("skipped: {} does not take O_DIRECT writes", tmp.path().display());
            return;
        };
        let mut given = Vec::new();
        for n in [ALIGN - 1, 1, ALIGN, chunk, chunk - 5, 5, chunk + 1, 0, 3 * chunk + 7] {
            let piece: Vec<u8> = (0..n).map(|i| (given.len() + i) as u8 | 1).collect();
            w.write_all(&piece).unwrap();
            given.extend(piece);
            w.write_out().unwrap();
            let file = std::fs::read(&path).unwrap();
            assert_eq!(file.len() % ALIGN, 0, "after {} bytes", given.len());
            assert!(file.len() - given.len() < ALIGN, "after {} bytes", given.len());
            assert_eq!(&file[..given.len()], &given[..]);
            assert!(file[given.len()..].iter().all(|&b| b == 0));
            let (surely, rest) = w.unwritten();
            assert_eq!(surely as usize + rest.len(), given.len());
            // Nothing new: nothing written, so a file that cannot be
            // written does not fail it.
            let writable = std::mem::replace(&mut w.file, File::open(&path).unwrap());
            w.write_out().unwrap();
            w.file = writable;
        }
        // Finished after a write-out that left a partial block: cut to
        // the bytes given.
        w.finish().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), given);
    }
}
