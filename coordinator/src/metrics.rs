//! Prometheus metrics of the coordinator, served at `/metrics` on its own
//! port (with the same tokens as every other call).
//!
//! Counters are counted by the event loop as things happen; gauges that
//! describe the scheduler's state (jobs by state, queue depth, workers)
//! are set from it just before each scrape. No label takes a job id, tile
//! or worker name, so the number of series is fixed.

use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::{Registry, Unit};
use std::sync::atomic::AtomicU64;

/// A `state` label.
#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct StateLabel {
    /// queued, running, done, failed or cancelled.
    pub state: String,
}

/// A `kind` label of rays.
#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RayKind {
    /// camera, shadow or secondary.
    pub kind: String,
}

/// Every job state, so that each series exists from the start.
pub const JOB_STATES: [&str; 5] = ["queued", "running", "done", "failed", "cancelled"];

/// The coordinator's metrics.
pub struct Metrics {
    registry: Registry,
    /// Jobs the coordinator holds, by state.
    pub jobs: Family<StateLabel, Gauge>,
    /// Tile hand-outs.
    pub tiles_dispatched: Counter,
    /// Tiles accepted into a film.
    pub tiles_merged: Counter,
    /// Hand-outs of a tile after its first.
    pub tiles_retried: Counter,
    /// Second hand-outs of tiles still out at the end of a job.
    pub tiles_speculated: Counter,
    /// Tiles a worker could not render, or sent back malformed.
    pub tiles_failed: Counter,
    /// Tiles of active jobs waiting for a worker.
    pub queue_depth: Gauge,
    /// Workers with an open session.
    pub workers: Gauge,
    /// Seconds from a tile's hand-out to its result.
    pub tile_latency: Histogram,
    /// Rays of merged tiles, by kind.
    pub rays: Family<RayKind, Counter>,
    /// Rays per second over the last heartbeat interval.
    pub rays_per_second: Gauge<f64, AtomicU64>,
    /// Bytes in the blob store.
    pub blob_bytes: Gauge,
    /// Bytes uploads brought in (a blob sent twice counts twice).
    pub blob_uploaded: Counter,
    /// Seconds the event loop spent handling events (not waiting for
    /// them): every scheduling decision and merge is made there, one at a
    /// time, so its share of a second is how close the coordinator is to
    /// the most it can take. (The journal's writer, on its own thread,
    /// could fall behind first on a slow disk; this does not show that.)
    pub loop_busy: Counter<f64, AtomicU64>,
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
}

impl Metrics {
    /// Every metric registered, at zero.
    pub fn new() -> Self {
        let mut r = Registry::with_prefix("farm");
        let jobs = Family::<StateLabel, Gauge>::default();
        for s in JOB_STATES {
            let _ = jobs.get_or_create(&StateLabel { state: s.into() });
        }
        r.register("jobs", "Jobs the coordinator holds, by state", jobs.clone());
        let tiles_dispatched = Counter::default();
        r.register("tiles_dispatched", "Tiles handed out to workers", tiles_dispatched.clone());
        let tiles_merged = Counter::default();
        r.register("tiles_merged", "Tile results accepted into a film", tiles_merged.clone());
        let tiles_retried = Counter::default();
        r.register(
            "tiles_retried",
            "Hand-outs of a tile after its first (lost worker, failure, bad result)",
            tiles_retried.clone(),
        );
        let tiles_speculated = Counter::default();
        r.register(
            "tiles_speculated",
            "Second hand-outs of tiles still out once none was left, each part of a tile split among idle workers counted (the first result wins)",
            tiles_speculated.clone(),
        );
        let tiles_failed = Counter::default();
        r.register(
            "tiles_failed",
            "Tiles a worker could not render or sent back malformed",
            tiles_failed.clone(),
        );
        let queue_depth = Gauge::default();
        r.register("queue_depth", "Tiles of active jobs waiting for a worker", queue_depth.clone());
        let workers = Gauge::default();
        r.register("workers_connected", "Workers with an open session", workers.clone());
        // 1 ms to about 65 s.
        let tile_latency = Histogram::new(exponential_buckets(0.001, 2.0, 17));
        r.register_with_unit(
            "tile_latency",
            "Time from a tile's hand-out to its result",
            Unit::Seconds,
            tile_latency.clone(),
        );
        let rays = Family::<RayKind, Counter>::default();
        for k in ["camera", "shadow", "secondary"] {
            let _ = rays.get_or_create(&RayKind { kind: k.into() });
        }
        r.register("rays", "Rays traced in merged tiles, by kind", rays.clone());
        let rays_per_second = Gauge::<f64, AtomicU64>::default();
        r.register(
            "rays_per_second",
            "Rays traced per second over the last heartbeat interval",
            rays_per_second.clone(),
        );
        let blob_bytes = Gauge::default();
        r.register_with_unit(
            "blob_store",
            "Bytes held in the blob store",
            Unit::Bytes,
            blob_bytes.clone(),
        );
        let blob_uploaded = Counter::default();
        r.register_with_unit(
            "blob_upload",
            "Bytes received by blob uploads, each time a blob is sent",
            Unit::Bytes,
            blob_uploaded.clone(),
        );
        let loop_busy = Counter::<f64, AtomicU64>::default();
        r.register_with_unit(
            "event_loop_busy",
            "Time the event loop spent handling events rather than waiting for them",
            Unit::Seconds,
            loop_busy.clone(),
        );
        Metrics {
            registry: r,
            jobs,
            tiles_dispatched,
            tiles_merged,
            tiles_retried,
            tiles_speculated,
            tiles_failed,
            queue_depth,
            workers,
            tile_latency,
            rays,
            rays_per_second,
            blob_bytes,
            blob_uploaded,
            loop_busy,
        }
    }

    /// Counts the rays of a merged tile.
    pub fn add_rays(&self, s: &farm_common::stats::RayStats) {
        for (k, n) in
            [("camera", s.camera_rays), ("shadow", s.shadow_rays), ("secondary", s.secondary_rays)]
        {
            self.rays.get_or_create(&RayKind { kind: k.into() }).inc_by(n);
        }
    }

    /// All rays counted so far.
    pub fn total_rays(&self) -> u64 {
        ["camera", "shadow", "secondary"]
            .iter()
            .map(|k| self.rays.get_or_create(&RayKind { kind: (*k).into() }).get())
            .sum()
    }

    /// The Prometheus text format of every metric.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        // Writing to a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }
}
