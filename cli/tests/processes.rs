//! Real processes: one `farm coordinator`, two `farm worker`s and a
//! `farm submit --coordinator`; one worker is killed with SIGKILL in the
//! middle of the job, and the image must equal the embedded render byte for
//! byte.

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

#[test]
fn sigkill_of_a_worker_process_changes_no_byte() {
    let dir = std::env::temp_dir().join(format!("farm-procs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut procs = Procs(Vec::new());

    // The coordinator picks a free port and says which.
    let mut coord = farm()
        .args(["coordinator", "--listen", "127.0.0.1:0", "--heartbeat", "0.2"])
        .stderr(Stdio::piped())
        .spawn()
        .expect("start coordinator");
    let stderr = coord.stderr.take().expect("stderr");
    procs.0.push(coord);
    let mut reader = BufReader::new(stderr);
    let mut line = String::new();
    reader.read_line(&mut line).expect("read coordinator banner");
    // Keep draining the coordinator's log so its writes never hit a closed pipe.
    std::thread::spawn(move || std::io::copy(&mut reader, &mut std::io::sink()));
    let addr = line.trim().rsplit(' ').next().expect("address").to_string();
    let url = format!("http://{addr}");

    for name in ["w1", "w2"] {
        let w = farm()
            .args(["worker", "--coordinator", &url, "--threads", "1", "--name", name])
            .stderr(Stdio::null())
            .spawn()
            .expect("start worker");
        procs.0.push(w);
    }

    let farm_out = dir.join("farm.pfm");
    let submit = farm()
        .args(["submit", "--quiet", "--spp", "4", "--coordinator", &url, "-o"])
        .arg(&farm_out)
        .arg(scene())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start submit");

    // Wait until the job is a fifth done, then SIGKILL the first worker.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut killed = false;
    while Instant::now() < deadline {
        if let Ok(s) = rt.block_on(farm_cli::client::status(&url)) {
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
