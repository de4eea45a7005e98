//! A worker's life: register with the coordinator, open the `Work` stream,
//! render the tiles it assigns on the render pool and send back each result
//! as soon as it is done, until shutdown. With `reconnect`, a lost
//! coordinator is re-registered with, backing off from 0.2 s to 5 s.

use crate::assignment::{render_tile, TileOutcome};
use crate::config::WorkerConfig;
use crate::error::Error;
use crate::health;
use crate::metrics::WorkerMetrics;
use crate::pool::CpuPool;
use crate::renderer_cache::{RendererCache, DEFAULT_RENDERERS};
use farm_proto::connect::{connect, Client, ConnectError};
use farm_proto::v1::coordinator_message::Kind as FromCoordinator;
use farm_proto::v1::worker_message::Kind as ToCoordinator;
use farm_proto::v1::{
    Heartbeat, Hello, RegisterWorkerRequest, RegisterWorkerResponse, TileAssignment, TileResult,
    WorkerMessage,
};
use farm_proto::PROTOCOL_VERSION;
use std::collections::HashMap;
use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::JoinSet;
use tokio_stream::wrappers::ReceiverStream;

/// First and largest pause between attempts to reach the coordinator.
const BACKOFF: (Duration, Duration) = (Duration::from_millis(200), Duration::from_secs(5));
/// How long a stopping worker waits for the coordinator to end the stream.
const CLOSE_GRACE: Duration = Duration::from_secs(1);

/// What a worker did before it stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkerSummary {
    /// Tiles rendered and sent.
    pub tiles_rendered: u64,
}

/// Runs a worker until `shutdown` completes (then returns `Ok`), or until
/// it fails for good: refused, or with `reconnect` off, unreachable or
/// disconnected.
pub async fn run(
    config: WorkerConfig,
    shutdown: impl Future<Output = ()> + Send,
) -> Result<WorkerSummary, Error> {
    let (stop_tx, stop_rx) = watch::channel(false);
    let work = run_until_stopped(config, stop_rx);
    tokio::pin!(work);
    tokio::select! {
        result = &mut work => result,
        () = shutdown => {
            tracing::info!("shutting down");
            let _ = stop_tx.send(true);
            work.await
        }
    }
}

/// When a server beside the worker stops.
type Shutdown = std::pin::Pin<Box<dyn Future<Output = ()> + Send>>;

/// Serves `what` on `listener` in the background until the returned guard
/// is dropped.
fn serve_beside<Fut>(
    listener: tokio::net::TcpListener,
    what: &'static str,
    serve: impl FnOnce(tokio::net::TcpListener, Shutdown) -> Fut,
) -> oneshot::Sender<()>
where
    Fut: Future<Output = Result<(), tonic::transport::Error>> + Send + 'static,
{
    if let Ok(bound) = listener.local_addr() {
        tracing::info!(%bound, "serving {what}");
    }
    let (guard, stopped) = oneshot::channel::<()>();
    let server = serve(
        listener,
        Box::pin(async move {
            let _ = stopped.await;
        }),
    );
    tokio::spawn(async move {
        if let Err(e) = server.await {
            tracing::warn!(error = %e, "{what} server failed");
        }
    });
    guard
}

/// Resolves once `stop` says so (or its sender is gone).
async fn stopped(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|s| *s).await;
}

/// Why a session ended.
enum SessionEnd {
    /// The worker was told to stop.
    Shutdown,
    /// The stream failed or the coordinator closed it.
    Lost(String),
}

impl SessionEnd {
    /// The coordinator's side of the stream is gone.
    fn closed() -> Self {
        SessionEnd::Lost("the coordinator closed the stream".into())
    }
}

/// Everything that outlives a session.
struct Worker {
    config: WorkerConfig,
    pool: CpuPool,
    renderers: RendererCache,
    max_in_flight: u32,
    summary: WorkerSummary,
    metrics: Arc<WorkerMetrics>,
}

