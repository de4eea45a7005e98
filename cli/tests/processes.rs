//! Real processes: one `farm coordinator` (TLS and tokens, as it starts by
//! default), two `farm worker`s and a `farm submit --coordinator`; one
//! worker is killed with SIGKILL in the middle of the job, and the image
//! must equal the embedded render byte for byte. Then what the security
//! model refuses, as a user meets it on the command line.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Kills its processes when dropped, so a failing test leaves none behind.
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

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

/// Starts `farm coordinator` on a free loopback port with its state in
/// `state`, logging at debug level to `state/../coordinator.log`; returns
/// its https:// URL.
fn start_coordinator(procs: &mut Procs, state: &Path) -> String {
    start_coordinator_on(procs, state, "127.0.0.1:0", "coordinator.log")
}

/// [`start_coordinator`] on `listen`, logging to `log` beside `state`.
fn start_coordinator_on(procs: &mut Procs, state: &Path, listen: &str, log: &str) -> String {
    let mut coord = farm()
        .args(["coordinator", "--listen", listen, "--heartbeat", "0.2", "--state-dir"])
        .arg(state)
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

fn token_file(state: &Path, role: &str) -> PathBuf {
    state.join(format!("{role}.token"))
}

#[test]
fn sigkill_of_a_worker_process_changes_no_byte() {
    let dir = std::env::temp_dir().join(format!("farm-procs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let url = start_coordinator(&mut procs, &state);
    let worker_token = token_file(&state, "worker");
    let client_token = token_file(&state, "client");

    for name in ["w1", "w2"] {
        let w = farm()
            .args(["worker", "--coordinator", &url, "--threads", "1", "--name", name])
            .arg("--token-file")
            .arg(&worker_token)
            .stderr(Stdio::null())
            .spawn()
            .expect("start worker");
        procs.0.push(w);
    }

    let farm_out = dir.join("farm.pfm");
    let submit = farm()
        .args(["submit", "--quiet", "--spp", "4", "--coordinator", &url, "-o"])
        .arg(&farm_out)
        .arg("--token-file")
        .arg(&client_token)
        .arg(scene())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start submit");

    // Wait until the job is a fifth done, then SIGKILL the first worker.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let text = std::fs::read_to_string(&client_token).expect("client token");
    let remote = farm_cli::client::Remote { url: url.clone(), token: Some(text.parse().unwrap()) };
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut killed = false;
    while Instant::now() < deadline {
        if let Ok(s) = rt.block_on(farm_cli::client::status(&remote)) {
            if let Some(j) = s.jobs.first() {
                if j.tiles_total > 0 && j.tiles_done * 5 >= j.tiles_total && s.workers.len() == 2 {
                    procs.0[1].kill().expect("SIGKILL worker");
                    killed = true;
                    break;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(killed, "the job never got a fifth done with two workers");
    let out = submit.wait_with_output().expect("submit finished");
    assert!(out.status.success(), "farm submit failed: {}", String::from_utf8_lossy(&out.stderr));

    let embedded_out = dir.join("embedded.pfm");
    let status = farm()
        .args(["submit", "--quiet", "--spp", "4", "-o"])
        .arg(&embedded_out)
        .arg(scene())
        .status()
        .expect("embedded render");
    assert!(status.success());
    let a = std::fs::read(&farm_out).expect("farm image");
    let b = std::fs::read(&embedded_out).expect("embedded image");
    assert!(a == b, "the farm's image differs from the embedded render");
}

/// A loopback port free now (bound and released), to restart a
/// coordinator on the same address.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

fn status(
    rt: &tokio::runtime::Runtime,
    remote: &farm_cli::client::Remote,
) -> Option<farm_proto::v1::GetStatusResponse> {
    rt.block_on(farm_cli::client::status(remote)).ok()
}

#[test]
fn sigkill_of_the_coordinator_loses_only_the_tiles_in_flight() {
    let dir = std::env::temp_dir().join(format!("farm-procs-restart-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let state = dir.join("state");
    let listen = format!("127.0.0.1:{}", free_port());
    let mut procs = Procs(Vec::new());
    let url = start_coordinator_on(&mut procs, &state, &listen, "coordinator.log");
    let worker_token = token_file(&state, "worker");
    let client_token = token_file(&state, "client");
    for name in ["w1", "w2"] {
        let w = farm()
            .args(["worker", "--coordinator", &url, "--threads", "1", "--name", name])
            .arg("--token-file")
            .arg(&worker_token)
            .stderr(Stdio::null())
            .spawn()
            .expect("start worker");
        procs.0.push(w);
    }
    let farm_out = dir.join("farm.pfm");
    let submit = farm()
        .args(["submit", "--quiet", "--spp", "8", "--coordinator", &url, "-o"])
        .arg(&farm_out)
        .arg("--token-file")
        .arg(&client_token)
        .arg(scene())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start submit");

    // SIGKILL the coordinator once a third of the job is in.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let text = std::fs::read_to_string(&client_token).expect("client token");
    let remote = farm_cli::client::Remote { url: url.clone(), token: Some(text.parse().unwrap()) };
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut done_at_kill = None;
    while Instant::now() < deadline && done_at_kill.is_none() {
        if let Some(s) = status(&rt, &remote) {
            if let Some(j) = s.jobs.first() {
                if j.tiles_total > 0 && j.tiles_done * 3 >= j.tiles_total {
                    procs.0[0].kill().expect("SIGKILL coordinator");
                    procs.0[0].wait().expect("reap coordinator");
                    done_at_kill = Some((j.tiles_done, j.tiles_total));
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let (done_at_kill, total) = done_at_kill.expect("the job never got a third done");

    // The same state directory, the same address: the job resumes, the
    // workers register again and the client reconnects to its job.
    start_coordinator_on(&mut procs, &state, &listen, "coordinator-2.log");
    let out = submit.wait_with_output().expect("submit finished");
    assert!(out.status.success(), "farm submit failed: {}", String::from_utf8_lossy(&out.stderr));
    let s = status(&rt, &remote).expect("status after the restart");
    let j = s.jobs.first().expect("the job survived the restart");
    assert_eq!((j.state.as_str(), j.tiles_done, j.tiles_total), ("done", total, total));
    // Rendered twice: the tiles in flight when the coordinator died (two
    // workers of one thread hold at most 6 each) and any whose result had
    // not been committed yet. Everything before survived.
    let window = 2 * farm_proto::default_in_flight(1);
    eprintln!(
        "coordinator killed with {done_at_kill} of {total} tiles in; {} rendered again after the restart",
        j.retries
    );
    assert!(
        j.retries <= window,
        "{} tiles were rendered again after the restart, more than the {window} in flight ({done_at_kill} of {total} were done)",
        j.retries
    );
    assert!(done_at_kill > window, "the kill came too early to tell");
    assert_eq!(j.attempts, total + j.retries);

    let embedded_out = dir.join("embedded.pfm");
    let status = farm()
        .args(["submit", "--quiet", "--spp", "8", "-o"])
        .arg(&embedded_out)
        .arg(scene())
        .status()
        .expect("embedded render");
    assert!(status.success());
    let a = std::fs::read(&farm_out).expect("farm image");
    let b = std::fs::read(&embedded_out).expect("embedded image");
    assert!(a == b, "the image after a coordinator restart differs from the embedded render");

    // `farm watch` fetches the finished image from anywhere, again.
    let watched = dir.join("watched.pfm");
    let (code, _, err) = run(&[
        "watch",
        &j.job_id.to_string(),
        "--coordinator",
        &url,
        "--token-file",
        &client_token.to_string_lossy(),
        "-o",
        &watched.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(std::fs::read(&watched).expect("watched image") == a, "farm watch wrote another image");
    drop(procs);
    std::fs::remove_dir_all(dir).ok();
}

/// Runs `farm ARGS` to the end; its exit code and standard error.
fn run(args: &[&str]) -> (Option<i32>, String, String) {
    let out = farm().args(args).output().expect("run farm");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

#[test]
fn the_command_line_refuses_what_the_security_model_refuses() {
    let dir = std::env::temp_dir().join(format!("farm-procs-sec-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let url = start_coordinator(&mut procs, &state);
    let file = |role: &str| token_file(&state, role).to_string_lossy().into_owned();
    // --insecure is for loopback only.
    let (code, _, err) = run(&["coordinator", "--insecure", "--listen", "0.0.0.0:0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("only allowed on a loopback address"), "{err}");
    // No token: a clear error, not a hang or a panic.
    let (code, _, err) = run(&["status", "--coordinator", &url]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("give a token"), "{err}");
    // A worker token cannot list jobs; a client token can.
    let (code, _, err) = run(&["status", "--coordinator", &url, "--token-file", &file("worker")]);
    assert_eq!(code, Some(1));
    assert!(err.contains("only client and admin tokens"), "{err}");
    let (code, out, err) = run(&["status", "--coordinator", &url, "--token-file", &file("client")]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("owner") && out.contains("retries"), "{out}");
    // A worker started with a client token stops at once, saying why.
    let (code, _, err) = run(&["worker", "--coordinator", &url, "--token-file", &file("client")]);
    assert_eq!(code, Some(1));
    assert!(err.contains("only worker and admin tokens"), "{err}");
    // Tokens are made, listed (without secrets) and revoked on the host.
    let state_arg = state.to_string_lossy().into_owned();
    let (code, token, err) =
        run(&["token", "create", "--role", "client", "--name", "carol", "--state-dir", &state_arg]);
    assert_eq!(code, Some(0), "{err}");
    let token = token.trim().to_string();
    let carol = dir.join("carol.token");
    std::fs::write(&carol, &token).expect("write token");
    let carol = carol.to_string_lossy().into_owned();
    let (code, _, _) = run(&["status", "--coordinator", &url, "--token-file", &carol]);
    assert_eq!(code, Some(0));
    let (_, list, _) = run(&["token", "list", "--state-dir", &state_arg]);
    let secret = token.rsplit('.').next().expect("secret");
    assert!(list.contains("carol") && !list.contains(secret), "{list}");
    let id = token.split(':').nth(2).and_then(|s| s.split('.').next()).expect("id");
    let (code, _, err) = run(&["token", "revoke", id, "--state-dir", &state_arg]);
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err) = run(&["status", "--coordinator", &url, "--token-file", &carol]);
    assert_eq!(code, Some(1));
    assert!(err.contains("unknown or revoked"), "{err}");
    // The coordinator's log, at debug level, never shows a secret.
    drop(procs);
    let log = std::fs::read_to_string(dir.join("coordinator.log")).expect("log");
    assert!(log.contains("call refused"), "{log}");
    for role in ["admin", "worker", "client"] {
        let t = std::fs::read_to_string(file(role)).expect("token");
        assert!(!log.contains(t.trim().rsplit('.').next().unwrap()), "a {role} secret was logged");
    }
    assert!(!log.contains(secret), "a secret was logged");
    std::fs::remove_dir_all(dir).ok();
}
