//! The `farm` binary as a user runs it: malformed scenes end with one line
//! naming file:line:column, exit code 2 and no panic.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// An empty folder of the test's own, removed when dropped.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("farm-cli-{name}-")).tempdir().expect("temp dir")
}

/// Runs `farm submit` on `scene` and returns (exit code, stderr).
fn submit(scene: &Path) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_farm"))
        .args(["submit", "--quiet", "-o"])
        .arg(scene.with_extension("exr"))
        .arg(scene)
        .output()
        .expect("run farm");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Runs `farm` with `args`, requires success and returns its stdout.
fn farm_ok<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_farm")).args(args).output().expect("run farm");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{stdout} {}", String::from_utf8_lossy(&out.stderr));
    stdout
}

fn expect_error(name: &str, scene: &str, extra: &[(&str, &[u8])], want_loc: &str) {
    let tmp = temp_dir(name);
    let dir = tmp.path();
    for (file, bytes) in extra {
        std::fs::write(dir.join(file), bytes).expect("write");
    }
    let path = dir.join(format!("{name}.pbrt"));
    std::fs::write(&path, scene).expect("write");
    let (code, stderr) = submit(&path);
    assert_eq!(code, 2, "{name}: exit code {code}, stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{name}: expected one line, got: {stderr}");
    let want = format!("error: {}:{want_loc}:", path.display());
    assert!(lines[0].starts_with(&want), "{name}: {:?} does not start with {want:?}", lines[0]);
}

const HEAD: &str = "Camera \"perspective\"\nFilm \"image\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n";

#[test]
fn unterminated_string_is_located() {
    expect_error(
        "unterminated",
        &format!("{HEAD}Shape \"sphere\" \"float radius\" [1]\nMaterial \"matte\n"),
        &[],
        "5:10",
    );
}

#[test]
fn unknown_directive_is_located() {
    expect_error(
        "directive",
        &format!("{HEAD}  Sphere \"float radius\" 1\nWorldEnd\n"),
        &[],
        "4:3",
    );
}

#[test]
fn wrong_parameter_type_is_located() {
    expect_error(
        "paramtype",
        &format!("{HEAD}Shape \"sphere\" \"float radius\" [ \"big\" ]\nWorldEnd\n"),
        &[],
        "4:33",
    );
}

#[test]
fn missing_include_is_located() {
    expect_error(
        "include",
        &format!("{HEAD}Include \"nowhere/geometry.pbrt\"\nWorldEnd\n"),
        &[],
        "4:1",
    );
}

#[test]
fn truncated_ply_is_located() {
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    ply.extend_from_slice(&[0u8; 20]);
    expect_error(
        "ply",
        &format!("{HEAD}Shape \"plymesh\" \"string filename\" \"cut.ply\"\nWorldEnd\n"),
        &[("cut.ply", &ply)],
        "4:17",
    );
}

