//! The coordinator's content-addressed store of scene manifests and assets.

use crate::error::{Error, Result};
use farm_proto::convert::{BlobAssembler, Hash};
use farm_proto::v1::BlobChunk;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Blobs by blake3 hash; shared by the service handlers.
#[derive(Clone, Default)]
pub struct BlobStore {
    inner: Arc<Mutex<HashMap<Hash, Arc<Vec<u8>>>>>,
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
    pub fn assemble(&self, chunks: &[BlobChunk]) -> Result<(Hash, usize)> {
        let mut a = BlobAssembler::new(MAX_BLOB_SIZE);
        for c in chunks {
            a.push(c)?;
        }
        let (hash, data) = a.finish()?;
        let hash: Hash = hash.as_slice().try_into().map_err(|_| Error::HashMismatch)?;
        if blake3::hash(&data).as_bytes() != &hash {
            return Err(Error::HashMismatch);
        }
        let n = data.len();
        self.put(hash, Arc::new(data));
        Ok((hash, n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_proto::convert::blob_chunks;
    use farm_proto::BLOB_CHUNK_SIZE;

    #[test]
    fn uploads_round_trip_and_corruption_is_refused() {
        let data: Vec<u8> = (0..3 * BLOB_CHUNK_SIZE as u32 / 2).map(|i| (i % 251) as u8).collect();
        let hash: Hash = blake3::hash(&data).into();
        let store = BlobStore::default();
        let parts = blob_chunks(&hash, &data);
        assert_eq!(parts.len(), 2);
        assert_eq!(store.assemble(&parts).unwrap(), (hash, data.len()));
        assert_eq!(store.get(&hash).as_deref(), Some(&data));
        let mut bad = parts.clone();
        bad[1].data[0] ^= 1;
        assert!(matches!(BlobStore::default().assemble(&bad), Err(Error::HashMismatch)));
        assert!(matches!(BlobStore::default().assemble(&parts[..1]), Err(Error::Chunks(_))));
    }
}
