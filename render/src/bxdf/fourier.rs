//! The tabulated Fourier BSDF (pbrt-v3 `FourierBSDFTable`, `FourierBSDF`):
//! an isotropic BSDF measured or computed by layerlab, stored as cosine
//! series in φ over a spline grid of zenith cosines, read from a `SCATFUN`
//! file. The file comes from a client, so every size and offset in it is
//! checked against the file before anything is allocated or indexed.

use super::reflection::{cos_theta, sin2_theta};
use super::{BxDFSample, BxDFType, TransportMode};
use crate::interpolation::{catmull_rom_weights, fourier, sample_catmull_rom_2d, sample_fourier};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::math;
use farm_common::Spectrum;
use std::cell::RefCell;

/// The header's size in bytes.
const HEADER: usize = 64;

/// A Fourier BSDF's tables (pbrt-v3 `FourierBSDFTable`).
#[derive(Clone, Debug, PartialEq)]
pub struct FourierTable {
    /// Relative index of refraction, bottom over top.
    pub eta: f32,
    /// Longest series in the file.
    pub m_max: usize,
    /// 1 (monochrome) or 3 (luminance, red, blue).
    pub n_channels: usize,
    /// The zenith-cosine nodes, increasing over [−1, 1].
    pub mu: Vec<f32>,
    /// Series length per (μo, μi) node pair, row-major in μo.
    m: Vec<u32>,
    /// Offset of each pair's coefficients in `a`.
    a_offset: Vec<u32>,
    /// All coefficients: per pair, `n_channels` series of its length.
    a: Vec<f32>,
    /// Each pair's constant term (luminance).
    a0: Vec<f32>,
    /// Running integrals of `a0` over μi, per μo.
    cdf: Vec<f32>,
    /// 1/k for k < `m_max`.
    recip: Vec<f32>,
}

/// Why a file is not a Fourier BSDF pbrt-v3 reads.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct TableError(pub String);

fn bad(what: impl Into<String>) -> TableError {
    TableError(what.into())
}

impl FourierTable {
    /// Reads a `SCATFUN` version 1 file (little-endian), the subset pbrt-v3
    /// reads: a BSDF (flags = 1), 1 or 3 channels, one basis function.
    pub fn read(bytes: &[u8]) -> Result<FourierTable, TableError> {
        if bytes.len() < HEADER || &bytes[..8] != b"SCATFUN\x01" {
            return Err(bad("not a SCATFUN version 1 file"));
        }
        let word = |i: usize| {
            let at = 8 + 4 * i;
            u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
        };
        let int = |i: usize| word(i) as i32;
        let (flags, n_mu, n_coeffs, m_max, n_channels, n_bases) =
            (int(0), int(1), int(2), int(3), int(4), int(5));
        let eta = f32::from_bits(word(9));
        if flags != 1 || !(n_channels == 1 || n_channels == 3) || n_bases != 1 {
            return Err(bad(format!(
                "unsupported contents (flags {flags}, {n_channels} channels, {n_bases} bases; \
                 pbrt-v3 reads flags 1, 1 or 3 channels, 1 basis)"
            )));
        }
        if n_mu < 2 || n_coeffs < 0 || m_max < 1 || m_max > n_coeffs.max(1) {
            return Err(bad(format!(
                "bad sizes ({n_mu} zenith nodes, {n_coeffs} coefficients, longest series {m_max})"
            )));
        }
        if !(eta.is_finite() && eta > 0.0) {
            return Err(bad(format!("bad relative index of refraction {eta}")));
        }
        let (n_mu, n_coeffs, m_max, n_channels) =
            (n_mu as usize, n_coeffs as usize, m_max as usize, n_channels as usize);
        // Every count is checked against the file's length, in u64, before
        // anything is allocated.
        let pairs = (n_mu as u64) * (n_mu as u64);
        let words = n_mu as u64 + pairs + 2 * pairs + n_coeffs as u64;
        if HEADER as u64 + 4 * words > bytes.len() as u64 {
            return Err(bad(format!(
                "truncated: {n_mu} zenith nodes and {n_coeffs} coefficients need {} bytes, the file has {}",
                HEADER as u64 + 4 * words,
                bytes.len()
            )));
        }
        let mut at = HEADER;
        let mut take = |n: usize| {
            let v: Vec<u32> = bytes[at..at + 4 * n]
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            at += 4 * n;
            v
        };
        let floats = |v: Vec<u32>| v.into_iter().map(f32::from_bits).collect::<Vec<f32>>();
        let mu = floats(take(n_mu));
        let cdf = floats(take(n_mu * n_mu));
        let offset_and_length = take(2 * n_mu * n_mu);
        let a = floats(take(n_coeffs));

        if mu.iter().any(|x| !x.is_finite()) || mu.windows(2).any(|w| w[0] >= w[1]) {
            return Err(bad("the zenith nodes are not finite and increasing"));
        }
        if cdf.iter().chain(&a).any(|x| !x.is_finite()) {
            return Err(bad("a coefficient or CDF value is not finite"));
        }
        let (mut m, mut a_offset, mut a0) = (Vec::new(), Vec::new(), Vec::new());
        for pair in offset_and_length.chunks_exact(2) {
            let (offset, length) = (pair[0] as u64, pair[1] as u64);
            if length > m_max as u64 || offset + length * n_channels as u64 > n_coeffs as u64 {
                return Err(bad(format!(
                    "a series (offset {}, length {}) lies outside the {n_coeffs} coefficients \
                     or is longer than the longest, {m_max}",
                    pair[0] as i32, pair[1] as i32
                )));
            }
            m.push(length as u32);
            a_offset.push(offset as u32);
            a0.push(if length > 0 { a[offset as usize] } else { 0.0 });
        }
        let recip = (0..m_max).map(|i| 1.0 / i as f32).collect();
        Ok(FourierTable { eta, m_max, n_channels, mu, m, a_offset, a, a0, cdf, recip })
    }

