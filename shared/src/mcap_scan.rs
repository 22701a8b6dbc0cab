//! Where an MCAP file stops being readable (feature `mcap`).
//!
//! A damaged record (a bad disk block, a hostile file) can declare any size;
//! a reader that believes it allocates what it declares and aborts the
//! process, or stops where the damage is and says nothing. [`scan`] walks
//! every record of the file by its framing (opcode, `u64` length: MCAP spec,
//! "Records") and checks each against the spec's layout of its fields: every
//! string, map and array length within its record. A chunk's header is
//! checked against the chunk (its compressed size within the record, an
//! uncompressed size within [`MAX_EXPANSION`] times the compressed one and at
//! most [`MAX_CHUNK_BYTES`]); the chunk is then decompressed into at most that
//! size, which it must fill exactly, its CRC checked when it has one, and the
//! records inside it walked the same way. Readers then read
//! `&bytes[..readable]`: everything before the damage, as for a file cut off.
//!
//! The data section's CRC, when the writer wrote one, is checked at the data
//! end record: damage in a record no other check covers (a message index)
//! shows there.
//!
//! The summary at the end of the file is checked on its own (its CRC, its
//! records, every chunk index pointing at a chunk the walk found whole), so
//! that a file damaged in the middle can still say how many messages it held
//! ([`Scan::message_count`]): what the damage cost.

use std::io::Read;

use mcap::records::op;

/// The most a chunk may declare to decompress to, bytes (writers use chunks
/// of about 1 MiB; `fusionctl record` of 768 KiB).
pub const MAX_CHUNK_BYTES: u64 = 1 << 28;

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
    /// Bytes from the damaged record to the end of the file: not read.
    pub lost_bytes: u64,
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
    /// Whether the summary section (after the data) is sound: its CRC (when
    /// written) holds, every record of it is, and every chunk index before the
    /// damage points at a whole chunk. Readers read it only when there is no
    /// damage.
    pub summary_sound: bool,
    /// The messages the file's statistics record counts, when its summary is
    /// sound (with damage in the data too: what a damaged file held).
    pub message_count: Option<u64>,
}

/// Scans `bytes` (an MCAP file, magic included).
pub fn scan(bytes: &[u8]) -> Scan {
    let mut chunks = Vec::new();
    let (readable, damage) = match walk_data(bytes, &mut chunks) {
        Ok(()) => (bytes.len(), None),
        Err((offset, what)) => {
            (offset, Some(Damage { offset: offset as u64, what, lost_bytes: (bytes.len() - offset) as u64 }))
        }
    };
    let summary = summary(bytes, &chunks, readable);
    // Whole data under a summary that fails its checks: the damage is the
    // summary's, and the data is read without it.
    if let (None, None, Some(start)) = (&damage, &summary, summary_start(bytes)) {
        let what = "its summary section (the index at the end of the file) does not match its CRC or is damaged: \
                    the data before it is whole, and is read without it";
        let damage = Damage { offset: start as u64, what: what.into(), lost_bytes: (bytes.len() - start) as u64 };
        return Scan { readable: start, damage: Some(damage), summary_sound: false, message_count: None };
    }
    Scan { readable, damage, summary_sound: summary.is_some(), message_count: summary.flatten() }
}

/// Where the footer of a whole file says its summary starts (`None`: no
/// footer, or no summary).
fn summary_start(bytes: &[u8]) -> Option<usize> {
    let footer_at = bytes.len().checked_sub(mcap::MAGIC.len() + 29)?;
    if !bytes.ends_with(mcap::MAGIC) || bytes[footer_at] != op::FOOTER {
        return None;
    }
    let start = u64::from_le_bytes(bytes[footer_at + 9..footer_at + 17].try_into().ok()?);
    usize::try_from(start).ok().filter(|&s| s > mcap::MAGIC.len() && s <= footer_at)
}

