//! Table 2 of the farm bench: a coordinator process's CPU a tile and a
//! job, with fake workers in this process answering at once.

use super::*;

/// Fake worker counts of table 2 (`FARM_FAKE_WORKERS`, e.g. "1,100").
const FAKE_WORKERS: [usize; 3] = [1, 100, 10_000];
/// Connections the fake workers share: each holds its Work stream on one
/// of them, as HTTP/2 streams, so 10,000 workers need no 10,000 sockets.
const FAKE_CONNECTIONS: usize = 64;
/// Runs of each row of table 2.
const CAPACITY_RUNS: usize = 3;
/// Jobs a run submits, one after the other, to the same coordinator and
/// workers: the first meets a fresh process (its streams' buffers first
/// touched), the next one a coordinator that has been running.
const JOBS: usize = 2;

/// The capacity job: a big film of trivial content. 2048² is the largest
/// square whose finished image (12 bytes a pixel) fits in one 64 MiB gRPC
/// message (4096² would be 192 MiB).
const CAPACITY_SCENE: &str = r#"
LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "image" "integer xresolution" [ 2048 ] "integer yresolution" [ 2048 ]
PixelFilter "box"
Sampler "halton" "integer pixelsamples" [ 1 ]
WorldBegin
LightSource "point" "point from" [ 0 0 -3 ] "rgb I" [ 10 10 10 ]
Shape "sphere" "float radius" [ 1 ]
WorldEnd
"#;

/// Precomputed answers: the film layout and one tile's bytes per distinct size.
struct Tiles {
    geometry: FilmGeometry,
    bytes: HashMap<(i32, i32), Vec<u8>>,
}

impl Tiles {
    fn new(geometry: FilmGeometry) -> Self {
        // Σw·rgb and Σw, then the same over the second half's samples.
        let sums = [0.5f32, 0.5, 0.5, 1.0, 0.25, 0.25, 0.25, 0.5];
        let px: Vec<u8> = sums.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut bytes = HashMap::new();
        for t in 0..geometry.tile_count() {
            let b = geometry.tile_pixel_bounds(TileId(t));
            bytes.entry((b.width(), b.height())).or_insert_with(|| px.repeat(b.area()));
        }
        Tiles { geometry, bytes }
    }

    fn tile(&self, t: u32) -> v1::FilmTile {
        let b = self.geometry.tile_pixel_bounds(TileId(t));
        v1::FilmTile {
            x0: b.min.x,
            y0: b.min.y,
            x1: b.max.x,
            y1: b.max.y,
            pixels: self.bytes[&(b.width(), b.height())].clone(),
        }
    }
}

/// Registers over `channel`, opens the Work stream and answers every
/// assignment at once; returns once the stream is open, leaving a task that
/// answers until the coordinator goes.
async fn fake_worker(channel: tonic::transport::Channel, tiles: Arc<Tiles>, in_flight: u32) {
    let mut c = CoordinatorClient::new(channel);
    let reg = v1::RegisterWorkerRequest {
        protocol_version: PROTOCOL_VERSION,
        name: "fake".into(),
        threads: 1,
    };
    let reply = c.register_worker(reg).await.expect("register").into_inner();
    let (tx, mut inbound) = open_session(&mut c, reply.worker_id, &reply.session_key, in_flight)
        .await
        .expect("work stream");
    tokio::spawn(async move {
        while let Ok(Some(msg)) = inbound.message().await {
            let Some(coordinator_message::Kind::Assign(a)) = msg.kind else { continue };
            let result = v1::TileResult {
                job_id: a.job_id,
                tile: a.tile,
                attempt: a.attempt,
                outcome: Some(tile_result::Outcome::FilmTile(tiles.tile(a.tile))),
                stats: None,
            };
            let msg = v1::WorkerMessage { kind: Some(worker_message::Kind::Result(result)) };
            if tx.send(msg).is_err() {
                break;
            }
        }
    });
}