    /// A table from its parts, as [`Self::read`] would hold them; for
    /// writing files (`series[o * n + i]` is the pair's channels, each the
    /// same length, concatenated).
    pub fn to_bytes(eta: f32, mu: &[f32], n_channels: usize, series: &[Vec<f32>]) -> Vec<u8> {
        let n = mu.len();
        let mut cdf = Vec::with_capacity(n * n);
        for o in 0..n {
            let a0: Vec<f32> =
                (0..n).map(|i| series[o * n + i].first().copied().unwrap_or(0.0)).collect();
            cdf.extend(crate::interpolation::integrate_catmull_rom(mu, &a0));
        }
        let (mut offsets, mut coeffs) = (Vec::new(), Vec::new());
        let mut m_max = 1;
        for s in series {
            let len = s.len() / n_channels;
            m_max = m_max.max(len);
            offsets.push([coeffs.len() as u32, len as u32]);
            coeffs.extend_from_slice(s);
        }
        let mut out = b"SCATFUN\x01".to_vec();
        let ints = [1, n as i32, coeffs.len() as i32, m_max as i32, n_channels as i32, 1, 0, 0, 0];
        ints.iter().for_each(|v| out.extend(v.to_le_bytes()));
        out.extend(eta.to_le_bytes());
        [0.0f32; 4].iter().for_each(|v| out.extend(v.to_le_bytes()));
        mu.iter().chain(&cdf).for_each(|v| out.extend(v.to_le_bytes()));
        offsets.iter().flatten().for_each(|v| out.extend(v.to_le_bytes()));
        coeffs.iter().for_each(|v| out.extend(v.to_le_bytes()));
        out
    }

    /// pbrt-v3 `GetWeightsAndOffset`: spline weights of the nodes around μ.
    #[inline]
    fn weights(&self, mu: f32) -> Option<(isize, [f32; 4])> {
        catmull_rom_weights(&self.mu, mu)
    }

    /// Adds each of the 4×4 node pairs' series, weighted, into `ak`
    /// (`channels` series of `m_max`); returns the longest length added.
    fn accumulate(
        &self,
        (off_i, w_i): (isize, [f32; 4]),
        (off_o, w_o): (isize, [f32; 4]),
        channels: usize,
        ak: &mut [f32],
    ) -> usize {
        let n = self.mu.len();
        let mut m_max = 0;
        for (b, &wo) in w_o.iter().enumerate() {
            for (a, &wi) in w_i.iter().enumerate() {
                let weight = wi * wo;
                if weight == 0.0 {
                    continue;
                }
                // A nonzero weight's node is inside the grid.
                let pair = (off_o + b as isize) as usize * n + (off_i + a as isize) as usize;
                let m = self.m[pair] as usize;
                let ap = &self.a[self.a_offset[pair] as usize..];
                m_max = m_max.max(m);
                for c in 0..channels {
                    let dst = &mut ak[c * self.m_max..c * self.m_max + m];
                    for (d, &s) in dst.iter_mut().zip(&ap[c * m..c * m + m]) {
                        *d += weight * s;
                    }
                }
            }
        }
        m_max
    }

    /// The BSDF's value from the luminance `y` and, with colour, the red
    /// and blue series (pbrt-v3's G from Y, R and B).
    fn value(&self, ak: &[f32], m: usize, cos_phi: f32, y: f32, scale: f32) -> Spectrum {
        if self.n_channels == 1 {
            return Spectrum::splat(y * scale);
        }
        let r = fourier(&ak[self.m_max..], m, cos_phi as f64);
        let b = fourier(&ak[2 * self.m_max..], m, cos_phi as f64);
        let g = 1.39829 * y - 0.100913 * b - 0.297375 * r;
        Spectrum::new(r * scale, g * scale, b * scale).clamp(0.0, f32::INFINITY)
    }

    /// 1/|μi|, times the squared relative index for radiance crossing the
    /// surface.
    fn scale(&self, mu_i: f32, mu_o: f32, mode: TransportMode) -> f32 {
        let mut scale = if mu_i != 0.0 { 1.0 / mu_i.abs() } else { 0.0 };
        if mode == TransportMode::Radiance && mu_i * mu_o > 0.0 {
            let eta = if mu_i > 0.0 { 1.0 / self.eta } else { self.eta };
            scale *= eta * eta;
        }
        scale
    }
}

