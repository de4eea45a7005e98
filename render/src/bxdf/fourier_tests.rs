use super::*;
use farm_common::math;
use std::f32::consts::PI;

/// Chebyshev–Lobatto nodes on [−1, 1], denser at the poles, like layerlab's.
fn nodes(n: usize) -> Vec<f32> {
    (0..n).map(|j| -math::cos(std::f32::consts::PI * j as f32 / (n - 1) as f32)).collect()
}

/// A table whose pair (o, i) holds `series(μo, μi)` in each channel.
fn table(n: usize, channels: usize, eta: f32, series: impl Fn(f32, f32) -> Vec<f32>) -> Vec<u8> {
    let mu = nodes(n);
    let mut all = Vec::new();
    for &mo in &mu {
        for &mi in &mu {
            let s = series(mo, mi);
            all.push((0..channels).flat_map(|_| s.clone()).collect());
        }
    }
    FourierTable::to_bytes(eta, &mu, channels, &all)
}

/// Lambertian reflection kd/π: its stored series is kd/π·|μi| on
/// reflection pairs (μi·μo < 0) and nothing on transmission ones.
fn lambert(kd: f32) -> Vec<u8> {
    table(24, 1, 1.0, |mo, mi| if mo * mi < 0.0 { vec![kd / PI * mi.abs()] } else { vec![] })
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(
        math::sin(theta) * math::cos(phi),
        math::sin(theta) * math::sin(phi),
        math::cos(theta),
    )
}

#[test]
fn reads_what_it_writes() {
    let bytes = lambert(0.5);
    let t = FourierTable::read(&bytes).unwrap();
    assert_eq!((t.n_channels, t.m_max, t.mu.len()), (1, 1, 24));
    assert_eq!(t.mu, nodes(24));
    // The last CDF entry of a row is ∫ a0 dμi: kd/π·½ over the other side.
    let row = 20 * 24 + 23;
    assert!((t.cdf[row] - 0.5 / PI * 0.5).abs() < 2e-3, "{}", t.cdf[row]);
}

#[test]
fn lambertian_table_is_kd_over_pi() {
    let t = FourierTable::read(&lambert(0.5)).unwrap();
    let b = FourierBsdf { table: &t, mode: TransportMode::Radiance };
    for (to, ti, phi) in [(0.3, 0.5, 0.0), (1.0, 0.2, 2.0), (0.1, 1.2, 3.0), (0.7, 0.7, 1.0)] {
        let v = b.f(dir(to, 0.3), dir(ti, phi)).r;
        assert!((v - 0.5 / PI).abs() < 0.01 * 0.5 / PI, "{to} {ti} {phi}: {v}");
        // Nothing is transmitted.
        assert_eq!(b.f(dir(to, 0.3), -dir(ti, phi)), Spectrum::ZERO);
    }
}

#[test]
fn at_nodes_f_is_the_series_over_mu_i() {
    // At node pairs the spline weights pick one pair: f is exactly its
    // cosine series divided by |μi|, times 1/η² for radiance crossing it.
    let series = |mo: f32, mi: f32| vec![1.0 + mo * mi, 0.3 * mo, -0.1 * mi];
    let bytes = table(9, 1, 1.5, series);
    let t = FourierTable::read(&bytes).unwrap();
    let b = FourierBsdf { table: &t, mode: TransportMode::Radiance };
    let mu = nodes(9);
    for &mo in &mu[1..8] {
        for &mi in &mu[1..8] {
            let phi = 0.7f32;
            let wo = Vec3::new((1.0 - mo * mo).sqrt(), 0.0, mo);
            // −wi has zenith cosine μi and azimuth φ from wo.
            let s = (1.0 - mi * mi).sqrt();
            let wi = -Vec3::new(s * math::cos(phi), s * math::sin(phi), mi);
            let a = series(mo, mi);
            let sum = a[0] + a[1] * math::cos(phi) + a[2] * math::cos(2.0 * phi);
            let mut expect = sum.max(0.0) / mi.abs();
            if mi * mo > 0.0 {
                expect *= if mi > 0.0 { 1.0 / (1.5 * 1.5) } else { 1.5 * 1.5 };
            }
            let v = b.f(wo, wi).r;
            assert!(
                (v - expect).abs() < 1e-4 * expect.abs().max(1.0),
                "μo {mo} μi {mi}: {v} vs {expect}"
            );
        }
    }
}

