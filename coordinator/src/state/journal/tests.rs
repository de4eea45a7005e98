//! Tests of the journal: what it writes, what it reads back, what a purge
//! forgets.

use super::writer::GATHER;
use super::*;
use crate::scheduler::JobUpdate;
use crate::scheduler::{Owner, ShotFrame};
use crate::server::events::job_events;
use farm_common::film::FilmGeometry;
use farm_common::film::PassPlan;
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::ids::JobId;
use prost::Message;
use rusqlite::params;
use std::time::Duration;

fn spec(blobs: Vec<Hash>) -> JobSpec {
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(8, 8));
    let geometry = FilmGeometry::new(
        Point2i::new(8, 8),
        b,
        Vec2::splat(0.5),
        1.0,
        f32::INFINITY,
        "x.exr".into(),
        35.0,
    );
    JobSpec {
        name: "j".into(),
        priority: 0,
        scene_hash: blobs[0].to_vec(),
        spp_override: 0,
        spp: 1,
        geometry,
        owner: Owner::default(),
        detach: false,
        blobs,
        shot: None,
        passes: None,
        parallel_tiles: false,
    }
}

/// An empty folder of its own for a test's database, and the database's path.
fn scratch_db(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("farm-journal-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let db = dir.join("state.db");
    (dir, db)
}

async fn purge(j: &Journal, jobs: Vec<u64>) -> Vec<Hash> {
    let (reply, rx) = oneshot::channel();
    j.send(Command::Purge { jobs, unreferenced_before: unix_now() + 10, reply });
    let mut v = rx.await.unwrap();
    v.sort();
    v
}

#[tokio::test]
async fn purges_forget_jobs_and_report_the_blobs_no_job_needs() {
    let (j, _) = Journal::open(None).unwrap();
    let (a, b, c) = ([1u8; 32], [2u8; 32], [3u8; 32]);
    for h in [a, b, c] {
        j.send(Command::BlobStored { hash: h, size: 10, owner: "t".into() });
    }
    let s1 = spec(vec![a, b]);
    j.send(Command::Submitted {
        id: 1,
        detach: false,
        blobs: s1.blobs.clone(),
        spec: Box::new(s1),
    });
    let s2 = spec(vec![b]);
    j.send(Command::Submitted {
        id: 2,
        detach: false,
        blobs: s2.blobs.clone(),
        spec: Box::new(s2),
    });
    // Only c is needed by no job.
    assert_eq!(purge(&j, vec![]).await, vec![c]);
    // Job 1 goes: a with it; b is still job 2's.
    assert_eq!(purge(&j, vec![1]).await, vec![a]);
    assert_eq!(purge(&j, vec![2]).await, vec![b]);
    assert_eq!(purge(&j, vec![]).await, Vec::<Hash>::new());
}

/// A frame's place in its shot, a job's passes and whether its tiles
/// render on all threads are journalled beside its job, come back when
/// the coordinator restarts, and go when the job is purged.
#[tokio::test]
async fn a_frames_shot_and_a_jobs_passes_survive_a_restart() {
    let dir = std::env::temp_dir().join(format!("farm-journal-shot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let db = dir.join("state.db");
    let frame = ShotFrame { shot: JobId(7), frame: 3, frames: 24 };
    let plan = PassPlan::new(64, Some(1e-3), Some(30.0));
    {
        let (j, _) = Journal::open(Some(&db)).unwrap();
        for (id, shot) in [(7, Some(frame)), (8, None)] {
            let passes = (id == 8).then(|| plan.clone());
            let parallel_tiles = id == 7;
            let s = JobSpec { shot, passes, parallel_tiles, ..spec(vec![[1u8; 32]]) };
            j.send(Command::Submitted { id, detach: false, blobs: vec![], spec: Box::new(s) });
        }
        j.flush().await;
    }
    let (j, restored) = Journal::open(Some(&db)).unwrap();
    let shots: Vec<_> = restored.jobs.iter().map(|s| (s.id, s.spec.shot)).collect();
    assert_eq!(shots, [(7, Some(frame)), (8, None)]);
    let passes: Vec<_> = restored.jobs.iter().map(|s| s.spec.passes.clone()).collect();
    assert_eq!(passes, [None, Some(plan)]);
    let parallel: Vec<_> = restored.jobs.iter().map(|s| s.spec.parallel_tiles).collect();
    assert_eq!(parallel, [true, false]);
    purge(&j, vec![7, 8]).await;
    drop(j);
    let (_, restored) = Journal::open(Some(&db)).unwrap();
    assert_eq!(restored.jobs.len(), 0);
    let conn = Connection::open(&db).unwrap();
    let rows: i64 = conn.query_row("SELECT count(*) FROM frames", [], |r| r.get(0)).unwrap();
    assert_eq!(rows, 0, "the purged frame's row is gone");
    let rows: i64 = conn.query_row("SELECT count(*) FROM passes", [], |r| r.get(0)).unwrap();
    assert_eq!(rows, 0, "the purged job's passes are gone");
    let rows: i64 =
        conn.query_row("SELECT count(*) FROM parallel_tiles", [], |r| r.get(0)).unwrap();
    assert_eq!(rows, 0, "the purged job's row is gone");
    std::fs::remove_dir_all(&dir).ok();
}

/// A film journalled when its halves were the bool
/// `independent_samples` still decodes: false as `Spread`, true as
/// `Independent`.
#[test]
fn a_film_journalled_before_half_images_still_decodes() {
    use farm_common::film::{FilmGeometry, HalfImages};
    use farm_common::geometry::{Bounds2i, Point2i, Vec2};
    #[derive(serde::Serialize)]
    struct Before {
        full_resolution: Point2i,
        cropped_pixel_bounds: Bounds2i,
        filter_radius: Vec2,
        sample_bounds: Bounds2i,
        n_tiles: Point2i,
        scale: f32,
        max_sample_luminance: f32,
        filename: String,
        diagonal: f32,
        independent_samples: bool,
        signed_weights: bool,
    }
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 30));
    let g = FilmGeometry::new(b.max, b, Vec2::splat(2.0), 1.0, 1e9, "x.exr".into(), 35.0);
    for (old, now) in [(false, HalfImages::Spread), (true, HalfImages::Independent)] {
        let before = Before {
            full_resolution: g.full_resolution,
            cropped_pixel_bounds: g.cropped_pixel_bounds,
            filter_radius: g.filter_radius,
            sample_bounds: g.sample_bounds,
            n_tiles: g.n_tiles,
            scale: g.scale,
            max_sample_luminance: g.max_sample_luminance,
            filename: g.filename.clone(),
            diagonal: g.diagonal,
            independent_samples: old,
            signed_weights: true,
        };
        let bytes = postcard::to_stdvec(&before).unwrap();
        let read: FilmGeometry = postcard::from_bytes(&bytes).unwrap();
        assert_eq!(read.half_images, now);
        assert!(read.signed_weights);
        assert_eq!(read.filename, "x.exr");
    }
}

/// Accepted tiles go to the job's tile log and come back in key order
/// after a restart, with rows a journal from before the logs holds; the
/// log goes when the job ends.
#[tokio::test]
async fn tiles_come_back_from_the_log_and_from_rows_written_before_it() {
    use farm_common::film::FilmTile;
    let (dir, db) = scratch_db("tiles");
    let tile = |k: u32| {
        let mut t = FilmTile::new(Bounds2i::new(Point2i::new(0, 0), Point2i::new(2, 1)));
        t.pixels[1].weight = k as f32;
        t
    };
    let stats = RayStats { camera_rays: 3, ..Default::default() };
    {
        let (j, _) = Journal::open(Some(&db)).unwrap();
        let s = spec(vec![[1u8; 32]]);
        j.send(Command::Submitted { id: 4, detach: false, blobs: vec![], spec: Box::new(s) });
        for k in [2, 0] {
            j.send(Command::Merged { job: 4, tile: k, film_tile: Arc::new(tile(k)), stats });
        }
        j.flush().await;
    }
    // A row as the journal stored tiles before (a later log record of the
    // same key would win).
    let conn = Connection::open(&db).unwrap();
    conn.execute(
        "INSERT INTO tiles (job, tile, data) VALUES (4, 1, ?1)",
        params![encode_tile(&tile(1), &stats)],
    )
    .unwrap();
    drop(conn);
    let (j, restored) = Journal::open(Some(&db)).unwrap();
    let tiles: Vec<_> =
        restored.jobs[0].tiles.iter().map(|(k, t, s)| (*k, t.pixels[1].weight, *s)).collect();
    assert_eq!(tiles, [(0, 0.0, stats), (1, 1.0, stats), (2, 2.0, stats)]);
    let log = dir.join("state.tiles").join("4.log");
    assert!(log.exists());
    j.send(Command::Ended { job: 4, ending: Ending::Cancelled, image: None });
    j.flush().await;
    assert!(!log.exists(), "an ended job's log is deleted");
    std::fs::remove_dir_all(&dir).ok();
}

/// A finished job's image is stored as the events a watcher is sent, in
/// order, and read back whole (chunked when it is large), in memory and
/// on disk, after a restart too; a purge forgets it.
#[tokio::test]
async fn a_finished_image_is_read_back_as_the_events_a_watcher_is_sent() {
    use crate::scheduler::FinishedJob;
    use farm_common::image::RgbImage;
    let (dir, db) = scratch_db("image");
    // Over one chunk of rows (8 MiB), so the image is several events.
    let (w, h) = (1024, 700);
    let pixels = (0..w * h).map(|i| [i as f32, 0.5, -(i as f32)]).collect();
    let finished = std::sync::Arc::new(FinishedJob {
        name: "stored.pbrt".into(),
        image: RgbImage { width: w, height: h, pixels },
        error: None,
        spp: 3,
        render_seconds: 2.0,
        stats: RayStats { camera_rays: 7, ..Default::default() },
        passes: Vec::new(),
        stopped: None,
    });
    let want: Vec<Vec<u8>> = job_events(&JobUpdate::Finished(finished.clone()))
        .iter()
        .map(|e| e.encode_to_vec())
        .collect();
    assert!(want.len() > 1, "the image should take several events");
    let read = |j: &Journal, job| {
        let (reply, rx) = oneshot::channel();
        j.send(Command::ReadImage { job, reply });
        rx
    };
    for on_disk in [false, true] {
        let (j, _) = Journal::open(on_disk.then_some(db.as_path())).unwrap();
        let s = spec(vec![[1u8; 32]]);
        j.send(Command::Submitted { id: 5, detach: false, blobs: vec![], spec: Box::new(s) });
        j.send(Command::Ended { job: 5, ending: Ending::Done, image: Some(finished.clone()) });
        assert_eq!(read(&j, 5).await.unwrap(), want, "on disk: {on_disk}");
        // A read is answered before its batch commits; a flush after.
        j.flush().await;
    }
    let file = dir.join("state.images").join("5.img");
    assert!(file.exists(), "the image is a file beside the database");
    // A job that ended before images had files keeps its rows; a file
    // whose job never ended (its ending's commit lost) is swept.
    let conn = Connection::open(&db).unwrap();
    conn.execute(
        "INSERT INTO jobs (id, spec, state, detach, submitted_at) VALUES (6, x'', 'done', 0, 0)",
        [],
    )
    .unwrap();
    for (seq, ev) in want.iter().enumerate() {
        conn.execute(
            "INSERT INTO images (job, seq, event) VALUES (6, ?1, ?2)",
            params![seq as i64, ev],
        )
        .unwrap();
    }
    drop(conn);
    let stray = dir.join("state.images").join("7.img");
    std::fs::copy(&file, &stray).unwrap();
    let (j, restored) = Journal::open(Some(&db)).unwrap();
    assert_eq!(restored.jobs.len(), 1, "job 6's spec does not decode: skipped");
    assert!(!stray.exists(), "an image whose job did not end is swept");
    assert_eq!(read(&j, 5).await.unwrap(), want, "after a restart");
    assert_eq!(read(&j, 6).await.unwrap(), want, "rows from before image files");
    assert!(purge(&j, vec![5, 6]).await.is_empty());
    assert!(read(&j, 5).await.unwrap().is_empty(), "a purged job's image is forgotten");
    assert!(read(&j, 6).await.unwrap().is_empty(), "and so are its rows");
    assert!(!file.exists(), "a purged job's image file is deleted");
    // Where no file can be written, the image goes in the database.
    let images = dir.join("state.images");
    std::fs::remove_dir_all(&images).unwrap();
    std::fs::write(&images, b"not a folder").unwrap();
    j.send(Command::Submitted {
        id: 8,
        detach: false,
        blobs: vec![],
        spec: Box::new(spec(vec![[1u8; 32]])),
    });
    j.send(Command::Ended { job: 8, ending: Ending::Done, image: Some(finished.clone()) });
    assert_eq!(read(&j, 8).await.unwrap(), want, "from rows, no file written");
    std::fs::remove_dir_all(&dir).ok();
}

/// Tiles that come in one at a time, faster than [`GATHER`], share
/// transactions: no more commits than `GATHER`s passed, the first and the
/// flush's.
#[tokio::test]
async fn tiles_coming_in_fast_are_committed_together() {
    use farm_common::film::FilmTile;
    let (dir, db) = scratch_db("gather");
    let (j, _) = Journal::open(Some(&db)).unwrap();
    j.send(Command::Submitted {
        id: 1,
        detach: false,
        blobs: vec![],
        spec: Box::new(spec(vec![[1u8; 32]])),
    });
    j.flush().await;
    let tile = Arc::new(FilmTile::new(Bounds2i::new(Point2i::new(0, 0), Point2i::new(16, 16))));
    let (before, start) = (j.commits(), std::time::Instant::now());
    for t in 0..400 {
        j.send(Command::HandedOut { job: 1, tile: t, n: 1 });
        let (film_tile, stats) = (tile.clone(), RayStats::default());
        j.send(Command::Merged { job: 1, tile: t, film_tile, stats });
        std::thread::sleep(Duration::from_micros(50));
    }
    j.flush().await;
    let (commits, took) = (j.commits() - before, start.elapsed());
    let most = (took.as_micros() / GATHER.as_micros()) as usize + 3;
    assert!(commits <= most, "{commits} commits in {took:?}: at most {most}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A tile's record has postcard's bytes, which restoring decodes: for
/// tiles of every size a job's tiles come in (cut by a crop window at
/// negative coordinates too), with sums of any bits, and large counts.
#[test]
fn a_tile_is_encoded_as_postcard_encodes_it() {
    use farm_common::film::FilmTile;
    let mut rng = farm_common::rng::Rng::new(7);
    // One buffer reused from tile to tile, larger ones first.
    let mut reused = Vec::new();
    for (x0, y0, w, h) in [(0, 0, 16, 16), (-3, -40, 5, 1), (1000, 7, 0, 0), (2, 3, 13, 7)] {
        let bounds = Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x0 + w, y0 + h));
        let mut tile = FilmTile::new(bounds);
        for p in &mut tile.pixels {
            let mut f = || f32::from_bits(rng.uniform_u32());
            *p = farm_common::film::Pixel {
                contrib: [f(), f(), f()],
                weight: f(),
                second_contrib: [f(), f(), f()],
                second_weight: f(),
            };
        }
        let stats = RayStats {
            camera_rays: u64::MAX,
            shadow_rays: 300,
            secondary_rays: 1 << 40,
            nan_samples: 0,
            inf_samples: 127,
            negative_samples: 128,
        };
        let ours = encode_tile(&tile, &stats);
        assert_eq!(ours, postcard::to_stdvec(&(&tile, &stats)).unwrap(), "{bounds:?}");
        encode_tile_into(&mut reused, &tile, &stats);
        assert_eq!(reused, ours, "{bounds:?} into a used buffer");
        // The pieces the writer frames a record from, in used buffers too.
        let (mut head, mut tail) = (reused.clone(), reused.clone());
        let parts = encode_tile_parts(&tile, &stats, &mut head, &mut tail);
        assert_eq!(parts.concat(), ours, "{bounds:?} in pieces");
        let (back, s): (FilmTile, RayStats) = postcard::from_bytes(&ours).unwrap();
        assert_eq!((back.pixel_bounds, s), (tile.pixel_bounds, stats));
        let bits = |t: &FilmTile| -> Vec<u32> {
            t.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
        };
        assert_eq!(bits(&back), bits(&tile));
    }
}
