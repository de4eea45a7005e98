//! `farm submit` of a shot as a user runs it: a folder of frames, an output
//! name with the frame number, a frame that fails alone (exit code 1, the
//! others written), and several frames with one plain output name refused
//! before anything renders (exit code 2).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shot_copy(name: &str, frames: usize, change: impl Fn(usize, String) -> String) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/shot");
    let dir = std::env::temp_dir().join(format!("farm-cli-shot-{}-{name}", std::process::id()));
    std::fs::create_dir_all(dir.join("world")).unwrap();
    std::fs::copy(src.join("mesh.ply"), dir.join("mesh.ply")).unwrap();
    std::fs::copy(src.join("world/world.pbrt"), dir.join("world/world.pbrt")).unwrap();
    for f in 1..=frames {
        let file = format!("frame-{f:04}.pbrt");
        let text = std::fs::read_to_string(src.join(&file)).unwrap();
        std::fs::write(dir.join(file), change(f, text)).unwrap();
    }
    dir
}

/// Runs `farm` with `args` in `dir`.
fn farm(dir: &Path, args: &[&std::ffi::OsStr]) -> Output {
    let farm = env!("CARGO_BIN_EXE_farm");
    Command::new(farm).current_dir(dir).args(args).output().expect("run farm")
}

#[test]
fn a_frame_that_fails_fails_alone_and_the_others_are_written() {
    // Frame 2's film is over the embedded render's pixel limit.
    let dir =
        shot_copy(
            "fails",
            3,
            |f, text| {
                if f == 2 {
                    text.replace("[ 160 ]", "[ 100000000 ]")
                } else {
                    text
                }
            },
        );
    let out_dir = dir.join("out");
    let pattern = out_dir.join("f-%02d.png");
    let args = ["submit".as_ref(), dir.as_os_str(), "-o".as_ref(), pattern.as_os_str()];
    let out = farm(&dir, &[&args[..], &["--spp".as_ref(), "1".as_ref()]].concat());
    let (stdout, stderr) =
        (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(stdout.contains("shot: 3 frames, 2 written, 1 failed"), "{stdout}");
    assert!(stderr.contains("too large") && stderr.contains("frame 2 failed"), "{stderr}");
    assert!(out_dir.join("f-01.png").is_file() && out_dir.join("f-03.png").is_file());
    assert!(!out_dir.join("f-02.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn several_frames_and_one_output_name_are_refused_before_rendering() {
    let dir = shot_copy("one-name", 2, |_, text| text);
    let one = dir.join("one.png");
    let out = farm(&dir, &["submit".as_ref(), dir.as_os_str(), "-o".as_ref(), one.as_os_str()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("several frames") && stderr.contains("%04d"), "{stderr}");
    assert!(!one.exists());
    // Without -o, each frame writes its own Film filename.
    let out = farm(&dir, &["submit".as_ref(), dir.as_os_str(), "--quick".as_ref()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("shot: 2 frames, 2 written, 0 failed"), "{stdout}");
    assert!(dir.join("frame-0001.exr").is_file() && dir.join("frame-0002.exr").is_file());
    std::fs::remove_dir_all(&dir).ok();
}
