//! What watching a render costs: the same farm render, unwatched and then
//! with tev attached (`--display-server`) and a dashboard job page open,
//! side by side in one run, alternating which goes first. Reports each
//! render's wall time and the coordinator's CPU time (summed over its
//! threads from /proc, in nanoseconds), their medians, the fastest of
//! each side, and the ratios.
//!
//! ```sh
//! cargo bench -p farm-cli --bench watch_overhead            # 5 pairs at 256 spp
//! FARM_ROUNDS=9 FARM_SPP=512 cargo bench -p farm-cli --bench watch_overhead
//! ```
//!
//! The farm is real processes on loopback: an insecure coordinator, two
//! workers of one thread, `farm submit --coordinator`. The "dashboard" is
//! this program making the requests a job page's script makes: the live
//! image at its pace (a look per 64 tiles merged, two to five seconds
//! apart, the job's facts with a look every five seconds) and the
//! finished image once the render ends. The coordinator's CPU is read a
//! few seconds after both, once the journal has also finished with the
//! job: all of it, and all but its journal thread's (SQLite's reads and
//! writes, which watching never touches and whose cost on a VM's disk
//! varies more than watching costs).
//!
//! CPU time on a shared machine varies by more than the few percent being
//! measured, so `FARM_CALLGRIND=1` runs the coordinator under valgrind's
//! callgrind and also reports the instructions it executed during each
//! render (zeroed before, dumped after, with `callgrind_control`): a count
//! that does not depend on the machine's load. Give it more samples per
//! pixel (the coordinator runs some 50× slower under valgrind). Its glibc
//! copies with vector loops there ([`STRING_LOOPS`]), so that a large
//! copy counts about what it costs.
//!
//! `FARM_PIN=1` (Linux, `taskset`) gives the coordinator CPU 0 to itself
//! and runs everything else (workers, `farm submit`, this program's page
//! and tev) on CPU 1, so the workers' rendering does not share a core with
//! the coordinator whose CPU time is measured; and, as under callgrind,
//! each render gets a fresh farm.
//!
//! `FARM_PERF=DIR` records the coordinator with `perf record` during each
//! render (DIR/plain-N.data, DIR/watched-N.data; the warm-up renders are
//! plain ones too): where its time goes in the kernel as well, which
//! callgrind does not see. `FARM_STRACE=DIR` counts its system calls
//! (`strace -c`) instead, to DIR/plain-N.txt and DIR/watched-N.txt.

#[path = "watch_overhead/callgrind.rs"]
mod callgrind;
#[path = "watch_overhead/proc.rs"]
mod proc;
#[path = "watch_overhead/watchers.rs"]
mod watchers;

use callgrind::{Callgrind, STRING_LOOPS};
use proc::{cpu_seconds, kernel, Cpu, Kernel};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use watchers::{dashboard, tev_sink};

struct Procs(Vec<Child>);

impl Drop for Procs {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn farm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_farm"))
}

/// Whether the coordinator gets a core to itself (`FARM_PIN=1`).
fn pinned() -> bool {
    std::env::var("FARM_PIN").is_ok_and(|v| v == "1")
}

/// `cmd` run on CPU `cpu` only, when pinning.
fn on_cpu(cpu: u32, cmd: Command) -> Command {
    if !pinned() {
        return cmd;
    }
    let mut t = Command::new("taskset");
    t.args(["-c", &cpu.to_string()]).arg(cmd.get_program()).args(cmd.get_args());
    for (k, v) in cmd.get_envs() {
        match v {
            Some(v) => t.env(k, v),
            None => t.env_remove(k),
        };
    }
    t
}

