//! `cargo bench -p farm-tests --bench farm`: what the farm costs.
//!
//! 1. Farm overhead: one scene rendered embedded (`farm submit`) and through
//!    a coordinator and one worker *process* on loopback, which needs
//!    `cargo build --release -p farm-cli` first.
//! 2. Coordinator capacity: a coordinator *process* (journal included) fed
//!    by 1, 100 and 10,000 fake workers in this process that answer every
//!    assignment at once with a precomputed tile. The coordinator's own CPU
//!    seconds, read from /proc, give tiles per second per coordinator core,
//!    with the client's and the fake workers' CPU left out.

use farm_cli::client::{self, RemoteOptions};
use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::film::FilmGeometry;
use farm_common::ids::TileId;
use farm_proto::v1::{
    self, coordinator_client::CoordinatorClient, coordinator_message, tile_result, worker_message,
};
use farm_proto::PROTOCOL_VERSION;
use farm_render::render::film_and_sampler;
use farm_render::RenderOptions;
use farm_tests::fake::open_session;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::runtime::Runtime;

/// Runs of each variant in table 1.
const RUNS: usize = 5;

#[path = "farm/capacity.rs"]
mod capacity;

fn main() {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("runtime");
    // `FARM_BENCH=overhead` or `=capacity` runs one table.
    let only = std::env::var("FARM_BENCH").unwrap_or_default();
    if only != "capacity" {
        overhead_table(&rt);
        println!();
    }
    if only != "overhead" {
        capacity::capacity_table(&rt);
    }
}

// ---------------------------------------------------------------- table 1

/// Child processes killed when dropped, also on panic, and the state
/// directory they used, then removed.
struct Procs(Vec<Child>, PathBuf);

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
        let _ = std::fs::remove_dir_all(&self.1);
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

/// `FARM_BIN` (to compare two builds in one sitting), else
/// `target/release/farm` beside `target/release/deps/<this bench>`.
fn farm_binary() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("FARM_BIN") {
        return Some(PathBuf::from(p));
    }
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

/// Starts `bin` with `args`, its output discarded.
fn spawn(bin: &Path, args: &[&str]) -> Child {
    Command::new(bin)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("starting {} {args:?}: {e}", bin.display()))
}

/// An insecure coordinator process on loopback with a state directory of
/// its own (removed with it) and `extra` arguments, once it answers; and
/// its URL.
async fn start_coordinator(bin: &Path, extra: &[&str]) -> (Procs, String) {
    let addr = format!("127.0.0.1:{}", free_port());
    let url = format!("http://{addr}");
    let state = std::env::temp_dir().join(format!("farm-bench-{}-{addr}", std::process::id()));
    let dir = state.to_str().expect("utf-8 temp dir");
    let mut args = vec!["coordinator", "--insecure", "--listen", &addr, "--state-dir", dir];
    args.extend(extra);
    let procs = Procs(vec![spawn(bin, &args)], state);
    wait_for_workers(&url, 0).await;
    (procs, url)
}

/// A coordinator process and, once it answers, one worker process of two threads.
fn start_farm(bin: &Path, rt: &Runtime) -> (Procs, String) {
    let (mut procs, url) = rt.block_on(start_coordinator(bin, &[]));
    procs.0.push(spawn(bin, &["worker", "--coordinator", &url, "--threads", "2"]));
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
