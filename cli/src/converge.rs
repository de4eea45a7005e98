//! `farm converge`: a scene rendered at increasing sample counts, with the
//! error of each render against a reference (or the highest-count render)
//! next to the render's own estimate of its error, its time and its rays.

use crate::embedded::Progress;
use crate::error::Error;
use farm_common::image as metrics;

use crate::embedded::{self, SubmitOptions};
use farm_common::image::RgbImage;
use farm_common::math;
use farm_coordinator::estimate::ErrorEstimate;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What `run` renders.
#[derive(Clone, Debug, Default)]
pub struct ConvergeOptions {
    /// Sample counts; empty means powers of two up to the scene's own count.
    pub spp: Vec<u32>,
    /// The image to measure against; `None` measures against the render
    /// with the most samples.
    pub reference: Option<PathBuf>,
    /// Render threads (0 = one per core).
    pub threads: usize,
    /// A sampler to render with instead of the scene's.
    pub sampler: Option<String>,
}

/// One render of the series.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds spent rendering tiles.
    pub render_seconds: f64,
    /// Seconds to parse, load and build the scene.
    pub startup_seconds: f64,
    /// Rays traced (camera, shadow, reflected and refracted).
    pub rays: u64,
    /// Render nanoseconds per image sample (pixels × spp).
    pub ns_per_sample: f64,
    /// relMSE against the reference; `None` for the render that is the
    /// reference.
    pub rel_mse: Option<f64>,
    /// The render's own estimate of its relMSE (`None` at 1 spp).
    pub estimate: Option<f64>,
    /// Whether the estimate is claimed to lie within 2× of the true
    /// relMSE: no fireflies, and a sampler without a caveat
    /// (`crate::passes::caveat`).
    pub claimed: bool,
    /// When the render has fireflies, its estimate is a lower bound and
    /// this the upper value (`ErrorEstimate::upper`).
    pub upper: Option<f64>,
}

/// What the errors were measured against.
#[derive(Clone, Debug, PartialEq)]
pub enum Against {
    /// A reference image file.
    Reference(PathBuf),
    /// The series' own render at this many samples per pixel.
    HighestSpp(u32),
}

/// A finished series, rows in increasing spp.
#[derive(Clone, Debug)]
pub struct Convergence {
    /// The scene file.
    pub scene: PathBuf,
    /// What `rel_mse` is measured against.
    pub against: Against,
    /// The renders.
    pub rows: Vec<Row>,
}

