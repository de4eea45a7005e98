//! The coordinator's content-addressed store of scene manifests and assets:
//! one file per blob, named by its blake3 hash, in `DIR/blobs`.
//!
//! An upload streams to a temporary file and is hashed as it arrives, so a
//! bad or oversize upload costs one chunk of memory; its declared size is
//! checked against the blob limit, the client's quota and the store's limit
//! before a byte is written. Downloads stream from the file.

use super::journal::{Command, Journal, SavedBlob};
use super::StateError;
use crate::error::Error;
use farm_proto::convert::{ChunkSequence, Hash};
use farm_proto::v1::BlobChunk;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use tokio::io::AsyncWriteExt;
use tracing::{info, warn};

/// How many bytes blobs may take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlobLimits {
    /// The largest single blob.
    pub max_blob: u64,
    /// The most bytes of blobs one client (token) may have stored.
    pub client_quota: u64,
    /// The most bytes of blobs in the store.
    pub store_limit: u64,
}

impl Default for BlobLimits {
    fn default() -> Self {
        BlobLimits { max_blob: 4 << 30, client_quota: 16 << 30, store_limit: 64 << 30 }
    }
}

/// Hex form of a hash (file names and messages).
pub fn hex(hash: &Hash) -> String {
    blake3::Hash::from(*hash).to_hex().to_string()
}

/// Bytes for messages: "3.2 GiB".
pub fn bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

#[derive(Debug, Default)]
struct Index {
    /// Stored blobs: size and the token charged for them.
    blobs: HashMap<Hash, (u64, String)>,
    /// Bytes charged to each token, uploads in progress included.
    usage: HashMap<String, u64>,
    /// Bytes stored or being uploaded.
    total: u64,
}

impl Index {
    fn charge(&mut self, owner: &str, n: u64) {
        *self.usage.entry(owner.to_string()).or_default() += n;
        self.total += n;
    }

    fn release(&mut self, owner: &str, n: u64) {
        if let Some(u) = self.usage.get_mut(owner) {
            *u = u.saturating_sub(n);
            if *u == 0 {
                self.usage.remove(owner);
            }
        }
        self.total = self.total.saturating_sub(n);
    }
}

#[derive(Debug)]
struct Inner {
    dir: PathBuf,
    /// Removed with the store (a coordinator with no state directory).
    ephemeral: bool,
    limits: BlobLimits,
    journal: Journal,
    index: Mutex<Index>,
    /// Bytes received by uploads, stored or not (a blob sent again is
    /// counted again).
    received: std::sync::atomic::AtomicU64,
}

