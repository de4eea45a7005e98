//! Parameter parity with pbrt-v3, walked from the table of every parameter
//! pbrt-v3's constructors read (`../shared/reference/pbrt-v3-parameters.tsv`:
//! file, function, how it is read, name, default).
//!
//! For each constructor of a type farm has, two scenes are built:
//! - one that gives every parameter of the table, with a value of the type
//!   pbrt-v3 reads it as: none of them may draw a "not used" warning, and
//!   each must be looked up;
//! - one that gives none: every lookup that falls back on a default must
//!   fall back on pbrt-v3's.
//!
//! Where pbrt-v3 reads a name farm does not, or a constructor farm lacks,
//! the lists below say why.

mod scenes;
mod table;

use farm_common::scene::{Lookup, Warning};
use farm_tests::shared_dir;
use scenes::{companion, own_lookups, slot, value, write_assets};
use std::collections::{BTreeMap, BTreeSet};
use table::{kind, parse_default, recorded, same, table, Default, Row};

/// Constructors farm does not have, and why.
const MISSING: &[(&str, &str)] = &[
    ("CreateAOIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateBDPTIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateDirectLightingIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateMLTIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreatePathIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateSPPMIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateVolPathIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateKdTreeAccelerator", "farm builds a BVH for every scene, with a warning"),
    ("MakeMedium", "participating media: pbrt-v3's Whitted integrator ignores them"),
    ("pbrtMakeNamedMedium", "participating media: pbrt-v3's Whitted integrator ignores them"),
    ("CreatePtexFloatTexture", "no Ptex reader; the texture is refused with a warning naming it"),
    (
        "CreatePtexSpectrumTexture",
        "no Ptex reader; the texture is refused with a warning naming it",
    ),
];

/// Names a constructor farm has reads in pbrt-v3 but not in farm, and why.
const NOT_READ: &[(&str, &str, &str)] = &[];

/// Defaults the table gives as C++ expressions rather than values, and what
/// they are; the test checks these names are read, not their default.
const EXPRESSION_DEFAULTS: &[(&str, &str, &str)] = &[
    ("CreateCurveShape", "splitdepth", "read as a float, then as an integer: 3 either way"),
    ("CreateCurveShape", "width0", "defaults to `width`"),
    ("CreateCurveShape", "width1", "defaults to `width`"),
    (
        "CreateDiffuseAreaLight",
        "samples",
        "defaults to `nsamples`; the Whitted integrator ignores both",
    ),
    (
        "CreateInfiniteLight",
        "samples",
        "defaults to `nsamples`; the Whitted integrator ignores both",
    ),
    ("CreateImageFloatTexture", "gamma", "true for .tga and .png files, else false"),
    ("CreateImageSpectrumTexture", "gamma", "true for .tga and .png files, else false"),
    ("CreateLoopSubdiv", "levels", "defaults to `nlevels`, itself 3"),
    ("CreateMetalMaterial", "eta", "copper's measured index of refraction"),
    ("CreateMetalMaterial", "k", "copper's measured absorption"),
    ("CreateOrthographicCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreatePerspectiveCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreateEnvironmentCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreateKdSubsurfaceMaterial", "Kd", "grey 0.5, for the BSSRDF, which Whitted ignores"),
    (
        "CreateSubsurfaceMaterial",
        "sigma_a",
        "measured skim milk, for the BSSRDF, which Whitted ignores",
    ),
    (
        "CreateSubsurfaceMaterial",
        "sigma_s",
        "measured skim milk, for the BSSRDF, which Whitted ignores",
    ),
    ("CreateNURBS", "u0", "the first knot of the u range, uknots[uorder - 1]"),
    ("CreateNURBS", "u1", "the last knot of the u range, uknots[nu]"),
    ("CreateNURBS", "v0", "the first knot of the v range, vknots[vorder - 1]"),
    ("CreateNURBS", "v1", "the last knot of the v range, vknots[nv]"),
    ("CreateSphereShape", "zmin", "-radius"),
    ("CreateSphereShape", "zmax", "radius"),
];

