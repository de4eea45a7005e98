//! Stiff and extreme cases for whole scenes (issue 4): the same scene at very
//! different scales and far from the origin, lit planes at grazing angles,
//! shading and lighting edge cases, and non-finite data in the scene file.
//! The intersection-level part of the suite is `render/tests/numerics.rs`.

mod scales;
mod shading;

use farm_cli::embedded::{RenderSummary, SubmitOptions};
use farm_common::geometry::{DVec3, Vec2, Vec3};
use farm_common::image::compare;
use farm_common::image::RgbImage;
use farm_render::lights::Light;
use farm_render::sampling::CameraSample;
use farm_render::{RenderOptions, Renderer};
use farm_scene::parse_str;
use farm_tests::{pixel, render_text};
use std::f64::consts::PI;
use std::path::Path;

fn opts() -> SubmitOptions {
    SubmitOptions { threads: 2, ..Default::default() }
}

/// Film values that are NaN or infinite.
fn non_finite(img: &RgbImage) -> usize {
    img.pixels.iter().flatten().filter(|v| !v.is_finite()).count()
}

/// Samples the film guard set to black, as `nan/inf/negative`.
fn guarded(r: &RenderSummary) -> String {
    let s = &r.stats;
    format!("{}/{}/{}", s.nan_samples, s.inf_samples, s.negative_samples)
}

/// A number as the scene file should read it back.
fn num(x: f64) -> String {
    format!("{x:e}")
}

/// Where a scene is put: scaled by `s` about the origin, then moved by `t`
/// along (1, 1, 1). With `ctm` the file says so with `Translate` and `Scale`
/// at the top of the world block (and a LookAt at the moved camera);
/// otherwise every coordinate and length in the file is multiplied by `s`.
#[derive(Clone, Copy, Debug)]
struct Frame {
    s: f64,
    t: f64,
    ctm: bool,
}

impl Frame {
    const UNIT: Frame = Frame { s: 1.0, t: 0.0, ctm: true };

    /// Every placement the invariance and acne tests try.
    fn all() -> Vec<Frame> {
        let mut v = vec![];
        for s in [1e-4, 1e-2, 1e2, 1e5] {
            v.push(Frame { s, t: 0.0, ctm: true });
            v.push(Frame { s, t: 0.0, ctm: false });
        }
        v.push(Frame { s: 1.0, t: 1e6, ctm: true });
        v
    }

    /// The `LookAt` line for a camera at `eye` looking at `look` (world
    /// coordinates of the unit scene; they should be multiples of 1/16 so
    /// that they stay exact in f32 when moved by 1e6).
    fn look_at(&self, eye: [f64; 3], look: [f64; 3]) -> String {
        let w = |p: [f64; 3]| p.map(|c| num(c * self.s + self.t)).join(" ");
        format!("LookAt {}  {}  0 1 0", w(eye), w(look))
    }

    /// The first lines of the world block.
    fn world(&self) -> String {
        if self.ctm {
            format!("Translate {t} {t} {t}\nScale {s} {s} {s}", t = num(self.t), s = num(self.s))
        } else {
            String::new()
        }
    }

    /// Coordinates or lengths as written in the file.
    fn p(&self, v: &[f64]) -> String {
        let k = if self.ctm { 1.0 } else { self.s };
        v.iter().map(|&c| num(c * k)).collect::<Vec<_>>().join(" ")
    }

    /// A point light at `at` with intensity `i` times s², so that irradiance
    /// (which falls with distance²) is unchanged. pbrt-v3 adds `from` after
    /// the CTM, unscaled, so under a CTM the light is placed by `Translate`.
    fn point_light(&self, at: [f64; 3], i: f64) -> String {
        let i = num(i * self.s * self.s);
        if self.ctm {
            format!(
                "AttributeBegin\nTranslate {}\nLightSource \"point\" \"rgb I\" [{i} {i} {i}]\nAttributeEnd",
                self.p(&at)
            )
        } else {
            format!(
                "LightSource \"point\" \"point from\" [{}] \"rgb I\" [{i} {i} {i}]",
                self.p(&at)
            )
        }
    }

    fn name(&self) -> String {
        let how = if self.ctm { "ctm" } else { "coords" };
        format!("s{:e}-t{:e}-{how}", self.s, self.t)
    }
}

/// A box mesh over [-0.5, 0.5] × [0, 1] × [-0.5, 0.5].
fn box_mesh(f: &Frame) -> String {
    let mut p = vec![];
    for i in 0..8 {
        p.extend([
            if i & 1 == 0 { -0.5 } else { 0.5 },
            if i & 2 == 0 { 0.0 } else { 1.0 },
            if i & 4 == 0 { -0.5 } else { 0.5 },
        ]);
    }
    let idx = "0 2 3 0 3 1  4 5 7 4 7 6  0 1 5 0 5 4  2 6 7 2 7 3  0 4 6 0 6 2  1 3 7 1 7 5";
    format!("Shape \"trianglemesh\" \"point P\" [{}] \"integer indices\" [{idx}]", f.p(&p))
}