#[test]
fn colour_tables_take_green_from_luminance() {
    // Channels are Y, R, B; pbrt-v3 recovers G = 1.39829 Y − 0.100913 B − 0.297375 R.
    let (y, r, bl) = (0.4f32, 0.7f32, 0.1f32);
    let mu = nodes(6);
    let all: Vec<Vec<f32>> = (0..36).map(|_| vec![y, r, bl]).collect();
    let t = FourierTable::read(&FourierTable::to_bytes(1.0, &mu, 3, &all)).unwrap();
    let b = FourierBsdf { table: &t, mode: TransportMode::Radiance };
    let (wo, wi) = (dir(0.4, 0.0), dir(0.9, 2.0));
    let scale = 1.0 / wi.z;
    let v = b.f(wo, wi);
    let g = 1.39829 * y - 0.100913 * bl - 0.297375 * r;
    for (got, want) in [(v.r, r), (v.g, g), (v.b, bl)] {
        assert!((got - want * scale).abs() < 1e-4, "{v:?}");
    }
}

/// A glossy table: a lobe around the mirror direction plus a little
/// diffuse transmission, so sampling has something to find.
fn glossy() -> FourierTable {
    let kappa = 8.0f32;
    let bytes = table(20, 1, 1.3, |mo, mi| {
        if mo * mi > 0.0 {
            return vec![0.05 * mi.abs()];
        }
        let (so, si) = ((1.0 - mo * mo).max(0.0).sqrt(), (1.0 - mi * mi).max(0.0).sqrt());
        // exp(κ(cos γ − 1)), cos γ = sᵢsₒ cos φ − μᵢμₒ, as a cosine series.
        (0..16)
            .map(|k| {
                let steps = 256;
                let mut s = 0.0;
                for j in 0..steps {
                    let phi = PI * (j as f32 + 0.5) / steps as f32;
                    let g = math::exp(kappa * (si * so * math::cos(phi) - mi * mo - 1.0));
                    s += g * math::cos(k as f32 * phi);
                }
                let ak = s / steps as f32 * if k == 0 { 1.0 } else { 2.0 };
                0.5 * mi.abs() * (if k == 0 { 0.2 } else { 0.0 } + ak)
            })
            .collect()
    });
    FourierTable::read(&bytes).unwrap()
}

#[test]
fn samples_carry_the_pdf_of_their_direction_and_it_integrates_to_one() {
    let t = glossy();
    let b = FourierBsdf { table: &t, mode: TransportMode::Radiance };
    for theta_o in [0.2f32, 0.8, 1.3] {
        let wo = dir(theta_o, 0.4);
        // ∫ pdf dω over the sphere, by a midpoint rule in (cos θ, φ).
        let (nt, np) = (200, 200);
        let mut total = 0.0;
        for i in 0..nt {
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
            for j in 0..np {
                let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                let s = (1.0 - z * z).sqrt();
                total += b.pdf(wo, Vec3::new(s * math::cos(phi), s * math::sin(phi), z));
            }
        }
        total *= 4.0 * PI / (nt * np) as f32;
        assert!((total - 1.0).abs() < 0.01, "θo {theta_o}: ∫pdf = {total}");
        let mut n = 0;
        for i in 0..16 {
            for j in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                let Some(s) = b.sample_f(wo, u, BxDFType::GLOSSY) else { continue };
                n += 1;
                assert!((s.wi.length() - 1.0).abs() < 1e-4);
                let p = b.pdf(wo, s.wi);
                assert!(
                    (s.pdf - p).abs() < 0.02 * p.max(0.05),
                    "θo {theta_o} u {u:?}: {} vs {p}",
                    s.pdf
                );
                let f = b.f(wo, s.wi);
                assert!((s.f.r - f.r).abs() < 0.02 * f.r.max(0.05), "{:?} vs {f:?}", s.f);
            }
        }
        assert!(n > 200, "only {n} of 256 samples");
    }
}