/// One capacity job's measures: the coordinator's CPU seconds a tile
/// while the job's middle tiles merge, and wall and CPU seconds from the
/// submit call to the finished image received.
struct Capacity {
    /// Seconds to register every fake worker and open its Work stream.
    register: f64,
    /// CPU seconds a tile between the progress events that first report
    /// 10% and 90% of the tiles merged: the cost of a tile alone, without
    /// the job's start (its film) and end (its image and estimate), which
    /// grow with pixels, not tiles.
    cpu_steady: f64,
    wall_image: f64,
    cpu_image: f64,
    /// CPU seconds from the image received to the coordinator going
    /// quiet ([`quiet`]): what it still does for the job once the client
    /// has its image, such as the journal storing it.
    cpu_after: f64,
    /// The longest the coordinator's event loop took to answer a probe
    /// while the job ran ([`probe_loop`]), in seconds.
    stall: f64,
    /// Seconds the coordinator's event loop was busy from the submit call
    /// until it went quiet after the image
    /// (`farm_event_loop_busy_seconds_total`): the part of its
    /// CPU that is done one event at a time, which no second core helps.
    loop_busy: f64,
    /// Speculative hand-outs (second copies and parts of tiles still out,
    /// once none is left to hand out) a tile of the job: messages to and
    /// from workers beyond the tile's own.
    speculated: f64,
}

/// The coordinator's event loop's busy seconds and speculative hand-outs
/// so far, from `/metrics`.
async fn loop_counters(url: &str) -> Result<(f64, f64), String> {
    let addr = url.trim_start_matches("http://").to_string();
    let (samples, _) = tokio::task::spawn_blocking(move || farm_tests::http::scrape(&addr))
        .await
        .map_err(|e| e.to_string())??;
    let value = |name: &str| {
        farm_tests::http::value(&samples, name, &[]).ok_or_else(|| format!("no {name}"))
    };
    Ok((value("farm_event_loop_busy_seconds_total")?, value("farm_tiles_speculated_total")?))
}

/// Asks the coordinator every 2 ms, until `stop`, to cancel a job that
/// does not exist (two events through its loop: the owner check and the
/// cancel), and returns the longest wait for an answer: how long the loop
/// was busy with one thing while the job ran, such as a film's end.
async fn probe_loop(url: String, stop: Arc<std::sync::atomic::AtomicBool>) -> f64 {
    let remote = farm_cli::client::Remote::insecure(&url);
    let Ok(mut c) = client::connect(&remote).await else { return f64::NAN };
    let mut longest = 0f64;
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        let t = Instant::now();
        let _ = c.cancel_job(v1::CancelJobRequest { job_id: u64::MAX }).await;
        longest = longest.max(t.elapsed().as_secs_f64());
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    longest
}

/// The coordinator's CPU seconds once it has gone quiet: read every 50 ms
/// until three readings agree (its /proc counters tick every 10 ms, so
/// 100 ms without a tick), at most 10 s; NaN if it never does. (A thread
/// waiting on the disk takes no CPU, so what it does after such a wait
/// can be missed: the commit after an image's sync, a few hundred µs.)
async fn quiet(cpu: impl Fn() -> Result<f64, String>) -> Result<f64, String> {
    let (mut last, mut same) = (cpu()?, 0);
    for _ in 0..200 {
        tokio::time::sleep(Duration::from_millis(50)).await;
        let now = cpu()?;
        same = if now == last { same + 1 } else { 0 };
        if same == 2 {
            return Ok(now);
        }
        last = now;
    }
    Ok(f64::NAN)
}

/// The progress events a run reads the coordinator's CPU at: the first
/// to report at least a tenth, and at least nine tenths, of the tiles
/// merged, with the tiles they report.
#[derive(Default)]
struct Marks {
    tenth: Option<(u32, f64)>,
    nine_tenths: Option<(u32, f64)>,
}

impl Marks {
    /// Notes the CPU at a progress event reporting `done` of `total`.
    fn progress(&mut self, done: u32, total: u32, cpu: impl Fn() -> Option<f64>) {
        if self.tenth.is_none() && done * 10 >= total {
            self.tenth = cpu().map(|c| (done, c));
        } else if self.nine_tenths.is_none() && done * 10 >= total * 9 {
            self.nine_tenths = cpu().map(|c| (done, c));
        }
    }

    /// CPU seconds a tile between the two marks.
    fn per_tile(&self) -> Option<f64> {
        let ((d0, c0), (d1, c1)) = (self.tenth?, self.nine_tenths?);
        (d1 > d0).then(|| (c1 - c0) / f64::from(d1 - d0))
    }
}

