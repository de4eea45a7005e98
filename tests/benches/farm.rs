//! `cargo bench -p farm-tests --bench farm`: what the farm costs.
//!
//! 1. Farm overhead: one scene rendered embedded (`farm submit`) and through
//!    a coordinator and one worker *process* on loopback, which needs
//!    `cargo build --release -p farm-cli` first.
//! 2. Coordinator capacity: an in-process coordinator fed by many fake
//!    workers that answer every assignment at once with a precomputed tile,
//!    so the only real work is the coordinator's (and the client's).

use farm_cli::client::{self, RemoteOptions};
use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::film::FilmGeometry;
use farm_common::ids::TileId;
use farm_coordinator::server::{serve, ServerConfig};
use farm_proto::v1::{
    self, coordinator_client::CoordinatorClient, coordinator_message, tile_result, worker_message,
};
use farm_proto::PROTOCOL_VERSION;
use farm_render::render::film_and_sampler;
use farm_render::RenderOptions;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::runtime::Runtime;
use tokio::sync::{mpsc, oneshot};
use tokio_stream::wrappers::UnboundedReceiverStream;

/// Runs of each variant in table 1.
const RUNS: usize = 5;
/// Fake worker counts of table 2.
const FAKE_WORKERS: [usize; 3] = [8, 32, 128];
/// Runs of each row of table 2.
const CAPACITY_RUNS: usize = 3;
/// Tiles each fake worker may hold.
const FAKE_IN_FLIGHT: u32 = 16;

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

fn main() {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("runtime");
    // `FARM_BENCH=overhead` or `=capacity` runs one table.
    let only = std::env::var("FARM_BENCH").unwrap_or_default();
    if only != "capacity" {
        overhead_table(&rt);
        println!();
    }
    if only != "overhead" {
        capacity_table(&rt);
    }
}

// ---------------------------------------------------------------- table 1

/// Child processes killed when dropped, also on panic.
struct Procs(Vec<Child>);

impl Procs {
    /// CPU seconds (user + system) each process has used so far.
    fn cpu_seconds(&self) -> Option<Vec<f64>> {
        self.0.iter().map(|c| cpu_seconds(&c.id().to_string())).collect()
    }
}

impl Drop for Procs {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// User + system CPU seconds of process `pid` ("self" for this one), from
/// `/proc/PID/stat` (Linux; in USER_HZ ticks, 100 a second), or `None`.
fn cpu_seconds(pid: &str) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name, which is in parentheses and may hold spaces.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// `target/release/farm` beside `target/release/deps/<this bench>`.
fn farm_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    exe.ancestors().skip(1).take(2).map(|d| d.join("farm")).find(|p| p.is_file())
}

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1:0");
    l.local_addr().expect("addr").port()
}

/// Waits until the coordinator at `url` answers and lists `n` workers.
async fn wait_for_workers(url: &str, n: usize) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        if let Ok(s) = client::status(&farm_cli::client::Remote::insecure(url)).await {
            if s.workers.len() >= n {
                return;
            }
        }
        assert!(Instant::now() < deadline, "no coordinator with {n} workers at {url} after 30 s");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// A coordinator process and, once it answers, one worker process of two threads.
fn start_farm(bin: &Path, rt: &Runtime) -> (Procs, String) {
    let addr = format!("127.0.0.1:{}", free_port());
    let url = format!("http://{addr}");
    let spawn = |args: &[&str]| {
        Command::new(bin)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {} {args:?}: {e}", bin.display()))
    };
    let mut procs = Procs(vec![spawn(&["coordinator", "--listen", &addr])]);
    rt.block_on(wait_for_workers(&url, 0));
    procs.0.push(spawn(&["worker", "--coordinator", &url, "--threads", "2"]));
    rt.block_on(wait_for_workers(&url, 1));
    (procs, url)
}

