//! A ROS 1 bag's chunk section, read with every size it declares checked
//! against the file and a limit before anything is allocated.
//!
//! The format (ROS wiki, "Bags/Format/2.0"): after the magic, records of
//! `header_len: u32`, a header of fields (`len: u32`, `name=value`),
//! `data_len: u32` and the data, all little-endian. The chunk section holds
//! chunk records (op `0x05`: `compression` = `none`, `lz4` or `bz2`, `size` =
//! the decompressed length) and index data records (op `0x04`); a chunk's data
//! holds connection records (op `0x07`) and message data records (op `0x02`).
//!
//! The `rosbag` crate believes a chunk's `size` (it reserves it before
//! decompressing, and an lz4 chunk may decompress past it): a damaged or
//! hostile bag aborted the process. Here a chunk decompresses into at most
//! its declared size, which is at most [`MAX_CHUNK_BYTES`], and must fill it
//! exactly.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use super::{BagError, BagItem, ROS1_MAGIC, Reading, Ros1};
use crate::mcap_scan::{MAX_CHUNK_BYTES, read_at_most};

/// One record: its header fields and its data.
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    /// The header's fields, unparsed.
    pub header: &'a [u8],
    /// The data.
    pub data: &'a [u8],
}

/// Record opcodes (the header field `op`).
pub mod op {
    /// Message data.
    pub const MESSAGE_DATA: u8 = 0x02;
    /// Index data.
    pub const INDEX_DATA: u8 = 0x04;
    /// Chunk.
    pub const CHUNK: u8 = 0x05;
    /// Connection.
    pub const CONNECTION: u8 = 0x07;
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at.checked_add(4)?)?.try_into().ok()?))
}

/// The record at `*at` in `bytes`; moves `*at` past it.
pub fn next_record<'a>(bytes: &'a [u8], at: &mut usize) -> Result<Record<'a>, String> {
    let start = *at;
    let header_len = u32_at(bytes, start).ok_or("a record's header length runs past the end")? as usize;
    let header = start
        .checked_add(4)
        .and_then(|h| bytes.get(h..h.checked_add(header_len)?))
        .ok_or_else(|| format!("a record declares a header of {header_len} bytes, past the end"))?;
    let data_at = start + 4 + header_len;
    let data_len = u32_at(bytes, data_at).ok_or("a record's data length runs past the end")? as usize;
    let data = bytes
        .get(data_at + 4..(data_at + 4).checked_add(data_len).ok_or("a record's data length overflows")?)
        .ok_or_else(|| format!("a record declares {data_len} bytes of data, past the end"))?;
    *at = data_at + 4 + data_len;
    Ok(Record { header, data })
}

/// The value of field `name` in a list of fields (a record's header, or a
/// connection's data), each length checked.
pub fn field<'a>(mut fields: &'a [u8], name: &str) -> Result<Option<&'a [u8]>, String> {
    while !fields.is_empty() {
        let n = u32_at(fields, 0).ok_or("a header field's length is cut off")? as usize;
        let f = fields
            .get(4..4usize.saturating_add(n))
            .ok_or_else(|| format!("a header field of {n} bytes runs past its header"))?;
        if let Some(v) = f.strip_prefix(name.as_bytes()).and_then(|v| v.strip_prefix(b"=")) {
            return Ok(Some(v));
        }
        fields = &fields[4 + n..];
    }
    Ok(None)
}

/// Field `name` of `fields`, required.
pub fn required<'a>(fields: &'a [u8], name: &str) -> Result<&'a [u8], String> {
    field(fields, name)?.ok_or_else(|| format!("a record without its {name:?} field"))
}

/// Field `name` as a little-endian `u32`.
pub fn field_u32(fields: &[u8], name: &str) -> Result<u32, String> {
    let v = required(fields, name)?;
    Ok(u32::from_le_bytes(v.try_into().map_err(|_| format!("field {name:?} is {} bytes, not 4", v.len()))?))
}

/// A record's opcode.
pub fn op_of(record: &Record<'_>) -> Result<u8, String> {
    match required(record.header, "op")? {
        [op] => Ok(*op),
        v => Err(format!("an op field of {} bytes", v.len())),
    }
}