impl Drop for Inner {
    fn drop(&mut self) {
        if self.ephemeral {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Blobs by hash; cheap to clone, shared by the service handlers.
#[derive(Clone, Debug)]
pub struct BlobStore {
    inner: Arc<Inner>,
}

fn random_hex() -> Result<String, Error> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| Error::Random(e.to_string()))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

impl BlobStore {
    /// The store in `dir` (a fresh temporary one, removed when the store
    /// is dropped, if `None`). Files already there are taken as they are,
    /// charged to the tokens the journal remembers; interrupted uploads are
    /// removed.
    pub fn open(
        dir: Option<&Path>,
        limits: BlobLimits,
        journal: Journal,
        saved: Vec<SavedBlob>,
    ) -> Result<BlobStore, StateError> {
        let (dir, ephemeral) = match dir {
            Some(d) => (d.to_path_buf(), false),
            None => {
                let name = random_hex().map_err(|e| StateError::Db(e.to_string()))?;
                (std::env::temp_dir().join(format!("farm-blobs-{name}")), true)
            }
        };
        let io = |what: &str, e| StateError::Io(format!("{what} {}", dir.display()), e);
        let _ = std::fs::remove_dir_all(dir.join("tmp"));
        std::fs::create_dir_all(dir.join("tmp")).map_err(|e| io("cannot create", e))?;
        let owners: HashMap<Hash, String> = saved.into_iter().map(|b| (b.hash, b.owner)).collect();
        let mut index = Index::default();
        for entry in std::fs::read_dir(&dir).map_err(|e| io("cannot read", e))? {
            let Ok(entry) = entry else { continue };
            let name = entry.file_name();
            let Some(hash) = name.to_str().and_then(parse_hex) else { continue };
            let Ok(meta) = entry.metadata() else { continue };
            if !meta.is_file() {
                continue;
            }
            let owner = match owners.get(&hash) {
                Some(o) => o.clone(),
                None => {
                    // Stored just before a crash, before its record was
                    // committed: record it now, so it can be purged.
                    journal.send(Command::BlobStored {
                        hash,
                        size: meta.len(),
                        owner: String::new(),
                    });
                    String::new()
                }
            };
            index.charge(&owner, meta.len());
            index.blobs.insert(hash, (meta.len(), owner));
        }
        if !index.blobs.is_empty() {
            info!(blobs = index.blobs.len(), bytes = index.total, "blob store opened");
        }
        let inner = Inner {
            dir,
            ephemeral,
            limits,
            journal,
            index: Mutex::new(index),
            received: Default::default(),
        };
        Ok(BlobStore { inner: Arc::new(inner) })
    }

    fn index(&self) -> MutexGuard<'_, Index> {
        // Every change to the index is a few statements that cannot panic
        // half-way; a poisoned lock still holds a consistent index.
        self.inner.index.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn path(&self, hash: &Hash) -> PathBuf {
        self.inner.dir.join(hex(hash))
    }

    /// Whether a blob is stored.
    pub fn contains(&self, hash: &Hash) -> bool {
        self.index().blobs.contains_key(hash)
    }

    /// The size of a stored blob.
    pub fn size(&self, hash: &[u8]) -> Option<u64> {
        let h: Hash = hash.try_into().ok()?;
        self.index().blobs.get(&h).map(|(n, _)| *n)
    }

    /// Bytes stored and being uploaded.
    pub fn total_bytes(&self) -> u64 {
        self.index().total
    }

    /// Bytes uploads have brought in, since the coordinator started.
    pub fn received_bytes(&self) -> u64 {
        self.inner.received.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The whole blob (for manifests, which the coordinator decodes).
    pub async fn read(&self, hash: &[u8]) -> Option<Vec<u8>> {
        let h: Hash = hash.try_into().ok()?;
        if !self.contains(&h) {
            return None;
        }
        tokio::fs::read(self.path(&h)).await.ok()
    }

    /// The blob's file, to stream from, and its size.
    pub async fn open_file(&self, hash: &[u8]) -> Option<(tokio::fs::File, u64)> {
        let h: Hash = hash.try_into().ok()?;
        let size = self.index().blobs.get(&h)?.0;
        let f = tokio::fs::File::open(self.path(&h)).await.ok()?;
        Some((f, size))
    }

    /// Starts an upload charged to `owner` (a token id).
    pub fn upload(&self, owner: &str) -> Upload {
        Upload {
            store: self.clone(),
            owner: owner.to_string(),
            seq: ChunkSequence::new(self.inner.limits.max_blob),
            file: None,
            tmp: None,
            hasher: blake3::Hasher::new(),
            reserved: 0,
        }
    }

    /// Deletes blobs no job needs any more.
    pub fn remove(&self, hashes: &[Hash]) {
        let mut freed = 0;
        for h in hashes {
            let removed = self.index().blobs.remove(h);
            if let Some((n, owner)) = removed {
                self.index().release(&owner, n);
                freed += n;
                if let Err(e) = std::fs::remove_file(self.path(h)) {
                    warn!(blob = %hex(h), error = %e, "cannot remove a purged blob");
                }
            }
        }
        if !hashes.is_empty() {
            info!(blobs = hashes.len(), bytes = freed, "unreferenced blobs purged");
        }
    }

    /// Reserves `n` bytes for `owner`'s upload, or says which limit it is over.
    fn reserve(&self, owner: &str, n: u64) -> Result<(), Error> {
        let limits = self.inner.limits;
        let mut ix = self.index();
        let used = ix.usage.get(owner).copied().unwrap_or(0);
        if used.saturating_add(n) > limits.client_quota {
            return Err(Error::QuotaExceeded(format!(
                "the upload of {} would bring this client's blobs to {}, over its quota of {} (farm coordinator --client-quota)",
                bytes(n),
                bytes(used.saturating_add(n)),
                bytes(limits.client_quota)
            )));
        }
        if ix.total.saturating_add(n) > limits.store_limit {
            return Err(Error::QuotaExceeded(format!(
                "the upload of {} would bring the coordinator's blob store to {}, over its limit of {} (farm coordinator --store-limit)",
                bytes(n),
                bytes(ix.total.saturating_add(n)),
                bytes(limits.store_limit)
            )));
        }
        ix.charge(owner, n);
        Ok(())
    }
}

fn parse_hex(s: &str) -> Option<Hash> {
    if s.len() != 64 {
        return None;
    }
    let mut h = [0u8; 32];
    for (i, b) in h.iter_mut().enumerate() {
        *b = u8::from_str_radix(s.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(h)
}

/// An upload in progress: chunks go to a temporary file as they arrive.
/// Dropped before [`Upload::finish`], it removes the file and gives back
/// what it reserved.
#[derive(Debug)]
pub struct Upload {
    store: BlobStore,
    owner: String,
    seq: ChunkSequence,
    file: Option<tokio::fs::File>,
    tmp: Option<PathBuf>,
    hasher: blake3::Hasher,
    reserved: u64,
}

impl Upload {
    /// Checks and writes the next chunk.
    pub async fn push(&mut self, c: &BlobChunk) -> Result<(), Error> {
        let first = self.seq.declared().is_none();
        self.seq.check(c)?;
        // A blob stored already is only checked, not written or charged again.
        if first && !c.hash.as_slice().try_into().is_ok_and(|h: Hash| self.store.contains(&h)) {
            self.store.reserve(&self.owner, c.total_size)?;
            self.reserved = c.total_size;
            let tmp = self.store.inner.dir.join("tmp").join(random_hex()?);
            let f = tokio::fs::File::create(&tmp).await.map_err(|e| Error::Store(e.to_string()))?;
            self.tmp = Some(tmp);
            self.file = Some(f);
        }
        self.hasher.update(&c.data);
        let n = c.data.len() as u64;
        self.store.inner.received.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        if let Some(f) = &mut self.file {
            f.write_all(&c.data).await.map_err(|e| Error::Store(e.to_string()))?;
        }
        Ok(())
    }

    /// Checks the whole blob against its hash and stores it.
    pub async fn finish(mut self) -> Result<(Hash, u64), Error> {
        let seq = std::mem::replace(&mut self.seq, ChunkSequence::new(0));
        let (named, size) = seq.finish()?;
        let hash: Hash = named.as_slice().try_into().map_err(|_| Error::HashMismatch)?;
        if self.hasher.finalize().as_bytes() != &hash {
            return Err(Error::HashMismatch);
        }
        let store = self.store.clone();
        let Some(mut file) = self.file.take() else {
            // Stored already when the upload began: the bytes were only
            // checked. Its record is refreshed, so it is kept a while longer.
            let owner = store.index().blobs.get(&hash).map(|(_, o)| o.clone());
            let owner = owner.ok_or(Error::Store("a blob vanished during its upload".into()))?;
            store.inner.journal.send(Command::BlobStored { hash, size, owner });
            return Ok((hash, size));
        };
        file.flush().await.map_err(|e| Error::Store(e.to_string()))?;
        drop(file);
        let tmp = self.tmp.take().ok_or(Error::HashMismatch)?;
        let known = store.index().blobs.contains_key(&hash);
        if known {
            // Stored already (by this client or another): keep the first.
            let _ = tokio::fs::remove_file(&tmp).await;
        } else {
            tokio::fs::rename(&tmp, store.path(&hash))
                .await
                .map_err(|e| Error::Store(e.to_string()))?;
        }
        let mut ix = store.index();
        if known || ix.blobs.contains_key(&hash) {
            ix.release(&self.owner, self.reserved);
        } else {
            ix.blobs.insert(hash, (size, self.owner.clone()));
        }
        self.reserved = 0;
        let owner = ix.blobs.get(&hash).map(|(_, o)| o.clone()).unwrap_or_default();
        drop(ix);
        store.inner.journal.send(Command::BlobStored { hash, size, owner });
        Ok((hash, size))
    }
}

impl Drop for Upload {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = std::fs::remove_file(tmp);
        }
        if self.reserved > 0 {
            self.store.index().release(&self.owner, self.reserved);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_proto::convert::blob_chunks;
    use farm_proto::BLOB_CHUNK_SIZE;

    fn store(limits: BlobLimits) -> BlobStore {
        let (journal, _) = Journal::open(None).unwrap();
        BlobStore::open(None, limits, journal, Vec::new()).unwrap()
    }

    async fn put(s: &BlobStore, owner: &str, parts: &[BlobChunk]) -> Result<(Hash, u64), Error> {
        let mut u = s.upload(owner);
        for p in parts {
            u.push(p).await?;
        }
        u.finish().await
    }

    #[tokio::test]
    async fn uploads_round_trip_and_corruption_is_refused() {
        let data: Vec<u8> = (0..3 * BLOB_CHUNK_SIZE as u32 / 2).map(|i| (i % 251) as u8).collect();
        let hash: Hash = blake3::hash(&data).into();
        let s = store(BlobLimits::default());
        let parts = blob_chunks(&hash, &data);
        assert_eq!(parts.len(), 2);
        assert_eq!(put(&s, "a", &parts).await.unwrap(), (hash, data.len() as u64));
        assert_eq!(s.read(&hash).await.as_deref(), Some(&data[..]));
        let mut bad = parts.clone();
        bad[1].data[0] ^= 1;
        let fresh = store(BlobLimits::default());
        assert!(matches!(put(&fresh, "a", &bad).await, Err(Error::HashMismatch)));
        assert!(matches!(put(&fresh, "a", &parts[..1]).await, Err(Error::Chunks(_))));
        assert!(!fresh.contains(&hash));
        assert_eq!(fresh.total_bytes(), 0, "failed uploads give back what they reserved");
        let tmp: Vec<_> = std::fs::read_dir(fresh.inner.dir.join("tmp")).unwrap().collect();
        assert!(tmp.is_empty(), "failed uploads leave no file");
    }

    #[tokio::test]
    async fn quotas_and_the_store_limit_refuse_before_writing() {
        let limits = BlobLimits { max_blob: 1000, client_quota: 300, store_limit: 500 };
        let s = store(limits);
        let blob = |n: usize, seed: u8| {
            let d: Vec<u8> = (0..n).map(|i| (i as u8).wrapping_mul(seed)).collect();
            blob_chunks(blake3::hash(&d).as_bytes(), &d)
        };
        assert!(put(&s, "a", &blob(200, 3)).await.is_ok());
        // The same blob again is not charged twice.
        assert!(put(&s, "a", &blob(200, 3)).await.is_ok());
        assert_eq!(s.total_bytes(), 200);
        let e = put(&s, "a", &blob(200, 5)).await.unwrap_err().to_string();
        assert!(e.contains("quota") && e.contains("--client-quota"), "{e}");
        assert!(put(&s, "b", &blob(250, 7)).await.is_ok());
        let e = put(&s, "c", &blob(100, 9)).await.unwrap_err().to_string();
        assert!(e.contains("store") && e.contains("--store-limit"), "{e}");
        let e = put(&s, "c", &blob(2000, 9)).await.unwrap_err();
        assert!(matches!(e, Error::Chunks(farm_proto::Error::TooLarge(2000, 1000))), "{e}");
        assert_eq!(s.total_bytes(), 450);
        let h: Hash =
            *blake3::hash(&(0..200).map(|i| (i as u8).wrapping_mul(3)).collect::<Vec<_>>())
                .as_bytes();
        s.remove(&[h]);
        assert_eq!(s.total_bytes(), 250);
        assert!(put(&s, "c", &blob(100, 9)).await.is_ok(), "removing frees room");
    }

    #[test]
    fn hex_names_round_trip() {
        let h: Hash = *blake3::hash(b"x").as_bytes();
        assert_eq!(parse_hex(&hex(&h)), Some(h));
        assert_eq!(parse_hex("zz"), None);
        assert_eq!(bytes(512), "512 B");
        assert_eq!(bytes(3 << 29), "1.5 GiB");
    }
}
