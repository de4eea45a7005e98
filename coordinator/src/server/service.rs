//! The `renderfarm.v1.Coordinator` service: checks what arrives from the
//! network and turns it into scheduler events.

use super::events::{Event, EventTx, FromWorker};
use crate::error::Error;
use crate::merge::Film;
use crate::scheduler::Owner;
use crate::security::{require, Action, Principal};
use crate::state::BlobStore;
use farm_common::film::Limits;
use farm_common::ids::{JobId, WorkerId};
use farm_proto::auth::Role;
use farm_proto::v1::{self, coordinator_server::Coordinator, worker_message};
use farm_proto::{default_in_flight, BLOB_CHUNK_SIZE, PROTOCOL_VERSION};
use std::collections::HashMap;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::AsyncReadExt;
use tokio::sync::{mpsc, oneshot};
use tokio_stream::wrappers::{ReceiverStream, UnboundedReceiverStream};
use tokio_stream::{Stream, StreamExt};
use tonic::{Request, Response, Status, Streaming};
use tracing::{debug, info, warn};

/// Bytes per `FetchBlob` chunk: smaller than uploads' chunks, since what a
/// stalled reader pins in memory is a few of them.
const DOWNLOAD_CHUNK: usize = BLOB_CHUNK_SIZE / 4;

type BoxStream<T> = Pin<Box<dyn Stream<Item = Result<T, Status>> + Send>>;

/// The service; cheap to clone.
#[derive(Clone)]
pub struct CoordinatorService {
    events: EventTx,
    blobs: BlobStore,
    registered: Arc<Mutex<Registry>>,
    next_worker: Arc<AtomicU64>,
    heartbeat: Duration,
    limits: Limits,
    /// Open WatchJob streams per token.
    watches: Arc<Mutex<HashMap<String, u32>>>,
}

/// The most WatchJob streams one token may have open: each may hold a
/// finished image its reader has not taken yet.
pub const MAX_WATCHES_PER_TOKEN: u32 = 16;

/// A WatchJob stream that gives its token's slot back when it ends.
struct Watched {
    inner: Option<UnboundedReceiverStream<Result<v1::JobEvent, Status>>>,
    /// Previews, for a live watcher: taken before the events, and over when
    /// the events are.
    live: Option<ReceiverStream<Result<v1::JobEvent, Status>>>,
    slots: Arc<Mutex<HashMap<String, u32>>>,
    token: String,
}

impl Stream for Watched {
    type Item = Result<v1::JobEvent, Status>;
    fn poll_next(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Self::Item>> {
        if let Some(live) = &mut self.live {
            if let std::task::Poll::Ready(Some(ev)) = Pin::new(live).poll_next(cx) {
                return std::task::Poll::Ready(Some(ev));
            }
        }
        match &mut self.inner {
            Some(s) => Pin::new(s).poll_next(cx),
            None => std::task::Poll::Ready(None),
        }
    }
}

impl Drop for Watched {
    fn drop(&mut self) {
        let mut m = self.slots.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = m.get_mut(&self.token) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                m.remove(&self.token);
            }
        }
    }
}

impl CoordinatorService {
    /// A service feeding `events`, refusing jobs over `limits`, keeping
    /// blobs in `blobs`.
    pub fn new(events: EventTx, heartbeat: Duration, limits: Limits, blobs: BlobStore) -> Self {
        CoordinatorService {
            events,
            blobs,
            registered: Arc::default(),
            next_worker: Arc::new(AtomicU64::new(1)),
            heartbeat,
            limits,
            watches: Arc::default(),
        }
    }

    fn registry(&self) -> std::sync::MutexGuard<'_, Registry> {
        // The registry's invariants hold between statements: a panic
        // elsewhere cannot leave it half-changed.
        self.registered.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Refuses a client's call about a job another token submitted (an
    /// admin may act on any job).
    async fn check_owner(&self, by: &Principal, job: JobId) -> Result<(), Status> {
        if by.role == Role::Admin {
            return Ok(());
        }
        let (reply, rx) = oneshot::channel();
        self.send(Event::Owner { job, reply })?;
        match answer(rx).await? {
            Some(owner) if owner.id != by.id => {
                warn!(job = job.0, token = %by.id, "call refused: another client's job");
                Err(Error::NotYourJob(job.0).into())
            }
            _ => Ok(()),
        }
    }

