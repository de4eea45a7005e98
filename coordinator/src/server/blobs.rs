//! The coordinator's content-addressed store of scene manifests and assets.

use farm_proto::convert::Hash;
use farm_proto::v1::BlobChunk;
use farm_proto::BLOB_CHUNK_SIZE;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Blobs by blake3 hash; shared by the service handlers.
#[derive(Clone, Default)]
pub struct BlobStore {
    inner: Arc<Mutex<HashMap<Hash, Arc<Vec<u8>>>>>,
}

/// Why an upload was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum UploadError {
    /// Nothing was sent.
    #[error("empty upload")]
    Empty,
    /// Chunks disagree on the hash or size, or arrive out of order.
    #[error("chunks are inconsistent: {0}")]
    Inconsistent(&'static str),
    /// The declared size exceeds the limit.
    #[error("blob of {0} bytes exceeds the {1}-byte limit")]
    TooLarge(u64, u64),
    /// The bytes do not hash to the declared hash.
    #[error("the data does not match its hash")]
    HashMismatch,
}

/// Largest blob accepted (4 GiB).
pub const MAX_BLOB_SIZE: u64 = 4 << 30;

impl BlobStore {
    /// The blob with this hash, if stored.
    pub fn get(&self, hash: &[u8]) -> Option<Arc<Vec<u8>>> {
        let h: Hash = hash.try_into().ok()?;
        self.inner.lock().ok()?.get(&h).cloned()
    }

    /// Stores bytes under their hash.
    pub fn put(&self, hash: Hash, data: Arc<Vec<u8>>) {
        if let Ok(mut m) = self.inner.lock() {
            m.insert(hash, data);
        }
    }

    /// Reassembles uploaded chunks, checks the hash and stores the blob.
    pub fn assemble(&self, chunks: &[BlobChunk]) -> Result<(Hash, usize), UploadError> {
        let first = chunks.first().ok_or(UploadError::Empty)?;
        let hash: Hash = first
            .hash
            .as_slice()
            .try_into()
            .map_err(|_| UploadError::Inconsistent("hash is not 32 bytes"))?;
        let total = first.total_size;
        if total > MAX_BLOB_SIZE {
            return Err(UploadError::TooLarge(total, MAX_BLOB_SIZE));
        }
        let mut data = Vec::with_capacity(total as usize);
        for c in chunks {
            if c.hash != first.hash || c.total_size != total {
                return Err(UploadError::Inconsistent("hash or size changes between chunks"));
            }
            if c.offset != data.len() as u64 {
                return Err(UploadError::Inconsistent("chunk offsets are not contiguous"));
            }
            data.extend_from_slice(&c.data);
            if data.len() as u64 > total {
                return Err(UploadError::Inconsistent("more bytes than declared"));
            }
        }
        if data.len() as u64 != total {
            return Err(UploadError::Inconsistent("fewer bytes than declared"));
        }
        if blake3::hash(&data).as_bytes() != &hash {
            return Err(UploadError::HashMismatch);
        }
        let n = data.len();
        self.put(hash, Arc::new(data));
        Ok((hash, n))
    }
}

/// The chunks of a blob, for streaming.
pub fn chunks(hash: &[u8], data: &[u8]) -> Vec<BlobChunk> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uploads_round_trip_and_corruption_is_refused() {
        let data: Vec<u8> = (0..3 * BLOB_CHUNK_SIZE as u32 / 2).map(|i| (i % 251) as u8).collect();
        let hash: Hash = blake3::hash(&data).into();
        let store = BlobStore::default();
        let parts = chunks(&hash, &data);
        assert_eq!(parts.len(), 2);
        assert_eq!(store.assemble(&parts), Ok((hash, data.len())));
        assert_eq!(store.get(&hash).as_deref(), Some(&data));
        let mut bad = parts.clone();
        bad[1].data[0] ^= 1;
        assert_eq!(BlobStore::default().assemble(&bad), Err(UploadError::HashMismatch));
        assert!(matches!(
            BlobStore::default().assemble(&parts[..1]),
            Err(UploadError::Inconsistent(_))
        ));
    }
}
