//! `farm bench`: renders every shared pbrt-v3 scene it finds, each in a
//! fresh process so its peak memory is its own, and tabulates wall and CPU
//! seconds, start-up, rays per second and peak RSS next to pbrt-v3's. With
//! `--pbrt PATH` pbrt-v3 renders each scene in the same run, turn about
//! with farm, so both see the same machine; without it the numbers are the
//! reference README's, measured on another machine another day.

use crate::embedded::{self, SubmitOptions};
use crate::error::Error;
use farm_common::math;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

mod pbrt;
use pbrt::measure_pbrt;

/// pbrt-v3's own measurements of a scene (reference README).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PbrtRun {
    /// Wall seconds.
    pub wall: f64,
    /// CPU seconds.
    pub cpu: f64,
    /// Peak resident set size in MB.
    pub rss_mb: f64,
    /// Camera rays traced.
    pub camera_rays: f64,
    /// Shadow rays traced.
    pub shadow_rays: f64,
}

/// One row of the reference README's table.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceScene {
    /// Folder under `scenes/` and `reference/`.
    pub scene: String,
    /// The Whitted scene file in that folder.
    pub file: String,
    /// pbrt-v3's own relMSE of its 16-spp render against the ground truth.
    pub pbrt_rel_mse: f64,
    /// Ground truth image name, e.g. `gt256`.
    pub ground_truth: String,
    /// pbrt-v3's time, memory and rays, when the table gives them.
    pub pbrt: Option<PbrtRun>,
}

/// A count such as `4.0M` or `1.08M` or `900k`.
fn count(s: &str) -> Option<f64> {
    let (num, mult) = match s.chars().last()? {
        'M' => (&s[..s.len() - 1], 1e6),
        'k' | 'K' => (&s[..s.len() - 1], 1e3),
        _ => (s, 1.0),
    };
    num.parse::<f64>().ok().map(|v| v * mult)
}

/// The scenes listed in `reference/README.md`'s measurement table.
pub fn reference_scenes(shared: &Path) -> Vec<ReferenceScene> {
    let text = std::fs::read_to_string(shared.join("reference/README.md")).unwrap_or_default();
    text.lines()
        .filter_map(|line| {
            let cols: Vec<&str> = line.split('|').map(str::trim).collect();
            // | scene | file | res | sampler | relMSE | ground truth | wall | CPU | RSS | camera | shadow |
            if cols.len() < 8 || !cols[2].ends_with(".pbrt") {
                return None;
            }
            let pbrt = (|| {
                Some(PbrtRun {
                    wall: cols.get(7)?.parse().ok()?,
                    cpu: cols.get(8)?.parse().ok()?,
                    rss_mb: cols.get(9)?.parse().ok()?,
                    camera_rays: count(cols.get(10)?)?,
                    shadow_rays: count(cols.get(11)?)?,
                })
            })();
            Some(ReferenceScene {
                scene: cols[1].to_string(),
                file: cols[2].to_string(),
                pbrt_rel_mse: cols[5].parse().ok()?,
                ground_truth: cols[6].to_string(),
                pbrt,
            })
        })
        .collect()
}

/// What one render measured about itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Measured {
    /// Parse + load + build + render seconds.
    pub wall: f64,
    /// CPU seconds of the whole process (user + system).
    pub cpu: f64,
    /// Parse + load + build seconds.
    pub startup: f64,
    /// Rays traced.
    pub rays: u64,
    /// Rays per second of rendering.
    pub rays_per_second: f64,
    /// Peak resident set size of the process in MB.
    pub peak_rss_mb: f64,
    /// Samples per pixel.
    pub spp: u32,
}

/// The line `farm bench` reads back from each child.
const RESULT_PREFIX: &str = "farm-bench-result";

impl Measured {
    fn to_line(&self) -> String {
        format!(
            "{RESULT_PREFIX} {} {} {} {} {} {} {}",
            self.wall,
            self.cpu,
            self.startup,
            self.rays,
            self.rays_per_second,
            self.peak_rss_mb,
            self.spp
        )
    }

