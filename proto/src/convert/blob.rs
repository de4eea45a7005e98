//! Blobs on the wire: split into `BlobChunk`s below the message limit, and
//! put back together with every chunk checked against the first.

use crate::error::Error;
use crate::v1::BlobChunk;
use crate::BLOB_CHUNK_SIZE;

/// The chunks of a blob, in order (one empty chunk for an empty blob).
pub fn blob_chunks(hash: &[u8], data: &[u8]) -> Vec<BlobChunk> {
    let total = data.len() as u64;
    if data.is_empty() {
        return vec![BlobChunk { hash: hash.to_vec(), total_size: 0, offset: 0, data: Vec::new() }];
    }
    data.chunks(BLOB_CHUNK_SIZE)
        .enumerate()
        .map(|(i, c)| BlobChunk {
            hash: hash.to_vec(),
            total_size: total,
            offset: (i * BLOB_CHUNK_SIZE) as u64,
            data: c.to_vec(),
        })
        .collect()
}

/// The checks every chunk of one upload must pass, whatever is done with
/// its bytes: the same hash and total size as the first chunk, offsets in
/// order with no gap, no more bytes than declared, and a declared size
/// under the limit (known from the first chunk, before any byte is kept).
#[derive(Debug)]
pub struct ChunkSequence {
    max_size: u64,
    first: Option<(Vec<u8>, u64)>,
    received: u64,
}

impl ChunkSequence {
    /// A sequence refusing blobs over `max_size` bytes.
    pub fn new(max_size: u64) -> Self {
        ChunkSequence { max_size, first: None, received: 0 }
    }

    /// Checks the next chunk; on success its bytes are counted as received.
    pub fn check(&mut self, c: &BlobChunk) -> Result<(), Error> {
        match &self.first {
            None => {
                if c.total_size > self.max_size {
                    return Err(Error::TooLarge(c.total_size, self.max_size));
                }
                self.first = Some((c.hash.clone(), c.total_size));
            }
            Some((hash, _)) if *hash != c.hash => return Err(Error::OtherBlob),
            Some((_, total)) if *total != c.total_size => return Err(Error::SizeChanged),
            Some(_) => {}
        }
        if c.offset != self.received {
            return Err(Error::OutOfOrder { got: c.offset, want: self.received });
        }
        let received = self.received + c.data.len() as u64;
        if received > c.total_size {
            return Err(Error::TooMany);
        }
        self.received = received;
        Ok(())
    }

    /// The declared hash and size, once the first chunk is in.
    pub fn declared(&self) -> Option<(&[u8], u64)> {
        self.first.as_ref().map(|(h, t)| (h.as_slice(), *t))
    }

    /// The hash every chunk named and the size, if every byte arrived.
    pub fn finish(self) -> Result<(Vec<u8>, u64), Error> {
        let (hash, total) = self.first.ok_or(Error::Empty)?;
        if self.received != total {
            return Err(Error::Incomplete { got: self.received, want: total });
        }
        Ok((hash, total))
    }
}

/// Reassembles chunks that must arrive in order. Checking the bytes against
/// the hash is the caller's job.
#[derive(Debug)]
pub struct BlobAssembler {
    seq: ChunkSequence,
    data: Vec<u8>,
}

impl BlobAssembler {
    /// An assembler refusing blobs over `max_size` bytes.
    pub fn new(max_size: u64) -> Self {
        BlobAssembler { seq: ChunkSequence::new(max_size), data: Vec::new() }
    }

    /// Adds the next chunk.
    pub fn push(&mut self, c: &BlobChunk) -> Result<(), Error> {
        let first = self.seq.declared().is_none();
        self.seq.check(c)?;
        if first {
            self.data.reserve(c.total_size.min(1 << 28) as usize);
        }
        self.data.extend_from_slice(&c.data);
        Ok(())
    }

    /// The hash every chunk named and the whole blob.
    pub fn finish(self) -> Result<(Vec<u8>, Vec<u8>), Error> {
        let (hash, _) = self.seq.finish()?;
        Ok((hash, self.data))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assemble(chunks: &[BlobChunk]) -> Result<(Vec<u8>, Vec<u8>), Error> {
        let mut a = BlobAssembler::new(u64::MAX);
        for c in chunks {
            a.push(c)?;
        }
        a.finish()
    }

    #[test]
    fn chunks_reassemble_and_disorder_is_refused() {
        let data: Vec<u8> = (0..5 * BLOB_CHUNK_SIZE / 2).map(|i| (i % 253) as u8).collect();
        let parts = blob_chunks(b"h", &data);
        assert_eq!(parts.len(), 3);
        assert_eq!(assemble(&parts), Ok((b"h".to_vec(), data)));
        assert_eq!(assemble(&blob_chunks(b"e", &[])), Ok((b"e".to_vec(), Vec::new())));
        assert_eq!(
            assemble(&[parts[0].clone(), parts[2].clone()]),
            Err(Error::OutOfOrder {
                got: 2 * BLOB_CHUNK_SIZE as u64,
                want: BLOB_CHUNK_SIZE as u64
            })
        );
        assert!(matches!(assemble(&parts[..2]), Err(Error::Incomplete { .. })));
        assert_eq!(assemble(&[]), Err(Error::Empty));
        let mut other = parts[1].clone();
        other.hash = b"x".to_vec();
        assert_eq!(assemble(&[parts[0].clone(), other]), Err(Error::OtherBlob));
        let mut a = BlobAssembler::new(10);
        assert_eq!(a.push(&parts[0]), Err(Error::TooLarge(data_len(&parts), 10)));
    }

    fn data_len(parts: &[BlobChunk]) -> u64 {
        parts[0].total_size
    }
}
