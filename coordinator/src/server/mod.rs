//! `farm coordinator`: the gRPC front of the scheduler. One event loop owns
//! the [`Scheduler`]; service handlers only translate messages into events
//! and replies.

pub(crate) mod events;
mod from_worker;
mod live;
mod outbox;
mod queues;
mod service;
#[cfg(test)]
mod shutdown_tests;
mod submission;

pub use events::{Event, FromWorker};
pub use service::MAX_WATCHES_PER_TOKEN;

use crate::scheduler::SchedulerConfig;
use crate::security::{Authenticate, Security};
use crate::state::{State, StateConfig};
use farm_common::film::Limits;
use farm_proto::v1::coordinator_server::CoordinatorServer;
use farm_proto::MAX_MESSAGE_SIZE;
use std::future::Future;
use std::time::Duration;
use tokio::net::TcpListener;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::server::TcpIncoming;
use tonic::transport::{Identity, ServerTlsConfig};

/// How often live watchers are sent what changed, at most. pbrt-v4
/// updates tev every 250 ms from the rendering process itself; here an
/// update costs the event loop, the watcher's stream and its HTTP/2
/// connection a wakeup, so a farm's watchers are sent one every two seconds
/// at most (an embedded render still shows tev its changes every 250 ms,
/// `farm_cli::display::INTERVAL`), and each goes out with a progress event
/// the watcher is sent anyway (`live::Pace`).
pub const LIVE_EVERY: Duration = Duration::from_secs(2);

/// A live watcher is sent an update once this many of its pixels (64
/// tiles' worth) are waiting, so the fixed cost of an update stays a small
/// part of the cost of merging the tiles it shows, however slowly a render
/// goes…
pub const LIVE_BATCH_PIXELS: usize = 64 * 16 * 16;
/// …or, with fewer waiting, once this long has passed since the last.
pub const LIVE_AT_MOST_EVERY: Duration = Duration::from_secs(5);

/// Settings of a coordinator.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// How often workers must send a heartbeat; a worker silent for three
    /// intervals is declared lost.
    pub heartbeat_interval: Duration,
    /// Scheduling limits.
    pub scheduler: SchedulerConfig,
    /// The largest film and sample counts a job may have.
    pub limits: Limits,
    /// TLS and tokens, or neither (loopback only).
    pub security: Security,
    /// The state directory, retention and blob limits.
    pub state: StateConfig,
    /// A job not submitted with `--detach` is cancelled when no client has
    /// watched it for this long.
    pub client_grace: Duration,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig::with_heartbeat(Duration::from_secs(2))
    }
}

impl ServerConfig {
    /// Defaults with the given heartbeat interval (lost after three).
    pub fn with_heartbeat(heartbeat_interval: Duration) -> Self {
        ServerConfig {
            heartbeat_interval,
            scheduler: SchedulerConfig {
                worker_timeout: heartbeat_interval * 3,
                ..Default::default()
            },
            limits: Limits::default(),
            security: Security::Insecure,
            state: StateConfig::default(),
            client_grace: Duration::from_secs(120),
        }
    }
}

/// Serves the coordinator on `listener` until `shutdown` completes; then
/// tells clients of unfinished jobs and stops. With a state directory,
/// jobs it held when it last stopped (or was killed) resume first.
pub async fn serve(
    listener: TcpListener,
    config: ServerConfig,
    shutdown: impl Future<Output = ()> + Send,
) -> crate::error::Result<()> {
    let state = State::open(&config.state)?;
    let blobs = state.blobs.clone();
    let durable = config.state.dir.is_some();
    let metrics = std::sync::Arc::new(crate::metrics::Metrics::new());
    let journal = durable.then(|| state.journal.clone());
    let loop_state = events::LoopState {
        journal: journal.clone(),
        blobs: blobs.clone(),
        jobs: state.jobs,
        next_job: state.next_job,
        metrics: metrics.clone(),
    };
    // The lock on the state directory is held until the server stops.
    let _lock = state.lock;
    let (events, rx) = events::channel();
    let mut loop_task = tokio::spawn(events::run(rx, config.clone(), loop_state));
    let ticker = {
        let events = events.clone();
        let every = config.heartbeat_interval;
        tokio::spawn(async move {
            let mut t = tokio::time::interval(every);
            loop {
                t.tick().await;
                if events.send(Event::Tick).is_err() {
                    break;
                }
            }
        })
    };
    let live_ticker = {
        let events = events.clone();
        tokio::spawn(async move {
            let mut t = tokio::time::interval(LIVE_EVERY);
            t.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                t.tick().await;
                if events.send(Event::LiveTick).is_err() {
                    break;
                }
            }
        })
    };
    let svc = service::CoordinatorService::new(
        events.clone(),
        config.heartbeat_interval,
        config.limits,
        blobs,
    );
    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_service_status("", tonic_health::ServingStatus::Serving).await;
    let grpc = CoordinatorServer::new(svc)
        .max_decoding_message_size(MAX_MESSAGE_SIZE)
        .max_encoding_message_size(MAX_MESSAGE_SIZE);
    // Every call of the farm's service is authenticated first; the health
    // service answers anyone (probes carry no token).
    let grpc = InterceptedService::new(grpc, Authenticate(config.security.clone()));
    let web = crate::web::router(crate::web::Web {
        events: events.clone(),
        security: config.security.clone(),
        metrics,
        journal,
    });
    let stop_events = events.clone();
    // HTTP/1.1 too, for browsers on a plaintext (loopback) coordinator;
    // over TLS they speak HTTP/2 like gRPC does.
    let mut builder = tonic::transport::Server::builder().accept_http1(true);
    if let Security::Tls { identity, .. } = &config.security {
        let id = Identity::from_pem(&identity.chain_pem, &identity.key_pem);
        builder = builder.tls_config(ServerTlsConfig::new().identity(id))?;
    }
    let routes = tonic::service::Routes::from(web).add_service(health_service).add_service(grpc);
    let result = builder
        .add_routes(routes)
        // Tiles and assignments are small messages: no Nagle delays.
        .serve_with_incoming_shutdown(TcpIncoming::from(listener).with_nodelay(Some(true)), async {
            // Stop on request, or if the scheduler's loop ever dies: a
            // coordinator without its scheduler must not linger.
            tokio::select! {
                _ = shutdown => {
                    tracing::info!("coordinator shutting down");
                    let _ = stop_events.send(Event::Shutdown);
                }
                r = &mut loop_task => {
                    tracing::error!(?r, "the scheduler stopped unexpectedly");
                }
            }
        })
        .await;
    ticker.abort();
    live_ticker.abort();
    let _ = events.send(Event::Shutdown);
    drop(events);
    let loop_result = if loop_task.is_finished() { Ok(()) } else { loop_task.await };
    result?;
    loop_result.map_err(|e| crate::error::Error::Scheduler(e.to_string()))
}
