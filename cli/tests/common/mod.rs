//! Helpers of the tests that run `farm` processes.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// Kills its processes when dropped, so a failing test leaves none behind.
pub struct Procs(pub Vec<Child>);

impl Drop for Procs {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

pub fn farm() -> Command {
    Command::new(env!("CARGO_BIN_EXE_farm"))
}

pub fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

/// Starts `farm coordinator` on a free loopback port with its state in
/// `state`, logging at debug level to `state/../coordinator.log`; returns
/// its https:// URL.
pub fn start_coordinator(procs: &mut Procs, state: &Path) -> String {
    start_coordinator_on(procs, state, "127.0.0.1:0", "coordinator.log")
}

/// [`start_coordinator`] on `listen`, logging to `log` beside `state`.
pub fn start_coordinator_on(procs: &mut Procs, state: &Path, listen: &str, log: &str) -> String {
    start_coordinator_with(procs, state, listen, log, &[])
}

/// [`start_coordinator_on`] with more arguments.
pub fn start_coordinator_with(
    procs: &mut Procs,
    state: &Path,
    listen: &str,
    log: &str,
    extra: &[&str],
) -> String {
    let mut coord = farm()
        .args(["coordinator", "--listen", listen, "--heartbeat", "0.2", "--state-dir"])
        .arg(state)
        .args(extra)
        .env("FARM_LOG", "debug")
        .stderr(Stdio::piped())
        .spawn()
        .expect("start coordinator");
    let stderr = coord.stderr.take().expect("stderr");
    procs.0.push(coord);
    let mut reader = BufReader::new(stderr);
    let log = state.parent().expect("parent").join(log);
    let mut log = std::fs::File::create(log).expect("log file");
    let mut line = String::new();
    while !line.contains("coordinator listening on") {
        line.clear();
        assert!(reader.read_line(&mut line).expect("read coordinator log") > 0, "no banner");
        std::io::Write::write_all(&mut log, line.as_bytes()).expect("log");
    }
    // Keep draining the coordinator's log so its writes never hit a closed pipe.
    std::thread::spawn(move || std::io::copy(&mut reader, &mut log));
    let start = line.find("https://").unwrap_or_else(|| panic!("no https URL in {line:?}"));
    line[start..].split_whitespace().next().expect("url").to_string()
}

pub fn token_file(state: &Path, role: &str) -> PathBuf {
    state.join(format!("{role}.token"))
}

/// A loopback port free now (bound and released), to restart a
/// coordinator on the same address.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

pub fn status(
    rt: &tokio::runtime::Runtime,
    remote: &farm_cli::client::Remote,
) -> Option<farm_proto::v1::GetStatusResponse> {
    rt.block_on(farm_cli::client::status(remote)).ok()
}

/// Starts `farm worker` with one render thread.
pub fn spawn_worker(url: &str, token: &Path, name: &str) -> std::process::Child {
    farm()
        .args(["worker", "--coordinator", url, "--threads", "1", "--name", name])
        .arg("--token-file")
        .arg(token)
        .stderr(Stdio::null())
        .spawn()
        .expect("start worker")
}

/// The client token of the coordinator whose state is in `state`, as a remote.
pub fn client_remote(url: &str, state: &Path) -> farm_cli::client::Remote {
    let text = std::fs::read_to_string(token_file(state, "client")).expect("client token");
    farm_cli::client::Remote {
        url: url.to_string(),
        token: Some(text.trim().parse().expect("token")),
    }
}

/// Peak and current resident memory of a process, in bytes (Linux).
pub fn memory(pid: u32) -> (u64, u64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("proc status");
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .expect("memory field")
            * 1024
    };
    (field("VmHWM:"), field("VmRSS:"))
}
