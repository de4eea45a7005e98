//! A shot: several scenes submitted at once, each a frame with its own
//! image. The files given (a folder gives its `.pbrt` and `.pbrt.gz` files
//! in name order) are read as one stream, pbrt-v3's way, and each scene
//! the stream describes is a frame, numbered from `--first-frame` in
//! order. An output name with a frame number in it (`out/frame-%04d.exr`)
//! names each frame's image; without one, each frame writes its scene's
//! Film filename, and two frames may not write the same file.

use crate::error::Error;
use farm_common::scene::{SceneDescription, Warning};
use farm_scene::{SceneError, StreamedScene};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// One frame of a shot, parsed.
pub struct FrameScene {
    /// Where its files go.
    pub out: FrameOutput,
    /// The file its scene ends in (the job's name).
    pub file: PathBuf,
    /// The scene.
    pub desc: SceneDescription,
    /// The parser's warnings.
    pub warnings: Vec<Warning>,
    /// How long it took to parse.
    pub parsed_in: Duration,
}

impl FrameScene {
    /// When its parsing would have begun, had it begun just now: the start
    /// of its start-up time, however long it waited to be rendered.
    pub fn start(&self) -> Instant {
        let now = Instant::now();
        now.checked_sub(self.parsed_in).unwrap_or(now)
    }
}

/// The frames of the scenes `scenes` yields from the files `inputs`, each
/// given its outputs by `outputs`; the first took `first_parsed` to parse
/// (it was read before the shot began), the others' parse is timed here.
pub fn frame_scenes<'a>(
    inputs: &'a [PathBuf],
    outputs: &'a mut Outputs,
    mut scenes: impl Iterator<Item = Result<StreamedScene, SceneError>> + 'a,
    first_parsed: Duration,
) -> impl Iterator<Item = Result<FrameScene, Error>> + 'a {
    let mut index = 0;
    std::iter::from_fn(move || {
        let t = Instant::now();
        let scene = scenes.next()?;
        let parsed_in = if index == 0 { first_parsed } else { t.elapsed() };
        let frame = scene.map_err(Error::from).and_then(|s| {
            let (film, _) = farm_common::film::FilmGeometry::from_description(&s.desc);
            let out = outputs.claim(index, &film.filename)?;
            Ok(FrameScene {
                out,
                file: inputs[s.file].clone(),
                desc: s.desc,
                warnings: s.warnings,
                parsed_in,
            })
        });
        index += 1;
        Some(frame)
    })
}

/// An output name with a printf-style frame number in it: `%d`, or `%0Nd`
/// for at least N digits padded with zeros.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputPattern {
    before: String,
    digits: usize,
    after: String,
}

impl OutputPattern {
    /// The pattern in `path`, if it has one. More than one number, or a
    /// `%` that starts none, is an error.
    pub fn parse(path: &Path) -> Result<Option<OutputPattern>, Error> {
        let text = path.to_string_lossy();
        let bad = |why: &str| {
            Error::Usage(format!(
                "the output name {text} {why}; a frame number is written %d or %04d"
            ))
        };
        let mut found = None;
        let mut rest = text.as_ref();
        let mut offset = 0;
        while let Some(i) = rest.find('%') {
            let spec = &rest[i + 1..];
            let width: String = spec.chars().take_while(char::is_ascii_digit).collect();
            if !spec[width.len()..].starts_with('d') {
                return Err(bad("has a % that is not a frame number"));
            }
            if found.is_some() {
                return Err(bad("has more than one frame number"));
            }
            let digits = if width.is_empty() { 1 } else { width.parse().unwrap_or(usize::MAX) };
            if digits > 9 || (!width.is_empty() && !width.starts_with('0')) {
                return Err(bad("pads its frame number oddly (use %d, or %0Nd with N at most 9)"));
            }
            let end = offset + i + 1 + width.len() + 1;
            found = Some((offset + i, digits, end));
            offset = end;
            rest = &text[end..];
        }
        Ok(found.map(|(start, digits, end)| OutputPattern {
            before: text[..start].to_string(),
            digits,
            after: text[end..].to_string(),
        }))
    }

    /// The name of frame `n`.
    pub fn frame(&self, n: u32) -> PathBuf {
        PathBuf::from(format!("{}{:0width$}{}", self.before, n, self.after, width = self.digits))
    }
}

