//! A shot: the project's 24-frame scene (`scenes/shot`, the camera
//! circling one PLY mesh that every frame Includes) renders embedded and on
//! a farm of two workers with identical frames, and the farm is sent the
//! mesh once: the bytes uploads bring the coordinator are counted on its
//! `/metrics` and must be the mesh once plus each frame's own manifest.

use farm_cli::client::RemoteOptions;
use farm_cli::embedded::{render_parsed, SubmitOptions};
use farm_cli::frames::{expand_inputs, frame_scenes, Outputs};
use farm_cli::shot::{existing_shot, submit_shot, FrameEnd, ShotPlace};
use farm_common::image::RgbImage;
use farm_proto::convert::encode_scene;
use farm_scene::SceneStream;
use farm_tests::cluster::TestCluster;
use farm_tests::http::{self, value};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_shot_renders_the_same_frames_embedded_and_on_two_workers_sending_its_mesh_once() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shot");
    let inputs = expand_inputs(&[folder]).unwrap();
    assert_eq!(inputs.len(), 24, "{inputs:?}");

    // Embedded, a frame at a time; and what a farm must be sent: each
    // blob once (the mesh's parameters are a blob of their own).
    let opts = SubmitOptions { spp: Some(2), threads: 2, ..Default::default() };
    let mut here = Vec::new();
    let mut blobs = BTreeMap::new();
    for scene in SceneStream::new(&inputs) {
        let mut s = scene.unwrap();
        let (manifest, assets) = encode_scene(&mut s.desc).unwrap();
        for b in assets.iter().chain([&manifest]) {
            blobs.insert(b.hash, b.data.len() as u64);
        }
        let summary = render_parsed(s.desc, s.warnings, Instant::now(), &opts, |_| {});
        here.push(summary.unwrap().image);
    }
    assert_eq!(here.len(), 24);
    assert_eq!(blobs.len(), 25, "one mesh blob and 24 manifests");
    let mesh = *blobs.values().max().unwrap();
    assert!(mesh > 16 << 10, "the mesh's blob is {mesh} bytes");

    let cluster = TestCluster::start(2, Duration::from_millis(500)).await;
    let mut outputs = Outputs::new(None, None, 1, true).unwrap();
    let frames = frame_scenes(&inputs, &mut outputs, SceneStream::new(&inputs), Duration::ZERO);
    let mut farm: BTreeMap<u32, RgbImage> = BTreeMap::new();
    let remote_opts = RemoteOptions { spp: Some(2), ..Default::default() };
    let place = ShotPlace { shot: None, frames: 24 };
    let totals = submit_shot(
        &cluster.remote(),
        frames,
        &remote_opts,
        place,
        3,
        |_, _| {},
        |end| match end {
            FrameEnd::Done(summary, out) => {
                let name = summary.output.to_string_lossy().into_owned();
                assert_eq!(
                    name,
                    format!("frame-{:04}.exr", out.frame),
                    "each scene's Film filename"
                );
                farm.insert(out.frame, summary.image);
            }
            FrameEnd::Failed(out, e) => panic!("frame {} failed: {e}", out.frame),
        },
    )
    .await
    .expect("the shot");
    assert_eq!(totals.frames, 24);
    assert_eq!(farm.keys().copied().collect::<Vec<_>>(), (1..=24).collect::<Vec<_>>());
    for (i, (frame, image)) in farm.iter().enumerate() {
        let (a, b) = (farm_tests::bits(image), farm_tests::bits(&here[i]));
        let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert!(a.len() == b.len() && differ == 0, "frame {frame}: {differ} floats differ");
    }

    let view = existing_shot(&cluster.remote(), totals.shot).await.unwrap();
    assert_eq!((view.frames, view.done.len(), view.failed.len()), (24, 24, 0));

    // Each blob was sent once: the mesh once, not 24 times.
    let sent: u64 = blobs.values().sum();
    assert_eq!(totals.uploaded_bytes, sent);
    assert_eq!(totals.blobs_reused, 23, "the mesh, named by 23 frames after the first");
    let address = cluster.url.trim_start_matches("http://").to_string();
    let (m, _) =
        tokio::task::spawn_blocking(move || http::scrape(&address)).await.unwrap().unwrap();
    let received = value(&m, "farm_blob_upload_bytes_total", &[]).expect("the upload counter");
    // Sent with each frame, the mesh would have added 23 × its size.
    assert_eq!(received, sent as f64, "bytes the coordinator received ({mesh}-byte mesh)");
    cluster.stop().await;
}

