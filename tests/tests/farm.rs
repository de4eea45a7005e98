//! The farm over gRPC on loopback: whatever the number of workers, however
//! they fail, the image is bit-identical to the embedded render.

use farm_cli::client::{self, RemoteOptions};
use farm_cli::embedded::{self as submit, RenderSummary, SubmitOptions};
use farm_common::image::RgbImage;
use farm_proto::v1::{
    self, coordinator_client::CoordinatorClient, coordinator_message, worker_message,
};
use farm_proto::PROTOCOL_VERSION;
use farm_tests::cluster::TestCluster;
use farm_tests::{bits, example_scene as scene};
use std::time::Duration;
use tokio::sync::mpsc;

const SPP: u32 = 2;

fn embedded() -> RgbImage {
    farm_tests::embedded_example(SPP)
}

async fn remote(url: &str) -> RgbImage {
    let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
    remote_render(url, &scene(), &opts).await.image
}

/// `path` rendered on the farm at `url`.
async fn remote_render(url: &str, path: &std::path::Path, opts: &RemoteOptions) -> RenderSummary {
    client::submit(&farm_cli::client::Remote::insecure(url), path, opts, |_, _| {})
        .await
        .expect("farm render")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn one_two_and_four_workers_match_the_embedded_render_bit_for_bit() {
    let reference = bits(&embedded());
    for n in [1, 2, 4] {
        let cluster = TestCluster::start(n, Duration::from_millis(500)).await;
        let image = remote(&cluster.url).await;
        assert!(bits(&image) == reference, "{n} workers: image differs from the embedded render");
        cluster.stop().await;
    }
}

/// A scene whose lights must keep their directive order (an area light
/// before two `LightSource`s, another after) renders on a worker what it
/// renders embedded: the order travels in the manifest.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_lights_order_travels_to_the_workers() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/parity/twins/light-order.pbrt");
    let opts = SubmitOptions { threads: 2, ..Default::default() };
    let local = submit::render(&path, &opts, |_| {}).expect("embedded render").image;
    let cluster = TestCluster::start(1, Duration::from_millis(500)).await;
    let remote = remote_render(&cluster.url, &path, &RemoteOptions::default()).await.image;
    assert!(bits(&remote) == bits(&local), "the farm's image differs from the embedded render");
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_worker_killed_mid_job_changes_no_bit() {
    let reference = bits(&embedded());
    let cluster = TestCluster::start(2, Duration::from_millis(200)).await;
    let victim = cluster.workers[0].abort_handle();
    let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
    let mut killed = false;
    let summary = client::submit(
        &farm_cli::client::Remote::insecure(&cluster.url),
        &scene(),
        &opts,
        |_, p| {
            if !killed && p.tiles_done * 5 >= p.tiles_total {
                victim.abort();
                killed = true;
            }
        },
    )
    .await
    .expect("farm render");
    assert!(killed, "the worker was killed during the job");
    assert!(bits(&summary.image) == reference, "image differs after a worker was killed");
    cluster.stop().await;
}

async fn fake_worker(
    url: &str,
    max_in_flight: u32,
) -> (mpsc::UnboundedSender<v1::WorkerMessage>, tonic::Streaming<v1::CoordinatorMessage>) {
    let w = farm_tests::fake::FakeWorker::connect(url, max_in_flight).await;
    (w.tx, w.inbound)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_stalled_worker_loses_its_tiles_without_changing_a_bit() {
    let reference = bits(&embedded());
    let cluster = TestCluster::start(0, Duration::from_millis(100)).await;
    // The staller takes tiles and never answers, not even with a heartbeat.
    let (_keep_open, mut staller) = fake_worker(&cluster.url, 8).await;
    let url = cluster.url.clone();
    let job = tokio::spawn(async move { remote(&url).await });
    let first = staller.message().await.expect("stream").expect("an assignment");
    assert!(matches!(first.kind, Some(coordinator_message::Kind::Assign(_))));
    let mut cluster = cluster;
    cluster.add_worker();
    let image = tokio::time::timeout(Duration::from_secs(120), job)
        .await
        .expect("job finishes")
        .expect("task");
    assert!(bits(&image) == reference, "image differs after a stalled worker");
    cluster.stop().await;
}

/// A worker that keeps its session alive but never finishes its tile: the
/// tile is never requeued, so the job can only end by idle workers
/// rendering it again. The example's tiles (Halton) render on all of a
/// worker's threads, so the real worker renders that tile in parts, each
/// a band of its rows, and the parts added in order give the image's bits.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_tile_held_forever_is_rendered_again_in_parts_without_changing_a_bit() {
    let reference = bits(&embedded());
    let cluster = TestCluster::start(0, Duration::from_millis(400)).await;
    let (tx, mut holder) = fake_worker(&cluster.url, 1).await;
    let url = cluster.url.clone();
    let job = tokio::spawn(async move { remote(&url).await });
    let first = holder.message().await.expect("stream").expect("an assignment");
    let Some(coordinator_message::Kind::Assign(a)) = first.kind else { panic!("{first:?}") };
    assert_eq!(a.part, 0, "a whole tile first");
    let beat = tokio::spawn(async move {
        loop {
            let msg =
                v1::WorkerMessage { kind: Some(worker_message::Kind::Heartbeat(v1::Heartbeat {})) };
            if tx.send(msg).is_err() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    });
    let mut cluster = cluster;
    cluster.add_worker();
    let image = tokio::time::timeout(Duration::from_secs(120), job)
        .await
        .expect("job finishes while the holder still holds its tile")
        .expect("task");
    assert!(bits(&image) == reference, "image differs with a tile rendered in parts");
    // The held tile went out again as its four parts (a whole second
    // hand-out would count one).
    let status = client::status(&cluster.remote()).await.expect("status");
    assert_eq!(status.jobs[0].speculated, 4);
    beat.abort();
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn duplicates_bad_tiles_and_unknown_jobs_are_refused_without_harm() {
    let reference = bits(&embedded());
    let cluster = TestCluster::start(0, Duration::from_millis(300)).await;
    let (tx, mut inbound) = fake_worker(&cluster.url, 2).await;
    let url = cluster.url.clone();
    let job = tokio::spawn(async move { remote(&url).await });
    let Some(coordinator_message::Kind::Assign(a)) =
        inbound.message().await.expect("stream").expect("msg").kind
    else {
        panic!("expected an assignment");
    };
    let result = |film_tile: v1::FilmTile, job_id: u64| v1::WorkerMessage {
        kind: Some(worker_message::Kind::Result(v1::TileResult {
            job_id,
            tile: a.tile,
            attempt: a.attempt,
            outcome: Some(v1::tile_result::Outcome::FilmTile(film_tile)),
            stats: None,
        })),
    };
    // A truncated tile, a tile with the wrong bounds, and a result for a job that does not exist.
    let truncated = v1::FilmTile { x0: 0, y0: 0, x1: 16, y1: 16, pixels: vec![0; 100] };
    let wrong = v1::FilmTile { x0: 0, y0: 0, x1: 3, y1: 3, pixels: vec![0; 9 * 16] };
    tx.send(result(truncated, a.job_id)).expect("send");
    tx.send(result(wrong.clone(), a.job_id)).expect("send");
    tx.send(result(wrong, 9999)).expect("send");
    // Then the next tile it is given, rendered for real, sent twice.
    let Some(coordinator_message::Kind::Assign(b)) =
        inbound.message().await.expect("stream").expect("msg").kind
    else {
        panic!("expected a second assignment");
    };
    let (desc, _) = farm_scene::parse_file(&scene()).expect("scene");
    let (renderer, _) = farm_render::Renderer::new(
        desc,
        &farm_render::RenderOptions { spp: Some(SPP), ..Default::default() },
    )
    .expect("renderer");
    let (tile, _) = renderer.render_tile(farm_common::ids::TileId(b.tile));
    for _ in 0..2 {
        tx.send(v1::WorkerMessage {
            kind: Some(worker_message::Kind::Result(v1::TileResult {
                job_id: b.job_id,
                tile: b.tile,
                attempt: b.attempt,
                outcome: Some(v1::tile_result::Outcome::FilmTile(v1::FilmTile::from(&tile))),
                stats: None,
            })),
        })
        .expect("send");
    }
    // Real workers finish the job; the coordinator is still answering.
    let mut cluster = cluster;
    cluster.add_worker();
    let image = tokio::time::timeout(Duration::from_secs(120), job)
        .await
        .expect("job finishes")
        .expect("task");
    assert!(bits(&image) == reference, "bad input changed the image");
    let status = client::status(&farm_cli::client::Remote::insecure(&cluster.url))
        .await
        .expect("coordinator still answers");
    assert_eq!(status.jobs[0].state, "done");
    drop(tx);
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_protocol_version_mismatch_is_refused() {
    let cluster = TestCluster::start(0, Duration::from_millis(500)).await;
    let mut c = CoordinatorClient::connect(cluster.url.clone()).await.expect("connect");
    let reg = v1::RegisterWorkerRequest {
        protocol_version: PROTOCOL_VERSION + 1,
        name: "future".into(),
        threads: 1,
    };
    let err = c.register_worker(reg).await.expect_err("refused");
    assert_eq!(err.code(), tonic::Code::FailedPrecondition);
    assert!(err.message().contains("protocol version"), "{}", err.message());
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_oversized_message_is_refused_and_the_coordinator_lives_on() {
    let cluster = TestCluster::start(0, Duration::from_millis(500)).await;
    let (tx, mut inbound) = fake_worker(&cluster.url, 1).await;
    let huge = v1::FilmTile {
        x0: 0,
        y0: 0,
        x1: 1,
        y1: 1,
        pixels: vec![0; farm_proto::MAX_MESSAGE_SIZE + 1],
    };
    tx.send(v1::WorkerMessage {
        kind: Some(worker_message::Kind::Result(v1::TileResult {
            job_id: 1,
            tile: 0,
            attempt: 0,
            outcome: Some(v1::tile_result::Outcome::FilmTile(huge)),
            stats: None,
        })),
    })
    .expect("send");
    // The coordinator drops this worker's session...
    let ended = tokio::time::timeout(Duration::from_secs(30), async {
        while let Ok(Some(_)) = inbound.message().await {}
    })
    .await;
    assert!(ended.is_ok(), "the oversized message did not end the session");
    // ...and keeps serving everyone else.
    let status = client::status(&farm_cli::client::Remote::insecure(&cluster.url))
        .await
        .expect("coordinator still answers");
    assert!(status.workers.is_empty(), "the offending worker is gone");
    cluster.stop().await;
}

/// A job whose film would need hundreds of gigabytes is refused by the
/// coordinator with a message saying so; the coordinator, which would have
/// aborted allocating it, goes on rendering other jobs.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_oversize_film_is_refused_and_the_coordinator_lives_on() {
    let cluster = TestCluster::start(1, Duration::from_millis(500)).await;
    let tmp = tempfile::Builder::new().prefix("farm-oversize-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let big = dir.join("big.pbrt");
    let film = "Film \"image\" \"integer xresolution\" 100000 \"integer yresolution\" 100000";
    std::fs::write(&big, format!("{film}\nWorldBegin\nShape \"sphere\"\nWorldEnd\n")).unwrap();
    let err = client::submit(
        &farm_cli::client::Remote::insecure(&cluster.url),
        &big,
        &RemoteOptions::default(),
        |_, _| {},
    )
    .await;
    let Err(farm_cli::Error::Rpc(status)) = err else { panic!("not refused: {err:?}") };
    assert_eq!(status.code(), tonic::Code::InvalidArgument);
    assert!(status.message().contains("10000000000 pixels"), "{}", status.message());
    let opts = RemoteOptions { spp: Some(u32::MAX), ..Default::default() };
    let err = client::submit(
        &farm_cli::client::Remote::insecure(&cluster.url),
        &scene(),
        &opts,
        |_, _| {},
    )
    .await;
    let Err(farm_cli::Error::Rpc(status)) = err else { panic!("not refused: {err:?}") };
    assert!(status.message().contains("--max-spp"), "{}", status.message());
    // The farm still renders, bit for bit as embedded.
    assert!(bits(&remote(&cluster.url).await) == bits(&embedded()));
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_shutting_down_tells_its_clients() {
    let cluster = TestCluster::start(0, Duration::from_millis(500)).await;
    let url = cluster.url.clone();
    let (watching, watched) = tokio::sync::oneshot::channel();
    let job = tokio::spawn(async move {
        let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
        let mut watching = Some(watching);
        client::submit(&farm_cli::client::Remote::insecure(&url), &scene(), &opts, |_, _| {
            if let Some(w) = watching.take() {
                let _ = w.send(());
            }
        })
        .await
    });
    // Wait until the client watches its job (there are no workers: the
    // first progress event comes when the watch opens), then stop the
    // coordinator. Other tests share the cores, so the client's parse and
    // upload may take a while; stopping before then would test a refused
    // connection instead.
    tokio::time::timeout(Duration::from_secs(120), watched)
        .await
        .expect("the job was never watched")
        .expect("the client stopped before watching");
    cluster.stop().await;
    let err = tokio::time::timeout(Duration::from_secs(30), job)
        .await
        .expect("client returns")
        .expect("task");
    match err {
        Err(e @ farm_cli::Error::JobFailed(_)) => {
            assert!(e.to_string().contains("shutting down"), "{e}")
        }
        other => {
            panic!("expected the job to fail with the shutdown, got {:?}", other.map(|s| s.output))
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_large_image_arrives_in_chunks_intact() {
    // 1024² RGB f32 is 12 MiB: more than one image chunk.
    let source = r#"
        LookAt 0 0 -4  0 0 0  0 1 0
        Camera "perspective" "float fov" 50
        Film "image" "integer xresolution" 1024 "integer yresolution" 1024
        Sampler "halton" "integer pixelsamples" 2
        Integrator "whitted"
        WorldBegin
        LightSource "point" "point from" [2 2 -3] "rgb I" [10 10 10]
        Material "matte" "rgb Kd" [0.6 0.4 0.2]
        Shape "sphere" "float radius" 1
        WorldEnd
    "#;
    let tmp = tempfile::Builder::new().prefix("farm-large-").tempdir().expect("dir");
    let dir = tmp.path();
    let path = dir.join("large.pbrt");
    std::fs::write(&path, source).expect("write");
    let embedded =
        submit::render(&path, &SubmitOptions { threads: 2, ..Default::default() }, |_| {})
            .expect("embedded");
    let cluster = TestCluster::start(2, Duration::from_millis(500)).await;
    let farm = remote_render(&cluster.url, &path, &RemoteOptions::default()).await;
    assert_eq!((farm.image.width, farm.image.height), (1024, 1024));
    assert!(bits(&farm.image) == bits(&embedded.image), "the chunked image differs");
    // The error estimate and its map come through the chunks unchanged too.
    let error = embedded.error.expect("2 spp gives an error estimate");
    assert!(error.rel_mse > 0.0 && error.per_pixel.len() == 1024 * 1024);
    assert_eq!(farm.error, Some(error), "the chunked error estimate differs");
    cluster.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_whose_client_went_away_is_cancelled_unless_detached() {
    let mut config =
        farm_coordinator::server::ServerConfig::with_heartbeat(Duration::from_millis(100));
    config.client_grace = Duration::from_millis(600);
    // No workers: both jobs stay queued, so only the grace period acts.
    let cluster = TestCluster::start_config(0, config).await;
    let remote = client::Remote::insecure(&cluster.url);
    let submit = |detach| {
        let opts = RemoteOptions { spp: Some(1), detach, ..Default::default() };
        let remote = remote.clone();
        async move { client::start(&remote, &scene(), &opts).await.expect("submit").job }
    };
    let (left, detached) = (submit(false).await, submit(true).await);
    // A third is watched throughout, and so is kept.
    let watched = submit(false).await;
    let mut c = client::connect(&remote).await.expect("connect");
    let _watch =
        c.watch_job(v1::WatchJobRequest { job_id: watched, live: false }).await.expect("watch");
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let status = client::status(&remote).await.expect("status");
    let state = |id| status.jobs.iter().find(|j| j.job_id == id).expect("job").state.clone();
    assert_eq!(state(left), "cancelled");
    assert_eq!(state(detached), "queued");
    assert_eq!(state(watched), "queued");
    cluster.stop().await;
}

/// A client whose token already has every watch it may open waits for a
/// slot instead of failing, and its job is not cancelled as left
/// meanwhile, so more scenes than that submitted at once with one token
/// all render (`farm submit` used to fail with "this client already has 16
/// job watches open"); a job that does not exist is said so at once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_refused_a_watch_slot_waits_for_one_and_keeps_its_job() {
    use farm_coordinator::server::MAX_WATCHES_PER_TOKEN;
    let mut config =
        farm_coordinator::server::ServerConfig::with_heartbeat(Duration::from_millis(100));
    // Three of the client's retries long, so that the test does not hang
    // on the scheduling of one.
    config.client_grace = Duration::from_millis(1500);
    // No workers yet: every job stays queued while the slots are taken.
    let mut cluster = TestCluster::start_config(0, config).await;
    let remote = client::Remote::insecure(&cluster.url);
    let start = |detach| {
        let opts = RemoteOptions { spp: Some(1), detach, ..Default::default() };
        let remote = remote.clone();
        async move { client::start(&remote, &scene(), &opts).await.expect("submit").job }
    };
    let held = start(true).await;
    let mut c = client::connect(&remote).await.expect("connect");
    let mut open = Vec::new();
    for _ in 0..MAX_WATCHES_PER_TOKEN {
        let s = c.watch_job(v1::WatchJobRequest { job_id: held, live: false }).await;
        open.push(s.expect("watch").into_inner());
    }
    let job = start(false).await;
    let following = {
        let remote = remote.clone();
        tokio::spawn(async move {
            client::follow(&remote, job, None, Duration::from_secs(30), |_| {}).await
        })
    };
    // With every slot taken, a job that does not exist is not waited for.
    let missing = tokio::time::timeout(
        Duration::from_secs(10),
        client::follow(&remote, job + 1000, None, Duration::from_secs(30), |_| {}),
    )
    .await
    .expect("an answer, not a wait");
    let e = missing.expect_err("no such job");
    assert!(e.to_string().contains("no job"), "{e}");
    // Well past the grace period, the waiting client's job is still there.
    tokio::time::sleep(Duration::from_millis(4000)).await;
    assert!(!following.is_finished(), "the client gave up: {:?}", following.await);
    let status = client::status(&remote).await.expect("status");
    let state = status.jobs.iter().find(|j| j.job_id == job).expect("job").state.clone();
    assert_eq!(state, "queued");
    // A slot frees, a worker comes: the waiting client gets its image.
    drop(open.pop());
    cluster.add_worker();
    let image = tokio::time::timeout(Duration::from_secs(60), following)
        .await
        .expect("the waiting client got its image in time")
        .expect("task")
        .expect("the job rendered");
    assert_eq!((image.image.width, image.image.height), (480, 320));
    cluster.stop().await;
}