async fn run_until_stopped(
    config: WorkerConfig,
    mut stop: watch::Receiver<bool>,
) -> Result<WorkerSummary, Error> {
    let pool = CpuPool::new(config.render_threads())?;
    // Health and metrics are served until this function returns, whatever
    // the coordinator does (dropping a guard stops its server).
    let mut _guards = Vec::new();
    if let Some(address) = config.health_listen {
        let listener = tokio::net::TcpListener::bind(address)
            .await
            .map_err(|source| Error::Health { address, source })?;
        _guards.push(serve_beside(listener, "grpc.health.v1", health::serve));
    }
    let metrics = Arc::new(WorkerMetrics::default());
    metrics.threads.set(pool.threads() as i64);
    if let Some(address) = config.metrics_listen {
        let listener = tokio::net::TcpListener::bind(address)
            .await
            .map_err(|source| Error::Metrics { address, source })?;
        let m = metrics.clone();
        _guards.push(serve_beside(listener, "/metrics", move |l, stop| {
            crate::metrics::serve(l, m, stop)
        }));
    }
    let renderers = RendererCache::new(DEFAULT_RENDERERS, Arc::default(), pool.clone());
    let max_in_flight = config.in_flight(pool.threads());
    let mut worker = Worker {
        config,
        pool,
        renderers,
        max_in_flight,
        summary: WorkerSummary::default(),
        metrics,
    };

    let mut delay = BACKOFF.0;
    loop {
        let registered = tokio::select! {
            r = worker.register() => r,
            () = stopped(&mut stop) => return Ok(worker.summary),
        };
        match registered {
            Ok((client, reply)) => {
                delay = BACKOFF.0;
                match worker.session(client, reply, &mut stop).await {
                    SessionEnd::Shutdown => return Ok(worker.summary),
                    SessionEnd::Lost(message) if worker.config.reconnect => {
                        tracing::warn!(%message, "lost the coordinator; registering again");
                    }
                    SessionEnd::Lost(message) => return Err(Error::Stream { message }),
                }
            }
            Err(
                e @ (Error::Refused { .. }
                | Error::Connect(ConnectError::BadUrl(_) | ConnectError::NeedToken(_))),
            ) => return Err(e),
            Err(e) if worker.config.reconnect => {
                tracing::warn!(error = %e, retry_in_ms = delay.as_millis() as u64, "coordinator unreachable");
            }
            Err(e) => return Err(e),
        }
        tokio::select! {
            () = tokio::time::sleep(delay) => {}
            () = stopped(&mut stop) => return Ok(worker.summary),
        }
        delay = (delay * 2).min(BACKOFF.1);
    }
}

impl Worker {
    /// Connects and registers.
    async fn register(&self) -> Result<(Client, RegisterWorkerResponse), Error> {
        let mut client = connect(&self.config.coordinator, self.config.token.as_ref()).await?;
        let request = RegisterWorkerRequest {
            protocol_version: PROTOCOL_VERSION,
            name: self.config.name.clone(),
            threads: u32::try_from(self.pool.threads()).unwrap_or(u32::MAX),
        };
        let reply = client.register_worker(request).await.map_err(|s| {
            use tonic::Code;
            if matches!(
                s.code(),
                Code::FailedPrecondition | Code::Unauthenticated | Code::PermissionDenied
            ) {
                Error::Refused { message: s.message().to_string() }
            } else {
                Error::Register { message: s.to_string() }
            }
        })?;
        let reply = reply.into_inner();
        tracing::info!(
            coordinator = %self.config.coordinator,
            worker_id = reply.worker_id,
            heartbeat_ms = reply.heartbeat_interval_ms,
            threads = self.pool.threads(),
            "registered"
        );
        Ok((client, reply))
    }

    /// Sends the held results, except those of cancelled jobs; false when
    /// the stream is gone.
    async fn send_held(&mut self, tx: &mpsc::Sender<WorkerMessage>, held: &mut Vec<Held>) -> bool {
        for (cancelled, rendered, result) in held.drain(..) {
            if cancelled.load(Ordering::Relaxed) {
                continue;
            }
            let message = WorkerMessage { kind: Some(ToCoordinator::Result(result)) };
            if tx.send(message).await.is_err() {
                return false;
            }
            self.summary.tiles_rendered += u64::from(rendered);
        }
        true
    }

