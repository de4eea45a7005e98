//! What watching a render costs: the same farm render, unwatched and then
//! with tev attached (`--display-server`) and a dashboard job page open,
//! side by side in one run, alternating which goes first. Reports each
//! render's wall time and the coordinator's CPU time (summed over its
//! threads from /proc, in nanoseconds), their medians and the ratios.
//!
//! ```sh
//! cargo bench -p farm-cli --bench watch_overhead            # 5 pairs at 256 spp
//! FARM_ROUNDS=9 FARM_SPP=512 cargo bench -p farm-cli --bench watch_overhead
//! ```
//!
//! The farm is real processes on loopback: an insecure coordinator, two
//! workers of one thread, `farm submit --coordinator`. The "dashboard" is
//! this program making the requests a job page's script makes: the live
//! image every second and the job's facts every two.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

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

/// CPU time of every thread of `pid`, in seconds.
fn cpu_seconds(pid: u32) -> f64 {
    let mut ns = 0u64;
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            let s = std::fs::read_to_string(t.path().join("schedstat")).unwrap_or_default();
            ns += s.split_whitespace().next().and_then(|v| v.parse().ok()).unwrap_or(0);
        }
    }
    ns as f64 * 1e-9
}

/// A browser's connection: HTTP/1.1 kept alive between requests.
struct Browser {
    addr: String,
    conn: Option<BufReader<TcpStream>>,
}

impl Browser {
    /// `GET path`, the body (empty on any failure; the next call reconnects).
    fn get(&mut self, path: &str) -> Vec<u8> {
        let body = self.try_get(path);
        if body.is_none() {
            self.conn = None;
        }
        body.unwrap_or_default()
    }

    fn try_get(&mut self, path: &str) -> Option<Vec<u8>> {
        if self.conn.is_none() {
            self.conn = Some(BufReader::new(TcpStream::connect(&self.addr).ok()?));
        }
        let c = self.conn.as_mut()?;
        let req = format!("GET {path} HTTP/1.1\r\nHost: {}\r\n\r\n", self.addr);
        c.get_mut().write_all(req.as_bytes()).ok()?;
        let mut len = 0usize;
        loop {
            let mut line = String::new();
            if c.read_line(&mut line).ok()? == 0 {
                return None;
            }
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some((k, v)) = line.split_once(':') {
                if k.eq_ignore_ascii_case("content-length") {
                    len = v.trim().parse().ok()?;
                }
            }
        }
        let mut body = vec![0u8; len];
        c.read_exact(&mut body).ok()?;
        Some(body)
    }
}

