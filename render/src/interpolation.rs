//! Spline and Fourier interpolation (pbrt-v3 `core/interpolation.cpp`), as
//! the tabulated Fourier BSDF uses them: Catmull–Rom weights over a
//! nonuniform grid, sampling the spline in one dimension of a 2D table, and
//! evaluating and sampling a cosine series in φ.

use crate::sampling::find_interval;
use farm_common::math;
use std::f64::consts::PI;

/// Most Newton/bisection steps the samplers take. pbrt-v3 loops until it
/// converges; on a well-formed table that takes a handful of steps, and the
/// cap keeps a hostile one from spinning.
const MAX_STEPS: u32 = 64;

/// pbrt-v3 `CatmullRomWeights`: the offset of the first of the four nodes
/// around `x` (it may be −1; that node's weight is then 0) and their weights,
/// or `None` when `x` lies outside the nodes.
pub fn catmull_rom_weights(nodes: &[f32], x: f32) -> Option<(isize, [f32; 4])> {
    let size = nodes.len();
    if size < 2 || !(x >= nodes[0] && x <= nodes[size - 1]) {
        return None;
    }
    let idx = find_interval(size, |i| nodes[i] <= x);
    let (x0, x1) = (nodes[idx], nodes[idx + 1]);
    let t = (x - x0) / (x1 - x0);
    let (t2, t3) = (t * t, t * t * t);
    let mut w = [0.0f32; 4];
    w[1] = 2.0 * t3 - 3.0 * t2 + 1.0;
    w[2] = -2.0 * t3 + 3.0 * t2;
    if idx > 0 {
        let w0 = (t3 - 2.0 * t2 + t) * (x1 - x0) / (x1 - nodes[idx - 1]);
        w[0] = -w0;
        w[2] += w0;
    } else {
        let w0 = t3 - 2.0 * t2 + t;
        w[0] = 0.0;
        w[1] -= w0;
        w[2] += w0;
    }
    if idx + 2 < size {
        let w3 = (t3 - t2) * (x1 - x0) / (nodes[idx + 2] - x0);
        w[1] -= w3;
        w[3] = w3;
    } else {
        let w3 = t3 - t2;
        w[1] -= w3;
        w[2] += w3;
        w[3] = 0.0;
    }
    Some((idx as isize - 1, w))
}

/// A sample of [`sample_catmull_rom_2d`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineSample {
    /// The sampled position along the second dimension.
    pub x: f32,
    /// The interpolated function's value there.
    pub f: f32,
    /// Its density.
    pub pdf: f32,
}

/// pbrt-v3 `SampleCatmullRom2D`: samples the second dimension of a spline
/// table `values` (`nodes1.len()` rows of `nodes2.len()`), at `alpha` in the
/// first, by inverting the running integrals `cdf` with Newton steps.
pub fn sample_catmull_rom_2d(
    nodes1: &[f32],
    nodes2: &[f32],
    values: &[f32],
    cdf: &[f32],
    alpha: f32,
    u: f32,
) -> Option<SplineSample> {
    let size2 = nodes2.len();
    let (offset, weights) = catmull_rom_weights(nodes1, alpha)?;
    let interpolate = |array: &[f32], idx: usize| {
        let mut value = 0.0;
        for (i, &w) in weights.iter().enumerate() {
            if w != 0.0 {
                value += array[(offset + i as isize) as usize * size2 + idx] * w;
            }
        }
        value
    };
    let maximum = interpolate(cdf, size2 - 1);
    let mut u = u * maximum;
    let idx = find_interval(size2, |i| interpolate(cdf, i) <= u);
    let (f0, f1) = (interpolate(values, idx), interpolate(values, idx + 1));
    let (x0, x1) = (nodes2[idx], nodes2[idx + 1]);
    let width = x1 - x0;
    u = (u - interpolate(cdf, idx)) / width;
    let d0 = if idx > 0 {
        width * (f1 - interpolate(values, idx - 1)) / (x1 - nodes2[idx - 1])
    } else {
        f1 - f0
    };
    let d1 = if idx + 2 < size2 {
        width * (interpolate(values, idx + 2) - f0) / (nodes2[idx + 2] - x0)
    } else {
        f1 - f0
    };

    // Invert the segment's integral, starting from a linear interpolant's.
    let mut t = if f0 != f1 {
        (f0 - (f0 * f0 + 2.0 * u * (f1 - f0)).max(0.0).sqrt()) / (f0 - f1)
    } else {
        u / f0
    };
    let (mut a, mut b) = (0.0f32, 1.0f32);
    let mut fhat;
    let mut steps = 0;
    loop {
        if !(t >= a && t <= b) {
            t = 0.5 * (a + b);
        }
        let big_f = t
            * (f0
                + t * (0.5 * d0
                    + t * ((1.0 / 3.0) * (-2.0 * d0 - d1) + f1 - f0
                        + t * (0.25 * (d0 + d1) + 0.5 * (f0 - f1)))));
        fhat = f0
            + t * (d0 + t * (-2.0 * d0 - d1 + 3.0 * (f1 - f0) + t * (d0 + d1 + 2.0 * (f0 - f1))));
        steps += 1;
        if (big_f - u).abs() < 1e-6 || b - a < 1e-6 || steps >= MAX_STEPS {
            break;
        }
        if big_f - u < 0.0 {
            a = t;
        } else {
            b = t;
        }
        t -= (big_f - u) / fhat;
    }
    Some(SplineSample { x: x0 + width * t, f: fhat, pdf: fhat / maximum })
}