/// Walks the records from the magic to the footer (or the end of a file cut
/// off), noting each whole chunk's (offset, record length). `Err`: the damaged
/// record's offset and what is wrong.
fn walk_data(bytes: &[u8], chunks: &mut Vec<(u64, u64)>) -> Result<(), (usize, String)> {
    // The file ends with a footer and the magic: every record before it is whole.
    let complete = bytes.len() >= 2 * mcap::MAGIC.len() && bytes.ends_with(mcap::MAGIC);
    let mut at = mcap::MAGIC.len();
    while at < bytes.len() {
        if at == mcap::MAGIC.len() && bytes[at] != op::HEADER {
            let opcode = bytes[at];
            return Err((
                at,
                format!(
                    "no header record after the magic (opcode {opcode:#04x}): not an MCAP file, or damaged at its start"
                ),
            ));
        }
        let (opcode, body) = match frame(bytes, at) {
            Ok(f) => f,
            // A last record cut off: a recorder killed, not damage.
            Err(Framing::PastEnd(_)) if !complete => return Ok(()),
            Err(Framing::PastEnd(what) | Framing::Opcode(what)) => return Err((at, what)),
        };
        if opcode == op::FOOTER {
            // The end magic must follow the footer.
            let end = at + 9 + body.len();
            return match fields(opcode, body) {
                Ok(()) if bytes.get(end..) == Some(mcap::MAGIC) => Ok(()),
                Ok(()) => Err((at, "the footer is not followed by the end magic".into())),
                Err(what) => Err((at, what)),
            };
        }
        if opcode == op::DATA_END {
            check_data_crc(&bytes[..at], body).map_err(|what| (at, what))?;
        }
        let checked = if opcode == op::CHUNK { check_chunk(body) } else { fields(opcode, body) };
        checked.map_err(|what| (at, what))?;
        if opcode == op::CHUNK {
            chunks.push((at as u64, 9 + body.len() as u64));
        }
        at += 9 + body.len();
    }
    Ok(())
}

/// Why a record's framing is wrong.
enum Framing {
    /// It runs past the end of the bytes (of a file cut off, no damage).
    PastEnd(String),
    /// Its opcode is none of MCAP's.
    Opcode(String),
}

impl Framing {
    fn what(self) -> String {
        match self {
            Framing::PastEnd(w) | Framing::Opcode(w) => w,
        }
    }
}

/// Checks the data section (`data`: the file up to the data end record)
/// against the CRC in that record's `body`, when the writer wrote one: damage
/// in a record that holds no message (a message index) shows only there.
fn check_data_crc(data: &[u8], body: &[u8]) -> Result<(), String> {
    let crc = body.get(..4).map_or(0, |b| u32::from_le_bytes(b.try_into().unwrap_or_default()));
    if crc != 0 && crc32fast::hash(data) != crc {
        return Err("the data section does not match its CRC: a record before here is damaged (one the checks of \
                    the chunks and their records cannot see, as a message index)"
            .into());
    }
    Ok(())
}

/// The opcode and body of the record at `at`, its length within the file.
fn frame(bytes: &[u8], at: usize) -> Result<(u8, &[u8]), Framing> {
    let Some(&opcode) = bytes.get(at) else {
        return Err(Framing::PastEnd("a record's header runs past the end of the file".into()));
    };
    if opcode == 0 || opcode > op::DATA_END {
        return Err(Framing::Opcode(format!("no MCAP record has opcode {opcode:#04x}")));
    }
    let Some(frame) = bytes.get(at..at + 9) else {
        return Err(Framing::PastEnd("a record's header runs past the end of the file".into()));
    };
    let len = u64::from_le_bytes(frame[1..9].try_into().unwrap_or_default());
    let body = usize::try_from(len).ok().and_then(|n| bytes.get(at + 9..(at + 9).checked_add(n)?));
    body.map(|b| (opcode, b)).ok_or_else(|| {
        Framing::PastEnd(format!("record of opcode {opcode:#04x} declares {len} bytes, past the end of the file"))
    })
}

