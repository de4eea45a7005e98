//! The event loop's shutdown, driven through `run` itself.

use super::events::{self, Event, FromWorker, LoopState};
use super::ServerConfig;
use crate::merge::Film;
use crate::scheduler::tests::{render, spec};
use crate::scheduler::JobSpec;
use crate::state::{State, StateConfig};
use farm_common::film::{FilmGeometry, PassPlan};
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_proto::v1::{self, coordinator_message, job_event};
use tokio::sync::{mpsc, oneshot};

/// What a watcher of a job whose last tile (of its first pass, with
/// `passes`) came in just before the coordinator was told to stop is sent,
/// with or without a state directory; and how many more tiles the worker
/// was handed out after it.
async fn watch_a_job_ended_by_a_shutdown(
    dir: Option<std::path::PathBuf>,
    passes: Option<PassPlan>,
) -> (Vec<String>, usize) {
    let config = StateConfig { dir, ..StateConfig::default() };
    let state = State::open(&config).expect("a state");
    let durable = config.dir.is_some();
    let loop_state = LoopState {
        journal: durable.then(|| state.journal.clone()),
        blobs: state.blobs.clone(),
        jobs: state.jobs,
        next_job: state.next_job,
        metrics: std::sync::Arc::new(crate::metrics::Metrics::new()),
    };
    let (events, rx) = events::channel();
    let server = ServerConfig { state: config, ..ServerConfig::default() };
    let run = tokio::spawn(events::run(rx, server, loop_state));

    // A film large enough that its end takes a while off the loop.
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(1024, 1024));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 1.0, f32::INFINITY, "x".into(), 35.0);
    let spp = passes.as_ref().map_or(2, |p| *p.totals.last().unwrap());
    let spec = JobSpec { spp, geometry: g.clone(), detach: true, passes, ..spec(0) };
    let (worker_tx, mut to_worker) = mpsc::unbounded_channel();
    let id = WorkerId(1);
    let joined =
        Event::WorkerJoined { id, name: "w".into(), threads: 1, max_in_flight: 64, tx: worker_tx };
    events.send(joined).unwrap();
    let (reply, job) = oneshot::channel();
    let film = Box::new(Film::new(g.clone()));
    events.send(Event::Submit { spec: Box::new(spec), film, reply }).unwrap();
    let job: JobId = job.await.unwrap().expect("the job is taken");
    let (watch_tx, mut watched) = mpsc::unbounded_channel();
    let (reply, exists) = oneshot::channel();
    events.send(Event::Watch { job, tx: watch_tx, live: None, reply }).unwrap();
    assert!(exists.await.unwrap());

    // The worker answers every hand-out; right behind the last tile, stop.
    let total = g.tile_count();
    let mut sent = 0;
    while sent < total {
        let msg = to_worker.recv().await.expect("hand-outs").expect("not an error");
        let Some(coordinator_message::Kind::Assign(a)) = msg.kind else { continue };
        let tile = TileId(a.tile);
        let key = TileAttempt { job, tile, attempt: a.attempt };
        let msg = FromWorker::Tile { key, film_tile: render(&g, tile), stats: Default::default() };
        events.send(Event::FromWorker { id, msg }).unwrap();
        sent += 1;
    }
    events.send(Event::Shutdown).unwrap();
    run.await.unwrap();
    let mut more = 0;
    while let Some(Ok(msg)) = to_worker.recv().await {
        more += usize::from(matches!(msg.kind, Some(coordinator_message::Kind::Assign(_))));
    }

    let mut seen = Vec::new();
    while let Some(ev) = watched.recv().await {
        let label = match ev {
            Ok(v1::JobEvent { kind: Some(job_event::Kind::Image(_)) }) => "image".to_string(),
            Ok(v1::JobEvent { kind: Some(job_event::Kind::Failed(f)) }) => f.message,
            Ok(_) => continue,
            Err(status) => status.message().to_string(),
        };
        if seen.last() != Some(&label) {
            seen.push(label);
        }
    }
    (seen, more)
}

/// A job whose every tile is in when the coordinator is told to stop is
/// delivered, not failed ("shutting down") nor left to be merged again at
/// the next start: the stop waits for its film's end off the loop.
#[tokio::test]
async fn a_shutdown_waits_for_a_film_being_ended() {
    let seen = watch_a_job_ended_by_a_shutdown(None, None).await;
    assert_eq!(seen, (vec!["image".to_string()], 0), "without a state directory");
    let tmp = tempfile::Builder::new().prefix("farm-shutdown-").tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    let seen = watch_a_job_ended_by_a_shutdown(Some(dir.clone()), None).await;
    assert_eq!(seen, (vec!["image".to_string()], 0), "with a state directory");
    // The next start finds it done: nothing to resume.
    let state = State::open(&StateConfig { dir: Some(dir.clone()), ..StateConfig::default() });
    let resumed = state.expect("the state reopens").jobs;
    assert_eq!(resumed.len(), 1, "the job is kept");
    assert!(resumed[0].ending.is_some(), "as ended, not to be resumed");
}

/// A stop while a pass's estimate is worked out neither waits for it nor
/// starts the next pass: no tile of it is handed out, and the job fails
/// as any unfinished job does without a state directory.
#[tokio::test]
async fn a_shutdown_does_not_start_the_next_pass() {
    let plan = PassPlan::new(16, Some(1e-12), None);
    let (seen, more) = watch_a_job_ended_by_a_shutdown(None, Some(plan)).await;
    assert_eq!(seen, ["the coordinator is shutting down"]);
    assert_eq!(more, 0, "tiles of the next pass were handed out");
}
