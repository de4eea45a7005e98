//! Tests of a worker's session against a scripted coordinator.

use super::*;
use crate::testing::{scene_blobs, start_fake, tiny_scene, FakeSession};
use farm_proto::v1::tile_result::Outcome;
use farm_proto::v1::{CoordinatorMessage, JobCancelled, TileAssignment, TileResult};

fn config(coordinator: String, reconnect: bool) -> WorkerConfig {
    WorkerConfig { coordinator, threads: 2, name: "t".into(), reconnect, ..Default::default() }
}

fn assign(job_id: u64, tile: u32, scene_hash: &[u8]) -> Result<CoordinatorMessage, tonic::Status> {
    let a = TileAssignment {
        job_id,
        tile,
        attempt: 0,
        scene_hash: scene_hash.to_vec(),
        spp: 0,
        samples: None,
        part: 0,
    };
    Ok(CoordinatorMessage { kind: Some(FromCoordinator::Assign(a)) })
}

/// The next tile result, skipping heartbeats.
async fn next_result(s: &mut FakeSession) -> TileResult {
    loop {
        match s.from_worker.recv().await.expect("stream ended").kind {
            Some(ToCoordinator::Result(r)) => return r,
            Some(ToCoordinator::Heartbeat(_)) => {}
            other => panic!("unexpected {other:?}"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_renders_tiles_and_stops_cleanly() {
    let (hash, mut blobs) = scene_blobs(&tiny_scene(32));
    let (big, big_blobs) = scene_blobs(&tiny_scene(256));
    blobs.extend(big_blobs);
    let (url, mut sessions, fetches) = start_fake(blobs, false).await;
    let (stop, stopped) = oneshot::channel::<()>();
    let worker = tokio::spawn(run(config(url, false), async {
        let _ = stopped.await;
    }));
    let mut s = sessions.recv().await.unwrap();
    let hello = s.from_worker.recv().await.unwrap().kind;
    assert_eq!(
        hello,
        Some(ToCoordinator::Hello(Hello {
            worker_id: 7,
            max_in_flight: 10,
            session_key: vec![7; 32]
        }))
    );

    // Four tiles of one job: each comes back once, with film and stats.
    for tile in 0..4 {
        s.to_worker.send(assign(1, tile, &hash)).await.unwrap();
    }
    let mut got = Vec::new();
    for _ in 0..4 {
        let r = next_result(&mut s).await;
        assert!(matches!(r.outcome, Some(Outcome::FilmTile(_))), "{r:?}");
        assert!(r.stats.unwrap().camera_rays > 0);
        got.push(r.tile);
    }
    got.sort();
    assert_eq!(got, vec![0, 1, 2, 3]);
    assert_eq!(fetches.load(Ordering::SeqCst), 2, "manifest and asset, once each");

    // Bad assignments fail without killing the session.
    s.to_worker.send(assign(2, 0, b"short")).await.unwrap();
    s.to_worker.send(assign(3, 0, &[0; 32])).await.unwrap();
    s.to_worker.send(assign(1, 99, &hash)).await.unwrap();
    // A part of a tile whose sampler has state (the random sampler's)
    // cannot be drawn apart: refused, retryable by the tile's holder.
    let mut part = assign(1, 0, &hash);
    if let Ok(CoordinatorMessage { kind: Some(FromCoordinator::Assign(a)) }) = &mut part {
        a.part = 2;
    }
    s.to_worker.send(part).await.unwrap();
    let mut failures = Vec::new();
    for _ in 0..4 {
        let r = next_result(&mut s).await;
        let Some(Outcome::Failure(f)) = r.outcome else { panic!("{r:?}") };
        failures.push((r.job_id, f.retryable));
    }
    failures.sort();
    assert_eq!(failures, vec![(1, false), (1, true), (2, false), (3, false)]);

    // A cancelled job's tiles are not reported once the cancel arrives;
    // later jobs still are. (Tiles finished before it may be.)
    for tile in 0..16 {
        let mut a = assign(4, tile, &big);
        if let Ok(CoordinatorMessage { kind: Some(FromCoordinator::Assign(a)) }) = &mut a {
            a.spp = 64;
        }
        s.to_worker.send(a).await.unwrap();
    }
    let cancel =
        CoordinatorMessage { kind: Some(FromCoordinator::Cancelled(JobCancelled { job_id: 4 })) };
    s.to_worker.send(Ok(cancel)).await.unwrap();
    s.to_worker.send(assign(5, 0, &hash)).await.unwrap();
    let mut cancelled_sent = 0;
    while next_result(&mut s).await.job_id == 4 {
        cancelled_sent += 1;
    }
    assert!(cancelled_sent < 16, "{cancelled_sent} tiles of a cancelled job were sent");

    // Heartbeats flow while idle.
    let beat = s.from_worker.recv().await.unwrap().kind;
    assert_eq!(beat, Some(ToCoordinator::Heartbeat(Heartbeat {})));

    // Shutdown closes the worker's side of the stream and returns Ok.
    stop.send(()).unwrap();
    let summary = worker.await.unwrap().unwrap();
    assert_eq!(summary.tiles_rendered, 5 + cancelled_sent);
    while let Some(m) = s.from_worker.recv().await {
        assert!(matches!(m.kind, Some(ToCoordinator::Heartbeat(_))), "{m:?}");
    }
}

#[tokio::test]
async fn a_lost_coordinator_ends_or_restarts_the_session() {
    let (url, mut sessions, _) = start_fake(Vec::new(), false).await;
    // Without reconnect, the end of the stream is an error.
    let worker = tokio::spawn(run(config(url.clone(), false), std::future::pending()));
    drop(sessions.recv().await.unwrap());
    assert!(matches!(worker.await.unwrap(), Err(Error::Stream { .. })));
    // With reconnect, the worker registers again.
    let (stop, stopped) = oneshot::channel::<()>();
    let worker = tokio::spawn(run(config(url, true), async {
        let _ = stopped.await;
    }));
    drop(sessions.recv().await.unwrap());
    let mut again = sessions.recv().await.unwrap();
    assert!(matches!(again.from_worker.recv().await.unwrap().kind, Some(ToCoordinator::Hello(_))));
    stop.send(()).unwrap();
    assert_eq!(worker.await.unwrap().unwrap(), WorkerSummary { tiles_rendered: 0 });
}

#[tokio::test]
async fn refusal_and_absence_fail_fast() {
    let (url, _sessions, _) = start_fake(Vec::new(), true).await;
    let err = run(config(url, true), std::future::pending()).await.unwrap_err();
    let Error::Refused { message } = err else { panic!("{err}") };
    assert!(message.contains("protocol version"));
    // Nothing listens on port 1.
    let err = run(config("http://127.0.0.1:1".into(), false), std::future::pending()).await;
    assert!(matches!(err, Err(Error::Connect(ConnectError::Failed { .. }))));
    let err = run(config("not a uri".into(), true), std::future::pending()).await;
    assert!(matches!(err, Err(Error::Connect(ConnectError::BadUrl(_)))));
    // https needs a token to know which CA to trust, and says so.
    let err = run(config("https://127.0.0.1:1".into(), true), std::future::pending()).await;
    assert!(matches!(err, Err(Error::Connect(ConnectError::NeedToken(_)))));
}

#[tokio::test]
async fn shutdown_interrupts_reconnecting() {
    let (stop, stopped) = oneshot::channel::<()>();
    let worker = tokio::spawn(run(config("http://127.0.0.1:1".into(), true), async {
        let _ = stopped.await;
    }));
    tokio::time::sleep(Duration::from_millis(300)).await;
    stop.send(()).unwrap();
    assert_eq!(worker.await.unwrap().unwrap().tiles_rendered, 0);
}