#[test]
fn renders_the_example_scene_to_exr() {
    let tmp = temp_dir("example");
    let dir = tmp.path();
    let out = dir.join("example.exr");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt");
    let status = Command::new(env!("CARGO_BIN_EXE_farm"))
        .args(["submit", "--quiet", "--spp", "1", "-o"])
        .arg(&out)
        .arg(&scene)
        .status()
        .expect("run farm");
    assert!(status.success());
    let img = farm_common::image::read_file(&out).expect("read back");
    assert_eq!((img.width, img.height), (480, 320));
    assert!(img.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
}

/// `farm diff` prints the README's relMSE and the largest difference, and
/// writes the difference image; images of different sizes are bad input.
#[test]
fn diff_reports_the_error_and_writes_the_difference() {
    use farm_common::image::{read_file, write_image, ImageMetadata, RgbImage};
    let tmp = temp_dir("diff");
    let dir = tmp.path();
    let meta =
        ImageMetadata { scene: "t".into(), spp: 1, render_seconds: 0.0, rel_mse_estimate: None };
    let reference = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.0, 0.5], [0.2; 3]] };
    let image = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.0, 0.5], [0.2, 0.7, 0.2]] };
    let (a, r, d) = (dir.join("a.exr"), dir.join("r.exr"), dir.join("d.exr"));
    write_image(&a, &image, &meta).expect("write");
    write_image(&r, &reference, &meta).expect("write");
    let stdout = farm_ok([
        OsStr::new("diff"),
        OsStr::new("-o"),
        d.as_os_str(),
        a.as_os_str(),
        r.as_os_str(),
    ]);
    // One channel of six differs by 0.5 against a reference value of 0.2.
    let rel = 0.25 / (0.04 + 0.01) / 6.0;
    assert!(stdout.contains(&format!("relMSE     {rel:.6e}")), "{stdout}");
    assert!(stdout.contains("at pixel (1, 0)"), "{stdout}");
    let diff = read_file(&d).expect("difference image");
    assert_eq!(diff.pixels[0], [0.0; 3]);
    assert!((diff.pixels[1][1] - 0.5).abs() < 1e-6, "{:?}", diff.pixels[1]);

    let small = RgbImage { width: 1, height: 1, pixels: vec![[0.0; 3]] };
    write_image(&r, &small, &meta).expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_farm")).args(["diff"]).args([&a, &r]).output();
    let out = out.expect("run farm");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("is 2×1 but"));
}

/// `farm converge` without a reference renders powers of two up to the
/// scene's own count, measures each against the highest and writes the
/// table and the plot.
#[test]
fn converge_writes_the_table_and_the_plot() {
    let tmp = temp_dir("converge");
    let dir = tmp.path();
    let scene = dir.join("ball.pbrt");
    std::fs::write(
        &scene,
        "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         Sampler \"halton\" \"integer pixelsamples\" 8\n\
         Film \"image\" \"integer xresolution\" 24 \"integer yresolution\" 16\n\
         WorldBegin\nLightSource \"point\" \"point from\" [0 2 -3] \"rgb I\" [4 4 4]\n\
         Material \"matte\"\nShape \"sphere\" \"float radius\" 1\nWorldEnd\n",
    )
    .expect("write");
    let (csv, svg) = (dir.join("t.csv"), dir.join("t.svg"));
    let stdout = farm_ok([
        OsStr::new("converge"),
        OsStr::new("--csv"),
        csv.as_os_str(),
        OsStr::new("--plot"),
        svg.as_os_str(),
        scene.as_os_str(),
    ]);
    let table = std::fs::read_to_string(&csv).expect("csv");
    let rows: Vec<Vec<&str>> = table.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let spp: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(spp, ["1", "2", "4", "8"], "{table}");
    // Every render but the reference itself has an error; 1 spp has no estimate.
    assert!(rows[..3].iter().all(|r| r[5].parse::<f64>().is_ok_and(|v| v > 0.0)), "{table}");
    assert_eq!(rows[3][5], "", "{table}");
    assert_eq!(rows[0][6], "", "{table}");
    assert!(rows[1..].iter().all(|r| r[6].parse::<f64>().is_ok()), "{table}");
    assert!(std::fs::read_to_string(&svg).expect("svg").contains("<polyline"));
    assert!(stdout.contains("wrote"), "{stdout}");
}

/// `farm submit --verbose` says which features the scene uses and what the
/// render skipped.
#[test]
fn verbose_submit_lists_features_and_skipped_paths() {
    let tmp = temp_dir("verbose");
    let dir = tmp.path();
    let scene = dir.join("plain.pbrt");
    std::fs::write(&scene, format!("{HEAD}Shape \"sphere\"\nWorldEnd\n")).expect("write");
    let image = dir.join("plain.pfm");
    let stdout = farm_ok([
        OsStr::new("submit"),
        OsStr::new("--verbose"),
        OsStr::new("--spp"),
        OsStr::new("1"),
        OsStr::new("-o"),
        image.as_os_str(),
        scene.as_os_str(),
    ]);
    for want in ["ray differentials: skipped", "motion: skipped", "textures: none"] {
        assert!(stdout.contains(want), "{want:?} missing from {stdout}");
    }
}

