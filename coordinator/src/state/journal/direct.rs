//! Writing a new file past the page cache (`O_DIRECT`, Linux), for the
//! journal's finished images.
//!
//! An image is synced to the disk as soon as it is written, and read again
//! only when a watcher asks for it after a restart, so the OS's copy of it
//! buys nothing. Copying 66 MB (a 2048² job's image) into fresh page-cache
//! pages was most of the journal's CPU for a job's ending: new memory
//! each time, and 66 MB of the cache taken from what is read again.
//! Written past the cache, the bytes go from one 4 MiB buffer to the
//! disk: the capacity bench's coordinator spent about 32 ms less a job on
//! its journal thread (perf samples, 1,110 and 1,006 → 902 and 838 over
//! six jobs), for about 12 ms more wall time to the ending's commit
//! (`cargo bench -p farm-coordinator --bench journal`: 51–57 → 66–71 ms).
//!
//! The OS wants such writes aligned to the disk's blocks: in address,
//! length and offset. [`Direct`] gathers the bytes in an aligned buffer,
//! writes it whole, pads the last piece with zeros and cuts the file back
//! to the bytes given before syncing it. Where the OS or the file system
//! refuses (a file system without `O_DIRECT`, other systems),
//! [`Direct::create`] or a write fails and the caller writes through the
//! cache instead.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

/// Alignment of address, length and offset that every Linux block device
/// accepts (a multiple of 512-byte and 4 KB sectors alike).
const ALIGN: usize = 4096;
/// Bytes written at once: enough that the disk is kept busy.
const CHUNK: usize = 4 << 20;

/// A new file written past the page cache.
pub(super) struct Direct {
    file: File,
    /// `CHUNK + ALIGN` bytes, of which `start..start + CHUNK` is aligned.
    buf: Vec<u8>,
    start: usize,
    /// Bytes of the chunk filled.
    len: usize,
    /// Bytes written to the file.
    written: u64,
}

impl Direct {
    /// Creates (or empties) `path` to write past the page cache; an error
    /// where the OS or the file system does not allow it.
    pub fn create(path: &Path) -> io::Result<Direct> {
        #[cfg(target_os = "linux")]
        {
            use std::os::unix::fs::OpenOptionsExt;
            let file = File::options()
                .write(true)
                .create(true)
                .truncate(true)
                .custom_flags(libc::O_DIRECT)
                .open(path)?;
            let buf = vec![0u8; CHUNK + ALIGN];
            let start = buf.as_ptr().align_offset(ALIGN);
            Ok(Direct { file, buf, start, len: 0, written: 0 })
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = path;
            Err(io::Error::new(io::ErrorKind::Unsupported, "no O_DIRECT here"))
        }
    }

    /// Writes the chunk's first `n` bytes (a multiple of [`ALIGN`]).
    fn write_chunk(&mut self, n: usize) -> io::Result<()> {
        self.file.write_all(&self.buf[self.start..self.start + n])?;
        self.written += n as u64;
        self.len = 0;
        Ok(())
    }

    /// Writes what is left, cuts the file to the bytes given and syncs
    /// its data (and so its length) to the disk.
    pub fn finish(mut self) -> io::Result<()> {
        let total = self.written + self.len as u64;
        let padded = self.len.next_multiple_of(ALIGN);
        let from = self.start + self.len;
        self.buf[from..self.start + padded].fill(0);
        if padded > 0 {
            self.write_chunk(padded)?;
        }
        self.file.set_len(total)?;
        self.file.sync_data()
    }
}

impl Write for Direct {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        let n = data.len().min(CHUNK - self.len);
        let at = self.start + self.len;
        self.buf[at..at + n].copy_from_slice(&data[..n]);
        self.len += n;
        if self.len == CHUNK {
            self.write_chunk(CHUNK)?;
        }
        Ok(n)
    }

    /// Nothing: [`Direct::finish`] writes the last, partial chunk.
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
}
