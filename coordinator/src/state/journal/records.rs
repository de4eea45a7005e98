//! The framing the journal's files share (tile logs, finished images): an
//! 8-byte magic, then records of payload length (u32 LE), CRC-32 of the
//! payload (u32 LE), payload = key (u32 LE) and the record's bytes.
//!
//! Reading stops at the first record that is short, too long to be one, or
//! fails its check: a write the process died in, or a corrupt file. What
//! came before it is read; what the caller does with the rest is its own
//! affair (a tile log cuts it off and goes on appending).

use std::io::{Read, Write};

/// Far more than any record (a tile is about 8 KB, an image event at most
/// a few MB): a longer length is a corrupt one, not allocated.
pub(super) const MAX_RECORD: u32 = 64 << 20;

/// Writes one record: `key` and `data`, framed; refuses `data` longer
/// than a record may be (it could not be read back).
pub(super) fn write(w: &mut impl Write, key: u32, data: &[u8]) -> std::io::Result<()> {
    write_parts(w, key, &[data])
}

/// [`write`] of the record whose bytes are `parts` one after the other,
/// without joining them first.
pub(super) fn write_parts(w: &mut impl Write, key: u32, parts: &[&[u8]]) -> std::io::Result<()> {
    let len = parts
        .iter()
        .try_fold(4u32, |n, p| u32::try_from(p.len()).ok().and_then(|l| n.checked_add(l)))
        .filter(|&len| len <= MAX_RECORD)
        .ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "a record too long to be read back",
            )
        })?;
    let mut crc = crc32fast::Hasher::new();
    crc.update(&key.to_le_bytes());
    for p in parts {
        crc.update(p);
    }
    let head = [len.to_le_bytes(), crc.finalize().to_le_bytes(), key.to_le_bytes()];
    w.write_all(head.as_flattened())?;
    for p in parts {
        w.write_all(p)?;
    }
    Ok(())
}

/// What [`read`] found.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Found {
    /// The file does not start with the magic.
    NotOurs,
    /// The records, in order; `complete` when the file ends after the
    /// last one, `end` its offset.
    Records { records: Vec<(u32, Vec<u8>)>, end: u64, complete: bool },
}

/// Reads every whole record of a file that starts with `magic`, one
/// allocation a record (never more than the record's length, which the
/// file's own size bounds).
pub(super) fn read(r: &mut impl Read, magic: &[u8; 8], size: u64) -> std::io::Result<Found> {
    let mut head = [0u8; 8];
    if read_full(r, &mut head)? < 8 || &head != magic {
        return Ok(Found::NotOurs);
    }
    let (mut records, mut end) = (Vec::new(), 8u64);
    loop {
        let mut frame = [0u8; 8];
        let got = read_full(r, &mut frame)?;
        if got == 0 {
            return Ok(Found::Records { records, end, complete: true });
        }
        let word =
            |i: usize| u32::from_le_bytes([frame[i], frame[i + 1], frame[i + 2], frame[i + 3]]);
        let (len, crc) = (word(0), word(4));
        if got < 8 || !(4..=MAX_RECORD).contains(&len) || end + 8 + u64::from(len) > size {
            return Ok(Found::Records { records, end, complete: false });
        }
        let mut key = [0u8; 4];
        let mut payload = vec![0u8; len as usize - 4];
        let whole = read_full(r, &mut key)? == 4 && read_full(r, &mut payload)? == payload.len();
        let mut check = crc32fast::Hasher::new();
        check.update(&key);
        check.update(&payload);
        if !whole || check.finalize() != crc {
            return Ok(Found::Records { records, end, complete: false });
        }
        records.push((u32::from_le_bytes(key), payload));
        end += 8 + u64::from(len);
    }
}

/// Reads until `buf` is full or the input ends; how many bytes it read.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut at = 0;
    while at < buf.len() {
        match r.read(&mut buf[at..]) {
            Ok(0) => break,
            Ok(n) => at += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(at)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAGIC: &[u8; 8] = b"FARMTEST";

    fn file(records: &[(u32, &[u8])]) -> Vec<u8> {
        let mut bytes = MAGIC.to_vec();
        for (k, d) in records {
            write(&mut bytes, *k, d).unwrap();
        }
        bytes
    }

    fn read_all(bytes: &[u8]) -> Found {
        read(&mut &bytes[..], MAGIC, bytes.len() as u64).unwrap()
    }

    #[test]
    fn records_read_back_in_order_and_a_bad_tail_is_told_apart() {
        let bytes = file(&[(3, b"three"), (1, b""), (3, &[9; 1000])]);
        let whole = Found::Records {
            records: vec![(3, b"three".to_vec()), (1, vec![]), (3, vec![9; 1000])],
            end: bytes.len() as u64,
            complete: true,
        };
        assert_eq!(read_all(&bytes), whole);
        // Cut anywhere inside the last record: the first two are read.
        let two = 8 + (12 + 5) + 12;
        for cut in [two + 1, two + 8, bytes.len() - 1] {
            let want = Found::Records {
                records: vec![(3, b"three".to_vec()), (1, vec![])],
                end: two as u64,
                complete: false,
            };
            assert_eq!(read_all(&bytes[..cut]), want, "cut at {cut}");
        }
        // A flipped bit fails the check of its record.
        let mut flipped = bytes.clone();
        flipped[8 + 12 + 2] ^= 4;
        assert_eq!(read_all(&flipped), Found::Records { records: vec![], end: 8, complete: false });
        assert_eq!(read_all(b"FARMTES"), Found::NotOurs);
        assert_eq!(read_all(b"NOTFARM!rest"), Found::NotOurs);
    }

    #[test]
    fn a_record_too_long_to_read_back_is_not_written() {
        let mut bytes = Vec::new();
        let long = vec![0u8; MAX_RECORD as usize - 3];
        let e = write(&mut bytes, 1, &long).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(bytes.is_empty(), "nothing written");
        write(&mut bytes, 1, &long[1..]).unwrap();
        assert_eq!(bytes.len(), 12 + long.len() - 1);
    }

    #[test]
    fn a_length_past_the_file_or_the_limit_is_not_allocated() {
        for len in [u32::MAX, MAX_RECORD + 1, 1 << 20] {
            let mut bytes = MAGIC.to_vec();
            bytes.extend(len.to_le_bytes());
            bytes.extend([0; 12]);
            assert_eq!(
                read_all(&bytes),
                Found::Records { records: vec![], end: 8, complete: false },
                "{len}"
            );
        }
    }
}
