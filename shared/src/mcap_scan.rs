//! Where an MCAP file stops being readable (feature `mcap`).
//!
//! A damaged chunk header (a bad disk block, a hostile file) can declare any
//! size; a reader that believes it allocates what it declares and aborts the
//! process. [`scan`] walks the file's records by their framing (opcode, `u64`
//! length: MCAP spec, "Records") without decompressing anything, and checks each
//! chunk's header against the file: its compression string, its compressed
//! size within the record, an uncompressed size within
//! [`MAX_EXPANSION`] times the compressed one (and at most [`MAX_CHUNK_BYTES`]),
//! and for an uncompressed chunk both sizes equal. Readers then read
//! `&bytes[..readable]`: everything before the damage, as for a file cut off.

use mcap::records::op;

/// The most a chunk may declare to decompress to, bytes (writers use chunks
/// of about 1 MiB; `fusionctl record` of 768 KiB).
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// The most a chunk may declare to expand on decompression (zstd and lz4 on
/// the JSON of a recording expand by 3 to 30 times).
pub const MAX_EXPANSION: u64 = 4096;

/// The damage [`scan`] found.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("damaged at byte {offset}: {what}")]
pub struct Damage {
    /// Offset of the damaged record in the file.
    pub offset: u64,
    /// What is wrong with it.
    pub what: String,
}

/// What [`scan`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scan {
    /// How many bytes from the start are readable: up to the damaged record,
    /// or the whole file.
    pub readable: usize,
    /// The damage, if any. A last record cut off by the end of the file (a
    /// recorder killed) is no damage: the readers say the file was cut off.
    pub damage: Option<Damage>,
}

/// Scans `bytes` (an MCAP file, magic included).
pub fn scan(bytes: &[u8]) -> Scan {
    let whole = Scan { readable: bytes.len(), damage: None };
    let damaged =
        |offset: usize, what: String| Scan { readable: offset, damage: Some(Damage { offset: offset as u64, what }) };
    // The file ends with a footer and the magic: every record before it is whole.
    let complete = bytes.len() >= 2 * mcap::MAGIC.len() && bytes.ends_with(mcap::MAGIC);
    let mut at = mcap::MAGIC.len();
    while at < bytes.len() {
        let Some(frame) = bytes.get(at..at + 9) else {
            return if complete {
                damaged(at, "a record's header runs past the end of the file".into())
            } else {
                whole
            };
        };
        let opcode = frame[0];
        if at == mcap::MAGIC.len() && opcode != op::HEADER {
            return damaged(
                at,
                format!(
                    "no header record after the magic (opcode {opcode:#04x}): not an MCAP file, or damaged at its start"
                ),
            );
        }
        if opcode == 0 || opcode > 0x0F {
            return damaged(at, format!("no MCAP record has opcode {opcode:#04x}"));
        }
        let len = u64::from_le_bytes(frame[1..9].try_into().unwrap_or_default());
        let body_start = at + 9;
        let Some(body) = usize::try_from(len).ok().and_then(|n| bytes.get(body_start..body_start.checked_add(n)?))
        else {
            return if complete {
                damaged(at, format!("record of opcode {opcode:#04x} declares {len} bytes, past the end of the file"))
            } else {
                whole
            };
        };
        match opcode {
            op::FOOTER => return whole,
            op::CHUNK => {
                if let Err(what) = check_chunk(body) {
                    return damaged(at, what);
                }
            }
            _ => {}
        }
        at = body_start + body.len();
    }
    whole
}

