//! Renderers by scene and sample count. Building one means fetching the
//! scene's manifest and assets, decoding them and building the BVH, so the
//! worker keeps the few most recently used, and concurrent tiles of a scene
//! being built wait for that one build.

use crate::blob_cache::{hex, BlobCache, BlobSource};
use crate::error::Error;
use crate::pool::CpuPool;
use farm_proto::convert::{attach_asset, decode_manifest, Hash};
use farm_render::{RenderOptions, Renderer};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use tokio::sync::watch;

/// Renderers kept by default.
pub const DEFAULT_RENDERERS: usize = 4;

/// A build's outcome, shared by everyone waiting for it.
pub type BuildResult = std::result::Result<Arc<Renderer>, Arc<Error>>;

/// Scene hash and samples per pixel (0 = the scene's).
type Key = (Hash, u32);

#[derive(Debug)]
struct Entry {
    /// `None` while building.
    result: watch::Receiver<Option<BuildResult>>,
    last_used: u64,
}

#[derive(Debug)]
struct Inner {
    entries: Mutex<(HashMap<Key, Entry>, u64)>,
    capacity: usize,
    blobs: Arc<BlobCache>,
    pool: CpuPool,
    builds: AtomicU64,
}

/// Built renderers by (scene hash, spp), least recently used dropped beyond
/// a capacity. Clones share the cache.
#[derive(Clone, Debug)]
pub struct RendererCache {
    inner: Arc<Inner>,
}

impl RendererCache {
    /// A cache of `capacity` renderers that fetches into `blobs` and builds
    /// on `pool`.
    pub fn new(capacity: usize, blobs: Arc<BlobCache>, pool: CpuPool) -> Self {
        let inner = Inner {
            entries: Mutex::new((HashMap::new(), 0)),
            capacity: capacity.max(1),
            blobs,
            pool,
            builds: AtomicU64::new(0),
        };
        RendererCache { inner: Arc::new(inner) }
    }

    /// Builds started so far.
    pub fn builds(&self) -> u64 {
        self.inner.builds.load(Ordering::Relaxed)
    }

    /// The renderer for a scene at `spp` (0 = the scene's), built from blobs
    /// fetched through `source` unless cached or being built.
    pub async fn get<S: BlobSource>(&self, source: &S, scene: Hash, spp: u32) -> BuildResult {
        let mut rx = self.entry(source, (scene, spp));
        let result = match rx.wait_for(Option::is_some).await {
            Ok(r) => r.clone(),
            Err(_) => None,
        };
        result.unwrap_or_else(|| Err(Arc::new(Error::BuildAbandoned)))
    }

    fn lock(&self) -> MutexGuard<'_, (HashMap<Key, Entry>, u64)> {
        self.inner.entries.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The entry for `key`, starting its build if there is none.
    fn entry<S: BlobSource>(&self, source: &S, key: Key) -> watch::Receiver<Option<BuildResult>> {
        let mut guard = self.lock();
        let (entries, tick) = &mut *guard;
        *tick += 1;
        if let Some(e) = entries.get_mut(&key) {
            e.last_used = *tick;
            return e.result.clone();
        }
        let (tx, rx) = watch::channel(None);
        entries.insert(key, Entry { result: rx.clone(), last_used: *tick });
        // Drop the least recently used finished renderers beyond capacity.
        while entries.len() > self.inner.capacity {
            let oldest = entries
                .iter()
                .filter(|(_, e)| e.result.borrow().is_some())
                .min_by_key(|(_, e)| e.last_used)
                .map(|(k, _)| *k);
            let Some(k) = oldest else { break };
            entries.remove(&k);
        }
        drop(guard);
        // The build runs detached so it finishes even if the tile that
        // started it is cancelled.
        self.inner.builds.fetch_add(1, Ordering::Relaxed);
        let (cache, source, watch) = (self.clone(), source.clone(), rx.clone());
        tokio::spawn(async move {
            let result = cache.build(&source, key.0, key.1).await;
            if let Err(e) = &result {
                tracing::warn!(scene = %hex(&key.0), spp = key.1, error = %e, "scene build failed");
                // Network trouble: let a later tile try again.
                if e.retryable() {
                    let mut guard = cache.lock();
                    if guard.0.get(&key).is_some_and(|e| e.result.same_channel(&watch)) {
                        guard.0.remove(&key);
                    }
                }
            }
            let _ = tx.send(Some(result));
        });
        rx
    }