    fn send(&self, ev: Event) -> Result<(), Status> {
        self.events.send(ev).map_err(|_| Error::ShuttingDown.into())
    }
}

/// Workers that registered, each with the secret its session must present.
#[derive(Default)]
struct Registry {
    workers: HashMap<WorkerId, Registration>,
    /// How many registrations the last sweep of unused ones left.
    after_sweep: usize,
}

struct Registration {
    name: String,
    threads: u32,
    key: [u8; 32],
    at: std::time::Instant,
    /// Whether its Work stream is open.
    live: bool,
}

/// A registration whose worker never opens its session is forgotten after
/// this long, so registrations alone cannot fill the coordinator's memory.
const UNUSED_REGISTRATION: Duration = Duration::from_secs(60);

/// Registrations are swept once there are twice as many as the last sweep
/// left, and at least this many: the sweep costs O(1) a registration, not
/// a scan of every worker (10,000 workers registering made 10⁸ checks),
/// and at most twice what a sweep on every call would keep is held.
const SWEEP_FROM: usize = 64;

impl Registry {
    fn register(&mut self, id: WorkerId, name: String, threads: u32) -> Result<[u8; 32], Status> {
        let now = std::time::Instant::now();
        if self.workers.len() >= (2 * self.after_sweep).max(SWEEP_FROM) {
            self.workers.retain(|_, r| r.live || now.duration_since(r.at) < UNUSED_REGISTRATION);
            self.after_sweep = self.workers.len();
        }
        let mut key = [0u8; 32];
        getrandom::fill(&mut key).map_err(|e| Error::Random(e.to_string()))?;
        self.workers.insert(id, Registration { name, threads, key, at: now, live: false });
        Ok(key)
    }

    /// Opens the session of `id` for the holder of `key`: refused for an
    /// unknown id, a wrong key, or a session already open.
    fn open(&mut self, id: WorkerId, key: &[u8]) -> Result<(String, u32), Error> {
        let r = self.workers.get_mut(&id).ok_or(Error::UnknownWorker)?;
        if !constant_time_eq::constant_time_eq(&r.key, key) {
            return Err(Error::UnknownWorker);
        }
        if r.live {
            return Err(Error::SessionOpen);
        }
        r.live = true;
        Ok((r.name.clone(), r.threads))
    }

    /// The session of `id` ended: the worker registers again to come back.
    fn close(&mut self, id: WorkerId) {
        self.workers.remove(&id);
    }
}

fn check_version(v: u32) -> Result<(), Status> {
    if v != PROTOCOL_VERSION {
        return Err(Error::ProtocolVersion(v).into());
    }
    Ok(())
}

/// The event loop's answer; none means it has stopped.
async fn answer<T>(rx: oneshot::Receiver<T>) -> Result<T, Status> {
    rx.await.map_err(|_| Error::ShuttingDown.into())
}

#[tonic::async_trait]
impl Coordinator for CoordinatorService {
    async fn register_worker(
        &self,
        req: Request<v1::RegisterWorkerRequest>,
    ) -> Result<Response<v1::RegisterWorkerResponse>, Status> {
        require(&req, Action::Work)?;
        let r = req.into_inner();
        if let Err(e) = check_version(r.protocol_version) {
            warn!(name = %r.name, version = r.protocol_version, "worker refused: protocol mismatch");
            return Err(e);
        }
        let id = WorkerId(self.next_worker.fetch_add(1, Ordering::Relaxed));
        info!(worker = id.0, name = %r.name, threads = r.threads, "worker registered");
        let key = self.registry().register(id, r.name, r.threads)?;
        Ok(Response::new(v1::RegisterWorkerResponse {
            worker_id: id.0,
            heartbeat_interval_ms: self.heartbeat.as_millis() as u32,
            session_key: key.to_vec(),
        }))
    }

    type WorkStream = BoxStream<v1::CoordinatorMessage>;