/// `FARM_PERF=DIR`: `perf record` of the coordinator during each render,
/// written to DIR/plain-N.data or DIR/watched-N.data; `FARM_STRACE=DIR`:
/// `strace -c`'s count of its system calls, to DIR/plain-N.txt or
/// DIR/watched-N.txt.
fn trace_coordinator(coord: u32, watched: bool) -> Option<Child> {
    let (var, ext) = if std::env::var_os("FARM_STRACE").is_some() {
        ("FARM_STRACE", "txt")
    } else {
        ("FARM_PERF", "data")
    };
    let dir = PathBuf::from(std::env::var_os(var)?);
    std::fs::create_dir_all(&dir).ok()?;
    let kind = if watched { "watched" } else { "plain" };
    let n = (1..).find(|n| !dir.join(format!("{kind}-{n}.{ext}")).exists())?;
    let out = dir.join(format!("{kind}-{n}.{ext}"));
    let pid = coord.to_string();
    let mut cmd = if ext == "txt" {
        let mut c = Command::new("strace");
        c.args(["-f", "-c", "-p", &pid, "-o"]).arg(out);
        c
    } else {
        let mut c = Command::new("perf");
        c.args(["record", "-q", "-F", "10000", "-p", &pid, "-o"]).arg(out);
        c
    };
    let child = cmd.stdout(Stdio::null()).stderr(Stdio::null()).spawn().ok()?;
    std::thread::sleep(Duration::from_millis(300));
    Some(child)
}

struct Run {
    wall: f64,
    cpu: Cpu,
    /// Instructions the coordinator executed, under callgrind.
    instructions: Option<u64>,
    tev_bytes: u64,
    requests: u64,
    kernel: Kernel,
}

fn render(
    url: &str,
    coord: u32,
    cg: Option<&Callgrind>,
    scene: &Path,
    out: &Path,
    spp: u32,
    watched: bool,
) -> Run {
    // FARM_WATCH=tev or dashboard watches with one of the two only.
    let how = std::env::var("FARM_WATCH").unwrap_or_default();
    let (with_tev, with_page) = (watched && how != "dashboard", watched && how != "tev");
    let addr = url.trim_start_matches("http://").to_string();
    let stop = Arc::new(AtomicBool::new(false));
    let (tev, bytes) = tev_sink();
    let poller = with_page.then(|| dashboard(addr, stop.clone()));
    if let Some(cg) = cg {
        cg.zero();
    }
    let perf = trace_coordinator(coord, watched);
    let cpu0 = cpu_seconds(coord);
    let k0 = kernel(coord);
    let t0 = Instant::now();
    let mut cmd = on_cpu(1, farm());
    cmd.args(["submit", "--quiet", "--coordinator", url, "--spp", &spp.to_string(), "-o"])
        .arg(out)
        .arg(scene);
    if with_tev {
        cmd.args(["--display-server", &tev]);
    }
    let status = cmd.status().expect("farm submit");
    assert!(status.success(), "farm submit failed");
    let wall = t0.elapsed().as_secs_f64();
    // The coordinator's work for watchers ends once the page has its
    // finished image.
    stop.store(true, Ordering::Relaxed);
    let requests = poller.map(|p| p.join().unwrap_or(0)).unwrap_or(0);
    // The render's own work goes on after its client has the image (the
    // journal deletes the job's tiles): let it end, the same time in both
    // modes, so neither is cut short.
    std::thread::sleep(Duration::from_secs(if cg.is_some() { 5 } else { 2 }));
    let cpu = cpu_seconds(coord) - cpu0;
    let kernel = kernel(coord) - k0;
    let instructions = cg.map(Callgrind::dump);
    if let Some(mut p) = perf {
        let _ = Command::new("kill").args(["-INT", &p.id().to_string()]).status();
        let _ = p.wait();
    }
    Run { wall, cpu, instructions, tev_bytes: bytes.load(Ordering::Relaxed), requests, kernel }
}

/// A coordinator (under callgrind if asked) and two workers of one thread.
struct Farm {
    url: String,
    pid: u32,
    callgrind: Option<Callgrind>,
    _procs: Procs,
}