/// A job page open on the running job until `stop`: returns the requests made.
fn dashboard(addr: String, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<u64> {
    std::thread::spawn(move || {
        let mut browser = Browser { addr, conn: None };
        let mut requests = 0u64;
        let job = loop {
            if stop.load(Ordering::Relaxed) {
                return requests;
            }
            requests += 1;
            let status: serde_json::Value =
                serde_json::from_slice(&browser.get("/api/status")).unwrap_or_default();
            let running = status["jobs"].as_array().and_then(|jobs| {
                jobs.iter().find(|j| j["state"] == "running").and_then(|j| j["id"].as_u64())
            });
            match running {
                Some(id) => break id,
                None => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        browser.get(&format!("/jobs/{job}"));
        let (mut cursor, mut last_facts) = (0u32, Instant::now());
        while !stop.load(Ordering::Relaxed) {
            let body = browser.get(&format!("/api/jobs/{job}/live?from={cursor}"));
            requests += 1;
            if body.len() >= 16 {
                cursor = u32::from_le_bytes([body[8], body[9], body[10], body[11]]);
                if body[12] != 0 {
                    // Done (or ended): the page stops looking, as the script does.
                    break;
                }
            }
            if last_facts.elapsed() >= Duration::from_secs(2) {
                browser.get(&format!("/fragments/job/{job}"));
                requests += 1;
                last_facts = Instant::now();
            }
            std::thread::sleep(Duration::from_millis(1000));
        }
        requests
    })
}

/// A display server that takes everything and counts the bytes.
fn tev_sink() -> (String, Arc<AtomicU64>) {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = l.local_addr().expect("addr").to_string();
    let bytes = Arc::new(AtomicU64::new(0));
    let count = bytes.clone();
    std::thread::spawn(move || {
        for s in l.incoming().flatten() {
            let count = count.clone();
            std::thread::spawn(move || {
                let mut s = s;
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n) = s.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    count.fetch_add(n as u64, Ordering::Relaxed);
                }
            });
        }
    });
    (addr, bytes)
}

struct Run {
    wall: f64,
    cpu: f64,
    tev_bytes: u64,
    requests: u64,
}

fn render(url: &str, coord: u32, scene: &Path, out: &Path, spp: u32, watched: bool) -> Run {
    // FARM_WATCH=tev or dashboard watches with one of the two only.
    let how = std::env::var("FARM_WATCH").unwrap_or_default();
    let (with_tev, with_page) = (watched && how != "dashboard", watched && how != "tev");
    let addr = url.trim_start_matches("http://").to_string();
    let stop = Arc::new(AtomicBool::new(false));
    let (tev, bytes) = tev_sink();
    let poller = with_page.then(|| dashboard(addr, stop.clone()));
    let cpu0 = cpu_seconds(coord);
    let t0 = Instant::now();
    let mut cmd = farm();
    cmd.args(["submit", "--quiet", "--coordinator", url, "--spp", &spp.to_string(), "-o"])
        .arg(out)
        .arg(scene);
    if with_tev {
        cmd.args(["--display-server", &tev]);
    }
    let status = cmd.status().expect("farm submit");
    assert!(status.success(), "farm submit failed");
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu_seconds(coord) - cpu0;
    stop.store(true, Ordering::Relaxed);
    let requests = poller.map(|p| p.join().unwrap_or(0)).unwrap_or(0);
    Run { wall, cpu, tev_bytes: bytes.load(Ordering::Relaxed), requests }
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
    let mut procs = Procs(Vec::new());
    let mut coord = farm()
        .args(["coordinator", "--insecure", "--listen", "127.0.0.1:0", "--state-dir"])
        .arg(dir.join("state"))
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the coordinator");
    let stderr = coord.stderr.take().expect("stderr");
    let coord_pid = coord.id();
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
        let w = farm()
            .args(["worker", "--coordinator", &url, "--threads", "1", "--name", &format!("w{i}")])
            .stderr(Stdio::null())
            .spawn()
            .expect("start a worker");
        procs.0.push(w);
    }
    let out = dir.join("out.exr");
    // Warm-up: workers fetch the scene and build it once.
    render(&url, coord_pid, &scene, &out, spp, false);
    println!("watch overhead: example.pbrt at {spp} spp, 2 workers × 1 thread, {rounds} pairs");
    println!(
        "{:>5}  {:>11} {:>11}  {:>11} {:>11}  {:>10} {:>8}",
        "pair", "wall plain", "wall watch", "cpu plain", "cpu watch", "tev bytes", "requests"
    );
    let (mut plain, mut watched) = (Vec::new(), Vec::new());
    for r in 0..rounds {
        let order = if r % 2 == 0 { [false, true] } else { [true, false] };
        let mut pair = [None, None];
        for w in order {
            pair[usize::from(w)] = Some(render(&url, coord_pid, &scene, &out, spp, w));
        }
        let [Some(p), Some(w)] = pair else { unreachable!() };
        println!(
            "{:>5}  {:>10.3}s {:>10.3}s  {:>10.3}s {:>10.3}s  {:>10} {:>8}",
            r + 1,
            p.wall,
            w.wall,
            p.cpu,
            w.cpu,
            w.tev_bytes,
            w.requests
        );
        assert!(w.tev_bytes > 0 || w.requests > 2, "the watched render was not watched");
        plain.push(p);
        watched.push(w);
    }
    let m = |v: &[Run], f: fn(&Run) -> f64| median(v.iter().map(f).collect());
    let (pw, ww) = (m(&plain, |r| r.wall), m(&watched, |r| r.wall));
    let (pc, wc) = (m(&plain, |r| r.cpu), m(&watched, |r| r.cpu));
    println!("median {:>10.3}s {:>10.3}s  {:>10.3}s {:>10.3}s", pw, ww, pc, wc);
    println!("watched ÷ plain: wall {:.3}, coordinator CPU {:.3}", ww / pw, wc / pc);
    drop(procs);
    std::fs::remove_dir_all(dir).ok();
}
