//! Blobs on the wire: split into `BlobChunk`s below the message limit, and
//! put back together with every chunk checked against the first.

use crate::v1::BlobChunk;
use crate::BLOB_CHUNK_SIZE;

/// Why a stream of chunks does not form a blob.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ChunkError {
    /// No chunk arrived.
    #[error("no chunk arrived")]
    Empty,
    /// A chunk names another blob.
    #[error("a chunk names another blob")]
    OtherBlob,
    /// Chunks disagree on the total size.
    #[error("chunks disagree on the total size")]
    SizeChanged,
    /// The declared size is over the limit.
    #[error("a blob of {0} bytes is over the {1}-byte limit")]
    TooLarge(u64, u64),
    /// A chunk is not where the previous one ended.
    #[error("chunk at offset {got} where {want} was expected")]
    OutOfOrder {
        /// Offset received.
        got: u64,
        /// Offset expected.
        want: u64,
    },
    /// More bytes than declared.
    #[error("more bytes than the total size")]
    TooMany,
    /// Fewer bytes than declared.
    #[error("{got} of {want} bytes arrived")]
    Incomplete {
        /// Bytes received.
        got: u64,
        /// Bytes declared.
        want: u64,
    },
}

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

/// Reassembles chunks that must arrive in order. Checking the bytes against
/// the hash is the caller's job.
#[derive(Debug)]
pub struct BlobAssembler {
    max_size: u64,
    first: Option<(Vec<u8>, u64)>,
    data: Vec<u8>,
}

impl BlobAssembler {
    /// An assembler refusing blobs over `max_size` bytes.
    pub fn new(max_size: u64) -> Self {
        BlobAssembler { max_size, first: None, data: Vec::new() }
    }

    /// Adds the next chunk.
    pub fn push(&mut self, c: &BlobChunk) -> Result<(), ChunkError> {
        match &self.first {
            None => {
                if c.total_size > self.max_size {
                    return Err(ChunkError::TooLarge(c.total_size, self.max_size));
                }
                self.data.reserve(c.total_size.min(1 << 28) as usize);
                self.first = Some((c.hash.clone(), c.total_size));
            }
            Some((hash, _)) if *hash != c.hash => return Err(ChunkError::OtherBlob),
            Some((_, total)) if *total != c.total_size => return Err(ChunkError::SizeChanged),
            Some(_) => {}
        }
        let want = self.data.len() as u64;
        if c.offset != want {
            return Err(ChunkError::OutOfOrder { got: c.offset, want });
        }
        self.data.extend_from_slice(&c.data);
        if self.data.len() as u64 > c.total_size {
            return Err(ChunkError::TooMany);
        }
        Ok(())
    }

    /// The hash every chunk named and the whole blob.
    pub fn finish(self) -> Result<(Vec<u8>, Vec<u8>), ChunkError> {
        let (hash, total) = self.first.ok_or(ChunkError::Empty)?;
        let got = self.data.len() as u64;
        if got != total {
            return Err(ChunkError::Incomplete { got, want: total });
        }
        Ok((hash, self.data))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assemble(chunks: &[BlobChunk]) -> Result<(Vec<u8>, Vec<u8>), ChunkError> {
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
            Err(ChunkError::OutOfOrder {
                got: 2 * BLOB_CHUNK_SIZE as u64,
                want: BLOB_CHUNK_SIZE as u64
            })
        );
        assert!(matches!(assemble(&parts[..2]), Err(ChunkError::Incomplete { .. })));
        assert_eq!(assemble(&[]), Err(ChunkError::Empty));
        let mut other = parts[1].clone();
        other.hash = b"x".to_vec();
        assert_eq!(assemble(&[parts[0].clone(), other]), Err(ChunkError::OtherBlob));
        let mut a = BlobAssembler::new(10);
        assert_eq!(a.push(&parts[0]), Err(ChunkError::TooLarge(data_len(&parts), 10)));
    }

    fn data_len(parts: &[BlobChunk]) -> u64 {
        parts[0].total_size
    }
}