/// A fresh coordinator process with `workers` fake workers, [`JOBS`]
/// jobs one after the other, each measured.
async fn capacity_run(
    bin: &Path,
    workers: usize,
    scene: &Path,
    tiles: &Arc<Tiles>,
) -> Result<Vec<Capacity>, String> {
    // Heartbeats are not what is measured: fake workers send none, and
    // must not be dropped as silent while they wait for tiles.
    let (procs, url) = start_coordinator(bin, &["--heartbeat", "60"]).await;
    let registering = Instant::now();
    let mut channels = Vec::new();
    for _ in 0..FAKE_CONNECTIONS.min(workers) {
        let endpoint = tonic::transport::Endpoint::from_shared(url.clone()).expect("url");
        channels.push(endpoint.connect().await.map_err(|e| e.to_string())?);
    }
    // As many tiles in flight as a worker of 16 threads asks for, but no
    // more slots in all than the job has tiles.
    let in_flight = (tiles.geometry.tile_count() as usize / workers).clamp(1, 32) as u32;
    let mut joining = tokio::task::JoinSet::new();
    for w in 0..workers {
        let (channel, tiles) = (channels[w % channels.len()].clone(), tiles.clone());
        joining.spawn(fake_worker(channel, tiles, in_flight));
        if joining.len() >= 256 {
            joining.join_next().await;
        }
    }
    joining.join_all().await;
    wait_for_workers(&url, workers).await;
    let register = registering.elapsed().as_secs_f64();

    let pid = procs.0[0].id().to_string();
    let mut jobs = Vec::new();
    for _ in 0..JOBS {
        jobs.push(capacity_job(&url, &pid, scene, register, tiles.geometry.tile_count()).await?);
    }
    drop(procs);
    Ok(jobs)
}

/// One job on the coordinator at `url` (process `pid`), measured.
async fn capacity_job(
    url: &str,
    pid: &str,
    scene: &Path,
    register: f64,
    tiles: u32,
) -> Result<Capacity, String> {
    let cpu = || cpu_seconds(pid).ok_or("no /proc reading of the coordinator".to_string());
    let (busy0, speculated0) = loop_counters(url).await?;
    let (t, cpu0) = (Instant::now(), cpu()?);
    let mut marks = Marks::default();
    let opts = RemoteOptions::default();
    let remote = farm_cli::client::Remote::insecure(url);
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let probe = tokio::spawn(probe_loop(url.to_string(), stop.clone()));
    let job = client::submit(&remote, scene, &opts, |_, p| {
        marks.progress(p.tiles_done, p.tiles_total, || cpu_seconds(pid));
    });
    match tokio::time::timeout(Duration::from_secs(300), job).await {
        Ok(Ok(_)) => {}
        Ok(Err(e)) => return Err(e.to_string()),
        Err(_) => return Err("timed out after 300 s".into()),
    }
    let (wall_image, cpu_image) = (t.elapsed().as_secs_f64(), cpu()? - cpu0);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let stall = probe.await.unwrap_or(f64::NAN);
    // Quiet before the metrics are scraped, whose answer would count.
    let cpu_after = quiet(cpu).await? - cpu0 - cpu_image;
    let (busy1, speculated1) = loop_counters(url).await?;
    let (loop_busy, speculated) = (busy1 - busy0, (speculated1 - speculated0) / f64::from(tiles));
    let cpu_steady = marks.per_tile().ok_or("no progress events at 10% and 90%")?;
    Ok(Capacity {
        register,
        cpu_steady,
        wall_image,
        cpu_image,
        cpu_after,
        stall,
        loop_busy,
        speculated,
    })
}

