//! Floats as little-endian bytes, the order of every binary format the
//! farm writes (its wire messages, the dashboard's answers, tev's packets).

/// Appends `values` to `out` as little-endian f32: on a little-endian
/// host, one copy of their bytes.
#[inline]
pub fn extend_f32s(out: &mut Vec<u8>, values: &[f32]) {
    if cfg!(target_endian = "little") {
        out.extend_from_slice(bytemuck::cast_slice(values));
    } else {
        out.reserve(values.len() * 4);
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_written_little_endian() {
        let mut out = vec![7u8];
        extend_f32s(&mut out, &[1.0, -2.5, f32::MIN_POSITIVE]);
        let mut expected = vec![7u8];
        for v in [1.0f32, -2.5, f32::MIN_POSITIVE] {
            expected.extend_from_slice(&v.to_le_bytes());
        }
        assert_eq!(out, expected);
        assert_eq!(&out[1..5], &[0, 0, 0x80, 0x3f], "1.0, least significant byte first");
    }
}
