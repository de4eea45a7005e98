//! pbrt-v3's command-line flags on `farm submit`, run as a user runs them.

mod common;

use common::{farm, scene};
use farm_common::image::read_file;

/// `--cropwindow` writes the full render's pixels there, bit for bit;
/// `--outfile` and `--nthreads` are pbrt-v3's names for `-o` and
/// `--threads`; `--quick` renders a quarter of the resolution each way.
#[test]
fn pbrt_v3_flags_crop_name_and_shrink_the_render() {
    let dir = std::env::temp_dir().join(format!("farm-flags-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (full, crop, quick) = (dir.join("full.pfm"), dir.join("crop.pfm"), dir.join("quick.pfm"));
    let run = |extra: &[&str]| {
        let out = farm()
            .args(["submit", "--quiet", "--spp", "2"])
            .arg(scene())
            .args(extra)
            .output()
            .expect("farm submit");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    };
    run(&["--outfile", full.to_str().unwrap(), "--nthreads", "2"]);
    run(&["-o", crop.to_str().unwrap(), "--cropwindow", "0.25", "0.75", "0.25", "0.75"]);
    run(&["-o", quick.to_str().unwrap(), "--quick"]);
    let (full, crop, quick) =
        (read_file(&full).unwrap(), read_file(&crop).unwrap(), read_file(&quick).unwrap());
    assert_eq!((full.width, full.height), (480, 320));
    assert_eq!((crop.width, crop.height), (240, 160));
    assert_eq!((quick.width, quick.height), (120, 80));
    for y in 0..crop.height {
        for x in 0..crop.width {
            let a = crop.pixels[y * crop.width + x].map(f32::to_bits);
            let b = full.pixels[(y + 80) * full.width + x + 120].map(f32::to_bits);
            assert_eq!(a, b, "pixel ({}, {})", x + 120, y + 80);
        }
    }
    let out = farm().args(["submit", "--cropwindow", "0.5"]).arg(scene()).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "a crop window needs four numbers");
    std::fs::remove_dir_all(&dir).ok();
}

/// Several files are one stream of scenes, each WorldEnd rendering one to
/// its Film filename; `-` reads the scene from standard input and
/// `.pbrt.gz` compressed, as pbrt-v3 and pbrt-v4 take them.
#[test]
fn several_files_stdin_and_gzip_are_read_as_pbrt_reads_them() {
    use std::io::Write;
    let dir = std::env::temp_dir().join(format!("farm-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = |name: &str, res: u32| {
        format!(
            "Film \"image\" \"integer xresolution\" [ {res} ] \"integer yresolution\" [ 8 ] \
             \"string filename\" \"{name}\"\nSampler \"halton\" \"integer pixelsamples\" [ 1 ]\n\
             WorldBegin\nLightSource \"infinite\"\nShape \"sphere\"\nWorldEnd\n"
        )
    };
    std::fs::write(dir.join("a.pbrt"), scene("a.pfm", 8)).unwrap();
    let mut gz = flate2_writer();
    gz.write_all(scene("b.pfm", 12).as_bytes()).unwrap();
    std::fs::write(dir.join("b.pbrt.gz"), gz.finish().unwrap()).unwrap();
    let out = farm()
        .current_dir(&dir)
        .args(["submit", "--quiet", "a.pbrt", "b.pbrt.gz"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(read_file(&dir.join("a.pfm")).unwrap().width, 8);
    assert_eq!(read_file(&dir.join("b.pfm")).unwrap().width, 12);

    let out = farm()
        .current_dir(&dir)
        .args(["submit", "a.pbrt", "b.pbrt.gz", "-o", "one.pfm"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "one --output for two scenes");

    let mut child = farm()
        .current_dir(&dir)
        .args(["submit", "--quiet", "-", "-o", "stdin.pfm"])
        .stdin(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(scene("unused.pfm", 10).as_bytes()).unwrap();
    assert!(child.wait().unwrap().success());
    assert_eq!(read_file(&dir.join("stdin.pfm")).unwrap().width, 10);
    std::fs::remove_dir_all(&dir).ok();
}

fn flate2_writer() -> flate2::write::GzEncoder<Vec<u8>> {
    flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default())
}

/// `--cat` prints the scene as pbrt-v3 text that reads back to itself:
/// the text of the text is the text (tests/tests/cat.rs checks the
/// descriptions on every project and shared scene).
#[test]
fn cat_prints_a_scene_that_reads_back_to_itself() {
    use std::io::Write;
    let out = farm().args(["submit", "--cat"]).arg(scene()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("WorldBegin") && text.contains("Shape \"sphere\""), "{text}");
    let mut child = farm()
        .current_dir(scene().parent().unwrap())
        .args(["submit", "--cat", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(text.as_bytes()).unwrap();
    let again = child.wait_with_output().unwrap();
    let again = String::from_utf8(again.stdout).unwrap();
    // Only the scene's name and the camera's matrix (inverted twice, to
    // the last bit and the sign of zero) may differ.
    let body = |t: &str| t.lines().skip(2).collect::<Vec<_>>().join("\n");
    assert_eq!(body(&text), body(&again));
}
