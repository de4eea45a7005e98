//! Tests of the PLY reader.

use super::*;

const ASCII: &str = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n\
element face 2\nproperty list uchar int vertex_indices\nelement edge 1\nproperty int a\nend_header\n\
0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n3 0 2 1\n7\n";

#[test]
fn ascii_with_normals_uv_and_quads() {
    let m = parse(ASCII.as_bytes()).unwrap();
    assert_eq!(m.p.len(), 4);
    assert_eq!(m.p[2], [1.0, 1.0, 0.0]);
    assert_eq!(m.n.as_ref().unwrap()[3], [0.0, 0.0, 1.0]);
    assert_eq!(m.uv.as_ref().unwrap()[1], [1.0, 0.0]);
    assert_eq!(m.indices, vec![0, 1, 2, 3, 0, 2, 0, 2, 1]);
}

fn binary(big: bool, faces: &[&[u32]], truncate: usize) -> Vec<u8> {
    let fmt = if big { "binary_big_endian" } else { "binary_little_endian" };
    let mut d = format!(
        "ply\nformat {fmt} 1.0\nelement vertex 3\nproperty double x\nproperty float y\nproperty float z\n\
property uchar flags\nelement face {}\nproperty uchar junk\nproperty list ushort uint vertex_index\nend_header\n",
        faces.len()
    )
    .into_bytes();
    for i in 0..3 {
        let x = i as f64;
        d.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
        for v in [2.0f32 * i as f32, -1.0] {
            d.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
        d.push(9);
    }
    for f in faces {
        d.push(0);
        let n = f.len() as u16;
        d.extend(if big { n.to_be_bytes() } else { n.to_le_bytes() });
        for &v in *f {
            d.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
    }
    d.truncate(d.len() - truncate);
    d
}

#[test]
fn binary_both_endians() {
    for big in [false, true] {
        let m = parse(&binary(big, &[&[0, 1, 2], &[2, 1, 0, 1, 2]], 0)).unwrap();
        assert_eq!(m.p, vec![[0.0, 0.0, -1.0], [1.0, 2.0, -1.0], [2.0, 4.0, -1.0]]);
        assert_eq!(m.indices, vec![0, 1, 2]);
        assert_eq!(m.warnings.len(), 1);
        assert!(m.n.is_none() && m.uv.is_none());
    }
}

#[test]
fn truncated_and_malformed_are_errors() {
    let e = parse(&binary(false, &[&[0, 1, 2]], 2)).unwrap_err();
    assert!(e.0.contains("truncated"), "{e}");
    let e = parse(&binary(false, &[&[0, 1, 7]], 0)).unwrap_err();
    assert!(e.0.contains("out of bounds"), "{e}");
    assert!(parse(b"ply\nformat ascii 1.0\n").is_err());
    assert!(parse(b"PLY\n").is_err());
    assert!(parse(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n")
        .is_err());
}

#[test]
fn counts_beyond_the_file_are_refused_before_allocating() {
    let head = |fmt: &str, n: &str| {
        format!(
            "ply\nformat {fmt} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    for fmt in ["ascii", "binary_little_endian"] {
        for n in ["2147483648", "4611686018427387904", "18446744073709551615"] {
            let mut d = head(fmt, n).into_bytes();
            d.extend([0u8; 64]);
            let e = parse(&d).unwrap_err();
            assert!(e.0.contains(&format!("declares {n} items")), "{e}");
            assert!(e.0.contains("only 64 bytes follow the header"), "{e}");
        }
    }
    // An element without properties costs nothing, whatever its count.
    let d = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nelement nothing 18446744073709551615\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2";
    assert_eq!(parse(d.as_bytes()).unwrap().indices, vec![0, 1, 2]);
}

/// A mesh in the layout exporters write (float positions, normals and
/// texture coordinates; faces of a byte count and 32-bit indices), which
/// little-endian files read a record at a time.
/// With `tagged`, an element of one list of ten numbers comes first, so
/// that a file cut short in its vertices passes the count check (which
/// counts a list as its length alone).
fn common_layout(
    big: bool,
    signed: bool,
    faces: &[Vec<i64>],
    truncate: usize,
    tagged: bool,
) -> Vec<u8> {
    let fmt = if big { "binary_big_endian" } else { "binary_little_endian" };
    let index = if signed { "int" } else { "uint" };
    let tag = if tagged { "element tag 1\nproperty list uchar int values\n" } else { "" };
    let mut d = format!(
        "ply\nformat {fmt} 1.0\n{tag}element vertex 5\nproperty float x\nproperty float y\n\
property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\n\
property float v\nelement face {}\nproperty list uchar {index} vertex_indices\nend_header\n",
        faces.len()
    )
    .into_bytes();
    if tagged {
        d.push(10);
        for k in 0..10i32 {
            d.extend(if big { k.to_be_bytes() } else { k.to_le_bytes() });
        }
    }
    for i in 0..5 {
        for k in 0..8 {
            let v = [1.5f32, -0.0, f32::NAN, 1e-40, 3.25e7][(i + k) % 5] * (k + 1) as f32;
            d.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
    }
    for f in faces {
        d.push(f.len() as u8);
        for &v in f {
            let v = v as u32;
            d.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
    }
    d.truncate(d.len() - truncate);
    d
}

/// The record-at-a-time reading of little-endian files gives what the
/// general reader gives for the same numbers big-endian: the same mesh,
/// warnings and errors, for triangles, quads, other polygons, indices out
/// of range either way, and files cut short in a triangle or in the
/// vertices.
#[test]
fn the_common_layout_reads_as_the_general_reader_does() {
    let good: Vec<Vec<i64>> =
        vec![vec![0, 1, 2], vec![4, 3, 2, 1], vec![0, 1, 2, 3, 4], vec![2, 4], vec![3, 4, 0]];
    let big_index = vec![vec![1i64 << 31 | 1, 1, 2]];
    let cases: Vec<(Vec<Vec<i64>>, usize, bool)> = vec![
        (good.clone(), 0, false),
        ([good.clone(), vec![vec![0, 5, 1]]].concat(), 0, false),
        ([good.clone(), vec![vec![0, 1, 2, -1]]].concat(), 0, false),
        ([good.clone(), big_index].concat(), 0, false),
        // Cut in the last triangle.
        (good.clone(), 3, false),
        (good.clone(), 0, true),
        // Cut in the vertices: 20 bytes short of them, faces and all.
        (good.clone(), 20 + 13 + 17 + 21 + 9 + 13, true),
    ];
    for signed in [true, false] {
        for (faces, cut, tagged) in &cases {
            let little = parse(&common_layout(false, signed, faces, *cut, *tagged));
            let big = parse(&common_layout(true, signed, faces, *cut, *tagged));
            // NaN positions compare unequal: compare the printed meshes.
            assert_eq!(format!("{little:?}"), format!("{big:?}"), "faces {faces:?}, cut {cut}");
            if *cut > 0 {
                let e = little.unwrap_err();
                let place = if *tagged { "\"vertex\"" } else { "\"face\" item 4" };
                assert!(e.0.contains("truncated") && e.0.contains(place), "{e}");
            }
        }
    }
    let m = parse(&common_layout(false, true, &good, 0, false)).unwrap();
    assert_eq!(m.indices, vec![0, 1, 2, 4, 3, 2, 1, 4, 2, 3, 4, 0]);
    let p = m.p[0];
    assert!(p[0] == 1.5 && p[1].to_bits() == (-0.0f32).to_bits() && p[2].is_nan());
    assert_eq!(m.n.as_ref().unwrap()[0], [1e-40 * 4.0, 3.25e7 * 5.0, 1.5 * 6.0]);
    assert_eq!(m.uv.as_ref().unwrap()[2], [1e-40 * 7.0, 3.25e7 * 8.0]);
    assert!(!m.warnings.is_empty());
}