/// The summary section, checked apart from the data: `None` when it cannot
/// be believed (no footer, a CRC that fails, a damaged record, a chunk index
/// before `readable` that points at no whole chunk); else the statistics'
/// message count, if the summary has statistics.
fn summary(bytes: &[u8], chunks: &[(u64, u64)], readable: usize) -> Option<Option<u64>> {
    let footer_at = bytes.len().checked_sub(mcap::MAGIC.len() + 29)?;
    if !bytes.ends_with(mcap::MAGIC) || bytes[footer_at] != op::FOOTER {
        return None;
    }
    let footer = &bytes[footer_at + 9..footer_at + 29];
    let u64_at = |b: &[u8], i: usize| b.get(i..i + 8).map(|v| u64::from_le_bytes(v.try_into().unwrap_or_default()));
    let (start, crc) = (u64_at(footer, 0)? as usize, u32::from_le_bytes(footer[16..20].try_into().ok()?));
    if u64_at(&bytes[footer_at + 1..], 0)? != 20 || start == 0 || start > footer_at {
        return if start == 0 { Some(None) } else { None };
    }
    // The CRC covers the summary, then the footer up to the CRC.
    if crc != 0 && crc32fast::hash(&bytes[start..footer_at + 9 + 16]) != crc {
        return None;
    }
    let mut count = None;
    let mut at = start;
    while at < footer_at {
        let (opcode, body) = frame(bytes, at).ok()?;
        fields(opcode, body).ok()?;
        match opcode {
            op::STATISTICS => count = u64_at(body, 0),
            op::CHUNK_INDEX => {
                let (offset, length) = (u64_at(body, 16)?, u64_at(body, 24)?);
                // After damage nothing is read: only what comes before it must match.
                let before = offset < readable as u64;
                if before && chunks.binary_search(&(offset, length)).is_err() {
                    return None;
                }
            }
            op::HEADER | op::CHUNK | op::MESSAGE | op::DATA_END => return None,
            _ => {}
        }
        at += 9 + body.len();
    }
    (at == footer_at).then_some(count)
}

/// The fields of a record's body, as the MCAP spec lays them out.
#[derive(Clone, Copy)]
enum Field {
    U8,
    U16,
    U32,
    U64,
    /// `u32` length, UTF-8 bytes.
    Str,
    /// `u32` length, bytes.
    Bytes32,
    /// `u64` length, bytes.
    Bytes64,
    /// `u32` length, then pairs of strings.
    StrMap,
    /// `u32` length, then entries of this many bytes.
    Fixed(usize),
    /// The rest of the record.
    Rest,
}

/// The layout of each record but the chunk (MCAP spec, "Records").
fn layout(opcode: u8) -> &'static [Field] {
    use Field::*;
    match opcode {
        op::HEADER => &[Str, Str],
        op::FOOTER => &[U64, U64, U32],
        op::SCHEMA => &[U16, Str, Str, Bytes32],
        op::CHANNEL => &[U16, U16, Str, Str, StrMap],
        op::MESSAGE => &[U16, U32, U64, U64, Rest],
        op::MESSAGE_INDEX => &[U16, Fixed(16)],
        op::CHUNK_INDEX => &[U64, U64, U64, U64, Fixed(10), U64, Str, U64, U64],
        op::ATTACHMENT => &[U64, U64, Str, Str, Bytes64, U32],
        op::ATTACHMENT_INDEX => &[U64, U64, U64, U64, U64, Str, Str],
        op::STATISTICS => &[U64, U16, U32, U32, U32, U32, U64, U64, Fixed(10)],
        op::METADATA => &[Str, StrMap],
        op::METADATA_INDEX => &[U64, U64, Str],
        op::SUMMARY_OFFSET => &[U8, U64, U64],
        op::DATA_END => &[U32],
        _ => &[Rest],
    }
}

