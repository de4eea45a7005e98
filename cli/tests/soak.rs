//! A seeded fault-injection soak with real processes on loopback: a TLS
//! coordinator with its state on disk, three `farm worker`s, a worker of
//! our own that sends every third result twice and sits on others until it
//! is declared lost (then sends them anyway), and several `farm submit`s.
//! While they run, workers are SIGKILLed and restarted or SIGSTOPped and
//! resumed at random, and the coordinator is SIGKILLed once and restarted
//! on the same state directory. Every image must equal the embedded render
//! byte for byte.
//!
//! `FARM_SOAK_SEED` picks the faults and `FARM_SOAK_JOBS` the number of jobs
//! (CI runs 4); `scripts/soak` runs a long one.

mod common;

use common::{
    client_remote, farm, free_port, scene, spawn_worker, start_coordinator_on, token_file, Procs,
};
use farm_common::ids::TileId;
use farm_common::rng::Rng;
use farm_proto::auth::Token;
use farm_proto::v1::{self, coordinator_message, worker_message};
use farm_render::render::{RenderOptions, Renderer};
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_stream::wrappers::UnboundedReceiverStream;

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

#[derive(Default)]
struct Counts {
    duplicates: AtomicU64,
    late: AtomicU64,
    sessions: AtomicU64,
}

/// Renderers of the example scene by samples per pixel.
type Renderers = Arc<Mutex<HashMap<u32, Arc<Renderer>>>>;

fn renderer(cache: &Renderers, spp: u32) -> Arc<Renderer> {
    let mut c = cache.lock().unwrap();
    c.entry(spp)
        .or_insert_with(|| {
            let (desc, _) = farm_scene::parse_file(&scene()).expect("scene");
            let opts = RenderOptions { spp: (spp > 0).then_some(spp), all_paths: false };
            Arc::new(Renderer::new(desc, &opts).expect("renderer").0)
        })
        .clone()
}

/// One session of the misbehaving worker: until the stream breaks, or until
/// it has held back results long enough to be declared lost.
async fn chaos_session(
    url: &str,
    token: &Token,
    rng: &mut Rng,
    renderers: &Renderers,
    counts: &Counts,
) -> Result<(), String> {
    let mut client =
        farm_proto::connect::connect(url, Some(token)).await.map_err(|e| e.to_string())?;
    let reg = v1::RegisterWorkerRequest {
        protocol_version: farm_proto::PROTOCOL_VERSION,
        name: "chaos".into(),
        threads: 1,
    };
    let reply = client.register_worker(reg).await.map_err(|e| e.to_string())?.into_inner();
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let hello = v1::Hello {
        worker_id: reply.worker_id,
        max_in_flight: 4,
        session_key: reply.session_key.clone(),
    };
    let send = |kind| {
        let _ = tx.send(v1::WorkerMessage { kind: Some(kind) });
    };
    send(worker_message::Kind::Hello(hello));
    let mut inbound = client
        .work(UnboundedReceiverStream::new(rx))
        .await
        .map_err(|e| e.to_string())?
        .into_inner();
    counts.sessions.fetch_add(1, Ordering::Relaxed);
    let mut held = Vec::new();
    let mut last_assign = tokio::time::Instant::now();
    let mut beat = tokio::time::interval(Duration::from_millis(100));
    loop {
        tokio::select! {
            m = inbound.message() => {
                let Ok(Some(m)) = m else { return Ok(()) };
                let Some(coordinator_message::Kind::Assign(a)) = m.kind else { continue };
                last_assign = tokio::time::Instant::now();
                let r = renderer(renderers, a.spp);
                let tile = TileId(a.tile);
                // A part of a late tile (speculation on a stateless
                // sampler's job) is that part's film, as a real worker sends.
                let part = a.part.checked_sub(1);
                let (ft, stats) = tokio::task::spawn_blocking(move || match part {
                    Some(k) => r.render_part(tile, None, k).expect("a stateless sampler's tile"),
                    None => r.render_tile(tile),
                })
                .await
                .map_err(|e| e.to_string())?;
                let result = v1::TileResult {
                    job_id: a.job_id,
                    tile: a.tile,
                    attempt: a.attempt,
                    outcome: Some(v1::tile_result::Outcome::FilmTile((&ft).into())),
                    stats: Some((&stats).into()),
                };
                match rng.uniform_u32_below(3) {
                    0 => {
                        send(worker_message::Kind::Result(result.clone()));
                        send(worker_message::Kind::Result(result));
                        counts.duplicates.fetch_add(1, Ordering::Relaxed);
                    }
                    1 => held.push(result),
                    _ => send(worker_message::Kind::Result(result)),
                }
            }
            _ = beat.tick() => {
                // Held results are released by falling silent once three
                // are held, or once no more work comes (a job's last tiles):
                // a worker that heartbeats while holding a tile for ever is
                // a stuck worker, a fault the scheduler does not yet detect
                // (no tile lease), not the one this session models.
                let idle = last_assign.elapsed() > Duration::from_secs(1);
                if held.len() >= 3 || (!held.is_empty() && idle) {
                    // Fall silent until declared lost (three heartbeats of
                    // 0.2 s), then send what was held: late results from a
                    // lost worker, for tiles handed to others since.
                    tokio::time::sleep(Duration::from_millis(1200)).await;
                    counts.late.fetch_add(held.len() as u64, Ordering::Relaxed);
                    for r in held.drain(..) {
                        send(worker_message::Kind::Result(r));
                    }
                    tokio::time::sleep(Duration::from_millis(200)).await;
                    return Ok(());
                }
                send(worker_message::Kind::Heartbeat(v1::Heartbeat {}));
            }
        }
    }
}