/// pbrt-v3 `IntegrateCatmullRom`: the running integrals of the spline
/// through `(x, values)`, one per node (the first is 0); what a Fourier
/// BSDF file stores as its `cdf`.
pub fn integrate_catmull_rom(x: &[f32], values: &[f32]) -> Vec<f32> {
    let n = x.len();
    let mut cdf = vec![0.0f32; n];
    let mut sum = 0.0f32;
    for i in 0..n.saturating_sub(1) {
        let (x0, x1) = (x[i], x[i + 1]);
        let (f0, f1) = (values[i], values[i + 1]);
        let width = x1 - x0;
        let d0 = if i > 0 { width * (f1 - values[i - 1]) / (x1 - x[i - 1]) } else { f1 - f0 };
        let d1 = if i + 2 < n { width * (values[i + 2] - f0) / (x[i + 2] - x0) } else { f1 - f0 };
        sum += ((d0 - d1) * (1.0 / 12.0) + (f0 + f1) * 0.5) * width;
        cdf[i + 1] = sum;
    }
    cdf
}

/// pbrt-v3 `Fourier`: Σₖ aₖ cos(kφ) for k < `m`, in double precision,
/// with the cosines by their recurrence.
#[inline]
pub fn fourier(a: &[f32], m: usize, cos_phi: f64) -> f32 {
    let mut value = 0.0f64;
    let (mut cos_prev, mut cos_k) = (cos_phi, 1.0f64);
    for &ak in &a[..m] {
        value += ak as f64 * cos_k;
        let next = 2.0 * cos_phi * cos_k - cos_prev;
        cos_prev = cos_k;
        cos_k = next;
    }
    value as f32
}

/// A sample of [`sample_fourier`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FourierSample {
    /// The series' value at `phi`.
    pub f: f32,
    /// The density of `phi` on [0, 2π).
    pub pdf: f32,
    /// The sampled angle.
    pub phi: f32,
}