/// The scene files `paths` name: a folder stands for its `.pbrt` and
/// `.pbrt.gz` files, in name order.
pub fn expand_inputs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for p in paths {
        if !p.is_dir() {
            files.push(p.clone());
            continue;
        }
        let entries = std::fs::read_dir(p)
            .map_err(|e| Error::Usage(format!("cannot read the folder {}: {e}", p.display())))?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|f| {
                let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
                f.is_file() && name.is_some_and(|n| n.ends_with(".pbrt") || n.ends_with(".pbrt.gz"))
            })
            .collect();
        if found.is_empty() {
            return Err(Error::Usage(format!("the folder {} holds no .pbrt files", p.display())));
        }
        found.sort();
        files.append(&mut found);
    }
    Ok(files)
}

/// What `iter` yields, each item made one ahead of its use on a thread of
/// `scope`: the next frame is parsed while this one renders. Dropping the
/// iterator stops the thread after the item it is making.
pub fn read_ahead<'s, T: Send + 's>(
    scope: &'s std::thread::Scope<'s, '_>,
    iter: impl Iterator<Item = T> + Send + 's,
) -> impl Iterator<Item = T> + 's {
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    scope.spawn(move || {
        for item in iter {
            if tx.send(item).is_err() {
                break;
            }
        }
    });
    rx.into_iter()
}

/// Where each frame's image (and error map) goes, and the check that no
/// two frames write the same file.
pub struct Outputs {
    image: Option<OutputPattern>,
    plain_image: Option<PathBuf>,
    error_map: Option<OutputPattern>,
    plain_error_map: Option<PathBuf>,
    /// The first frame's number.
    pub first: u32,
    taken: HashMap<PathBuf, u32>,
}

/// Where one frame's files go.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    /// Its number.
    pub frame: u32,
    /// Its image (`None`: its scene's Film filename).
    pub image: Option<PathBuf>,
    /// Its error map, if one was asked for.
    pub error_map: Option<PathBuf>,
}

impl Outputs {
    /// The outputs of a shot's frames: `-o` and `--error-map` must carry a
    /// frame number when there are `several` frames (if that is not known
    /// yet, a plain name is refused at the second frame, by
    /// [`Outputs::claim`]).
    pub fn new(
        output: Option<&Path>,
        error_map: Option<&Path>,
        first: u32,
        several: bool,
    ) -> Result<Outputs, Error> {
        let split = |p: Option<&Path>, flag: &str| -> Result<_, Error> {
            let Some(p) = p else { return Ok((None, None)) };
            match OutputPattern::parse(p)? {
                Some(pattern) => Ok((Some(pattern), None)),
                None if several => Err(one_name(flag, &p.display().to_string())),
                None => Ok((None, Some(p.to_path_buf()))),
            }
        };
        let (image, plain_image) = split(output, "--output")?;
        let (error_map, plain_error_map) = split(error_map, "--error-map")?;
        Ok(Outputs { image, plain_image, error_map, plain_error_map, first, taken: HashMap::new() })
    }

    /// Whether frames are numbered in the outputs.
    pub fn numbered(&self) -> bool {
        self.image.is_some()
    }

    /// The files of the `index`-th frame (from 0), whose scene's Film
    /// filename is `film_filename`. A frame that would overwrite an
    /// earlier frame's image is refused.
    pub fn claim(&mut self, index: usize, film_filename: &str) -> Result<FrameOutput, Error> {
        let frame = self.first.saturating_add(index as u32);
        let at = |pattern: &Option<OutputPattern>, plain: &Option<PathBuf>, flag: &str| match (
            pattern, plain,
        ) {
            (Some(p), _) => Ok(Some(p.frame(frame))),
            (None, Some(p)) if index > 0 => Err(one_name(flag, &p.display().to_string())),
            (None, plain) => Ok(plain.clone()),
        };
        let image = at(&self.image, &self.plain_image, "--output")?;
        let error_map = at(&self.error_map, &self.plain_error_map, "--error-map")?;
        let written = image.clone().unwrap_or_else(|| PathBuf::from(film_filename));
        if let Some(earlier) = self.taken.insert(written.clone(), frame) {
            return Err(Error::Usage(format!(
                "frames {earlier} and {frame} would both write {}: give -o a frame number, e.g. -o out/frame-%04d.exr",
                written.display()
            )));
        }
        Ok(FrameOutput { frame, image, error_map })
    }
}