    async fn work(
        &self,
        req: Request<Streaming<v1::WorkerMessage>>,
    ) -> Result<Response<Self::WorkStream>, Status> {
        require(&req, Action::Work)?;
        let mut inbound = req.into_inner();
        let first = inbound.message().await?.ok_or(Error::EmptyWorkStream)?;
        let Some(worker_message::Kind::Hello(hello)) = first.kind else {
            return Err(Error::NoHello.into());
        };
        let id = WorkerId(hello.worker_id);
        let (name, threads) = self.registry().open(id, &hello.session_key).inspect_err(|e| {
            warn!(worker = id.0, error = %e, "work stream refused");
        })?;
        let (tx, rx) = mpsc::unbounded_channel();
        let max_in_flight = if hello.max_in_flight == 0 {
            default_in_flight(threads as usize)
        } else {
            hello.max_in_flight
        };
        if let Err(e) = self.send(Event::WorkerJoined { id, name, threads, max_in_flight, tx }) {
            self.registry().close(id);
            return Err(e);
        }
        let events = self.events.clone();
        let registered = self.registered.clone();
        tokio::spawn(async move {
            loop {
                match inbound.message().await {
                    Ok(Some(m)) => {
                        let msg = FromWorker::decode(id, m.kind);
                        if events.send(Event::FromWorker { id, msg }).is_err() {
                            break;
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        warn!(worker = id.0, error = %e, "worker stream broke");
                        break;
                    }
                }
            }
            let _ = events.send(Event::WorkerGone { id });
            registered.lock().unwrap_or_else(|p| p.into_inner()).close(id);
        });
        Ok(Response::new(Box::pin(UnboundedReceiverStream::new(rx))))
    }

    type FetchBlobStream = BoxStream<v1::BlobChunk>;

    async fn fetch_blob(
        &self,
        req: Request<v1::FetchBlobRequest>,
    ) -> Result<Response<Self::FetchBlobStream>, Status> {
        require(&req, Action::Work)?;
        let hash = req.into_inner().hash;
        let (mut file, total) = self.blobs.open_file(&hash).await.ok_or(Error::NoBlob)?;
        // Read from disk a chunk at a time, no further ahead than the
        // reader takes them: a stalled reader holds a few small chunks
        // (one queued, one in HTTP/2's send buffer), not the blob.
        let (tx, rx) = mpsc::channel(1);
        tokio::spawn(async move {
            let mut offset = 0u64;
            loop {
                let want = (total - offset).min(DOWNLOAD_CHUNK as u64) as usize;
                let mut data = vec![0u8; want];
                if let Err(e) = file.read_exact(&mut data).await {
                    let _ = tx.send(Err(Error::Store(e.to_string()).into())).await;
                    return;
                }
                let chunk = v1::BlobChunk { hash: hash.clone(), total_size: total, offset, data };
                if tx.send(Ok(chunk)).await.is_err() {
                    return;
                }
                offset += want as u64;
                if offset >= total {
                    return;
                }
            }
        });
        Ok(Response::new(Box::pin(ReceiverStream::new(rx))))
    }

    async fn upload_blob(
        &self,
        req: Request<Streaming<v1::BlobChunk>>,
    ) -> Result<Response<v1::UploadBlobResponse>, Status> {
        let by = require(&req, Action::Submit)?;
        let mut stream = req.into_inner();
        // Each chunk is checked, hashed and written as it arrives: a bad
        // upload costs one chunk of memory, whatever it claims.
        let mut upload = self.blobs.upload(&by.id);
        let result = async {
            while let Some(c) = stream.next().await {
                upload.push(&c?).await?;
            }
            Ok::<_, Status>(upload.finish().await?)
        }
        .await;
        let (_, size) = result.inspect_err(|e| {
            warn!(error = %e.message(), token = %by.id, "upload refused");
        })?;
        Ok(Response::new(v1::UploadBlobResponse { size }))
    }

    async fn submit_job(
        &self,
        req: Request<v1::SubmitJobRequest>,
    ) -> Result<Response<v1::SubmitJobResponse>, Status> {
        let by = require(&req, Action::Submit)?;
        let r = req.into_inner();
        check_version(r.protocol_version)?;
        let owner = Owner { id: by.id, name: by.name };
        let spec = super::submission::job_spec(&self.blobs, &self.limits, r, owner).await?;
        // The film (its pages mapped, 32 bytes a pixel) is made here, off
        // the event loop, once the spec has passed its limits.
        let geometry = spec.geometry.clone();
        let film = tokio::task::spawn_blocking(move || Box::new(Film::new(geometry)))
            .await
            .map_err(|e| Status::internal(format!("making the job's film: {e}")))?;
        let (reply, rx) = oneshot::channel();
        self.send(Event::Submit { spec: Box::new(spec), film, reply })?;
        let id = answer(rx).await??;
        Ok(Response::new(v1::SubmitJobResponse { job_id: id.0 }))
    }

    type WatchJobStream = BoxStream<v1::JobEvent>;

    async fn watch_job(
        &self,
        req: Request<v1::WatchJobRequest>,
    ) -> Result<Response<Self::WatchJobStream>, Status> {
        let by = require(&req, Action::Submit)?;
        let r = req.into_inner();
        let job = JobId(r.job_id);
        self.check_owner(&by, job).await?;
        let slot = {
            let mut m = self.watches.lock().unwrap_or_else(|p| p.into_inner());
            let n = m.entry(by.id.clone()).or_default();
            (*n < MAX_WATCHES_PER_TOKEN).then(|| {
                *n += 1;
                Watched {
                    inner: None,
                    live: None,
                    slots: self.watches.clone(),
                    token: by.id.clone(),
                }
            })
        };
        let Some(mut slot) = slot else {
            // Its client waits for a slot (`farm_cli::client::follow`) and
            // asks again, twice a second: no warning each time. Its job
            // must not be cancelled as left meanwhile, and a job that does
            // not exist is said so, not waited for.
            debug!(token = %by.id, job = job.0, "watch refused: too many open");
            let (reply, known) = oneshot::channel();
            self.send(Event::WatchWaiting { job, reply })?;
            if !answer(known).await? {
                return Err(Error::NoJob(job.0).into());
            }
            return Err(Error::TooManyWatches(MAX_WATCHES_PER_TOKEN).into());
        };
        let (tx, rx) = mpsc::unbounded_channel();
        // One preview waiting at most: the loop sends the next only once
        // this reader has taken it.
        let (live, live_rx) = if r.live {
            let (t, r) = mpsc::channel(1);
            (Some(t), Some(ReceiverStream::new(r)))
        } else {
            (None, None)
        };
        let (reply, known) = oneshot::channel();
        self.send(Event::Watch { job, tx, live, reply })?;
        // No answer at all means the event loop has stopped: the
        // coordinator is shutting down, which is not the same as "no job".
        // (The slot is given back if this fails: `slot` is dropped.)
        if !answer(known).await? {
            return Err(Error::NoJob(job.0).into());
        }
        slot.inner = Some(UnboundedReceiverStream::new(rx));
        slot.live = live_rx;
        Ok(Response::new(Box::pin(slot)))
    }

    async fn get_status(
        &self,
        req: Request<v1::GetStatusRequest>,
    ) -> Result<Response<v1::GetStatusResponse>, Status> {
        let by = require(&req, Action::Submit)?;
        let (reply, rx) = oneshot::channel();
        self.send(Event::Status { reply })?;
        let (mut jobs, workers) = answer(rx).await?;
        // A client lists its own jobs; an admin every job.
        if by.role != Role::Admin {
            jobs.retain(|j| j.owner.id == by.id);
        }
        Ok(Response::new(v1::GetStatusResponse {
            jobs: jobs
                .into_iter()
                .map(|j| v1::JobStatus {
                    job_id: j.id.0,
                    name: j.name,
                    state: j.state.to_string(),
                    tiles_done: j.done,
                    tiles_total: j.total,
                    priority: j.priority,
                    owner: j.owner.name,
                    attempts: j.attempts,
                    retries: j.retries,
                    speculated: j.speculated,
                    shot: j.shot.map(|s| v1::ShotFrame {
                        shot: s.shot.0,
                        frame: s.frame,
                        frames: s.frames,
                    }),
                })
                .collect(),
            workers: workers
                .into_iter()
                .map(|w| v1::WorkerStatus {
                    worker_id: w.id.0,
                    name: w.name,
                    threads: w.threads,
                    in_flight: w.in_flight,
                    tiles_done: w.tiles_done,
                })
                .collect(),
        }))
    }

    async fn cancel_job(
        &self,
        req: Request<v1::CancelJobRequest>,
    ) -> Result<Response<v1::CancelJobResponse>, Status> {
        let by = require(&req, Action::Submit)?;
        let job = JobId(req.into_inner().job_id);
        self.check_owner(&by, job).await?;
        let (reply, rx) = oneshot::channel();
        self.send(Event::Cancel { job, reply })?;
        let cancelled = answer(rx).await?;
        Ok(Response::new(v1::CancelJobResponse { cancelled }))
    }
}