    /// Fetches, decodes and builds one scene.
    async fn build<S: BlobSource>(&self, source: &S, scene: Hash, spp: u32) -> BuildResult {
        let fetch_failed = Arc::new;
        let bad_scene = |message: String| Arc::new(Error::BadScene(message));
        let started = std::time::Instant::now();
        let blobs = &self.inner.blobs;
        let pool = &self.inner.pool;
        let manifest = blobs.get_or_fetch(source, scene).await.map_err(fetch_failed)?;

        // Decode on the pool: a manifest holds whole meshes.
        let decoded = pool.run(move || decode_manifest(&manifest)).await;
        let (mut desc, assets) =
            decoded.map_err(|e| bad_scene(e.to_string()))?.map_err(|e| bad_scene(e.to_string()))?;
        // Assets come verified from the blob cache; they are put in the
        // description on the pool, since a shape's parameters sent apart
        // are a whole mesh to decode.
        let mut fetched = Vec::with_capacity(assets.len());
        for (key, hash) in assets {
            fetched.push((key, blobs.get_or_fetch(source, hash).await.map_err(fetch_failed)?));
        }
        let attached = pool
            .run(move || {
                for (key, data) in fetched {
                    attach_asset(&mut desc, key, &data)?;
                }
                Ok::<_, farm_proto::Error>(desc)
            })
            .await;
        let desc = attached
            .map_err(|e| bad_scene(e.to_string()))?
            .map_err(|e| bad_scene(e.to_string()))?;

        let opts = RenderOptions { spp: (spp > 0).then_some(spp), ..Default::default() };
        let built = pool.run(move || Renderer::new(desc, &opts)).await;
        let (renderer, warnings) = built
            .map_err(|e| bad_scene(format!("building the scene: {e}")))?
            .map_err(|e| bad_scene(e.to_string()))?;
        for w in &warnings {
            tracing::debug!(scene = %hex(&scene), "{w}");
        }
        tracing::info!(
            scene = %hex(&scene),
            spp = renderer.samples_per_pixel(),
            warnings = warnings.len(),
            seconds = started.elapsed().as_secs_f64(),
            "scene built"
        );
        Ok(Arc::new(renderer))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blob_cache::tests::MapSource;
    use crate::testing::tiny_scene;
    use farm_common::ids::TileId;

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn concurrent_requests_build_a_scene_once() {
        let (manifest, assets) = farm_proto::convert::encode_scene(&mut tiny_scene(16)).unwrap();
        let blobs = std::iter::once(manifest.data.as_ref().clone())
            .chain(assets.iter().map(|b| b.data.as_ref().clone()));
        let source = MapSource::new(blobs);
        let cache = RendererCache::new(2, Arc::default(), CpuPool::new(2).unwrap());
        let h = manifest.hash;
        let (a, b, c) = tokio::join!(
            cache.get(&source, h, 0),
            cache.get(&source, h, 0),
            cache.get(&source, h, 0)
        );
        let (a, b, c) = (a.unwrap(), b.unwrap(), c.unwrap());
        assert!(Arc::ptr_eq(&a, &b) && Arc::ptr_eq(&b, &c));
        assert_eq!(cache.builds(), 1);
        // Manifest and one asset, each fetched once.
        assert_eq!(source.fetches.load(Ordering::SeqCst), 2);
        assert_eq!(a.samples_per_pixel(), 1);
        let (tile, stats) = a.render_tile(TileId(0));
        assert_eq!(stats.camera_rays, 256);
        assert!(tile.pixels.iter().any(|p| p.weight > 0.0));

        // Another spp is another renderer, but the blobs are not fetched again.
        let d = cache.get(&source, h, 4).await.unwrap();
        assert_eq!(d.samples_per_pixel(), 4);
        assert_eq!((cache.builds(), source.fetches.load(Ordering::SeqCst)), (2, 2));
        // A third pushes out the least recently used (spp 0), which is rebuilt.
        cache.get(&source, h, 2).await.unwrap();
        cache.get(&source, h, 4).await.unwrap();
        assert_eq!(cache.builds(), 3);
        cache.get(&source, h, 0).await.unwrap();
        assert_eq!(cache.builds(), 4);
    }

    #[tokio::test]
    async fn failures_say_whether_to_retry() {
        let source = MapSource::new([b"not a manifest".to_vec()]);
        let cache = RendererCache::new(4, Arc::default(), CpuPool::new(1).unwrap());
        let bad = cache.get(&source, *blake3::hash(b"not a manifest").as_bytes(), 0).await;
        assert!(!bad.unwrap_err().retryable());
        // A bad scene is remembered, not rebuilt.
        let _ = cache.get(&source, *blake3::hash(b"not a manifest").as_bytes(), 0).await;
        assert_eq!(cache.builds(), 1);
        // Bytes that do not match their hash may be a network fault.
        let corrupt = MapSource { corrupt: true, ..source };
        let cache = RendererCache::new(4, Arc::default(), CpuPool::new(1).unwrap());
        let err =
            cache.get(&corrupt, *blake3::hash(b"not a manifest").as_bytes(), 0).await.unwrap_err();
        assert!(err.retryable(), "{err}");
    }
}
