//! Content-addressed blobs (scene manifests and assets) held in memory and
//! fetched from the coordinator with `FetchBlob`. Every blob is checked
//! against its blake3 hash before it is kept, and concurrent requests for
//! one blob share a single fetch.

use crate::error::Error;
use farm_proto::connect::Client;
use farm_proto::convert::{BlobAssembler, Hash};
use farm_proto::v1::FetchBlobRequest;
use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use tokio::sync::OnceCell;

/// Bytes of blobs a worker keeps by default.
pub const DEFAULT_BLOB_CACHE_BYTES: usize = 1 << 30;

/// Hex form of a hash, for messages.
pub fn hex(hash: &Hash) -> String {
    blake3::Hash::from(*hash).to_hex().to_string()
}

/// Checks `data` against `hash`.
pub fn verify(hash: &Hash, data: &[u8]) -> Result<(), Error> {
    let got = blake3::hash(data);
    if got.as_bytes() == hash {
        Ok(())
    } else {
        Err(Error::BlobHashMismatch { expected: hex(hash), got: got.to_hex().to_string() })
    }
}

/// Somewhere blobs come from: the coordinator, or a map in tests.
pub trait BlobSource: Clone + Send + Sync + 'static {
    /// The whole blob named by `hash` (not yet verified).
    fn fetch(&self, hash: Hash) -> impl Future<Output = Result<Vec<u8>, Error>> + Send;
}

impl BlobSource for Client {
    async fn fetch(&self, hash: Hash) -> Result<Vec<u8>, Error> {
        let status = |status| Error::BlobStatus { hash: hex(&hash), status };
        let malformed = |reason: String| Error::BlobMalformed { hash: hex(&hash), reason };
        let request = FetchBlobRequest { hash: hash.to_vec() };
        let mut stream = self.clone().fetch_blob(request).await.map_err(status)?.into_inner();
        // Reassemble the chunks, which must arrive in order.
        let mut assembler = BlobAssembler::new(u64::MAX);
        while let Some(chunk) = stream.message().await.map_err(status)? {
            assembler.push(&chunk).map_err(|e| malformed(e.to_string()))?;
        }
        let (named, data) = match assembler.finish() {
            Err(farm_proto::Error::Empty) => return Ok(Vec::new()),
            r => r.map_err(|e| malformed(e.to_string()))?,
        };
        if named != hash {
            return Err(malformed("a chunk names another blob".into()));
        }
        Ok(data)
    }
}

/// One cached blob, or a fetch in progress.
#[derive(Debug)]
struct Slot {
    cell: Arc<OnceCell<Arc<Vec<u8>>>>,
    last_used: u64,
}

#[derive(Debug, Default)]
struct State {
    slots: HashMap<Hash, Slot>,
    tick: u64,
}

/// Verified blobs by hash, least recently used dropped beyond a byte budget.
#[derive(Debug)]
pub struct BlobCache {
    max_bytes: usize,
    state: Mutex<State>,
}

impl Default for BlobCache {
    fn default() -> Self {
        BlobCache::new(DEFAULT_BLOB_CACHE_BYTES)
    }
}