async fn chaos_worker(
    url: String,
    token: Token,
    seed: u64,
    stop: Arc<AtomicBool>,
    counts: Arc<Counts>,
) {
    let mut rng = Rng::new(seed ^ 0x9e37_79b9);
    let renderers = Renderers::default();
    while !stop.load(Ordering::Relaxed) {
        if chaos_session(&url, &token, &mut rng, &renderers, &counts).await.is_err() {
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    }
}

fn render_embedded(dir: &Path, spp: u32) -> Vec<u8> {
    let out = dir.join(format!("embedded-{spp}.pfm"));
    let status = farm()
        .args(["submit", "--quiet", "--spp", &spp.to_string(), "-o"])
        .arg(&out)
        .arg(scene())
        .status()
        .expect("embedded render");
    assert!(status.success());
    std::fs::read(out).expect("embedded image")
}

fn signal(pid: u32, sig: &str) {
    let _ = std::process::Command::new("kill").args([sig, &pid.to_string()]).status();
}

#[test]
fn seeded_faults_change_no_byte_of_any_image() {
    let seed = env_u64("FARM_SOAK_SEED", 1);
    let jobs = env_u64("FARM_SOAK_JOBS", 4).max(1) as usize;
    let dir = std::env::temp_dir().join(format!("farm-soak-{}-{seed}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let state = dir.join("state");
    let listen = format!("127.0.0.1:{}", free_port());
    let mut procs = Procs(Vec::new());
    let url = start_coordinator_on(&mut procs, &state, &listen, "coordinator.log");
    let mut coordinator = procs.0.len() - 1;
    let worker_token = token_file(&state, "worker");
    let mut workers: Vec<usize> = Vec::new();
    for i in 0..3 {
        procs.0.push(spawn_worker(&url, &worker_token, &format!("w{i}")));
        workers.push(procs.0.len() - 1);
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("runtime");
    let stop = Arc::new(AtomicBool::new(false));
    let counts = Arc::new(Counts::default());
    let token: Token = std::fs::read_to_string(&worker_token).unwrap().trim().parse().unwrap();
    let chaos = rt.spawn(chaos_worker(url.clone(), token, seed, stop.clone(), counts.clone()));

    let spps = [1u32, 2, 3];
    let mut submits = Vec::new();
    for i in 0..jobs {
        let spp = spps[i % spps.len()];
        let out = dir.join(format!("job-{i}.pfm"));
        let child = farm()
            .args(["submit", "--quiet", "--spp", &spp.to_string(), "--coordinator", &url])
            .args(["--priority", &(i % 3).to_string(), "-o"])
            .arg(&out)
            .arg("--token-file")
            .arg(token_file(&state, "client"))
            .arg(scene())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("start submit");
        submits.push((child, spp, out));
    }

    let mut rng = Rng::new(seed);
    let start = Instant::now();
    let deadline = start + Duration::from_secs(60 + 30 * jobs as u64);
    let (mut kills, mut stops, mut restarted) = (0, 0, false);
    let mut stopped: Vec<(usize, Instant)> = Vec::new();
    let remote = client_remote(&url, &state);
    let mut pending: Vec<bool> = vec![true; jobs];
    while pending.iter().any(|p| *p) {
        assert!(Instant::now() < deadline, "the soak did not finish in time (seed {seed})");
        std::thread::sleep(Duration::from_millis(150 + rng.uniform_u32_below(250) as u64));
        let now = Instant::now();
        stopped.retain(|(i, until)| {
            if now >= *until {
                signal(procs.0[*i].id(), "-CONT");
                false
            } else {
                true
            }
        });
        // Once, when some tiles are in and some jobs still run: the
        // coordinator dies and comes back. (Waiting a fixed 1.5 s first let
        // every job end before on a fast machine.)
        if !restarted && now.duration_since(start) > Duration::from_millis(300) {
            let busy = rt.block_on(farm_cli::client::status(&remote)).is_ok_and(|s| {
                s.jobs.len() == jobs
                    && s.jobs.iter().any(|j| j.tiles_done > 0)
                    && s.jobs.iter().any(|j| j.state == "queued" || j.state == "running")
            });
            if busy {
                procs.0[coordinator].kill().expect("SIGKILL coordinator");
                procs.0[coordinator].wait().expect("reap");
                std::thread::sleep(Duration::from_millis(300));
                start_coordinator_on(&mut procs, &state, &listen, "coordinator-2.log");
                coordinator = procs.0.len() - 1;
                restarted = true;
            }
        }
        let w = workers[rng.uniform_u32_below(workers.len() as u32) as usize];
        match rng.uniform_u32_below(4) {
            0 => {
                let name = format!("w{}-{kills}", w);
                let _ = procs.0[w].kill();
                let _ = procs.0[w].wait();
                stopped.retain(|(i, _)| *i != w);
                procs.0[w] = spawn_worker(&url, &worker_token, &name);
                kills += 1;
            }
            1 if !stopped.iter().any(|(i, _)| *i == w) => {
                signal(procs.0[w].id(), "-STOP");
                let pause = Duration::from_millis(300 + rng.uniform_u32_below(1200) as u64);
                stopped.push((w, now + pause));
                stops += 1;
            }
            _ => {}
        }
        for (i, (child, _, _)) in submits.iter_mut().enumerate() {
            if pending[i] && child.try_wait().expect("try_wait").is_some() {
                pending[i] = false;
            }
        }
    }
    for (i, _) in &stopped {
        signal(procs.0[*i].id(), "-CONT");
    }
    stop.store(true, Ordering::Relaxed);
    chaos.abort();

    let mut references: HashMap<u32, Vec<u8>> = HashMap::new();
    let mut differences = 0;
    for (i, (child, spp, out)) in submits.into_iter().enumerate() {
        let o = child.wait_with_output().expect("submit");
        assert!(
            o.status.success(),
            "job {i} failed (seed {seed}): {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let reference = references.entry(spp).or_insert_with(|| render_embedded(&dir, spp));
        if std::fs::read(&out).expect("job image") != *reference {
            differences += 1;
        }
    }
    let c = &counts;
    eprintln!(
        "soak seed {seed}: {jobs} jobs, {kills} worker SIGKILLs, {stops} SIGSTOPs, {} duplicate and {} late results over {} chaos sessions, {} coordinator SIGKILL, {differences} images differ, {:.1} s",
        c.duplicates.load(Ordering::Relaxed),
        c.late.load(Ordering::Relaxed),
        c.sessions.load(Ordering::Relaxed),
        u32::from(restarted),
        start.elapsed().as_secs_f64()
    );
    assert!(restarted, "the coordinator was never killed: the jobs ended too soon");
    assert_eq!(differences, 0, "images differ from the embedded render (seed {seed})");
    drop(procs);
    std::fs::remove_dir_all(dir).ok();
}