/// Renders `scene` once, in passes that end at each sample count (and at
/// every doubling between them, so each pass's estimate compares two equal
/// halves where it can), and measures the image after each of those
/// passes. A count's row is the render stopped there: its time is the
/// time to reach it. `progress` gets the highest count and the tile
/// progress of the pass under way.
pub fn run(
    scene: &Path,
    opts: &ConvergeOptions,
    mut progress: impl FnMut(u32, &Progress),
) -> Result<Convergence, Error> {
    let reference = match &opts.reference {
        Some(p) => Some(metrics::read_file(p).map_err(Error::Reference)?),
        None => None,
    };
    let start = std::time::Instant::now();
    let (mut desc, mut warnings) = farm_scene::parse_file(scene)?;
    let overrides = farm_scene::Overrides { sampler: opts.sampler.clone(), ..Default::default() };
    overrides.apply(&mut desc, &mut warnings);
    let mut counts = opts.spp.clone();
    counts.sort_unstable();
    counts.dedup();
    let (layout, _) = farm_common::film::layout(&desc, counts.last().copied());
    let top = layout.spp();
    let b = layout.geometry.cropped_pixel_bounds;
    let (w, h) = (b.width().max(0) as usize, b.height().max(0) as usize);
    if let Some(r) = reference.as_ref().filter(|r| (r.width, r.height) != (w, h)) {
        return Err(Error::SizeMismatch {
            path: opts.reference.as_deref().unwrap_or(scene).display().to_string(),
            rw: r.width,
            rh: r.height,
            w,
            h,
        });
    }
    // The sampler may round the count up (Sobol', (0,2)-sequence).
    if let Some(last) = counts.last_mut() {
        *last = top;
    }
    if counts.is_empty() {
        counts = std::iter::successors(Some(1u32), |n| n.checked_mul(2))
            .take_while(|&n| n < top)
            .chain([top])
            .collect();
    }
    let mut totals: Vec<u32> = std::iter::successors(Some(counts[0]), |n| n.checked_mul(2))
        .take_while(|&n| n < top)
        .chain(counts.iter().copied())
        .collect();
    totals.sort_unstable();
    totals.dedup();
    let o = SubmitOptions {
        spp: Some(top),
        threads: opts.threads,
        pass_totals: totals,
        ..Default::default()
    };
    let caveat = crate::passes::caveat(layout.sampler, true);
    let pixels = |img: &RgbImage| (img.width * img.height) as f64;
    let row =
        |spp: u32, seconds: f64, rays: u64, image: &RgbImage, e: Option<&ErrorEstimate>| Row {
            spp,
            render_seconds: seconds,
            startup_seconds: 0.0,
            rays,
            ns_per_sample: seconds * 1e9 / (pixels(image) * f64::from(spp)).max(1.0),
            rel_mse: reference.as_ref().and_then(|r| metrics::compare(image, r).map(|e| e.rel_mse)),
            estimate: e.map(|e| e.rel_mse),
            claimed: e.is_some_and(|e| e.fireflies.is_none()) && caveat.is_none(),
            upper: e.filter(|e| e.fireflies.is_some()).map(|e| e.upper()),
        };
    // Without a reference, each earlier image waits for the last one.
    let mut rows = Vec::with_capacity(counts.len());
    let mut images = Vec::new();
    let summary = embedded::render_parsed_with(
        desc,
        warnings,
        start,
        &o,
        |p| progress(top, p),
        |end, film, stats| {
            if counts.contains(&end.spp) {
                let image = film.image();
                let estimate = film.error_estimate(end.spp);
                rows.push(row(end.spp, end.seconds, stats.total_rays(), &image, estimate.as_ref()));
                if reference.is_none() {
                    images.push(image);
                }
            }
        },
    )?;
    let seconds = summary.passes.last().map_or(summary.render_seconds, |p| p.seconds);
    let mut last = row(
        summary.spp,
        seconds,
        summary.stats.total_rays(),
        &summary.image,
        summary.error.as_ref(),
    );
    last.startup_seconds = summary.startup_seconds;
    if reference.is_none() {
        for (row, image) in rows.iter_mut().zip(&images) {
            row.rel_mse = metrics::compare(image, &summary.image).map(|e| e.rel_mse);
        }
        last.rel_mse = None;
    }
    for row in &mut rows {
        row.startup_seconds = summary.startup_seconds;
    }
    rows.push(last);
    let against = match &opts.reference {
        Some(p) => Against::Reference(p.clone()),
        None => Against::HighestSpp(summary.spp),
    };
    Ok(Convergence { scene: scene.to_path_buf(), against, rows })
}

/// An optional number as a CSV field (empty when absent).
fn field(v: Option<f64>) -> String {
    v.map(|v| format!("{v:e}")).unwrap_or_default()
}