/// A chunk record's messages and connections, decompressed: at most its
/// declared `size` bytes (itself at most [`MAX_CHUNK_BYTES`]), and exactly that.
pub fn chunk_data<'a>(chunk: &Record<'a>) -> Result<Cow<'a, [u8]>, String> {
    let compression = required(chunk.header, "compression")?;
    let size = u64::from(field_u32(chunk.header, "size")?);
    if size > MAX_CHUNK_BYTES {
        return Err(format!("a chunk declares {size} bytes decompressed, more than {MAX_CHUNK_BYTES}"));
    }
    let data = chunk.data;
    let out: Vec<u8> = match compression {
        b"none" if data.len() as u64 == size => return Ok(Cow::Borrowed(data)),
        b"none" => return Err(format!("an uncompressed chunk declares {size} bytes and holds {}", data.len())),
        b"lz4" => {
            let decoder = lz4::Decoder::new(data).map_err(|e| format!("an lz4 chunk does not decompress: {e}"))?;
            read_at_most(decoder, size, data.len()).map_err(|e| format!("an lz4 chunk does not decompress: {e}"))?
        }
        b"bz2" => read_at_most(bzip2::read::BzDecoder::new(data), size, data.len())
            .map_err(|e| format!("a bz2 chunk does not decompress: {e}"))?,
        other => {
            return Err(format!(
                "a chunk compressed with {:?}, which ROS 1 bags do not use (none, lz4 or bz2)",
                String::from_utf8_lossy(other)
            ));
        }
    };
    if out.len() as u64 != size {
        return Err(format!(
            "a chunk declares {size} bytes and decompresses to {}{}",
            out.len(),
            if out.len() as u64 > size { " or more" } else { "" }
        ));
    }
    Ok(Cow::Owned(out))
}

/// The `index_pos` of a ROS 1 bag's header record, checked against the file
/// (the `rosbag` crate takes it on trust).
fn ros1_index_pos(bytes: &[u8]) -> Result<u64, BagError> {
    let bad = || BagError::Format("its bag header record is damaged".into());
    let at = ROS1_MAGIC.len();
    let len = bytes.get(at..at + 4).ok_or_else(bad)?;
    let len = u32::from_le_bytes(len.try_into().map_err(|_| bad())?) as usize;
    let mut fields = bytes.get(at + 4..at + 4 + len).ok_or_else(bad)?;
    while fields.len() >= 4 {
        let n = u32::from_le_bytes(fields[..4].try_into().map_err(|_| bad())?) as usize;
        let field = fields.get(4..4 + n).ok_or_else(bad)?;
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            let pos = u64::from_le_bytes(v.try_into().map_err(|_| bad())?);
            let end = bytes.len() as u64;
            if pos == 0 {
                return Err(BagError::Format(
                    "it has no index (its recording was cut off): `rosbag reindex` repairs it".into(),
                ));
            }
            if pos > end || pos < (at + 4 + len) as u64 {
                return Err(BagError::Format(format!(
                    "it is truncated: its index is at byte {pos} of a file of {end} bytes (`rosbag reindex` \
                     repairs a bag whose recording was cut off)"
                )));
            }
            return Ok(pos);
        }
        fields = &fields[4 + n..];
    }
    Err(bad())
}

/// Reads the ROS 1 bag `bytes` (at `path`): the index's connections (checked
/// against the topic map), then every chunk's messages, up to any damage.
pub(super) fn read<F: FnMut(BagItem)>(path: &Path, bytes: &[u8], r: &mut Reading<'_, F>) -> Result<(), BagError> {
    use rosbag::{IndexRecord, RosBag};
    let index_pos = ros1_index_pos(bytes)? as usize;
    let bag = RosBag::new(path)?;
    // The index lists every connection: the topic map is checked before a message is read.
    for record in bag.index_records() {
        match record {
            Ok(IndexRecord::Connection(c)) => r.topic(c.topic, c.tp)?,
            Ok(_) => {}
            Err(e) => return Err(BagError::Format(format!("its index is damaged: {e}"))),
        }
    }
    // The chunk section: from the bag header record to the index.
    let mut at = ROS1_MAGIC.len();
    next_record(bytes, &mut at).map_err(|e| BagError::Format(format!("its bag header record is damaged: {e}")))?;
    let section = &bytes[..index_pos];
    let mut connections: BTreeMap<u32, String> = BTreeMap::new();
    while at < section.len() {
        let offset = at;
        if let Err(what) = ros1_record(section, &mut at, &mut connections, r)? {
            r.t.summary.damage = Some(format!("at byte {offset} (after message {}): {what}", r.t.position));
            return Ok(());
        }
    }
    Ok(())
}

/// The record of the chunk section at `*at`: a chunk's messages read, index
/// data skipped. `Err` when a topic does not fit the topic map, `Ok(Err)`
/// where the bag is damaged.
fn ros1_record<F: FnMut(BagItem)>(
    section: &[u8],
    at: &mut usize,
    connections: &mut BTreeMap<u32, String>,
    r: &mut Reading<'_, F>,
) -> Result<Result<(), String>, BagError> {
    let chunk = match next_record(section, at).and_then(|c| Ok((op_of(&c)?, c))) {
        Ok((op::CHUNK, chunk)) => chunk,
        Ok((op::INDEX_DATA, _)) => return Ok(Ok(())),
        Ok((op, _)) => return Ok(Err(format!("a record of op {op:#04x} in the chunk section"))),
        Err(e) => return Ok(Err(e)),
    };
    match chunk_data(&chunk) {
        Ok(data) => Ok(ros1_chunk(&data, connections, r)?.map_err(|e| format!("in a chunk: {e}"))),
        Err(e) => Ok(Err(e)),
    }
}