thread_local! {
    /// Scratch for summed coefficients (pbrt-v3 uses `alloca`): it grows to
    /// the largest table a thread meets and is then reused.
    static SCRATCH: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f32]) -> R) -> R {
    SCRATCH.with(|s| {
        let mut s = s.borrow_mut();
        s.clear();
        s.resize(len, 0.0);
        f(&mut s)
    })
}

/// pbrt-v3 `CosDPhi`: the cosine of the azimuth between two directions.
#[inline]
fn cos_d_phi(wa: Vec3, wb: Vec3) -> f32 {
    let waxy = wa.x * wa.x + wa.y * wa.y;
    let wbxy = wb.x * wb.x + wb.y * wb.y;
    if waxy == 0.0 || wbxy == 0.0 {
        return 1.0;
    }
    ((wa.x * wb.x + wa.y * wb.y) / (waxy * wbxy).sqrt()).clamp(-1.0, 1.0)
}

/// The lobe: a borrowed table and the transport mode.
#[derive(Clone, Copy, Debug)]
pub struct FourierBsdf<'a> {
    /// The table, owned by the material.
    pub table: &'a FourierTable,
    /// Radiance or importance.
    pub mode: TransportMode,
}

impl PartialEq for FourierBsdf<'_> {
    fn eq(&self, o: &Self) -> bool {
        std::ptr::eq(self.table, o.table) && self.mode == o.mode
    }
}

impl FourierBsdf<'_> {
    /// pbrt-v3 `FourierBSDF::f`.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let t = self.table;
        let (mu_i, mu_o) = (cos_theta(-wi), cos_theta(wo));
        let cos_phi = cos_d_phi(-wi, wo);
        let (Some(wi_), Some(wo_)) = (t.weights(mu_i), t.weights(mu_o)) else {
            return Spectrum::ZERO;
        };
        with_scratch(t.m_max * t.n_channels, |ak| {
            let m = t.accumulate(wi_, wo_, t.n_channels, ak);
            let y = fourier(ak, m, cos_phi as f64).max(0.0);
            t.value(ak, m, cos_phi, y, t.scale(mu_i, mu_o, self.mode))
        })
    }

    /// pbrt-v3 `FourierBSDF::Sample_f`: μi from the spline of the constant
    /// terms, then φ from the luminance series.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let t = self.table;
        let mu_o = cos_theta(wo);
        let s = sample_catmull_rom_2d(&t.mu, &t.mu, &t.a0, &t.cdf, mu_o, u.y)?;
        let mu_i = s.x;
        let (wi_, wo_) = (t.weights(mu_i)?, t.weights(mu_o)?);
        with_scratch(t.m_max * t.n_channels, |ak| {
            let m = t.accumulate(wi_, wo_, t.n_channels, ak);
            let phi = sample_fourier(ak, &t.recip, m, u.x);
            let pdf = (phi.pdf * s.pdf).max(0.0);
            let sin2_i = (1.0 - mu_i * mu_i).max(0.0);
            let mut norm = (sin2_i / sin2_theta(wo)).sqrt();
            if norm.is_infinite() {
                norm = 0.0;
            }
            let (sin_phi, cos_phi) = math::sin_cos(phi.phi);
            let wi = -Vec3::new(
                norm * (cos_phi * wo.x - sin_phi * wo.y),
                norm * (sin_phi * wo.x + cos_phi * wo.y),
                mu_i,
            );
            // pbrt-v3 normalises again: rounding in the rotation can leave
            // wi far from unit length near grazing wo.
            let wi = wi.normalize();
            let f = t.value(ak, m, cos_phi, phi.f, t.scale(mu_i, mu_o, self.mode));
            (pdf > 0.0 && wi.is_finite()).then_some(BxDFSample { f, wi, pdf, sampled_type: ty })
        })
    }

    /// pbrt-v3 `FourierBSDF::Pdf`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let t = self.table;
        let (mu_i, mu_o) = (cos_theta(-wi), cos_theta(wo));
        let cos_phi = cos_d_phi(-wi, wo);
        let (Some(wi_), Some((off_o, w_o))) = (t.weights(mu_i), t.weights(mu_o)) else {
            return 0.0;
        };
        let n = t.mu.len();
        with_scratch(t.m_max, |ak| {
            let m = t.accumulate(wi_, (off_o, w_o), 1, ak);
            let mut rho = 0.0;
            for (o, &w) in w_o.iter().enumerate() {
                if w != 0.0 {
                    let row = (off_o + o as isize) as usize;
                    rho += w * t.cdf[row * n + n - 1] * 2.0 * std::f32::consts::PI;
                }
            }
            let y = fourier(ak, m, cos_phi as f64);
            if rho > 0.0 && y > 0.0 {
                y / rho
            } else {
                0.0
            }
        })
    }
}

#[cfg(test)]
#[path = "fourier_tests.rs"]
mod tests;