impl Convergence {
    /// The table as CSV, one header line and one line per render.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "spp,render_seconds,startup_seconds,rays,ns_per_sample,rel_mse,rel_mse_estimate,estimate_over_rel_mse,rel_mse_upper,claimed\n",
        );
        for r in &self.rows {
            let ratio = r.estimate.zip(r.rel_mse).map(|(e, t)| e / t);
            let _ = writeln!(
                out,
                "{},{:.4},{:.4},{},{:.2},{},{},{},{},{}",
                r.spp,
                r.render_seconds,
                r.startup_seconds,
                r.rays,
                r.ns_per_sample,
                field(r.rel_mse),
                field(r.estimate),
                ratio.map(|v| format!("{v:.3}")).unwrap_or_default(),
                field(r.upper),
                r.claimed
            );
        }
        out
    }

    /// A log–log plot of relMSE (measured and estimated) against render
    /// seconds, as an SVG document.
    pub fn svg(&self) -> String {
        let (w, h, margin) = (640.0, 420.0, 70.0);
        let points = |f: fn(&Row) -> Option<f64>| -> Vec<(f64, f64, u32)> {
            self.rows
                .iter()
                .filter_map(|r| {
                    let y = f(r)?;
                    (y > 0.0 && r.render_seconds > 0.0).then_some((r.render_seconds, y, r.spp))
                })
                .collect()
        };
        let measured = points(|r| r.rel_mse);
        let estimated = points(|r| r.estimate);
        let all = measured.iter().chain(&estimated);
        let decades = |vals: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(math::log10(v)), hi.max(math::log10(v)))
            });
            if lo.is_finite() {
                (math::floor(lo), math::ceil(hi).max(math::floor(lo) + 1.0))
            } else {
                (0.0, 1.0)
            }
        };
        let (x0, x1) = decades(&mut all.clone().map(|p| p.0));
        let (y0, y1) = decades(&mut all.map(|p| p.1));
        let px = |x: f64| margin + (math::log10(x) - x0) / (x1 - x0) * (w - 2.0 * margin);
        let py = |y: f64| h - margin - (math::log10(y) - y0) / (y1 - y0) * (h - 2.0 * margin);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
        let against = match &self.against {
            Against::Reference(p) => format!("against {}", file_name(p)),
            Against::HighestSpp(n) => format!("against the {n} spp render"),
        };
        let _ = writeln!(
            s,
            r#"<text x="{margin}" y="24" font-size="14">{}: relMSE {} and self-estimate</text>"#,
            xml_escape(&file_name(&self.scene)),
            xml_escape(&against)
        );
        for d in x0 as i32..=x1 as i32 {
            let x = px(10f64.powi(d));
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{}" x2="{x:.1}" y2="{}" stroke="#ddd"/><text x="{x:.1}" y="{}" text-anchor="middle">1e{d}</text>"##,
                margin,
                h - margin,
                h - margin + 16.0
            );
        }
        for d in y0 as i32..=y1 as i32 {
            let y = py(10f64.powi(d));
            let _ = writeln!(
                s,
                r##"<line x1="{margin}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">1e{d}</text>"##,
                w - margin,
                margin - 6.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">render seconds</text><text x="16" y="{}" transform="rotate(-90 16 {})" text-anchor="middle">relMSE</text>"#,
            w / 2.0,
            h - 20.0,
            h / 2.0,
            h / 2.0
        );
        for (pts, colour, dash, name, row) in [
            (&measured, "#1f77b4", "", "relMSE", 0.0),
            (&estimated, "#d62728", r#" stroke-dasharray="6 4""#, "self-estimate", 1.0),
        ] {
            let line: Vec<String> =
                pts.iter().map(|&(x, y, _)| format!("{:.1},{:.1}", px(x), py(y))).collect();
            let _ = writeln!(
                s,
                r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="2"{dash}/>"#,
                line.join(" ")
            );
            for &(x, y, spp) in pts.iter() {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{colour}"><title>{spp} spp</title></circle>"#,
                    px(x),
                    py(y)
                );
            }
            let ly = margin + 8.0 + 16.0 * row;
            let _ = writeln!(
                s,
                r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{colour}" stroke-width="2"{dash}/><text x="{}" y="{}">{name}</text>"#,
                w - margin - 120.0,
                w - margin - 96.0,
                w - margin - 90.0,
                ly + 4.0
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().unwrap_or(p.as_os_str()).to_string_lossy().into_owned()
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Default output paths: `<scene stem>-converge.csv` and `.svg` in the
/// working directory.
pub fn default_paths(scene: &Path) -> (PathBuf, PathBuf) {
    let stem = scene.file_stem().map(|s| s.to_string_lossy().into_owned());
    let stem = stem.unwrap_or_else(|| "scene".into());
    (PathBuf::from(format!("{stem}-converge.csv")), PathBuf::from(format!("{stem}-converge.svg")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series() -> Convergence {
        let row = |spp, secs: f64, err: f64, est: f64| Row {
            spp,
            render_seconds: secs,
            startup_seconds: 0.1,
            rays: u64::from(spp) * 1000,
            ns_per_sample: 50.0,
            rel_mse: Some(err),
            estimate: Some(est),
            claimed: true,
            upper: None,
        };
        Convergence {
            scene: PathBuf::from("a<b>.pbrt"),
            against: Against::HighestSpp(16),
            rows: vec![row(4, 0.5, 4e-3, 5e-3), row(8, 1.0, 1e-3, 2e-3)],
        }
    }

    #[test]
    fn the_csv_has_a_header_and_one_line_per_render() {
        let csv = series().csv();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[0].starts_with("spp,render_seconds"));
        let f: Vec<&str> = lines[2].split(',').collect();
        assert_eq!(f.len(), 10);
        assert_eq!(f[0], "8");
        assert_eq!(f[5].parse::<f64>().unwrap(), 1e-3);
        assert_eq!(f[7], "2.000");
        assert_eq!(f[8], "", "no fireflies, no upper value");
        assert_eq!(f[9], "true");
    }

    #[test]
    fn the_plot_places_both_series_inside_the_axes() {
        let svg = series().svg();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("a&lt;b&gt;.pbrt"));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches("<circle").count(), 4);
        for c in svg.split("<circle cx=\"").skip(1) {
            let x: f64 = c.split('"').next().unwrap().parse().unwrap();
            assert!((70.0..=570.0).contains(&x), "{x}");
        }
    }
}