/// Checks a record's body against its layout: every length within the
/// record. Bytes after the last field are allowed (the spec lets records grow).
fn fields(opcode: u8, body: &[u8]) -> Result<(), String> {
    let name = |f: &str| format!("a record of opcode {opcode:#04x}: {f}");
    let mut rest = body;
    let mut take = |n: u64| -> Result<&[u8], String> {
        let n = usize::try_from(n)
            .ok()
            .filter(|&n| n <= rest.len())
            .ok_or_else(|| name(&format!("a field declares {n} bytes, {} left in the record", rest.len())))?;
        let (head, tail) = rest.split_at(n);
        rest = tail;
        Ok(head)
    };
    fn len32(b: &[u8]) -> u64 {
        u64::from(u32::from_le_bytes(b.try_into().unwrap_or_default()))
    }
    for field in layout(opcode) {
        match *field {
            Field::U8 => drop(take(1)?),
            Field::U16 => drop(take(2)?),
            Field::U32 => drop(take(4)?),
            Field::U64 => drop(take(8)?),
            Field::Str => {
                let n = len32(take(4)?);
                std::str::from_utf8(take(n)?).map_err(|_| name("a string that is not UTF-8"))?;
            }
            Field::Bytes32 => {
                let n = len32(take(4)?);
                take(n)?;
            }
            Field::Bytes64 => {
                let n = u64::from_le_bytes(take(8)?.try_into().unwrap_or_default());
                take(n)?;
            }
            Field::StrMap => {
                let n = len32(take(4)?);
                let mut map = take(n)?;
                while !map.is_empty() {
                    for _ in 0..2 {
                        let n = map.get(..4).map(len32).ok_or_else(|| name("a map entry cut off"))?;
                        let s = map.get(4..).and_then(|m| m.get(..usize::try_from(n).ok()?));
                        let s = s.ok_or_else(|| name(&format!("a map string of {n} bytes past its map")))?;
                        std::str::from_utf8(s).map_err(|_| name("a map string that is not UTF-8"))?;
                        map = &map[4 + s.len()..];
                    }
                }
            }
            Field::Fixed(size) => {
                let n = len32(take(4)?);
                if !n.is_multiple_of(size as u64) {
                    return Err(name(&format!("an array of {n} bytes, not of {size}-byte entries")));
                }
                take(n)?;
            }
            Field::Rest => return Ok(()),
        }
    }
    Ok(())
}

/// Checks a chunk record's body: its header against its own length, its data
/// decompressed into at most the declared size (and filling it), its CRC when
/// written, and the records inside it.
fn check_chunk(body: &[u8]) -> Result<(), String> {
    // message_start_time, message_end_time, uncompressed_size (u64 each),
    // uncompressed_crc (u32), compression (u32 length + bytes), compressed_size (u64).
    let u32_at = |i: usize| body.get(i..i + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()));
    let u64_at = |i: usize| body.get(i..i + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()));
    let (Some(uncompressed), Some(crc), Some(name_len)) = (u64_at(16), u32_at(24), u32_at(28)) else {
        return Err("a chunk too short for its header".into());
    };
    let name_end = 32usize.saturating_add(name_len as usize);
    let Some(name) = body.get(32..name_end) else {
        return Err(format!("a chunk's compression name declares {name_len} bytes, past the chunk"));
    };
    let Some(compressed) = u64_at(name_end) else { return Err("a chunk too short for its header".into()) };
    let data = &body[name_end + 8..];
    if compressed != data.len() as u64 {
        return Err(format!("a chunk declares {compressed} compressed bytes in a record of {}", data.len()));
    }
    let records = match name {
        b"" if uncompressed != compressed => {
            return Err(format!("an uncompressed chunk declares {uncompressed} bytes and holds {compressed}"));
        }
        b"" => std::borrow::Cow::Borrowed(data),
        b"zstd" | b"lz4"
            if uncompressed > MAX_CHUNK_BYTES || uncompressed > compressed.saturating_mul(MAX_EXPANSION) =>
        {
            return Err(format!("a chunk declares {uncompressed} bytes decompressed from {compressed}"));
        }
        b"zstd" | b"lz4" => std::borrow::Cow::Owned(decompress(name, data, uncompressed)?),
        other => {
            return Err(format!(
                "a chunk compressed with {:?}, which no MCAP reader knows",
                String::from_utf8_lossy(other)
            ));
        }
    };
    if crc != 0 && crc32fast::hash(&records) != crc {
        return Err("a chunk whose data does not match its CRC".into());
    }
    let mut at = 0;
    while at < records.len() {
        let (opcode, record) = frame(&records, at).map_err(|e| format!("in a chunk at byte {at}: {}", e.what()))?;
        if !matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE) {
            return Err(format!("in a chunk at byte {at}: a record of opcode {opcode:#04x}, which chunks do not hold"));
        }
        fields(opcode, record).map_err(|e| format!("in a chunk at byte {at}: {e}"))?;
        at += 9 + record.len();
    }
    Ok(())
}

