//! `cargo build --release -p farm-cli --bin farm && cargo bench -p
//! farm-tests --bench mesh`: how start-up (PLY read + BVH build), the cost
//! per ray and memory grow with the triangle count. Writes binary PLY
//! spheres of about 10k, 100k, 1M and 4M triangles (FARM_MESH_SIZES, e.g.
//! "10000,100000"), renders each in a fresh `farm bench-one` process on one
//! thread (RAYON_NUM_THREADS=1) and prints start-up seconds, start-up per
//! N·log₂N, nanoseconds per ray, peak RSS and bytes per triangle.

use farm_cli::bench::Measured;
use farm_common::math;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Writes a UV sphere of radius 1 with `rings × segments` quads (two
/// triangles each) as binary little-endian PLY; returns the triangle count.
fn write_sphere(path: &Path, rings: usize, segments: usize) -> usize {
    let mut verts = Vec::with_capacity((rings + 1) * segments * 3);
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            // A little relief so the BVH is not built over a perfect sphere.
            let r = 1.0 + 0.02 * (math::sin(7.0 * theta) * math::cos(5.0 * phi));
            verts.extend([
                r * math::sin(theta) * math::cos(phi),
                r * math::cos(theta),
                r * math::sin(theta) * math::sin(phi),
            ]);
        }
    }
    let mut faces = Vec::with_capacity(rings * segments * 2);
    for i in 0..rings {
        for j in 0..segments {
            let a = (i * segments + j) as u32;
            let b = (i * segments + (j + 1) % segments) as u32;
            let (c, d) = (a + segments as u32, b + segments as u32);
            faces.push([a, c, b]);
            faces.push([b, c, d]);
        }
    }
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).expect("create ply"));
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        verts.len() / 3,
        faces.len()
    )
    .expect("write");
    for v in &verts {
        out.write_all(&v.to_le_bytes()).expect("write");
    }
    for f in &faces {
        out.write_all(&[3u8]).expect("write");
        for i in f {
            out.write_all(&i.to_le_bytes()).expect("write");
        }
    }
    faces.len()
}

fn farm_binary() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/release/farm")
}

fn main() {
    let farm = farm_binary();
    if !farm.is_file() {
        eprintln!(
            "SKIPPED: build the farm binary first: cargo build --release -p farm-cli --bin farm"
        );
        return;
    }
    let sizes: Vec<usize> = std::env::var("FARM_MESH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10_000, 100_000, 1_000_000, 4_000_000]);
    let dir = std::env::temp_dir().join(format!("farm-mesh-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    println!(
        "{:>10} {:>10} {:>16} {:>9} {:>16} {:>8} {:>10}",
        "triangles",
        "start-up s",
        "ns / (N log2 N)",
        "ns / ray",
        "ns/ray / log2 N",
        "RSS MB",
        "bytes/tri"
    );
    let mut base: Option<(f64, usize)> = None;
    for n in sizes {
        // rings × 2·rings quads, two triangles each: 4·rings² ≈ n.
        let rings = ((n as f64 / 4.0).sqrt().round() as usize).max(2);
        let ply = dir.join(format!("sphere-{n}.ply"));
        let tris = write_sphere(&ply, rings, 2 * rings);
        let scene = dir.join(format!("sphere-{n}.pbrt"));
        std::fs::write(
            &scene,
            format!(
                "LookAt 0 0 -3.2  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
                 Sampler \"halton\" \"integer pixelsamples\" 4\n\
                 Film \"image\" \"integer xresolution\" 256 \"integer yresolution\" 256\n\
                 WorldBegin\nLightSource \"point\" \"point from\" [2 3 -4] \"rgb I\" [20 20 20]\n\
                 Material \"matte\"\nShape \"plymesh\" \"string filename\" \"{}\"\nWorldEnd\n",
                ply.display()
            ),
        )
        .expect("write scene");
        let out = Command::new(&farm)
            .env("RAYON_NUM_THREADS", "1")
            .args(["bench-one", "--threads", "1"])
            .arg(&scene)
            .output()
            .expect("run farm");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let Some(m) = Measured::from_output(&stdout) else {
            println!("{n:>10} failed: {}", String::from_utf8_lossy(&out.stderr));
            continue;
        };
        let (startup, rays_per_s, rss) = (m.startup, m.rays_per_second, m.peak_rss_mb);
        let log_n = math::log2(tris as f64);
        let ns_per_ray = 1e9 / rays_per_s;
        let bytes_per_tri = match base {
            Some((rss0, tris0)) if tris > tris0 => (rss - rss0) * 1048576.0 / (tris - tris0) as f64,
            _ => f64::NAN,
        };
        if base.is_none() {
            base = Some((rss, tris));
        }
        println!(
            "{tris:>10} {startup:>10.3} {:>16.2} {ns_per_ray:>9.1} {:>16.2} {rss:>8.1} {bytes_per_tri:>10.1}",
            startup * 1e9 / (tris as f64 * log_n),
            ns_per_ray / log_n
        );
        let _ = std::fs::remove_file(&ply);
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("bytes/tri: peak RSS growth over the smallest mesh, per added triangle");
}