#[test]
fn every_parameter_pbrt_v3_reads_is_read_with_its_default() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (with pbrt-v3's parameter table) is not present");
        return;
    };
    let rows = table(&shared);
    let dir = std::env::temp_dir().join(format!("farm-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_assets(&dir);

    let mut by_function: BTreeMap<String, Vec<Row>> = BTreeMap::new();
    for r in rows {
        by_function.entry(r.function.clone()).or_default().push(r);
    }
    let missing: BTreeMap<&str, &str> = MISSING.iter().copied().collect();
    let not_read: BTreeSet<(&str, &str)> = NOT_READ.iter().map(|(f, n, _)| (*f, *n)).collect();
    let expressions: BTreeSet<(&str, &str)> =
        EXPRESSION_DEFAULTS.iter().map(|(f, n, _)| (*f, *n)).collect();
    let mut failures = Vec::new();
    let mut checked = (0, 0);

    for (function, rows) in &by_function {
        if missing.contains_key(function.as_str()) {
            continue;
        }
        let Some(slot) = slot(function) else {
            failures
                .push(format!("{function}: neither mapped to a directive nor listed as missing"));
            continue;
        };
        // Every parameter given: none unused, each looked up. A name that
        // is not read beside the others (pbrt-v3 reads `index` only without
        // `eta`) must be read when given alone.
        let mut names = BTreeSet::new();
        let given: Vec<(String, String)> = rows
            .iter()
            .filter(|r| !not_read.contains(&(function.as_str(), r.name.as_str())))
            .filter(|r| names.insert(r.name.clone()))
            .map(|r| (r.name.clone(), value(r)))
            .collect();
        let all: Vec<&str> = given.iter().map(|(_, v)| v.as_str()).collect();
        let together = own_lookups(&dir, function, slot, &all.join(" "));
        if let Err(e) = &together {
            failures.push(format!("{function}: all parameters given: {e}"));
        }
        for (name, v) in &given {
            let read = |r: &Result<(Vec<Warning>, Vec<Lookup>), String>| match r {
                Ok((warnings, lookups)) => {
                    let unused = format!("Parameter \"{name}\" not used");
                    match warnings.iter().find(|w| w.to_string().contains(&unused)) {
                        Some(w) => Err(w.to_string()),
                        None if !lookups.iter().any(|l| &l.name == name) => {
                            Err(format!("\"{name}\" is never looked up"))
                        }
                        None => Ok(()),
                    }
                }
                Err(e) => Err(e.clone()),
            };
            checked.0 += 1;
            if read(&together).is_ok() {
                continue;
            }
            let alone =
                own_lookups(&dir, function, slot, &format!("{v} {}", companion(function, name)));
            if let Err(e) = read(&alone) {
                failures.push(format!("{function}: {e}"));
            }
        }
        // None given: each default is pbrt-v3's.
        let lookups = match own_lookups(&dir, function, slot, "") {
            Err(e) => {
                failures.push(format!("{function}: no parameters given: {e}"));
                continue;
            }
            Ok((_, l)) => l,
        };
        for name in &names {
            let defaults: Vec<&Row> = rows.iter().filter(|r| &r.name == name).collect();
            let theirs: Vec<Option<Default>> =
                defaults.iter().map(|r| parse_default(&r.default)).collect();
            if theirs.iter().all(|d| matches!(d, Some(Default::List))) {
                continue;
            }
            if theirs.iter().any(|d| d.is_none()) {
                if !expressions.contains(&(function.as_str(), name.as_str())) {
                    failures.push(format!(
                        "{function}: \"{name}\" defaults to an expression ({}) not explained here",
                        defaults.iter().map(|r| r.default.as_str()).collect::<Vec<_>>().join(" | ")
                    ));
                }
                continue;
            }
            let kinds: BTreeSet<&str> = defaults.iter().map(|r| kind(&r.read_as)).collect();
            for l in lookups.iter().filter(|l| &l.name == name && kinds.contains(l.kind)) {
                let Some(ours) = recorded(l) else { continue };
                if !theirs.iter().flatten().any(|t| same(t, &ours)) {
                    failures.push(format!(
                        "{function}: \"{name}\" defaults to {} here, {} in pbrt-v3",
                        l.default.as_deref().unwrap_or("?"),
                        defaults.iter().map(|r| r.default.as_str()).collect::<Vec<_>>().join(" | ")
                    ));
                }
                checked.1 += 1;
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("{} names read, {} defaults compared", checked.0, checked.1);
    assert!(
        failures.is_empty(),
        "{} mismatches with pbrt-v3:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
