//! A worker that lies: forged, unassigned, stale and non-finite results, a
//! second stream with another worker's id, and a request for every tile.
//! None of it reaches the image, and honest workers finish the job bit for
//! bit as the embedded render.

use farm_cli::client::{self, RemoteOptions};
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::ids::TileId;
use farm_common::image::RgbImage;
use farm_proto::v1;
use farm_tests::cluster::TestCluster;
use farm_tests::fake::{open_session, FakeWorker};
use farm_tests::{bits, example_scene as scene};
use std::time::Duration;

const SPP: u32 = 2;

fn embedded() -> RgbImage {
    farm_tests::embedded_example(SPP)
}

fn geometry() -> FilmGeometry {
    let (desc, _) = farm_scene::parse_file(&scene()).expect("scene");
    farm_common::film::layout(&desc, Some(SPP)).0.geometry
}

/// A tile of the right size whose every pixel is `value` with weight `weight`.
fn forged(g: &FilmGeometry, tile: u32, value: f32, weight: f32) -> v1::FilmTile {
    let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(tile)));
    for p in &mut t.pixels {
        p.contrib = [value; 3];
        p.weight = weight;
    }
    v1::FilmTile::from(&t)
}

fn result(job_id: u64, tile: u32, attempt: u32, film_tile: v1::FilmTile) -> v1::TileResult {
    v1::TileResult {
        job_id,
        tile,
        attempt,
        outcome: Some(v1::tile_result::Outcome::FilmTile(film_tile)),
        stats: None,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn forged_unassigned_non_finite_and_hijacked_results_leave_the_image_unchanged() {
    let reference = bits(&embedded());
    let g = geometry();
    let cluster = TestCluster::start(0, Duration::from_millis(300)).await;
    // The liar asks for every tile there is.
    let mut liar = FakeWorker::connect(&cluster.url, u32::MAX).await;
    let url = cluster.url.clone();
    let job = tokio::spawn(async move {
        let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
        client::submit(&farm_cli::client::Remote::insecure(&url), &scene(), &opts, |_, _| {}).await
    });
    let first = liar.assignment().await;
    let held = {
        let mut held = vec![first.clone()];
        // Whatever it asked for, it holds at most the coordinator's cap.
        while let Ok(Ok(a)) =
            tokio::time::timeout(Duration::from_millis(300), liar.inbound.message()).await
        {
            if let Some(v1::coordinator_message::Kind::Assign(a)) = a.and_then(|m| m.kind) {
                held.push(a);
            }
        }
        held
    };
    assert!((held.len() as u32) < g.tile_count(), "the liar holds the whole job");
    let holds = |t: u32| held.iter().any(|a| a.tile == t);
    // Made-up pixels for every tile it does not hold, as several attempts,
    // and a forged non-retryable failure of each.
    for t in (0..g.tile_count()).filter(|&t| !holds(t)) {
        for attempt in 0..2 {
            liar.send(result(first.job_id, t, attempt, forged(&g, t, 1e6, 1.0)));
            liar.send(v1::TileResult {
                outcome: Some(v1::tile_result::Outcome::Failure(v1::TileFailure {
                    message: "forged".into(),
                    retryable: false,
                })),
                ..result(first.job_id, t, attempt, forged(&g, t, 0.0, 0.0))
            });
        }
    }
    // A tile far outside the film, and its own tiles as a later attempt.
    liar.send(result(first.job_id, 99_999, 0, forged(&g, 0, 1.0, 1.0)));
    for a in &held {
        liar.send(result(a.job_id, a.tile, a.attempt + 1, forged(&g, a.tile, 1e6, 1.0)));
    }
    // Its own tiles with NaN, infinite and negative-weight sums.
    for (i, a) in held.iter().enumerate() {
        let (v, w) = [(f32::NAN, 1.0), (f32::INFINITY, 1.0), (1.0, -3.0)][i % 3];
        liar.send(result(a.job_id, a.tile, a.attempt, forged(&g, a.tile, v, w)));
    }
    // Another stream with the liar's id: a wrong key is refused, and so is
    // the right key while the session is open.
    let mut c = liar.client.clone();
    let e = open_session(&mut c, liar.id, &[0; 32], 1).await.expect_err("hijack refused");
    assert_eq!(e.code(), tonic::Code::FailedPrecondition, "{e}");
    let e = open_session(&mut c, liar.id, &liar.session_key, 1).await.expect_err("refused");
    assert_eq!(e.code(), tonic::Code::AlreadyExists, "{e}");
    let status =
        client::status(&farm_cli::client::Remote::insecure(&cluster.url)).await.expect("status");
    assert_eq!(status.jobs[0].state, "running", "no forged failure failed the job");
    assert_eq!(status.jobs[0].tiles_done, 0, "no forged tile was merged");
    // Honest workers finish it.
    drop(liar);
    let mut cluster = cluster;
    cluster.add_worker();
    cluster.add_worker();
    let summary = tokio::time::timeout(Duration::from_secs(120), job)
        .await
        .expect("job finishes")
        .expect("task")
        .expect("the job succeeds");
    assert!(bits(&summary.image) == reference, "a lie reached the image");
    cluster.stop().await;
}

/// A scene naming a file outside its folder is refused before anything is
/// uploaded, naming the file; with `allow_assets_outside` it renders.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn files_outside_the_scene_folder_are_not_uploaded_unless_allowed() {
    let dir = std::env::temp_dir().join(format!("farm-outside-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("scene")).unwrap();
    std::fs::create_dir_all(dir.join("secret")).unwrap();
    // A 1×1 PFM: enough for an image map.
    let mut pfm = b"PF\n1 1\n-1\n".to_vec();
    pfm.extend([0.5f32, 0.25, 1.0].iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(dir.join("secret/key.pfm"), pfm).unwrap();
    let scene = dir.join("scene/s.pbrt");
    std::fs::write(
        &scene,
        "Film \"image\" \"integer xresolution\" 16 \"integer yresolution\" 16\n\
         Sampler \"halton\" \"integer pixelsamples\" 1\nWorldBegin\n\
         Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"../secret/key.pfm\"\n\
         Material \"matte\" \"texture Kd\" \"t\"\nLightSource \"point\"\n\
         Translate 0 0 5\nShape \"sphere\"\nWorldEnd\n",
    )
    .unwrap();
    let cluster = TestCluster::start(1, Duration::from_millis(300)).await;
    let err = client::submit(
        &farm_cli::client::Remote::insecure(&cluster.url),
        &scene,
        &RemoteOptions::default(),
        |_, _| {},
    )
    .await;
    let Err(e @ farm_cli::Error::AssetsOutside { .. }) = err else {
        panic!("not refused: {:?}", err.map(|s| s.output))
    };
    assert!(e.to_string().contains("../secret/key.pfm"), "{e}");
    assert!(e.to_string().contains("--allow-assets-outside"), "{e}");
    let status =
        client::status(&farm_cli::client::Remote::insecure(&cluster.url)).await.expect("status");
    assert!(status.jobs.is_empty(), "nothing was submitted");
    let opts = RemoteOptions { allow_assets_outside: true, ..Default::default() };
    let summary =
        client::submit(&farm_cli::client::Remote::insecure(&cluster.url), &scene, &opts, |_, _| {})
            .await
            .expect("renders");
    assert_eq!((summary.image.width, summary.image.height), (16, 16));
    cluster.stop().await;
    std::fs::remove_dir_all(dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_cannot_open_watches_without_bound() {
    use farm_coordinator::server::MAX_WATCHES_PER_TOKEN;
    let cluster = TestCluster::start(1, Duration::from_millis(300)).await;
    let remote = farm_cli::client::Remote::insecure(&cluster.url);
    let opts = RemoteOptions { spp: Some(1), detach: true, ..Default::default() };
    let job = client::start(&remote, &scene(), &opts).await.expect("submit").job;
    let mut c = client::connect(&remote).await.expect("connect");
    // Streams nobody reads (each may come to hold the finished image).
    let mut open = Vec::new();
    for _ in 0..MAX_WATCHES_PER_TOKEN {
        let s = c.watch_job(v1::WatchJobRequest { job_id: job, live: false }).await.expect("watch");
        open.push(s.into_inner());
    }
    let e = c
        .watch_job(v1::WatchJobRequest { job_id: job, live: false })
        .await
        .expect_err("one too many");
    assert_eq!(e.code(), tonic::Code::ResourceExhausted, "{e}");
    // Closing one frees its slot.
    drop(open.pop());
    let mut freed = None;
    for _ in 0..50 {
        match c.watch_job(v1::WatchJobRequest { job_id: job, live: false }).await {
            Ok(s) => {
                freed = Some(s);
                break;
            }
            Err(_) => tokio::time::sleep(Duration::from_millis(20)).await,
        }
    }
    assert!(freed.is_some(), "a closed watch kept its slot");
    cluster.stop().await;
}