    /// One `Work` stream, from Hello until shutdown or a lost coordinator.
    #[tracing::instrument(skip_all, fields(worker_id = reply.worker_id))]
    async fn session(
        &mut self,
        client: Client,
        reply: RegisterWorkerResponse,
        stop: &mut watch::Receiver<bool>,
    ) -> SessionEnd {
        // The outgoing stream: Hello first, then results and heartbeats.
        let (tx, rx) = mpsc::channel::<WorkerMessage>(self.max_in_flight as usize + 16);
        let hello = Hello {
            worker_id: reply.worker_id,
            max_in_flight: self.max_in_flight,
            session_key: reply.session_key.clone(),
        };
        let _ = tx.send(WorkerMessage { kind: Some(ToCoordinator::Hello(hello)) }).await;
        let mut stream_client = client.clone();
        let opened = tokio::select! {
            r = stream_client.work(ReceiverStream::new(rx)) => r,
            () = stopped(stop) => return SessionEnd::Shutdown,
        };
        let mut inbound = match opened {
            Ok(response) => response.into_inner(),
            Err(status) => return SessionEnd::Lost(format!("opening the work stream: {status}")),
        };
        tracing::info!(max_in_flight = self.max_in_flight, "work stream open");
        self.metrics.connected.set(1);

        let period = Duration::from_millis(match reply.heartbeat_interval_ms {
            0 => 1000,
            ms => u64::from(ms),
        });
        let mut heartbeat = tokio::time::interval_at(tokio::time::Instant::now() + period, period);
        heartbeat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        // Finished results are held back and sent together once no more than
        // `low_water` tiles are left in progress: one write then carries
        // several results (and the coordinator answers with several
        // assignments), while the tiles still in progress keep every thread
        // busy over the round trip. Each message costs both sides system
        // calls and wake-ups, which a tile-at-a-time exchange pays per tile.
        let low_water = self.pool.threads().max(self.max_in_flight as usize / 2);
        let mut work = InFlight::default();

        let end = loop {
            tokio::select! {
                // Cancellations before results, so a cancelled job's tiles are not sent.
                biased;
                () = stopped(stop) => break SessionEnd::Shutdown,
                message = inbound.message() => match message {
                    Ok(Some(m)) => match m.kind {
                        Some(FromCoordinator::Assign(a)) => work.start(self, &client, a),
                        Some(FromCoordinator::Cancelled(c)) => work.cancel(c.job_id),
                        None => {}
                    },
                    Ok(None) => break SessionEnd::closed(),
                    Err(status) => break SessionEnd::Lost(status.to_string()),
                },
                Some(joined) = work.tiles.join_next() => {
                    let Ok(outcome) = joined else { continue };
                    work.finished(outcome, &self.metrics);
                    if work.tiles.len() <= low_water && !self.send_held(&tx, &mut work.held).await {
                        break SessionEnd::closed();
                    }
                }
                _ = heartbeat.tick() => {
                    if !self.send_held(&tx, &mut work.held).await {
                        break SessionEnd::closed();
                    }
                    let beat = WorkerMessage { kind: Some(ToCoordinator::Heartbeat(Heartbeat {})) };
                    if tx.send(beat).await.is_err() {
                        break SessionEnd::closed();
                    }
                }
            }
        };

        // Drop queued tiles (the coordinator requeues them) and close our side.
        self.metrics.connected.set(0);
        work.drop_all();
        drop(tx);
        if matches!(end, SessionEnd::Shutdown) {
            let drain = async { while let Ok(Some(_)) = inbound.message().await {} };
            let _ = tokio::time::timeout(CLOSE_GRACE, drain).await;
        }
        end
    }
}

/// A held result: its job's cancellation flag, whether it holds a rendered
/// tile, and the message.
type Held = (Arc<AtomicBool>, bool, TileResult);

/// A session's tiles: those rendering or queued, and results not yet sent.
#[derive(Default)]
struct InFlight {
    /// Per job: a flag set on cancellation, and its tiles in flight.
    jobs: HashMap<u64, (Arc<AtomicBool>, usize)>,
    tiles: JoinSet<TileOutcome>,
    held: Vec<Held>,
}

impl InFlight {
    /// Starts rendering an assignment.
    fn start(&mut self, worker: &Worker, client: &Client, a: TileAssignment) {
        let (flag, n) = self.jobs.entry(a.job_id).or_default();
        *n += 1;
        let (renderers, pool) = (worker.renderers.clone(), worker.pool.clone());
        self.tiles.spawn(render_tile(renderers, client.clone(), pool, a, flag.clone()));
    }

    /// Flags a cancelled job's tiles, so they are neither rendered nor sent.
    fn cancel(&mut self, job_id: u64) {
        tracing::debug!(job_id, "job cancelled");
        if let Some((flag, _)) = self.jobs.remove(&job_id) {
            flag.store(true, Ordering::Relaxed);
        }
    }

    /// Takes a finished tile: its result waits in `held`.
    fn finished(&mut self, outcome: TileOutcome, metrics: &WorkerMetrics) {
        if let Some((flag, n)) = self.jobs.get_mut(&outcome.job_id) {
            if Arc::ptr_eq(flag, &outcome.cancelled) {
                *n -= 1;
                if *n == 0 {
                    self.jobs.remove(&outcome.job_id);
                }
            }
        }
        if let Some(result) = outcome.result {
            metrics.result(&result, outcome.seconds);
            self.held.push((outcome.cancelled, outcome.rendered, result));
        }
    }

    /// Drops every queued and rendering tile.
    fn drop_all(&mut self) {
        for (flag, _) in self.jobs.values() {
            flag.store(true, Ordering::Relaxed);
        }
        self.tiles.abort_all();
    }
}

#[cfg(test)]
#[path = "session_tests.rs"]
mod tests;