/// Minimum and median.
fn min_median(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

/// Wall and CPU seconds of each run; for the farm, also the CPU seconds of
/// the client and coordinator alone (all but the worker).
#[derive(Default)]
struct Runs {
    wall: Vec<f64>,
    cpu: Vec<f64>,
    cpu_beside_worker: Vec<f64>,
}

fn overhead_table(rt: &Runtime) {
    println!("Farm overhead: embedded (2 threads) vs coordinator + 1 worker process (2 threads)");
    let Some(bin) = farm_binary() else {
        println!("  SKIPPED: no `farm` binary beside this bench; run");
        println!("  `cargo build --release -p farm-cli --bin farm` first.");
        return;
    };
    let mut scenes =
        vec![("example", Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt"))];
    if let Some(shared) = farm_tests::shared_dir() {
        let k = shared.join("scenes/killeroo-simple/killeroo-simple-whitted.pbrt");
        if k.is_file() {
            scenes.push(("killeroo-simple", k));
        }
    }
    let spp = 16;
    println!(
        "{:<16} {:>4} | {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9} | {:>8} {:>8} {:>8} | {:>11}",
        "", "", "embedded", "farm", "", "embedded", "farm", "", "embedded", "farm", "", "client +"
    );
    println!(
        "{:<16} {:>4} | {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9} | {:>8} {:>8} {:>8} | {:>11}",
        "scene",
        "spp",
        "wall min",
        "wall min",
        "ratio",
        "wall med",
        "wall med",
        "ratio",
        "CPU min",
        "CPU min",
        "ratio",
        "coord. CPU"
    );
    for (name, path) in &scenes {
        let (mut embedded, mut farm) = (Runs::default(), Runs::default());
        for _ in 0..RUNS {
            let opts = SubmitOptions { threads: 2, spp: Some(spp), ..Default::default() };
            let cpu = cpu_seconds("self");
            let t = Instant::now();
            submit::render(path, &opts, |_| {}).expect("embedded render");
            embedded.wall.push(t.elapsed().as_secs_f64());
            if let (Some(a), Some(b)) = (cpu, cpu_seconds("self")) {
                embedded.cpu.push(b - a);
            }

            // A fresh farm per run, so the worker's scene cache is cold like the embedded render.
            let (procs, url) = start_farm(&bin, rt);
            let opts = RemoteOptions { spp: Some(spp), ..Default::default() };
            let cpu = (cpu_seconds("self"), procs.cpu_seconds());
            let t = Instant::now();
            rt.block_on(client::submit(
                &farm_cli::client::Remote::insecure(&url),
                path,
                &opts,
                |_, _| {},
            ))
            .expect("farm render");
            farm.wall.push(t.elapsed().as_secs_f64());
            // Client (this process) + coordinator (procs[0]) + worker (procs[1]).
            if let ((Some(a), Some(pa)), Some(b), Some(pb)) =
                (cpu, cpu_seconds("self"), procs.cpu_seconds())
            {
                let (client, coordinator, worker) = (b - a, pb[0] - pa[0], pb[1] - pa[1]);
                farm.cpu.push(client + coordinator + worker);
                farm.cpu_beside_worker.push(client + coordinator);
            }
            drop(procs);
        }
        let (e_min, e_med) = min_median(&mut embedded.wall);
        let (f_min, f_med) = min_median(&mut farm.wall);
        let cpu = if embedded.cpu.len() == RUNS && farm.cpu.len() == RUNS {
            let (e, e_med) = min_median(&mut embedded.cpu);
            let (f, _) = min_median(&mut farm.cpu);
            let (_, beside) = min_median(&mut farm.cpu_beside_worker);
            format!("{e:>8.2} {f:>8.2} {:>8.3} | {:>10.1}%", f / e, 100.0 * beside / e_med)
        } else {
            format!("{:>26} | {:>11}", "(no /proc)", "")
        };
        println!(
            "{name:<16} {spp:>4} | {e_min:>9.3} {f_min:>9.3} {:>9.3} | {e_med:>9.3} {f_med:>9.3} {:>9.3} | {cpu}",
            f_min / e_min,
            f_med / e_med,
        );
    }
    println!(
        "{RUNS} runs each, alternating. Wall = submit call to image received (for the farm: \
         client parse, upload, worker scene fetch and build, render, merge, image transfer). \
         CPU = user + system seconds of every process involved (embedded: this process; farm: \
         client + coordinator + worker). Client + coord. CPU = median CPU of the client and \
         coordinator alone, as a share of the embedded render's median CPU: the part of the \
         overhead that is the farm's own rather than the worker's. Goal: ratio ≤ 1.03. On a \
         shared machine the ratios move by several per cent from run to run in both directions."
    );
}

// ---------------------------------------------------------------- table 2

/// Precomputed answers: the film layout and one tile's bytes per distinct size.
struct Tiles {
    geometry: FilmGeometry,
    bytes: HashMap<(i32, i32), Vec<u8>>,
}

impl Tiles {
    fn new(geometry: FilmGeometry) -> Self {
        let px: Vec<u8> = [0.5f32, 0.5, 0.5, 1.0].iter().flat_map(|v| v.to_le_bytes()).collect();
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

/// Registers, opens the Work stream and answers every assignment at once.
async fn fake_worker(url: String, tiles: Arc<Tiles>) {
    let mut c = CoordinatorClient::connect(url).await.expect("connect");
    let reg = v1::RegisterWorkerRequest {
        protocol_version: PROTOCOL_VERSION,
        name: "fake".into(),
        threads: 1,
    };
    let reply = c.register_worker(reg).await.expect("register").into_inner();
    let (tx, rx) = mpsc::unbounded_channel();
    let hello = v1::Hello {
        worker_id: reply.worker_id,
        max_in_flight: FAKE_IN_FLIGHT,
        session_key: reply.session_key,
    };
    tx.send(v1::WorkerMessage { kind: Some(worker_message::Kind::Hello(hello)) }).expect("hello");
    let mut inbound = c.work(UnboundedReceiverStream::new(rx)).await.expect("work").into_inner();
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
}

/// Seconds to the last tile's progress event and to the image, or why not.
async fn capacity_run(
    workers: usize,
    scene: &Path,
    tiles: &Arc<Tiles>,
) -> Result<(f64, f64), String> {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let url = format!("http://{}", listener.local_addr().expect("addr"));
    let (stop, stopped) = oneshot::channel::<()>();
    let config = ServerConfig::with_heartbeat(Duration::from_secs(5));
    let server = tokio::spawn(serve(listener, config, async {
        let _ = stopped.await;
    }));
    let fakes: Vec<_> =
        (0..workers).map(|_| tokio::spawn(fake_worker(url.clone(), tiles.clone()))).collect();
    wait_for_workers(&url, workers).await;

    let t = Instant::now();
    let mut last_tile = None;
    let opts = RemoteOptions::default();
    let remote = farm_cli::client::Remote::insecure(&url);
    let job = client::submit(&remote, scene, &opts, |_, p| {
        if p.tiles_done == p.tiles_total && last_tile.is_none() {
            last_tile = Some(t.elapsed().as_secs_f64());
        }
    });
    let result = match tokio::time::timeout(Duration::from_secs(120), job).await {
        Ok(Ok(_)) => {
            let total = t.elapsed().as_secs_f64();
            Ok((last_tile.unwrap_or(total), total))
        }
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => Err("timed out after 120 s".into()),
    };

    let _ = stop.send(());
    let _ = tokio::time::timeout(Duration::from_secs(10), server).await;
    for f in fakes {
        f.abort();
    }
    result
}

fn capacity_table(rt: &Runtime) {
    println!("Coordinator capacity: in-process coordinator, fake workers answering at once");
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
    println!(
        "{:>7} {:>7} | {:>12} {:>12} | {:>12} {:>12}",
        "", "", "to last tile", "", "to image", ""
    );
    println!(
        "{:>7} {:>7} | {:>12} {:>12} | {:>12} {:>12}",
        "workers", "tiles", "best tiles/s", "med tiles/s", "best tiles/s", "med tiles/s"
    );
    for workers in FAKE_WORKERS {
        let (mut last, mut total) = (Vec::new(), Vec::new());
        let mut failure = None;
        for _ in 0..CAPACITY_RUNS {
            match rt.block_on(capacity_run(workers, &scene, &tiles)) {
                Ok((l, t)) => {
                    last.push(l);
                    total.push(t);
                }
                Err(e) => failure = Some(e),
            }
        }
        if let Some(e) = failure {
            println!("{workers:>7} {n:>7} failed: {e}");
            continue;
        }
        let (l_min, l_med) = min_median(&mut last);
        let (t_min, t_med) = min_median(&mut total);
        let rate = |s: f64| n as f64 / s;
        println!(
            "{workers:>7} {n:>7} | {:>12.0} {:>12.0} | {:>12.0} {:>12.0}",
            rate(l_min),
            rate(l_med),
            rate(t_min),
            rate(t_med)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "{CAPACITY_RUNS} runs each. To last tile = submit call to the progress event that \
         reports every tile merged (dispatch and merge, the goal's measure: > 50,000 tiles/s); \
         to image = submit call to the finished {}×{} image received by the client. Client, \
         fake workers and coordinator share this machine's {} cores.",
        tiles.geometry.cropped_pixel_bounds.width(),
        tiles.geometry.cropped_pixel_bounds.height(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
}