    /// The measurement a `farm bench-one` child printed, if any.
    pub fn from_output(out: &str) -> Option<Measured> {
        let line = out.lines().find_map(|l| l.strip_prefix(RESULT_PREFIX))?;
        let f: Vec<&str> = line.split_whitespace().collect();
        Some(Measured {
            wall: f.first()?.parse().ok()?,
            cpu: f.get(1)?.parse().ok()?,
            startup: f.get(2)?.parse().ok()?,
            rays: f.get(3)?.parse().ok()?,
            rays_per_second: f.get(4)?.parse().ok()?,
            peak_rss_mb: f.get(5)?.parse().ok()?,
            spp: f.get(6)?.parse().ok()?,
        })
    }
}

/// CPU seconds (user + system) this process has used, from /proc (0 where
/// /proc is missing).
pub fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    let rest = stat.rfind(')').map_or("", |i| stat.get(i + 2..).unwrap_or(""));
    let f: Vec<&str> = rest.split_whitespace().collect();
    let field = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (field(11) + field(12)) / 100.0
}

/// This process's peak resident set size in MB (`VmHWM`), 0 if unknown.
pub fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

/// Renders `scene` in this process and prints the result line `farm bench`
/// reads (the hidden `farm bench-one` command).
pub fn measure_here(scene: &Path, threads: usize) -> Result<Measured, Error> {
    let t = Instant::now();
    let opts = SubmitOptions { threads, ..Default::default() };
    let r = embedded::render(scene, &opts, |_| {})?;
    let rays = r.stats.total_rays();
    let m = Measured {
        wall: t.elapsed().as_secs_f64(),
        cpu: cpu_seconds(),
        startup: r.startup_seconds,
        rays,
        rays_per_second: rays as f64 / r.render_seconds.max(1e-9),
        peak_rss_mb: peak_rss_mb(),
        spp: r.spp,
    };
    say!("{}", m.to_line());
    Ok(m)
}

/// One scene's row of the table.
#[derive(Clone, Debug)]
pub struct BenchRow {
    /// The reference entry.
    pub scene: ReferenceScene,
    /// Our measurement, or why it failed.
    pub measured: Result<Measured, String>,
    /// The same render on one thread, when thread scaling was asked for.
    pub one_thread: Option<Result<Measured, String>>,
    /// pbrt-v3 measured in this run, when a pbrt-v3 binary was given.
    pub pbrt_here: Option<Result<PbrtRun, String>>,
}

impl BenchRow {
    /// pbrt-v3's numbers: this run's when it ran here, else the table's.
    pub fn pbrt(&self) -> Option<PbrtRun> {
        match &self.pbrt_here {
            Some(Ok(p)) => Some(p.clone()),
            Some(Err(_)) => None,
            None => self.scene.pbrt.clone(),
        }
    }

    /// Our CPU seconds over pbrt-v3's, when both are known.
    pub fn cpu_ratio(&self) -> Option<f64> {
        let (m, p) = (self.measured.as_ref().ok()?, self.pbrt()?);
        (p.cpu > 0.0 && m.cpu > 0.0).then(|| m.cpu / p.cpu)
    }

    /// Wall-time speed-up of the measured render over the one-thread one.
    pub fn speedup(&self) -> Option<f64> {
        match (&self.measured, &self.one_thread) {
            (Ok(m), Some(Ok(one))) if m.wall > 0.0 => Some(one.wall / m.wall),
            _ => None,
        }
    }
}

/// What [`best_of`] measured of one scene: farm with each thread count
/// asked for, and pbrt-v3 when it was given.
struct Best {
    farm: Vec<Result<Measured, String>>,
    pbrt: Option<Result<PbrtRun, String>>,
}

/// Keeps the faster of two results; a failure stands.
fn faster<T>(
    best: Option<Result<T, String>>,
    new: Result<T, String>,
    wall: impl Fn(&T) -> f64,
) -> Result<T, String> {
    match (best, new) {
        (Some(Err(e)), _) => Err(e),
        (Some(Ok(old)), Ok(new)) if wall(&old) <= wall(&new) => Ok(old),
        (_, new) => new,
    }
}

