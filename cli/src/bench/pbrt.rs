//! pbrt-v3 rendering a scene in the same run as farm, measured from the
//! outside: wall time, and CPU seconds and peak RSS as the kernel accounts
//! them to the child process.

use super::PbrtRun;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Renders `scene` with the pbrt-v3 binary `pbrt` on `threads` threads (0:
/// pbrt-v3's default, one per core), its image into a temporary folder,
/// and measures its wall time and, from the kernel's account of the child
/// (`wait4`), its CPU seconds and peak RSS.
pub fn measure_pbrt(pbrt: &Path, scene: &Path, threads: usize) -> Result<PbrtRun, String> {
    let dir = std::env::temp_dir().join(format!(
        "farm-bench-pbrt-{}-{}",
        std::process::id(),
        PBRT_RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let result = run_pbrt(pbrt, scene, threads, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Names each pbrt-v3 run's temporary folder apart.
static PBRT_RUNS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

fn run_pbrt(pbrt: &Path, scene: &Path, threads: usize, dir: &Path) -> Result<PbrtRun, String> {
    // Absolute, since pbrt-v3 runs in the scene's folder (as the reference
    // renders did, so that relative asset paths resolve the same way).
    let scene = &std::fs::canonicalize(scene).unwrap_or_else(|_| scene.to_path_buf());
    let log_path = dir.join("stderr.txt");
    let log = std::fs::File::create(&log_path).map_err(|e| e.to_string())?;
    let mut cmd = Command::new(pbrt);
    if threads > 0 {
        cmd.args(["--nthreads", &threads.to_string()]);
    }
    cmd.arg("--outfile").arg(dir.join("image.exr")).arg(scene);
    // Its glog files into the folder that goes after the run, not one more
    // set in the temporary directory per run.
    cmd.arg("--logdir").arg(dir);
    if let Some(parent) = scene.parent().filter(|p| !p.as_os_str().is_empty()) {
        cmd.current_dir(parent);
    }
    let start = Instant::now();
    let child = cmd
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(log)
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", pbrt.display()))?;
    let (status, usage) = wait_with_usage(child)?;
    let wall = start.elapsed().as_secs_f64();
    if status != 0 {
        let err = std::fs::read_to_string(&log_path).unwrap_or_default();
        let last = err.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("");
        return Err(format!("pbrt-v3 failed (wait status {status}) {last}"));
    }
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Ok(PbrtRun {
        wall,
        cpu: secs(usage.ru_utime) + secs(usage.ru_stime),
        // Linux gives the peak in KiB.
        rss_mb: usage.ru_maxrss as f64 / 1024.0,
        ..Default::default()
    })
}

/// Waits for `child` and returns its wait status and resource usage.
fn wait_with_usage(child: std::process::Child) -> Result<(i32, libc::rusage), String> {
    let pid = libc::pid_t::try_from(child.id()).map_err(|e| e.to_string())?;
    let mut status = 0;
    // SAFETY: an all-zero `rusage` is a valid value of the plain C struct.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: `pid` is our unreaped child (`Child` never waited for
        // it), and both pointers are to live locals of the right types.
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if r == pid {
            return Ok((status, usage));
        }
        let err = std::io::Error::last_os_error();
        if err.kind() != std::io::ErrorKind::Interrupted {
            return Err(format!("cannot wait for pbrt-v3: {err}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;
    use std::path::PathBuf;

    /// A stand-in for pbrt-v3: a shell script with `body`, in a fresh folder
    /// that also holds an empty `scene.pbrt`.
    fn fake_pbrt(name: &str, body: &str) -> (PathBuf, PathBuf) {
        let dir =
            std::env::temp_dir().join(format!("farm-fake-pbrt-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let exe = dir.join("pbrt");
        std::fs::write(&exe, format!("#!/bin/sh\n{body}\n")).unwrap();
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::fs::write(dir.join("scene.pbrt"), "").unwrap();
        (exe, dir)
    }

    #[test]
    fn pbrts_cpu_is_the_childs_and_it_runs_in_the_scenes_folder() {
        // Both stand-ins check that they are called as farm calls pbrt-v3:
        // threads, an output file, the scene, the output's folder for its
        // logs, from the scene's folder. One then burns CPU, the other
        // sleeps; the CPU measured must tell them apart (this process's own
        // CPU, shared with other tests running at the same time, cannot).
        let check = "[ \"$1 $2 $3\" = \"--nthreads 2 --outfile\" ] || exit 5\n\
                     [ \"$5\" = \"$(pwd)/scene.pbrt\" ] || exit 6\n\
                     [ \"$6 $4\" = \"--logdir $7/image.exr\" ] || exit 7\n";
        let (busy, dir) =
            fake_pbrt("busy", &format!("{check}i=0; while [ $i -lt 300000 ]; do i=$((i+1)); done"));
        let (idle, idle_dir) = fake_pbrt("idle", &format!("{check}sleep 0.3"));
        let b = measure_pbrt(&busy, &dir.join("scene.pbrt"), 2).expect("the busy stand-in runs");
        let i = measure_pbrt(&idle, &idle_dir.join("scene.pbrt"), 2).expect("the idle one runs");
        assert!(b.cpu > 0.05 && b.cpu > i.cpu + 0.04, "busy {b:?}, idle {i:?}");
        assert!(i.wall >= 0.3 && i.cpu < 0.1, "sleeping costs wall time, not CPU: {i:?}");
        assert!(b.wall >= b.cpu * 0.5 && b.rss_mb > 0.0, "{b:?}");
        std::fs::remove_dir_all(dir).unwrap();
        std::fs::remove_dir_all(idle_dir).unwrap();
    }

    #[test]
    fn a_failing_or_missing_pbrt_is_an_error_that_says_why() {
        let (exe, dir) = fake_pbrt("fails", "echo 'Error: scene.pbrt:3: boom' >&2; exit 3");
        let e = measure_pbrt(&exe, &dir.join("scene.pbrt"), 0).unwrap_err();
        assert!(e.contains("boom") && e.contains("failed"), "{e}");
        let e = measure_pbrt(&dir.join("nothing-here"), &dir.join("scene.pbrt"), 0).unwrap_err();
        assert!(e.contains("cannot run"), "{e}");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