/// A chunk's data decompressed: exactly `size` bytes, or why not.
fn decompress(compression: &[u8], data: &[u8], size: u64) -> Result<Vec<u8>, String> {
    let name = String::from_utf8_lossy(compression);
    let read = match compression {
        b"zstd" => zstd::stream::read::Decoder::with_buffer(data).and_then(|d| read_at_most(d, size, data.len())),
        _ => lz4::Decoder::new(data).and_then(|d| read_at_most(d, size, data.len())),
    };
    let out = read.map_err(|e| format!("a {name} chunk does not decompress: {e}"))?;
    if out.len() as u64 != size {
        return Err(format!("a {name} chunk declares {size} bytes and decompresses to {}", out.len()));
    }
    Ok(out)
}

/// Reads a decompressing `reader` to its end or to `limit + 1` bytes,
/// whichever comes first (more than `limit` says the data holds more than
/// it may), reserving up front no more than 8 times the `compressed` length:
/// a hostile size is never allocated before the data shows it.
pub(crate) fn read_at_most(reader: impl Read, limit: u64, compressed: usize) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::with_capacity((compressed as u64).saturating_mul(8).min(limit) as usize);
    reader.take(limit.saturating_add(1)).read_to_end(&mut out)?;
    Ok(out)
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
            let s = scan(&bytes);
            assert_eq!((s.readable, s.damage, s.summary_sound, s.message_count), (bytes.len(), None, true, Some(400)));
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
                let damage = s.damage.unwrap();
                assert_eq!((damage.offset, damage.lost_bytes), (at as u64, (bytes.len() - at) as u64));
                // The summary is whole: what the file held is known.
                assert_eq!(s.message_count, Some(400));
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

    /// Damage inside a chunk's data (a bit flipped, bytes overwritten), in
    /// its compressed or its plain records, is found by the chunk's CRC or
    /// its records' framing, wherever it is.
    #[test]
    fn damage_inside_a_chunk_is_found_at_that_chunk() {
        for c in [None, Some(mcap::Compression::Zstd), Some(mcap::Compression::Lz4)] {
            let clean = recording(c);
            let at = chunk_offset(&clean, 2);
            let summary = mcap::Summary::read(&clean).unwrap().unwrap();
            let index = summary.chunk_indexes.iter().find(|c| c.chunk_start_offset == at as u64).unwrap();
            let end = at + index.chunk_length as usize;
            for offset in [at + 80, (at + end) / 2, end - 3] {
                let mut flipped = clean.clone();
                flipped[offset] ^= 0x10;
                let s = scan(&flipped);
                assert_eq!(s.readable, at, "{c:?}, bit flipped at {}", offset - at);
                assert!(s.message_count.is_some());
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
        let s = scan(cut);
        assert_eq!((s.readable, s.damage, s.summary_sound), (cut.len(), None, false));
    }
}
