//! Prometheus metrics of one worker, served with `farm worker
//! --metrics-listen ADDR` at `/metrics`. They hold counts only (no job,
//! tile or scene names), so the endpoint has no token: bind it where your
//! Prometheus can reach it and nothing else can.

use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::{Registry, Unit};
use std::future::Future;
use std::sync::Arc;
use tokio::net::TcpListener;
use tokio_stream::wrappers::TcpListenerStream;

/// A ray kind label.
#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct Kind {
    kind: &'static str,
}

/// What a worker counts.
pub struct WorkerMetrics {
    registry: Registry,
    /// Tiles rendered and sent.
    pub tiles_rendered: Counter,
    /// Tiles that failed here.
    pub tiles_failed: Counter,
    /// Seconds from an assignment's arrival to its result.
    pub tile_seconds: Histogram,
    rays: Family<Kind, Counter>,
    /// Render threads.
    pub threads: Gauge,
    /// 1 while a session with the coordinator is open.
    pub connected: Gauge,
}

impl Default for WorkerMetrics {
    fn default() -> Self {
        let mut r = Registry::with_prefix("farm_worker");
        let tiles_rendered = Counter::default();
        r.register("tiles_rendered", "Tiles rendered and sent", tiles_rendered.clone());
        let tiles_failed = Counter::default();
        r.register("tiles_failed", "Tiles that failed on this worker", tiles_failed.clone());
        let tile_seconds = Histogram::new(exponential_buckets(0.001, 2.0, 17));
        r.register_with_unit(
            "tile_duration",
            "Time from a tile's assignment to its result",
            Unit::Seconds,
            tile_seconds.clone(),
        );
        let rays = Family::<Kind, Counter>::default();
        r.register("rays", "Rays traced, by kind", rays.clone());
        let threads = Gauge::default();
        r.register("threads", "Render threads", threads.clone());
        let connected = Gauge::default();
        r.register(
            "connected",
            "1 while a session with the coordinator is open",
            connected.clone(),
        );
        WorkerMetrics {
            registry: r,
            tiles_rendered,
            tiles_failed,
            tile_seconds,
            rays,
            threads,
            connected,
        }
    }
}

impl WorkerMetrics {
    /// Counts a result about to be sent.
    pub fn result(&self, r: &farm_proto::v1::TileResult, seconds: f64) {
        use farm_proto::v1::tile_result::Outcome;
        match r.outcome {
            Some(Outcome::FilmTile(_)) => self.tiles_rendered.inc(),
            _ => self.tiles_failed.inc(),
        };
        self.tile_seconds.observe(seconds);
        if let Some(s) = &r.stats {
            for (kind, n) in [
                ("camera", s.camera_rays),
                ("shadow", s.shadow_rays),
                ("secondary", s.secondary_rays),
            ] {
                self.rays.get_or_create(&Kind { kind }).inc_by(n);
            }
        }
    }

    /// The Prometheus text format.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }
}

/// Serves `/metrics` (plain HTTP) on `listener` until `shutdown`.
pub async fn serve(
    listener: TcpListener,
    metrics: Arc<WorkerMetrics>,
    shutdown: impl Future<Output = ()> + Send,
) -> Result<(), tonic::transport::Error> {
    use axum::http::header;
    let app = axum::Router::new().route(
        "/metrics",
        axum::routing::get(move || {
            let m = metrics.clone();
            async move {
                (
                    [(
                        header::CONTENT_TYPE,
                        "application/openmetrics-text; version=1.0.0; charset=utf-8",
                    )],
                    m.encode(),
                )
            }
        }),
    );
    tonic::transport::Server::builder()
        .accept_http1(true)
        .add_routes(tonic::service::Routes::from(app))
        .serve_with_incoming_shutdown(TcpListenerStream::new(listener), shutdown)
        .await
}