#[test]
fn hostile_files_are_refused_without_panicking() {
    let good = lambert(0.5);
    // Every truncation.
    for len in 0..good.len() {
        assert!(FourierTable::read(&good[..len]).is_err(), "accepted {len} bytes");
    }
    let patch = |word: usize, v: u32| {
        let mut b = good.clone();
        b[8 + 4 * word..12 + 4 * word].copy_from_slice(&v.to_le_bytes());
        FourierTable::read(&b)
    };
    // Header: flags, channels, bases, and sizes that would allocate gigabytes.
    assert!(patch(0, 3).unwrap_err().0.contains("flags 3"));
    assert!(patch(4, 2).is_err());
    assert!(patch(5, 4).is_err());
    let huge = patch(1, 1 << 30).unwrap_err().0;
    assert!(huge.contains("truncated"), "{huge}");
    assert!(patch(2, u32::MAX).is_err()); // negative count
    assert!(patch(3, 1 << 20).is_err()); // longest series beyond the coefficients
    assert!(patch(9, f32::NAN.to_bits()).is_err()); // eta
                                                    // Body: unsorted nodes, a NaN coefficient, a series outside the file.
    let body = HEADER;
    let mut b = good.clone();
    b[body..body + 4].copy_from_slice(&2.0f32.to_le_bytes());
    assert!(FourierTable::read(&b).unwrap_err().0.contains("increasing"));
    let mut b = good.clone();
    let last = b.len() - 4;
    b[last..].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(FourierTable::read(&b).is_err());
    let n = 24;
    let offsets = body + 4 * (n + n * n);
    let mut b = good.clone();
    b[offsets..offsets + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    b[offsets + 4..offsets + 8].copy_from_slice(&1u32.to_le_bytes());
    assert!(FourierTable::read(&b).unwrap_err().0.contains("outside"));
    assert!(FourierTable::read(b"SCATFUN\x02").is_err());
}

/// A scene whose table is not one pbrt-v3 reads renders the material black
/// with pbrt-v3's message, once for the file however many materials name it.
#[test]
fn unreadable_tables_warn_once_and_are_black() {
    use crate::materials::{build, Material, MaterialFiles};
    use crate::textures::TextureSet;
    use farm_common::scene::{Entity, FileLoc, MaterialEntity, Param, ParamSet, ParamValue};
    use std::collections::BTreeMap;
    let mut assets = BTreeMap::new();
    assets.insert("bad.bsdf".to_string(), b"SCATFUN\x01".to_vec());
    assets.insert("good.bsdf".to_string(), lambert(0.5));
    let files = MaterialFiles::new(&assets);
    let material = |file: &str| {
        let mut params = ParamSet::default();
        let value = ParamValue::String(vec![file.into()]);
        params.add(Param { name: "bsdffile".into(), value, loc: FileLoc::default() });
        MaterialEntity {
            name: None,
            entity: Entity { name: "fourier".into(), params, loc: FileLoc::default() },
        }
    };
    let mut w = Vec::new();
    let set = TextureSet::default();
    let built = build(
        &[material("bad.bsdf"), material("bad.bsdf"), material("good.bsdf")],
        &set,
        &files,
        &mut w,
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("incompatible file format") && w[0].message.contains("bad.bsdf"));
    let tables: Vec<bool> = built
        .iter()
        .map(|m| match m {
            Material::Fourier(f) => f.table.is_some(),
            _ => panic!("{m:?}"),
        })
        .collect();
    assert_eq!(tables, [false, false, true]);
}