/// A frame the farm refuses fails alone: the others are written, the shot
/// lists them, and a retry of the shot submits only the missing frame (the
/// files fixed), into the same shot.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_failed_frame_fails_alone_and_a_retry_renders_only_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shot");
    let dir = std::env::temp_dir().join(format!("farm-shot-retry-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("world")).unwrap();
    std::fs::copy(src.join("mesh.ply"), dir.join("mesh.ply")).unwrap();
    std::fs::copy(src.join("world/world.pbrt"), dir.join("world/world.pbrt")).unwrap();
    for f in 1..=3 {
        let name = format!("frame-{f:04}.pbrt");
        let text = std::fs::read_to_string(src.join(&name)).unwrap();
        // Frame 2's film is over the coordinator's pixel limit.
        let text = if f == 2 { text.replace("[ 160 ]", "[ 100000000 ]") } else { text };
        std::fs::write(dir.join(name), text).unwrap();
    }
    let cluster = TestCluster::start(2, Duration::from_millis(500)).await;
    let opts = RemoteOptions { spp: Some(1), ..Default::default() };
    let run = |shot: Option<u64>, skip: Vec<u32>| {
        let (dir, remote, opts) = (dir.clone(), cluster.remote(), opts.clone());
        async move {
            let inputs = expand_inputs(&[dir]).unwrap();
            let mut outputs = Outputs::new(None, None, 1, true).unwrap();
            let frames =
                frame_scenes(&inputs, &mut outputs, SceneStream::new(&inputs), Duration::ZERO)
                    .filter(|f| f.as_ref().map_or(true, |f| !skip.contains(&f.out.frame)));
            let (mut done, mut failed) = (Vec::new(), Vec::new());
            let place = ShotPlace { shot, frames: 3 };
            let totals = submit_shot(
                &remote,
                frames,
                &opts,
                place,
                2,
                |_, _| {},
                |end| match end {
                    FrameEnd::Done(_, out) => done.push(out.frame),
                    FrameEnd::Failed(out, e) => failed.push((out.frame, e.to_string())),
                },
            )
            .await
            .unwrap();
            done.sort();
            (totals, done, failed)
        }
    };
    let (totals, done, failed) = run(None, vec![]).await;
    assert_eq!(done, [1, 3]);
    assert_eq!(failed.len(), 1);
    assert_eq!(failed[0].0, 2);
    assert!(failed[0].1.contains("too large"), "{}", failed[0].1);
    let shot = totals.shot;
    let view = existing_shot(&cluster.remote(), shot).await.unwrap();
    assert_eq!((view.frames, view.done.clone(), view.failed.len()), (3, vec![1, 3], 0));

    // Fixed, and retried: only frame 2 goes to the farm, into the same shot.
    let text = std::fs::read_to_string(dir.join("frame-0002.pbrt")).unwrap();
    std::fs::write(dir.join("frame-0002.pbrt"), text.replace("[ 100000000 ]", "[ 160 ]")).unwrap();
    let have: Vec<u32> = view.done.iter().chain(&view.rendering).copied().collect();
    let (totals, done, failed) = run(Some(shot), have).await;
    assert_eq!((totals.frames, totals.shot, done, failed.len()), (1, shot, vec![2], 0));
    let view = existing_shot(&cluster.remote(), shot).await.unwrap();
    assert_eq!(view.done, [1, 2, 3]);
    // A made-up shot is not listed, and the coordinator refuses frames of it.
    let e = existing_shot(&cluster.remote(), shot + 100).await.unwrap_err().to_string();
    assert!(e.contains("no shot"), "{e}");
    let mut s = SceneStream::new(&[dir.join("frame-0001.pbrt")]).next().unwrap().unwrap();
    let (manifest, assets) = encode_scene(&mut s.desc).unwrap();
    let mut c = farm_cli::client::connect(&cluster.remote()).await.unwrap();
    for b in assets.iter().chain([&manifest]) {
        farm_cli::client::upload(&mut c, b).await.unwrap();
    }
    let frame = farm_proto::v1::ShotFrame { shot: shot + 100, frame: 1, frames: 3 };
    let request = farm_cli::client::submit_request(&manifest, "x".into(), &opts, Some(frame));
    let e = c.submit_job(request).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
    assert!(e.message().contains("no shot"), "{e}");
    cluster.stop().await;
    std::fs::remove_dir_all(&dir).ok();
}