/// Checks a chunk record's body (its header against its own length).
fn check_chunk(body: &[u8]) -> Result<(), String> {
    // message_start_time, message_end_time, uncompressed_size (u64 each),
    // uncompressed_crc (u32), compression (u32 length + bytes), compressed_size (u64).
    let u32_at = |i: usize| body.get(i..i + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()));
    let u64_at = |i: usize| body.get(i..i + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()));
    let (Some(uncompressed), Some(name_len)) = (u64_at(16), u32_at(28)) else {
        return Err("a chunk too short for its header".into());
    };
    let name_end = 32usize.saturating_add(name_len as usize);
    let Some(name) = body.get(32..name_end) else {
        return Err(format!("a chunk's compression name declares {name_len} bytes, past the chunk"));
    };
    let Some(compressed) = u64_at(name_end) else { return Err("a chunk too short for its header".into()) };
    let data = (body.len() - name_end - 8) as u64;
    if compressed > data {
        return Err(format!("a chunk declares {compressed} compressed bytes in a record of {data}"));
    }
    match name {
        b"" if uncompressed != compressed => {
            Err(format!("an uncompressed chunk declares {uncompressed} bytes and holds {compressed}"))
        }
        b"" => Ok(()),
        b"zstd" | b"lz4"
            if uncompressed > MAX_CHUNK_BYTES || uncompressed > compressed.saturating_mul(MAX_EXPANSION) =>
        {
            Err(format!("a chunk declares {uncompressed} bytes decompressed from {compressed}"))
        }
        b"zstd" | b"lz4" => Ok(()),
        other => {
            Err(format!("a chunk compressed with {:?}, which no MCAP reader knows", String::from_utf8_lossy(other)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recording(compression: Option<mcap::Compression>) -> Vec<u8> {
        let mut out = std::io::Cursor::new(Vec::new());
        let options = mcap::WriteOptions::new().compression(compression).chunk_size(Some(4096));
        let mut w = options.create(&mut out).unwrap();
        let channel = w.add_channel(0, "/t", "json", &Default::default()).unwrap();
        for i in 0..400u64 {
            let data = format!("{{\"i\": {i}, \"x\": {}}}", i as f64 / 7.0);
            let header =
                mcap::records::MessageHeader { channel_id: channel, sequence: i as u32, log_time: i, publish_time: i };
            w.write_to_known_channel(&header, data.as_bytes()).unwrap();
        }
        w.finish().unwrap();
        drop(w);
        out.into_inner()
    }

    /// The offset of the `n`-th chunk record.
    fn chunk_offset(bytes: &[u8], n: usize) -> usize {
        let summary = mcap::Summary::read(bytes).unwrap().unwrap();
        let mut offsets: Vec<u64> = summary.chunk_indexes.iter().map(|c| c.chunk_start_offset).collect();
        offsets.sort();
        offsets[n] as usize
    }

    #[test]
    fn a_whole_file_is_readable_to_its_end() {
        for c in [None, Some(mcap::Compression::Zstd)] {
            let bytes = recording(c);
            assert_eq!(scan(&bytes), Scan { readable: bytes.len(), damage: None });
        }
    }

    #[test]
    fn a_damaged_chunk_header_ends_the_readable_part_there() {
        for c in [None, Some(mcap::Compression::Zstd)] {
            let clean = recording(c);
            let at = chunk_offset(&clean, 2);
            // Over the record length, the sizes, the compression name.
            for start in [at + 1, at + 9 + 16, at + 9 + 24, at + 9 + 36] {
                let mut bytes = clean.clone();
                bytes[start..start + 16].fill(0xff);
                let s = scan(&bytes);
                assert_eq!(s.readable, at, "{c:?} at {}", start - at);
                assert_eq!(s.damage.unwrap().offset, at as u64);
                // What is before the damage reads, as a cut-off file.
                let read: Vec<_> = mcap::MessageStream::new_with_options(
                    &bytes[..s.readable],
                    mcap::read::Options::IgnoreEndMagic.into(),
                )
                .unwrap()
                .map_while(Result::ok)
                .collect();
                assert!(!read.is_empty());
            }
        }
    }

    #[test]
    fn magic_and_garbage_is_damaged_at_its_start() {
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.extend_from_slice(b"this is no recording at all, only text");
        let s = scan(&bytes);
        assert_eq!(s.readable, 8);
        assert!(s.damage.unwrap().what.contains("no header record"));
    }

    #[test]
    fn a_file_cut_off_is_not_damaged() {
        let bytes = recording(Some(mcap::Compression::Zstd));
        let at = chunk_offset(&bytes, 3);
        let cut = &bytes[..at + 100];
        assert_eq!(scan(cut), Scan { readable: cut.len(), damage: None });
    }
}