impl BlobCache {
    /// An empty cache keeping at most `max_bytes` (the newest blob is kept
    /// whatever its size).
    pub fn new(max_bytes: usize) -> Self {
        BlobCache { max_bytes, state: Mutex::new(State::default()) }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The slot for `hash`, created if needed, marked as just used.
    fn slot(&self, hash: Hash) -> Arc<OnceCell<Arc<Vec<u8>>>> {
        let mut state = self.lock();
        state.tick += 1;
        let tick = state.tick;
        let slot =
            state.slots.entry(hash).or_insert_with(|| Slot { cell: Arc::default(), last_used: 0 });
        slot.last_used = tick;
        slot.cell.clone()
    }

    /// The blob, if held.
    pub fn get(&self, hash: &Hash) -> Option<Arc<Vec<u8>>> {
        let mut state = self.lock();
        state.tick += 1;
        let tick = state.tick;
        let slot = state.slots.get_mut(hash)?;
        slot.last_used = tick;
        slot.cell.get().cloned()
    }

    /// Keeps `data` under `hash` after checking that it hashes to it.
    pub fn insert(&self, hash: Hash, data: Vec<u8>) -> Result<Arc<Vec<u8>>, Error> {
        verify(&hash, &data)?;
        let cell = self.slot(hash);
        let data = match cell.set(Arc::new(data)) {
            Ok(()) => cell.get().cloned(),
            Err(_) => cell.get().cloned(),
        };
        self.evict(&hash);
        data.ok_or_else(|| Error::BlobMalformed { hash: hex(&hash), reason: "lost".into() })
    }

    /// The blob, fetched from `source` (once, however many callers ask at
    /// the same time) and verified if not held. A failed fetch is not kept.
    pub async fn get_or_fetch<S: BlobSource>(
        &self,
        source: &S,
        hash: Hash,
    ) -> Result<Arc<Vec<u8>>, Error> {
        let cell = self.slot(hash);
        let data = cell
            .get_or_try_init(|| async {
                let data = source.fetch(hash).await?;
                verify(&hash, &data)?;
                tracing::debug!(hash = %hex(&hash), bytes = data.len(), "fetched blob");
                Ok::<_, Error>(Arc::new(data))
            })
            .await
            .cloned();
        drop(cell);
        self.evict(&hash);
        data
    }

    /// Drops failed fetches nobody waits for, then the least recently used
    /// blobs other than `keep` while over budget.
    fn evict(&self, keep: &Hash) {
        let mut state = self.lock();
        state.slots.retain(|_, s| s.cell.initialized() || Arc::strong_count(&s.cell) > 1);
        let size = |s: &Slot| s.cell.get().map_or(0, |d| d.len());
        let mut total: usize = state.slots.values().map(size).sum();
        while total > self.max_bytes {
            let oldest = state
                .slots
                .iter()
                .filter(|(h, s)| *h != keep && s.cell.initialized())
                .min_by_key(|(_, s)| s.last_used)
                .map(|(h, s)| (*h, size(s)));
            let Some((hash, bytes)) = oldest else { break };
            state.slots.remove(&hash);
            total -= bytes;
        }
    }

    /// Number of blobs held.
    pub fn len(&self) -> usize {
        self.lock().slots.values().filter(|s| s.cell.initialized()).count()
    }

    /// Whether no blob is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Blobs served from a map, counting fetches; `corrupt` serves wrong bytes.
    #[derive(Clone, Default)]
    pub(crate) struct MapSource {
        pub blobs: Arc<HashMap<Hash, Vec<u8>>>,
        pub fetches: Arc<AtomicUsize>,
        pub corrupt: bool,
    }

    impl MapSource {
        pub(crate) fn new(blobs: impl IntoIterator<Item = Vec<u8>>) -> Self {
            let blobs = blobs.into_iter().map(|d| (*blake3::hash(&d).as_bytes(), d)).collect();
            MapSource { blobs: Arc::new(blobs), ..Default::default() }
        }
    }

    impl BlobSource for MapSource {
        async fn fetch(&self, hash: Hash) -> Result<Vec<u8>, Error> {
            self.fetches.fetch_add(1, Ordering::SeqCst);
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
            match self.blobs.get(&hash) {
                Some(d) if self.corrupt => Ok(d.iter().map(|b| b ^ 1).collect()),
                Some(d) => Ok(d.clone()),
                None => Err(Error::BlobStatus {
                    hash: hex(&hash),
                    status: tonic::Status::not_found("no"),
                }),
            }
        }
    }

    fn h(data: &[u8]) -> Hash {
        *blake3::hash(data).as_bytes()
    }

    #[test]
    fn insert_rejects_data_that_does_not_match_its_hash() {
        let cache = BlobCache::default();
        let err = cache.insert(h(b"abc"), b"abd".to_vec()).unwrap_err();
        assert!(matches!(err, Error::BlobHashMismatch { .. }), "{err}");
        assert!(cache.is_empty() && cache.get(&h(b"abc")).is_none());
        let got = cache.insert(h(b"abc"), b"abc".to_vec()).unwrap();
        assert_eq!(got.as_slice(), b"abc");
        assert_eq!(cache.get(&h(b"abc")).unwrap().as_slice(), b"abc");
    }

    #[tokio::test]
    async fn fetches_are_verified_shared_and_evicted_by_age() {
        let (a, b) = (vec![1u8; 60], vec![2u8; 60]);
        let source = MapSource::new([a.clone(), b.clone()]);
        let cache = BlobCache::new(100);
        // Corrupt bytes are refused and not kept.
        let bad = MapSource { corrupt: true, ..source.clone() };
        let err = cache.get_or_fetch(&bad, h(&a)).await.unwrap_err();
        assert!(matches!(err, Error::BlobHashMismatch { .. }) && err.retryable());
        assert!(cache.is_empty());
        // Concurrent requests share one fetch.
        let (x, y) =
            tokio::join!(cache.get_or_fetch(&source, h(&a)), cache.get_or_fetch(&source, h(&a)));
        assert_eq!((x.unwrap().as_slice(), y.unwrap().as_slice()), (&a[..], &a[..]));
        assert_eq!(source.fetches.load(Ordering::SeqCst), 2);
        // A second blob pushes the first out of the 100-byte budget.
        cache.get_or_fetch(&source, h(&b)).await.unwrap();
        assert_eq!(cache.len(), 1);
        assert!(cache.get(&h(&a)).is_none() && cache.get(&h(&b)).is_some());
        // Unknown blobs are not retryable.
        let err = cache.get_or_fetch(&source, h(b"nope")).await.unwrap_err();
        assert!(!err.retryable());
    }
}
