//! `Shape "curve"` (pbrt-v3 `CreateCurveShape`): checking a curve's
//! parameters, converting its control points from the Bézier or B-spline
//! basis to cubic Bézier segments, and splitting each segment into
//! 2^`splitdepth` pieces.

use super::curve::{lerp, lerp3, Curve, CurveCommon, CurveType};
use super::efloat::Placement;
use super::mesh::warn;
use super::Shape;
use farm_common::geometry::Vec3;
use farm_common::scene::{Params, Warning};
use std::sync::Arc;

/// The segments of a `Shape "curve"` (pbrt-v3 `CreateCurveShape`), each
/// split into 2^`splitdepth` pieces.
pub(super) fn create(params: &Params, pl: &Placement, warnings: &mut Vec<Warning>) -> Vec<Shape> {
    let width = params.float("width", 1.0);
    let width0 = params.float("width0", width);
    let width1 = params.float("width1", width);
    let degree = params.int("degree", 3);
    if degree != 2 && degree != 3 {
        warn(
            warnings,
            format!("Invalid degree {degree}: only degree 2 and 3 curves are supported."),
        );
        return vec![];
    }
    let basis = params.string("basis", "bezier");
    if basis != "bezier" && basis != "bspline" {
        warn(
            warnings,
            format!("Invalid basis \"{basis}\": only \"bezier\" and \"bspline\" are supported."),
        );
        return vec![];
    }
    let cp: Vec<Vec3> = params.point3s("P").unwrap_or(&[]).iter().map(|&a| Vec3::from(a)).collect();
    let ncp = cp.len() as i64;
    let deg = degree as i64;
    let n_segments = if basis == "bezier" {
        if (ncp - 1 - deg) % deg != 0 {
            warn(
                warnings,
                format!(
                    "Invalid number of control points {ncp}: for the degree {deg} Bezier basis {} + n * {deg} are required, for n >= 0.",
                    deg + 1
                ),
            );
            return vec![];
        }
        ((ncp - 1) / deg).max(0) as usize
    } else {
        if ncp < deg + 1 {
            warn(
                warnings,
                format!(
                    "Invalid number of control points {ncp}: for the degree {deg} b-spline basis, must have >= {}.",
                    deg + 1
                ),
            );
            return vec![];
        }
        (ncp - deg) as usize
    };
    let kind = match params.string("type", "flat").as_str() {
        "flat" => CurveType::Flat,
        "ribbon" => CurveType::Ribbon,
        "cylinder" => CurveType::Cylinder,
        other => {
            warn(warnings, format!("Unknown curve type \"{other}\".  Using \"cylinder\"."));
            CurveType::Cylinder
        }
    };
    let mut normals: Option<Vec<Vec3>> =
        params.normals("N").map(|n| n.iter().map(|&a| Vec3::from(a)).collect());
    if let Some(n) = &normals {
        if kind != CurveType::Ribbon {
            warn(warnings, "Curve normals are only used with \"ribbon\" type curves.".into());
            normals = None;
        } else if n.len() != n_segments + 1 {
            warn(
                warnings,
                format!(
                    "Invalid number of normals {}: must provide {} normals for ribbon curves with {n_segments} segments.",
                    n.len(),
                    n_segments + 1
                ),
            );
            return vec![];
        }
    } else if kind == CurveType::Ribbon {
        warn(warnings, "Must provide normals \"N\" at curve endpoints with ribbon curves.".into());
        return vec![];
    }
    let split_float = params.float("splitdepth", 3.0);
    let mut sd = params.int("splitdepth", split_float as i32);
    if !(0..=16).contains(&sd) {
        warn(warnings, format!("Curve \"splitdepth\" {sd} out of range [0, 16]; clamping."));
        sd = sd.clamp(0, 16);
    }
    if cp.iter().any(|p| !p.is_finite()) {
        warn(warnings, "Curve has non-finite control points. Ignoring.".into());
        return vec![];
    }
    let mut out = Vec::new();
    let mut base = 0usize;
    for seg in 0..n_segments {
        let c = &cp[base..];
        let bez = if basis == "bezier" {
            base += degree as usize;
            if degree == 2 {
                [c[0], lerp3(2.0 / 3.0, c[0], c[1]), lerp3(1.0 / 3.0, c[1], c[2]), c[2]]
            } else {
                [c[0], c[1], c[2], c[3]]
            }
        } else {
            base += 1;
            if degree == 2 {
                let (p01, p12, p23) = (c[0], c[1], c[2]);
                let p11 = lerp3(0.5, p01, p12);
                let p22 = lerp3(0.5, p12, p23);
                [p11, lerp3(2.0 / 3.0, p11, p12), lerp3(1.0 / 3.0, p12, p22), p22]
            } else {
                let (p012, p123, p234, p345) = (c[0], c[1], c[2], c[3]);
                let p122 = lerp3(2.0 / 3.0, p012, p123);
                let p223 = lerp3(1.0 / 3.0, p123, p234);
                let p233 = lerp3(2.0 / 3.0, p123, p234);
                let p334 = lerp3(1.0 / 3.0, p234, p345);
                [lerp3(0.5, p122, p223), p223, p233, lerp3(0.5, p233, p334)]
            }
        };
        let w0 = lerp(seg as f32 / n_segments as f32, width0, width1);
        let w1 = lerp((seg + 1) as f32 / n_segments as f32, width0, width1);
        let norm = normals.as_ref().map(|n| [n[seg], n[seg + 1]]);
        let common = Arc::new(CurveCommon::new(*pl, bez, w0, w1, kind, norm));
        let n = 1usize << sd;
        for i in 0..n {
            let (u_min, u_max) = (i as f32 / n as f32, (i + 1) as f32 / n as f32);
            out.push(Shape::Curve(Curve { common: common.clone(), u_min, u_max }));
        }
    }
    out
}