impl Farm {
    fn start(dir: &Path, callgrind: bool) -> Farm {
        std::fs::create_dir_all(dir).expect("farm dir");
        let mut procs = Procs(Vec::new());
        let coord = if callgrind {
            let mut c = Command::new("valgrind");
            let mut out = std::ffi::OsString::from("--callgrind-out-file=");
            out.push(dir.join("cg.out"));
            c.args(["--tool=callgrind", "--dump-instr=no"])
                .arg(out)
                .arg(env!("CARGO_BIN_EXE_farm"))
                .env("GLIBC_TUNABLES", STRING_LOOPS);
            c
        } else {
            farm()
        };
        let mut coord = on_cpu(0, coord);
        let mut coord = coord
            .args(["coordinator", "--insecure", "--listen", "127.0.0.1:0", "--state-dir"])
            .arg(dir.join("state"))
            .stderr(Stdio::piped())
            .spawn()
            .expect("start the coordinator");
        let stderr = coord.stderr.take().expect("stderr");
        let pid = coord.id();
        procs.0.push(coord);
        let mut reader = BufReader::new(stderr);
        let mut line = String::new();
        while !line.contains("listening on") {
            line.clear();
            assert!(reader.read_line(&mut line).expect("coordinator log") > 0, "no banner");
        }
        std::thread::spawn(move || std::io::copy(&mut reader, &mut std::io::sink()));
        let at = line.find("http://").expect("an http:// URL");
        let url = line[at..].split_whitespace().next().expect("url").to_string();
        for i in 0..2 {
            let w = on_cpu(1, farm())
                .args([
                    "worker",
                    "--coordinator",
                    &url,
                    "--threads",
                    "1",
                    "--name",
                    &format!("w{i}"),
                ])
                .stderr(Stdio::null())
                .spawn()
                .expect("start a worker");
            procs.0.push(w);
        }
        let callgrind = callgrind.then(|| Callgrind { pid, dir: dir.to_path_buf() });
        Farm { url, pid, callgrind, _procs: procs }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

fn main() {
    let env = |k: &str, d: u32| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let (rounds, spp) = (env("FARM_ROUNDS", 5), env("FARM_SPP", 256));
    let dir = std::env::temp_dir().join(format!("farm-watch-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt");
    let callgrind = std::env::var("FARM_CALLGRIND").is_ok_and(|v| v == "1");
    if pinned() {
        let me = std::process::id().to_string();
        let ok = Command::new("taskset").args(["-pc", "1", &me]).stdout(Stdio::null()).status();
        assert!(ok.is_ok_and(|s| s.success()), "FARM_PIN=1 needs taskset and two CPUs");
    }
    let out = dir.join("out.exr");
    let mut n = 0;
    let mut start = || {
        n += 1;
        let farm = Farm::start(&dir.join(format!("farm-{n}")), callgrind);
        // Warm-up: workers fetch the scene and build it once.
        render(&farm.url, farm.pid, None, &scene, &out, 1, false);
        farm
    };
    // Under callgrind or pinned, each render gets a farm of its own, so the
    // journal's history (whose SQLite costs vary with it by more than
    // watching costs) is the same for both.
    let fresh = callgrind || pinned();
    let shared = (!fresh).then(&mut start);
    let mut run = |watched: bool| {
        let fresh = fresh.then(&mut start);
        let farm = fresh.as_ref().or(shared.as_ref()).expect("a farm");
        render(&farm.url, farm.pid, farm.callgrind.as_ref(), &scene, &out, spp, watched)
    };
    println!("watch overhead: example.pbrt at {spp} spp, 2 workers × 1 thread, {rounds} pairs");
    println!(
        "{:>5}  {:>11} {:>11}  {:>11} {:>11}  {:>11} {:>11}  {:>10} {:>8}",
        "pair",
        "wall plain",
        "wall watch",
        "cpu plain",
        "cpu watch",
        "-jrnl plain",
        "-jrnl watch",
        "tev bytes",
        "requests"
    );
    let (mut plain, mut watched) = (Vec::new(), Vec::new());
    for r in 0..rounds {
        let order = if r % 2 == 0 { [false, true] } else { [true, false] };
        let mut pair = [None, None];
        for w in order {
            pair[usize::from(w)] = Some(run(w));
        }
        let [Some(p), Some(w)] = pair else { unreachable!() };
        let ins = |r: &Run| r.instructions.map(|i| format!("  {:>14} ins", i)).unwrap_or_default();
        println!(
            "{:>5}  {:>10.3}s {:>10.3}s  {:>10.3}s {:>10.3}s  {:>10.3}s {:>10.3}s  {:>10} {:>8}{}{}",
            r + 1,
            p.wall,
            w.wall,
            p.cpu.total,
            w.cpu.total,
            p.cpu.outside_journal(),
            w.cpu.outside_journal(),
            w.tev_bytes,
            w.requests,
            ins(&p),
            ins(&w)
        );
        assert!(w.tev_bytes > 0 || w.requests > 2, "the watched render was not watched");
        plain.push(p);
        watched.push(w);
    }
    let m = |v: &[Run], f: fn(&Run) -> f64| median(v.iter().map(f).collect());
    let (pw, ww) = (m(&plain, |r| r.wall), m(&watched, |r| r.wall));
    let (pc, wc) = (m(&plain, |r| r.cpu.total), m(&watched, |r| r.cpu.total));
    println!("median {:>10.3}s {:>10.3}s  {:>10.3}s {:>10.3}s", pw, ww, pc, wc);
    println!("watched ÷ plain: wall {:.3}, coordinator CPU {:.3}", ww / pw, wc / pc);
    let pairs =
        |f: fn(&Run) -> f64| median(plain.iter().zip(&watched).map(|(p, w)| f(w) / f(p)).collect());
    println!(
        "median of the pairs' ratios: wall {:.3}, coordinator CPU {:.3}",
        pairs(|r| r.wall),
        pairs(|r| r.cpu.total)
    );
    // Noise on a shared machine only ever adds time: the fastest of each
    // side is the least disturbed reading.
    let fastest = |v: &[Run], f: fn(&Run) -> f64| v.iter().map(f).fold(f64::INFINITY, f64::min);
    let (fp, fw) = (fastest(&plain, |r| r.cpu.total), fastest(&watched, |r| r.cpu.total));
    let (fpe, fwe) = (
        fastest(&plain, |r| r.cpu.outside_journal()),
        fastest(&watched, |r| r.cpu.outside_journal()),
    );
    let (fpw, fww) = (fastest(&plain, |r| r.wall), fastest(&watched, |r| r.wall));
    println!(
        "fastest: wall {fpw:.3}s / {fww:.3}s ({:.3}), coordinator CPU {fp:.3}s / {fw:.3}s ({:.3}), outside the journal {fpe:.3}s / {fwe:.3}s ({:.3})",
        fww / fpw,
        fw / fp,
        fwe / fpe
    );
    let (pe, we) =
        (m(&plain, |r| r.cpu.outside_journal()), m(&watched, |r| r.cpu.outside_journal()));
    println!(
        "coordinator CPU outside the journal thread: median {pe:.3}s / {we:.3}s, ratio {:.3}, median of the pairs' ratios {:.3}",
        we / pe,
        pairs(|r| r.cpu.outside_journal())
    );
    println!(
        "median system time {:.2}s / {:.2}s, context switches {:.0} / {:.0}, page faults {:.0} / {:.0} (plain / watched)",
        m(&plain, |r| r.kernel.sys),
        m(&watched, |r| r.kernel.sys),
        m(&plain, |r| r.kernel.switches as f64),
        m(&watched, |r| r.kernel.switches as f64),
        m(&plain, |r| r.kernel.faults as f64),
        m(&watched, |r| r.kernel.faults as f64),
    );
    if callgrind {
        let (pi, wi) = (
            m(&plain, |r| r.instructions.unwrap_or(0) as f64),
            m(&watched, |r| r.instructions.unwrap_or(0) as f64),
        );
        println!(
            "coordinator instructions (median): plain {pi:.0}, watched {wi:.0}, ratio {:.4}",
            wi / pi
        );
    }
    drop(shared);
    if callgrind {
        println!("callgrind dumps (for callgrind_annotate) kept in {}", dir.display());
    } else {
        std::fs::remove_dir_all(dir).ok();
    }
}