/// The fastest of `runs` renders of `scene` with each thread count in
/// `threads`, each in a child process, and of `runs` pbrt-v3 renders with
/// the first count when `pbrt` is given. They take turns run by run, so
/// that a load the shared machine picks up or drops midway weighs on all of
/// them alike (a speed-up or a ratio compares two of them).
fn best_of(exe: &Path, pbrt: Option<&Path>, scene: &Path, threads: &[usize], runs: usize) -> Best {
    let mut best: Vec<Option<Result<Measured, String>>> = vec![None; threads.len()];
    let mut best_pbrt = None;
    for _ in 0..runs.max(1) {
        for (b, &t) in best.iter_mut().zip(threads) {
            let m = measure_child(exe, scene, t);
            *b = Some(faster(b.take(), m, |m| m.wall));
        }
        if let Some(pbrt) = pbrt {
            let p = measure_pbrt(pbrt, scene, threads.first().copied().unwrap_or(0));
            best_pbrt = Some(faster(best_pbrt.take(), p, |p| p.wall));
        }
    }
    Best {
        farm: best.into_iter().map(|b| b.unwrap_or_else(|| Err("no run".into()))).collect(),
        pbrt: best_pbrt,
    }
}

/// Renders `scene` in a child process (`exe bench-one SCENE`).
fn measure_child(exe: &Path, scene: &Path, threads: usize) -> Result<Measured, String> {
    let out = Command::new(exe)
        .arg("bench-one")
        .arg(scene)
        .args(["--threads", &threads.to_string()])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", exe.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    Measured::from_output(&stdout).ok_or_else(|| {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().rev().find(|l| l.starts_with("error")).unwrap_or("");
        format!("render failed ({}) {last}", out.status)
    })
}

/// What `run` measures.
#[derive(Clone, Debug, Default)]
pub struct BenchOptions {
    /// Only this scene folder.
    pub only: Option<String>,
    /// Render threads (0 = one per core).
    pub threads: usize,
    /// Also render each scene on one thread.
    pub scaling: bool,
    /// Renders per measurement; the fastest is kept (the machine may be shared).
    pub runs: usize,
    /// A pbrt-v3 binary to render each scene with in the same run.
    pub pbrt: Option<PathBuf>,
}

/// Renders each scene in child processes and collects the measurements.
pub fn run(
    exe: &Path,
    shared: &Path,
    opts: &BenchOptions,
    mut each: impl FnMut(&BenchRow),
) -> Vec<BenchRow> {
    let mut rows = Vec::new();
    for s in reference_scenes(shared) {
        if opts.only.as_ref().is_some_and(|o| *o != s.scene) {
            continue;
        }
        let path: PathBuf = shared.join("scenes").join(&s.scene).join(&s.file);
        let counts: &[usize] = if opts.scaling { &[opts.threads, 1] } else { &[opts.threads] };
        let best = best_of(exe, opts.pbrt.as_deref(), &path, counts, opts.runs);
        let mut results = best.farm.into_iter();
        let measured = results.next().unwrap_or_else(|| Err("no run".into()));
        let one_thread = results.next();
        let row = BenchRow { scene: s, measured, one_thread, pbrt_here: best.pbrt };
        each(&row);
        rows.push(row);
    }
    rows
}

/// The table as CSV: ours and pbrt-v3's numbers side by side.
pub fn csv(rows: &[BenchRow]) -> String {
    let mut out = String::from(
        "scene,spp,wall_s,cpu_s,startup_s,rays,mrays_per_s,peak_rss_mb,pbrt_wall_s,pbrt_cpu_s,pbrt_peak_rss_mb,cpu_ratio,one_thread_wall_s,speedup\n",
    );
    for r in rows {
        let Ok(m) = &r.measured else { continue };
        let p = r.pbrt().unwrap_or_default();
        let ratio = r.cpu_ratio().map(|v| format!("{v:.3}")).unwrap_or_default();
        let one = match &r.one_thread {
            Some(Ok(one)) => format!("{:.3}", one.wall),
            _ => String::new(),
        };
        let speedup = r.speedup().map(|v| format!("{v:.3}")).unwrap_or_default();
        let _ = writeln!(
            out,
            "{},{},{:.3},{:.3},{:.4},{},{:.3},{:.1},{},{},{},{ratio},{one},{speedup}",
            r.scene.scene,
            m.spp,
            m.wall,
            m.cpu,
            m.startup,
            m.rays,
            m.rays_per_second / 1e6,
            m.peak_rss_mb,
            p.wall,
            p.cpu,
            p.rss_mb
        );
    }
    out
}