/// pbrt-v3 `SampleFourier`: samples φ ∈ [0, 2π) proportionally to the
/// (even) series `ak`, by bisection and Newton steps on its integral over
/// [0, π], mirrored for the upper half of `u`. `recip[k]` is 1/k.
pub fn sample_fourier(ak: &[f32], recip: &[f32], m: usize, u: f32) -> FourierSample {
    let flip = u >= 0.5;
    let u = if flip { 1.0 - 2.0 * (u - 0.5) } else { u * 2.0 };
    let (mut a, mut b, mut phi) = (0.0f64, PI, 0.5 * PI);
    let (mut big_f, mut f);
    let mut steps = 0;
    loop {
        let cos_phi = math::cos(phi);
        let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt();
        let (mut cos_prev, mut cos_cur) = (cos_phi, 1.0f64);
        let (mut sin_prev, mut sin_cur) = (-sin_phi, 0.0f64);
        big_f = ak[0] as f64 * phi;
        f = ak[0] as f64;
        for k in 1..m {
            let sin_next = 2.0 * cos_phi * sin_cur - sin_prev;
            let cos_next = 2.0 * cos_phi * cos_cur - cos_prev;
            sin_prev = sin_cur;
            sin_cur = sin_next;
            cos_prev = cos_cur;
            cos_cur = cos_next;
            big_f += (ak[k] * recip[k]) as f64 * sin_next;
            f += ak[k] as f64 * cos_next;
        }
        big_f -= (u * ak[0]) as f64 * PI;
        if big_f > 0.0 {
            b = phi;
        } else {
            a = phi;
        }
        steps += 1;
        if big_f.abs() < 1e-6 || b - a < 1e-6 || steps >= MAX_STEPS {
            break;
        }
        phi -= big_f / f;
        if !(phi > a && phi < b) {
            phi = 0.5 * (a + b);
        }
    }
    if flip {
        phi = 2.0 * PI - phi;
    }
    FourierSample { f: f as f32, pdf: (f / (2.0 * PI) / ak[0] as f64) as f32, phi: phi as f32 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catmull_rom_reproduces_nodes_and_sums_to_one() {
        let nodes = [-1.0, -0.6, -0.1, 0.0, 0.3, 0.9, 1.0];
        for (i, &x) in nodes.iter().enumerate() {
            let (off, w) = catmull_rom_weights(&nodes, x).unwrap();
            // At a node, that node has weight 1 and the others 0.
            for (j, &wj) in w.iter().enumerate() {
                let expect = if off + j as isize == i as isize { 1.0 } else { 0.0 };
                assert!((wj - expect).abs() < 1e-6, "x={x} {w:?} off {off}");
            }
        }
        for k in 0..=200 {
            let x = -1.0 + 2.0 * k as f32 / 200.0;
            let (_, w) = catmull_rom_weights(&nodes, x).unwrap();
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{x}: {w:?}");
        }
        assert!(catmull_rom_weights(&nodes, 1.0001).is_none());
        assert!(catmull_rom_weights(&nodes, f32::NAN).is_none());
    }

    #[test]
    fn catmull_rom_is_exact_for_lines_inside() {
        // Interior segments reproduce a linear function exactly (the
        // finite-difference slopes of a line are its slope).
        let nodes: Vec<f32> = (0..9).map(|i| math::powf(i as f32 / 8.0, 1.3)).collect();
        let line = |x: f32| 0.25 + 2.0 * x;
        for k in 0..100 {
            let x = k as f32 / 99.0;
            let (off, w) = catmull_rom_weights(&nodes, x).unwrap();
            let v: f32 = (0..4)
                .filter(|&j| w[j] != 0.0)
                .map(|j| w[j] * line(nodes[(off + j as isize) as usize]))
                .sum();
            assert!((v - line(x)).abs() < 1e-5, "{x}: {v} vs {}", line(x));
        }
    }

    #[test]
    fn fourier_is_the_cosine_series() {
        let a = [0.5f32, -0.25, 0.125, 0.3];
        for k in 0..50 {
            let phi = k as f64 * 0.13;
            let direct: f64 =
                a.iter().enumerate().map(|(i, &c)| c as f64 * math::cos(i as f64 * phi)).sum();
            assert!((fourier(&a, 4, math::cos(phi)) as f64 - direct).abs() < 1e-6);
        }
        assert_eq!(fourier(&a, 0, 0.3), 0.0);
    }

    #[test]
    fn sample_fourier_inverts_the_integral() {
        // f(φ) = 1 + 0.8 cos φ + 0.1 cos 2φ: the CDF at the sample is u.
        let a = [1.0f32, 0.8, 0.1];
        let recip = [f32::INFINITY, 1.0, 0.5];
        let cdf =
            |phi: f64| (phi + 0.8 * math::sin(phi) + 0.05 * math::sin(2.0 * phi)) / (2.0 * PI);
        for k in 0..64 {
            let u = (k as f32 + 0.5) / 64.0;
            let s = sample_fourier(&a, &recip, 3, u);
            assert!((cdf(s.phi as f64) - u as f64).abs() < 1e-5, "u {u}: φ {}", s.phi);
            let f = fourier(&a, 3, math::cos(s.phi as f64));
            assert!((s.f - f).abs() < 1e-5);
            assert!((s.pdf - f / (2.0 * PI as f32)).abs() < 1e-5);
        }
    }

    #[test]
    fn sample_catmull_rom_2d_matches_its_pdf() {
        // Rows f(α, x) = 1 + α x² over x ∈ [0, 1]: sampled x has CDF u.
        let n1: Vec<f32> = (0..5).map(|i| i as f32 / 4.0).collect();
        let n2: Vec<f32> = (0..17).map(|i| i as f32 / 16.0).collect();
        let mut values = Vec::new();
        let mut cdf = Vec::new();
        for &al in &n1 {
            let row: Vec<f32> = n2.iter().map(|&x| 1.0 + al * x * x).collect();
            cdf.extend(integrate_catmull_rom(&n2, &row));
            values.extend(row);
        }
        let al = 0.6f32;
        let total = 1.0 + al / 3.0;
        for k in 0..32 {
            let u = (k as f32 + 0.5) / 32.0;
            let s = sample_catmull_rom_2d(&n1, &n2, &values, &cdf, al, u).unwrap();
            let c = (s.x + al * s.x.powi(3) / 3.0) / total;
            assert!((c - u).abs() < 2e-3, "u {u}: x {} cdf {c}", s.x);
            assert!((s.pdf - (1.0 + al * s.x * s.x) / total).abs() < 2e-3);
        }
        assert!(sample_catmull_rom_2d(&n1, &n2, &values, &cdf, 1.5, 0.5).is_none());
    }
}