/// The connections and messages of a decompressed ROS 1 chunk: `Err` when a
/// topic does not fit the topic map, `Ok(Err)` where the chunk is damaged.
fn ros1_chunk<F: FnMut(BagItem)>(
    data: &[u8],
    connections: &mut BTreeMap<u32, String>,
    r: &mut Reading<'_, F>,
) -> Result<Result<(), String>, BagError> {
    let mut at = 0;
    while at < data.len() {
        let record = match next_record(data, &mut at).and_then(|m| Ok((op_of(&m)?, m))) {
            Ok(record) => record,
            Err(e) => return Ok(Err(e)),
        };
        match record {
            (op::CONNECTION, c) => {
                let connection = field_u32(c.header, "conn").and_then(|id| {
                    let topic = required(c.header, "topic")?;
                    Ok((id, String::from_utf8_lossy(topic).into_owned(), required(c.data, "type")?))
                });
                let (id, topic, ty) = match connection {
                    Ok(c) => c,
                    Err(e) => return Ok(Err(e)),
                };
                r.topic(&topic, &String::from_utf8_lossy(ty))?;
                connections.insert(id, topic);
            }
            (op::MESSAGE_DATA, m) => {
                let topic = match field_u32(m.header, "conn") {
                    Ok(id) => connections
                        .get(&id)
                        .ok_or_else(|| format!("message {} is of an unknown connection {id}", r.t.position + 1)),
                    Err(e) => Err(e),
                };
                match topic {
                    Ok(topic) => r.message::<Ros1>(topic, m.data),
                    Err(e) => return Ok(Err(e)),
                }
            }
            (op, _) => return Ok(Err(format!("a record of op {op:#04x}"))),
        }
    }
    Ok(Ok(()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_bytes(name: &str, value: &[u8]) -> Vec<u8> {
        let mut f = ((name.len() + 1 + value.len()) as u32).to_le_bytes().to_vec();
        f.extend_from_slice(name.as_bytes());
        f.push(b'=');
        f.extend_from_slice(value);
        f
    }

    fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
        let header: Vec<u8> = fields.iter().flat_map(|(n, v)| field_bytes(n, v)).collect();
        let mut r = (header.len() as u32).to_le_bytes().to_vec();
        r.extend_from_slice(&header);
        r.extend_from_slice(&(data.len() as u32).to_le_bytes());
        r.extend_from_slice(data);
        r
    }

    #[test]
    fn a_chunk_that_declares_more_than_the_limit_is_refused_before_decompressing() {
        let bytes = record(&[("op", &[op::CHUNK]), ("compression", b"lz4"), ("size", &u32::MAX.to_le_bytes())], b"x");
        let r = next_record(&bytes, &mut 0).unwrap();
        let e = chunk_data(&r).unwrap_err();
        assert!(e.contains("4294967295 bytes decompressed"), "{e}");
    }

    #[test]
    fn a_chunk_decompresses_to_exactly_its_size() {
        let payload = vec![7u8; 10_000];
        let mut compressed = Vec::new();
        {
            let mut enc = lz4::EncoderBuilder::new().build(&mut compressed).unwrap();
            std::io::Write::write_all(&mut enc, &payload).unwrap();
            enc.finish().1.unwrap();
        }
        for (size, ok) in [(10_000u32, true), (9_999, false), (10_001, false)] {
            let bytes =
                record(&[("op", &[op::CHUNK]), ("compression", b"lz4"), ("size", &size.to_le_bytes())], &compressed);
            let r = next_record(&bytes, &mut 0).unwrap();
            assert_eq!(chunk_data(&r).is_ok(), ok, "{size}");
        }
        let zip = record(&[("compression", b"zip"), ("size", &[0; 4])], b"");
        let e = chunk_data(&next_record(&zip, &mut 0).unwrap()).unwrap_err();
        assert!(e.contains("\"zip\""), "{e}");
    }

    #[test]
    fn lengths_past_the_end_are_named_not_believed() {
        let mut bytes = record(&[("op", &[op::MESSAGE_DATA])], b"abc");
        assert!(next_record(&bytes, &mut 0).is_ok());
        let data_len_at = bytes.len() - 3 - 4;
        bytes[data_len_at..data_len_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(next_record(&bytes, &mut 0).unwrap_err().contains("past the end"));
        bytes[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(next_record(&bytes, &mut 0).unwrap_err().contains("past the end"));
        assert!(field(&[255, 255, 255, 255, b'o'], "op").unwrap_err().contains("past its header"));
    }
}
