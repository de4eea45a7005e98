//! `farm submit --display-server`: the image streamed to tev as it renders.
//! A fake tev decodes the packets; what it ends up showing must be the
//! written image, bit for bit, and the error estimate as a second image.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_tests::fake_tev::FakeTev;
use std::path::Path;

fn scene() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

#[test]
fn tev_ends_showing_the_written_image_and_its_error_map() {
    let tev = FakeTev::start();
    let opts = SubmitOptions {
        spp: Some(4),
        threads: 2,
        display_server: Some(tev.address.clone()),
        ..Default::default()
    };
    let summary = submit::render(&scene(), &opts, |_| {}).expect("render");
    assert!(
        summary.warnings.iter().all(|w| !w.message.contains("display")),
        "{:?}",
        summary.warnings
    );
    let seen = tev.finish();
    assert!(seen.errors.is_empty(), "{:?}", seen.errors);
    assert_eq!(seen.images.len(), 2, "{:?}", seen.images.keys().collect::<Vec<_>>());
    let (title, img) = seen.images.iter().find(|(t, _)| !t.contains("relMSE")).expect("the image");
    assert!(title.starts_with("example"), "{title}");
    let (w, h) = (summary.image.width, summary.image.height);
    assert_eq!(img.size, (w, h));
    assert_eq!(img.channels.keys().collect::<Vec<_>>(), ["B", "G", "R"]);
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let shown = &img.channels[*name];
        let written: Vec<f32> = summary.image.pixels.iter().map(|p| p[c]).collect();
        assert!(
            shown.iter().zip(&written).all(|(a, b)| a.to_bits() == b.to_bits()),
            "channel {name} differs"
        );
    }
    // 480×320 is 4×3 pieces of 128², each sent per channel at least at the end.
    assert!(img.updates >= 3 * 12, "{} updates", img.updates);
    let (_, err) = seen.images.iter().find(|(t, _)| t.contains("relMSE")).expect("the error map");
    let e = summary.error.as_ref().expect("4 spp has an estimate");
    assert_eq!(err.size, (e.width, e.height));
    assert_eq!(err.channels["relMSE"], e.per_pixel);
}

#[test]
fn a_missing_display_server_is_a_warning_not_a_failure() {
    // A port nothing listens on: bind one, then free it.
    let address =
        std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    let opts = SubmitOptions {
        spp: Some(1),
        threads: 2,
        display_server: Some(address.clone()),
        overrides: farm_scene::Overrides { quick: true, ..Default::default() },
        ..Default::default()
    };
    let summary = submit::render(&scene(), &opts, |_| {}).expect("the render goes on");
    let w: Vec<&str> = summary.warnings.iter().map(|w| w.message.as_str()).collect();
    assert!(w.iter().any(|m| m.contains(&address) && m.contains("not streaming")), "{w:?}");
    let bad = SubmitOptions { display_server: Some("no-port-here".into()), ..opts };
    let summary = submit::render(&scene(), &bad, |_| {}).expect("the render goes on");
    assert!(
        summary.warnings.iter().any(|w| w.message.contains("HOST:PORT")),
        "{:?}",
        summary.warnings
    );
}

/// The image the fake tev ends showing, checked against `written`; returns
/// how many updates it took.
fn check_shown(seen: &farm_tests::fake_tev::Seen, summary: &submit::RenderSummary) -> usize {
    assert!(seen.errors.is_empty(), "{:?}", seen.errors);
    let (_, img) = seen.images.iter().find(|(t, _)| !t.contains("relMSE")).expect("the image");
    assert_eq!(img.size, (summary.image.width, summary.image.height));
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let written: Vec<f32> = summary.image.pixels.iter().map(|p| p[c]).collect();
        assert!(
            img.channels[*name].iter().zip(&written).all(|(a, b)| a.to_bits() == b.to_bits()),
            "channel {name} differs"
        );
    }
    let (_, err) = seen.images.iter().find(|(t, _)| t.contains("relMSE")).expect("the error map");
    assert_eq!(err.channels["relMSE"], summary.error.as_ref().expect("an estimate").per_pixel);
    img.updates
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn on_the_farm_tev_sees_the_image_as_it_renders_and_ends_on_the_written_one() {
    use farm_cli::client::{self, RemoteOptions};
    let cluster =
        farm_tests::cluster::TestCluster::start(2, std::time::Duration::from_millis(500)).await;
    let tev = FakeTev::start();
    let opts = RemoteOptions {
        spp: Some(64),
        display_server: Some(tev.address.clone()),
        ..Default::default()
    };
    let summary =
        client::submit(&cluster.remote(), &scene(), &opts, |_, _| {}).await.expect("farm render");
    let seen = tev.finish();
    let updates = check_shown(&seen, &summary);
    // The end alone sends 4×3 pieces × 3 channels; the rest came while it rendered.
    assert!(updates > 36, "only {updates} updates: no live preview reached tev");
    cluster.stop().await;
}