/// `farm bench` renders each scene of a shared folder's reference table in
/// its own process and writes its time, rays and peak memory beside
/// pbrt-v3's.
#[test]
fn bench_tabulates_each_reference_scene() {
    let tmp = temp_dir("bench");
    let dir = tmp.path();
    std::fs::create_dir_all(dir.join("scenes/ball")).expect("dirs");
    std::fs::create_dir_all(dir.join("reference")).expect("dirs");
    // Enough work (96×96 pixels at 64 spp) for the CPU time, counted in
    // 10 ms ticks, to be above zero.
    std::fs::write(
        dir.join("scenes/ball/ball-whitted.pbrt"),
        "Camera \"perspective\"\nSampler \"halton\" \"integer pixelsamples\" 64\n\
         Film \"image\" \"integer xresolution\" 96 \"integer yresolution\" 96\n\
         WorldBegin\nLightSource \"point\" \"point from\" [0 0 -5]\n\
         Material \"matte\"\nShape \"sphere\"\nWorldEnd\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("reference/README.md"),
        "| scene | file | res | sampler, spp | relMSE | gt | wall | CPU | RSS | cam | shadow |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n\
         | ball | ball-whitted.pbrt | 96×96 | halton 64 | 1e-3 | gt256 | 0.5 | 1.0 | 10 | 590k | 2k |\n",
    )
    .expect("write");
    let csv = dir.join("bench.csv");
    let stdout = farm_ok([
        OsStr::new("bench"),
        OsStr::new("--threads"),
        OsStr::new("1"),
        OsStr::new("--shared"),
        dir.as_os_str(),
        OsStr::new("--csv"),
        csv.as_os_str(),
    ]);
    let table = std::fs::read_to_string(&csv).expect("csv");
    let row: Vec<&str> = table.lines().nth(1).expect("a row").split(',').collect();
    assert_eq!(row[0], "ball");
    let num = |i: usize| row[i].parse::<f64>().unwrap_or_else(|_| panic!("column {i}: {table}"));
    // 96×96 pixels at 64 spp grown by the filter: camera rays at least 96²·64.
    assert!(num(5) >= 96.0 * 96.0 * 64.0, "{table}");
    assert!(num(3) > 0.0 && num(7) > 1.0, "CPU seconds and peak RSS: {table}");
    assert_eq!((num(8), num(9), num(10)), (0.5, 1.0, 10.0), "{table}");
    assert!(stdout.contains("geometric mean"), "{stdout}");

    // A folder without the reference table is bad input.
    let out = Command::new(env!("CARGO_BIN_EXE_farm"))
        .args(["bench", "--shared"])
        .arg(dir.join("scenes"))
        .output()
        .expect("run farm");
    assert_eq!(out.status.code(), Some(2));
}