/// Geometric mean of our CPU seconds over pbrt-v3's, over the rows that
/// have both (pbrt-v3's from this run where it ran).
pub fn cpu_ratio_geomean(rows: &[BenchRow]) -> Option<f64> {
    let logs: Vec<f64> = rows.iter().filter_map(|r| r.cpu_ratio().map(math::ln)).collect();
    (!logs.is_empty()).then(|| math::exp(logs.iter().sum::<f64>() / logs.len() as f64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_table_is_read_with_pbrts_numbers() {
        let dir = std::env::temp_dir().join(format!("farm-bench-ref-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("reference")).unwrap();
        std::fs::write(
            dir.join("reference/README.md"),
            "| scene | file | res | sampler | rel | gt | wall | CPU | RSS | cam | shadow |\n\
             |---|---|---|---|---|---|---|---|---|---|---|\n\
             | box | box-whitted.pbrt | 8×8 | halton 16 | 6.03e-4 | gt256 | 2.3 | 4.4 | 28 | 4.0M | 900k |\n\
             | old | old.pbrt | 8×8 | halton 16 | 1e-3 | gt128 |\n",
        )
        .unwrap();
        let rows = reference_scenes(&dir);
        assert_eq!(rows.len(), 2, "{rows:?}");
        assert_eq!(rows[1].pbrt, None, "a row without pbrt-v3's numbers has none");
        let p = rows[0].pbrt.clone().expect("pbrt numbers");
        assert_eq!((p.wall, p.cpu, p.rss_mb), (2.3, 4.4, 28.0));
        assert_eq!((p.camera_rays, p.shadow_rays), (4.0e6, 9.0e5));
        assert_eq!(rows[0].ground_truth, "gt256");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_child_result_line_round_trips_and_ratios_are_geometric() {
        let m = Measured {
            wall: 1.5,
            cpu: 2.0,
            startup: 0.01,
            rays: 123,
            rays_per_second: 4e6,
            peak_rss_mb: 30.5,
            spp: 16,
        };
        let back = Measured::from_output(&format!("noise\n{}\n", m.to_line()));
        assert_eq!(back, Some(m.clone()));
        let scene = |cpu| ReferenceScene {
            scene: "s".into(),
            file: "s.pbrt".into(),
            pbrt_rel_mse: 0.0,
            ground_truth: "gt".into(),
            pbrt: Some(PbrtRun { cpu, ..Default::default() }),
        };
        let rows = [
            BenchRow {
                scene: scene(1.0),
                measured: Ok(m.clone()),
                one_thread: None,
                pbrt_here: None,
            },
            BenchRow {
                scene: scene(4.0),
                measured: Ok(m.clone()),
                one_thread: Some(Ok(Measured { wall: 2.85, ..m.clone() })),
                pbrt_here: None,
            },
            BenchRow {
                scene: scene(8.0),
                measured: Err("failed".into()),
                one_thread: None,
                pbrt_here: None,
            },
        ];
        // 2/1 and 2/4: geometric mean 1; the failed row does not count.
        assert!((cpu_ratio_geomean(&rows).unwrap() - 1.0).abs() < 1e-12);
        // pbrt-v3 measured in this run replaces the table's numbers, and a
        // failed pbrt-v3 run leaves the row without a ratio.
        let mut here = rows.clone();
        here[0].pbrt_here = Some(Ok(PbrtRun { cpu: 0.5, ..Default::default() }));
        here[1].pbrt_here = Some(Err("pbrt-v3 failed".into()));
        assert_eq!(here[0].cpu_ratio(), Some(4.0));
        assert_eq!(here[1].cpu_ratio(), None);
        assert!((cpu_ratio_geomean(&here).unwrap() - 4.0).abs() < 1e-12);
        assert_eq!(csv(&rows).lines().count(), 3);
        assert!((rows[1].speedup().unwrap() - 1.9).abs() < 1e-12);
        assert!(csv(&rows).lines().nth(2).unwrap().ends_with(",2.850,1.900"));
    }
}