/// A farm's live watchers are paced by the work an update shows: each
/// preview carries at least 64 tiles' worth of new pixels (a quarter of a
/// small film), unless 5 s passed since the one before. One worker of one
/// thread merges fewer than 32 tiles a second here, so previews sent every
/// two seconds regardless would fail this.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn live_previews_come_in_batches_worth_sending() {
    use farm_cli::client::{self, RemoteOptions};
    use farm_coordinator::server::{LIVE_AT_MOST_EVERY, LIVE_BATCH_PIXELS};
    use farm_proto::v1::{self, job_event::Kind};
    use std::time::{Duration, Instant};
    let cluster =
        farm_tests::cluster::TestCluster::start(1, std::time::Duration::from_millis(500)).await;
    let remote = cluster.remote();
    let opts = RemoteOptions { spp: Some(64), detach: true, ..Default::default() };
    let job = client::start(&remote, &scene(), &opts).await.expect("submit").job;
    let mut c = client::connect(&remote).await.expect("connect");
    let mut events = c
        .watch_job(v1::WatchJobRequest { job_id: job, live: true })
        .await
        .expect("watch")
        .into_inner();
    let (mut previews, mut last, mut image) = (Vec::new(), Instant::now(), 0usize);
    while let Some(ev) = events.message().await.expect("the stream") {
        match ev.kind {
            Some(Kind::Preview(p)) => {
                let pixels: usize = p
                    .bounds
                    .chunks_exact(4)
                    .map(|b| ((b[2] - b[0]) * (b[3] - b[1])) as usize)
                    .sum();
                assert_eq!(pixels * 16, p.sums.len());
                image = (p.width * p.height) as usize;
                previews.push((pixels, last.elapsed()));
                last = Instant::now();
            }
            Some(Kind::Image(_)) | Some(Kind::Failed(_)) => break,
            _ => {}
        }
    }
    assert!(previews.len() >= 3, "only {} previews", previews.len());
    let batch = LIVE_BATCH_PIXELS.min(image / 4);
    // Times are taken on arrival, so a late delivery can make the gap
    // before the next one look shorter.
    let slack = Duration::from_secs(2);
    for (i, &(pixels, gap)) in previews.iter().enumerate().skip(1) {
        assert!(
            pixels >= batch || gap + slack >= LIVE_AT_MOST_EVERY,
            "preview {i}: {pixels} pixels after {gap:?} (batch {batch})"
        );
    }
    cluster.stop().await;
}

/// `farm watch --display-server` names the image in tev after the job, as
/// `farm submit` does, before the finished image (which carries the name)
/// arrives; it used to show "job N".
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn farm_watch_names_its_tev_image_after_the_job() {
    use farm_cli::client::{self, RemoteOptions};
    use farm_cli::commands::watch::{self, WatchArgs};
    use farm_cli::commands::{RemoteArgs, TokenArgs};
    let cluster =
        farm_tests::cluster::TestCluster::start(1, std::time::Duration::from_millis(500)).await;
    let remote = cluster.remote();
    let opts = RemoteOptions { spp: Some(4), detach: true, ..Default::default() };
    let job = client::start(&remote, &scene(), &opts).await.expect("submit").job;
    let dir = tempfile::tempdir().expect("temp dir");
    let tev = FakeTev::start();
    let args = WatchArgs {
        job,
        output: Some(dir.path().join("watched.exr")),
        quiet: true,
        display_server: Some(tev.address.clone()),
        reconnect_for: 10.0,
        remote: RemoteArgs { coordinator: remote.url.clone(), token: TokenArgs::default() },
    };
    assert_eq!(watch::run(args).await, std::process::ExitCode::SUCCESS);
    let seen = tev.finish();
    assert!(seen.errors.is_empty(), "{:?}", seen.errors);
    let titles: Vec<&String> = seen.images.keys().collect();
    assert!(
        titles.iter().any(|t| t.starts_with("example.pbrt (")),
        "no image named after the job: {titles:?}"
    );
    assert!(titles.iter().all(|t| !t.starts_with("job ")), "{titles:?}");
    cluster.stop().await;
}