/// An oversize film or sample count ends with one clear line and exit code
/// 2 before anything is allocated (a 100000² film would need 320 GB; the
/// test would abort or take minutes if it were).
#[test]
fn oversize_films_and_sample_counts_are_refused_before_rendering() {
    let tmp = temp_dir("oversize");
    let dir = tmp.path();
    let big = dir.join("big.pbrt");
    let film = "Film \"image\" \"integer xresolution\" 100000 \"integer yresolution\" 100000";
    std::fs::write(&big, format!("{film}\nWorldBegin\nShape \"sphere\"\nWorldEnd\n")).unwrap();
    let (code, stderr) = submit(&big);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("10000000000 pixels (100000×100000)"), "{stderr}");
    assert!(stderr.contains("--max-pixels") && !stderr.contains("panicked"), "{stderr}");
    // A film below one pixel is an error at the Film directive, not a blank render.
    let none = dir.join("none.pbrt");
    let film = "Film \"image\" \"integer xresolution\" -5";
    std::fs::write(&none, format!("{film}\nWorldBegin\nShape \"sphere\"\nWorldEnd\n")).unwrap();
    let (code, stderr) = submit(&none);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("none.pbrt:1:1: \"integer xresolution\" is -5"), "{stderr}");

    let small = dir.join("small.pbrt");
    let film = "Film \"image\" \"integer xresolution\" 16 \"integer yresolution\" 16";
    std::fs::write(&small, format!("{film}\nWorldBegin\nShape \"sphere\"\nWorldEnd\n")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_farm"))
        .args(["submit", "-q", "--spp", "4294967295", "-o"])
        .arg(dir.join("small.exr"))
        .arg(&small)
        .output()
        .expect("run farm");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("4294967295 samples per pixel") && stderr.contains("--max-spp"));
    // The same scene within raised limits renders.
    let out = Command::new(env!("CARGO_BIN_EXE_farm"))
        .args(["submit", "-q", "--spp", "4", "--max-samples", "100000", "-o"])
        .arg(dir.join("small.exr"))
        .arg(&small)
        .output()
        .expect("run farm");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `farm diff a b | head -1`: a reader that goes away early ends the output
/// quietly; it is not a panic.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    use farm_common::image::{write_image, ImageMetadata, RgbImage};
    let tmp = temp_dir("pipe");
    let dir = tmp.path();
    let img = RgbImage { width: 1, height: 1, pixels: vec![[0.5; 3]] };
    let a = dir.join("a.exr");
    write_image(&a, &img, &ImageMetadata::default()).expect("write");
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_farm"))
        .arg("diff")
        .arg(&a)
        .arg(&a)
        .stdout(writer)
        .output()
        .expect("run farm");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

/// The summary says when the estimate is not to be trusted, and why: a
/// lower bound with fireflies (here tiny bright stars that few samples
/// find), a caveat for maxmindist samples, nothing for Halton; and a render
/// in passes lists them and says why it stopped.
#[test]
fn the_summary_says_when_the_estimate_is_not_to_be_trusted() {
    let tmp = temp_dir("caveats");
    let dir = tmp.path();
    let mut stars = String::from(
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n\
         Film \"image\" \"integer xresolution\" [ 64 ] \"integer yresolution\" [ 64 ]\n\
         Sampler \"halton\"\nWorldBegin\n",
    );
    for i in 0..200 {
        let (x, y) = ((i * 37 % 61) as f32 / 61.0 - 0.5, (i * 53 % 59) as f32 / 59.0 - 0.5);
        stars.push_str(&format!(
            "AttributeBegin\n Translate {} {} 10\n AreaLightSource \"diffuse\" \"rgb L\" [ 1000 1000 1000 ]\n \
             Shape \"sphere\" \"float radius\" [ 0.01 ]\nAttributeEnd\n",
            x * 6.0,
            y * 6.0
        ));
    }
    let path = dir.join("stars.pbrt");
    std::fs::write(&path, stars).unwrap();
    let out = dir.join("stars.exr");
    let run = |scene: &Path, args: &[&str]| {
        let mut all = vec!["submit", "-o", out.to_str().unwrap(), scene.to_str().unwrap()];
        all.extend_from_slice(args);
        farm_ok(all)
    };
    let said = run(&path, &["--spp", "8"]);
    assert!(said.contains("estimated relMSE at least"), "{said}");
    assert!(said.contains("the estimate is a lower bound") && said.contains("fireflies"), "{said}");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt");
    let said = run(&example, &["--spp", "4", "--sampler", "maxmindist"]);
    assert!(said.contains("may be far too low"), "{said}");
    let said = run(&example, &["--spp", "4"]);
    assert_eq!(said.lines().count(), 1, "no caveat for Halton: {said}");
    let said = run(&example, &["--spp", "16", "--target-error", "1e9"]);
    assert!(said.contains("pass    spp"), "{said}");
    assert!(said.contains("stopped: the estimate is at most the target error"), "{said}");
}