pub(super) fn capacity_table(rt: &Runtime) {
    println!("Coordinator capacity: a coordinator process, fake workers in this process answering at once");
    let Some(bin) = farm_binary() else {
        println!("skipped: no target/release/farm; run `cargo build --release -p farm-cli` first");
        return;
    };
    let dir = std::env::temp_dir().join(format!("farm-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let scene = dir.join("capacity.pbrt");
    std::fs::write(&scene, CAPACITY_SCENE).expect("write scene");
    let (desc, _) = farm_scene::parse_str(CAPACITY_SCENE, "capacity.pbrt", &dir)
        .expect("capacity scene parses");
    let (geometry, ..) =
        film_and_sampler(&desc, &RenderOptions { spp: None, ..Default::default() });
    let n = geometry.tile_count();
    let tiles = Arc::new(Tiles::new(geometry));
    let counts: Vec<usize> = match std::env::var("FARM_FAKE_WORKERS") {
        Ok(v) => v.split(',').filter_map(|c| c.trim().parse().ok()).collect(),
        Err(_) => FAKE_WORKERS.to_vec(),
    };
    println!(
        "{:>7} {:>4} {:>7} {:>7} | {:>10} {:>12} | {:>10} {:>10} {:>12} {:>10} | {:>8} {:>8} {:>8} | {:>6}",
        "", "", "", "", "10-90%", "", "to image", "", "", "loop", "job", "after", "stall", "spec"
    );
    println!(
        "{:>7} {:>4} {:>7} {:>7} | {:>10} {:>12} | {:>10} {:>10} {:>12} {:>10} | {:>8} {:>8} {:>8} | {:>6}",
        "workers",
        "#",
        "tiles",
        "joined",
        "µs/tile",
        "tiles/s/core",
        "tiles/s",
        "µs/tile",
        "tiles/s/core",
        "µs/tile",
        "ms",
        "ms",
        "ms",
        "/tile"
    );
    for workers in counts {
        let mut runs: Vec<Vec<Capacity>> = Vec::new();
        let mut failure = None;
        for _ in 0..CAPACITY_RUNS {
            match rt.block_on(capacity_run(&bin, workers, &scene, &tiles)) {
                Ok(c) => runs.push(c),
                Err(e) => failure = Some(e),
            }
        }
        if let Some(e) = failure {
            println!("{workers:>7} {:>4} {n:>7} failed: {e}", "");
            continue;
        }
        for job in 0..JOBS {
            // Medians over the runs, each column on its own.
            let median = |f: &dyn Fn(&Capacity) -> f64| {
                let mut v: Vec<f64> = runs.iter().map(|r| f(&r[job])).collect();
                min_median(&mut v).1
            };
            let per_tile = |s: f64| 1e6 * s / n as f64;
            let rate = |s: f64| n as f64 / s;
            let steady = median(&|c| c.cpu_steady);
            let (wi, ci) = (median(&|c| c.wall_image), median(&|c| c.cpu_image));
            println!(
                "{workers:>7} {:>4} {n:>7} {:>7} | {:>10.1} {:>12.0} | {:>10.0} {:>10.1} {:>12.0} {:>10.1} | {:>8.0} {:>8.0} {:>8.1} | {:>6.2}",
                job + 1,
                // Workers join once, before the run's first job.
                if job == 0 { format!("{:.2}", median(&|c| c.register)) } else { "-".into() },
                1e6 * steady,
                1.0 / steady,
                rate(wi),
                per_tile(ci),
                rate(ci),
                per_tile(median(&|c| c.loop_busy)),
                1e3 * median(&|c| c.cpu_image - c.cpu_steady * n as f64),
                1e3 * median(&|c| c.cpu_after),
                1e3 * median(&|c| c.stall),
                median(&|c| c.speculated),
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "Medians of {CAPACITY_RUNS} runs, each on a fresh coordinator with its journal, of the \
         run's first job and of the next one (# = 2: the same coordinator and workers, warm \
         from the first, as in a farm left running). Joined = \
         wall seconds to register every fake worker and open its Work stream. 10-90% = the \
         coordinator process's own CPU seconds (user + system, /proc, 10 ms ticks) a tile \
         between the progress events that first report 10% and 90% of the tiles merged \
         (dispatch, merge, journal: what grows with tiles), and its inverse. To image = from \
         the submit call to the finished {}×{} image received by the client: tiles/s over wall \
         seconds, the coordinator's CPU a tile and its inverse, and its event loop's busy time a tile \
         until it went quiet \
         (farm_event_loop_busy_seconds_total: the part done one event at a time, which \
         more cores do not share; the stall probe's events included). Job = the coordinator's CPU \
         to image less 10-90%'s cost for every tile: the job's own start and end (its film, \
         estimate and image), which grow with pixels. After = the coordinator's CPU from the \
         image received to the process going quiet (no CPU tick for 100 ms): what it still does \
         for the job, such as its journal storing the image, and the last stall probes. Stall = the longest the coordinator's \
         event loop took to answer a probe sent every 2 ms while the job ran (two events: a \
         cancel of a job that does not exist). Spec = speculative hand-outs a tile \
         (farm_tiles_speculated_total): copies and parts of tiles still out, given to idle \
         workers once no tile is left to hand out, each a message to a worker and one back. The client's and the fake workers' CPU \
         is left out. The fake workers share {FAKE_CONNECTIONS} connections and ask for \
         tiles/workers tiles each (1 to 32).",
        tiles.geometry.cropped_pixel_bounds.width(),
        tiles.geometry.cropped_pixel_bounds.height(),
    );
}