fn one_name(flag: &str, name: &str) -> Error {
    Error::Usage(format!(
        "{flag} {name} names one file but there are several frames: put a frame number in it, e.g. frame-%04d.exr"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_number_frames_as_printf_does() {
        let p = OutputPattern::parse(Path::new("out/frame-%04d.exr")).unwrap().unwrap();
        assert_eq!(p.frame(7), PathBuf::from("out/frame-0007.exr"));
        assert_eq!(p.frame(12345), PathBuf::from("out/frame-12345.exr"));
        let p = OutputPattern::parse(Path::new("f%d_x.png")).unwrap().unwrap();
        assert_eq!(p.frame(3), PathBuf::from("f3_x.png"));
        assert_eq!(OutputPattern::parse(Path::new("plain.exr")).unwrap(), None);
        for bad in ["a%d%d.exr", "a%s.exr", "a%4d.exr", "a%012d.exr", "100%.exr"] {
            let e = OutputPattern::parse(Path::new(bad)).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains("%04d"), "{bad}: {e}");
        }
    }

    #[test]
    fn several_frames_need_a_number_or_distinct_film_names() {
        // Several files and a plain -o: refused before anything renders.
        let e = Outputs::new(Some(Path::new("one.exr")), None, 1, true).err().unwrap();
        assert!(e.to_string().contains("frame-%04d"), "{e}");
        // A pattern: frames from --first-frame.
        let mut o =
            Outputs::new(Some(Path::new("f%03d.exr")), Some(Path::new("e%d.pfm")), 10, true)
                .unwrap();
        let f = o.claim(1, "ignored.exr").unwrap();
        assert_eq!(f.frame, 11);
        assert_eq!(f.image, Some(PathBuf::from("f011.exr")));
        assert_eq!(f.error_map, Some(PathBuf::from("e11.pfm")));
        // No -o: each scene's Film filename, once.
        let mut o = Outputs::new(None, None, 1, true).unwrap();
        assert_eq!(o.claim(0, "a.exr").unwrap().image, None);
        assert!(o.claim(1, "b.exr").is_ok());
        let e = o.claim(2, "a.exr").unwrap_err().to_string();
        assert!(e.contains("frames 1 and 3 would both write a.exr"), "{e}");
        // One file, a plain -o, and a second scene in it.
        let mut o = Outputs::new(Some(Path::new("one.exr")), None, 1, false).unwrap();
        assert_eq!(o.claim(0, "x.exr").unwrap().image, Some(PathBuf::from("one.exr")));
        assert!(o.claim(1, "x.exr").is_err());
    }

    #[test]
    fn reading_ahead_yields_the_same_items_and_stops_when_dropped() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let made = AtomicUsize::new(0);
        std::thread::scope(|scope| {
            let all: Vec<u32> = read_ahead(scope, 0..100u32).collect();
            assert_eq!(all, (0..100).collect::<Vec<_>>());
            let counted = (0..1000u32).inspect(|_| {
                made.fetch_add(1, Ordering::Relaxed);
            });
            let first: Vec<u32> = read_ahead(scope, counted).take(3).collect();
            assert_eq!(first, [0, 1, 2]);
        });
        // Three taken, one waiting in the channel, one made and refused.
        assert!(made.load(Ordering::Relaxed) <= 5, "{}", made.load(Ordering::Relaxed));
    }

    #[test]
    fn a_folder_stands_for_its_scene_files_in_name_order() {
        let dir = std::env::temp_dir().join(format!("farm-frames-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub.pbrt")).unwrap();
        for f in ["b.pbrt", "a.pbrt.gz", "c.txt", "a.pbrt"] {
            std::fs::write(dir.join(f), "").unwrap();
        }
        let got = expand_inputs(&[dir.clone(), PathBuf::from("x.pbrt")]).unwrap();
        let names: Vec<_> =
            got.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["a.pbrt", "a.pbrt.gz", "b.pbrt", "x.pbrt"]);
        std::fs::remove_dir_all(&dir).unwrap();
        std::fs::create_dir_all(&dir).unwrap();
        assert!(expand_inputs(std::slice::from_ref(&dir)).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
