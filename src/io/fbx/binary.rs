//! Binary FBX records into a [`Node`] tree.
//!
//! A record is its end offset, value count, values' byte length and name,
//! then its values and its children, closed by a null record when it has
//! any. Offsets and counts are 32-bit before version 7500 and 64-bit from
//! it on; files written big-endian (a flag after the magic) have every
//! number reversed. Arrays are stored raw or zlib-compressed.
//!
//! fbxcel (the crate drape read binary files with before) aborts a whole
//! file on a `c` array or a name that is not UTF-8, and reads neither FBX 6
//! binaries nor big-endian ones; this reader takes all of them. Every count
//! is checked against the bytes left before anything is allocated, and the
//! nesting depth is bounded, so no file can exhaust memory or the stack.

use std::io::Read;

use super::tree::{Node, Value};

/// The start of every binary FBX file.
pub const MAGIC: &[u8] = b"Kaydara FBX Binary  \0";
/// Bytes before the first record: magic, two flag bytes, version.
const HEADER_LEN: usize = 27;
/// Deepest nesting of records accepted (real files nest fewer than 10).
const MAX_DEPTH: usize = 64;
/// Largest decompressed array accepted, bytes.
const MAX_ARRAY_BYTES: usize = 1 << 31;
/// zlib cannot expand data by more than about 1032 times.
const MAX_EXPANSION: usize = 1100;

/// The header's facts: version and byte order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// FBX version × 1000 (7400 for 7.4).
    pub version: u32,
    /// Numbers are stored big-endian.
    pub big_endian: bool,
}

/// Reads the header; `None` when the bytes are too short for one.
pub fn header(bytes: &[u8]) -> Option<Header> {
    let flag = *bytes.get(MAGIC.len() + 1)?;
    let raw: [u8; 4] = bytes.get(MAGIC.len() + 2..HEADER_LEN)?.try_into().ok()?;
    let big_endian = flag == 1;
    let version = if big_endian { u32::from_be_bytes(raw) } else { u32::from_le_bytes(raw) };
    Some(Header { version, big_endian })
}

/// Reads every top-level record of a binary FBX file into a root node.
pub fn parse(bytes: &[u8]) -> Result<Node, String> {
    let header = header(bytes).ok_or("the header is truncated")?;
    let mut reader = Reader { bytes, at: HEADER_LEN, big_endian: header.big_endian, wide: header.version >= 7500 };
    let mut root = Node::default();
    while let Some(node) = reader.record(0)? {
        root.children.push(node);
    }
    Ok(root)
}

/// A cursor over the file's bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    big_endian: bool,
    /// 64-bit offsets and counts (version 7500 on).
    wide: bool,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end =
            end.ok_or_else(|| format!("the file ends inside a record (byte {} of {})", self.at, self.bytes.len()))?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut raw: [u8; N] = self.take(N)?.try_into().map_err(|_| "a short read".to_owned())?;
        if self.big_endian {
            raw.reverse();
        }
        Ok(raw)
    }

    fn u32(&mut self) -> Result<u32, String> {
        self.array::<4>().map(u32::from_le_bytes)
    }

    /// An offset or count: 32 or 64 bits by version.
    fn offset(&mut self) -> Result<u64, String> {
        if self.wide { self.array::<8>().map(u64::from_le_bytes) } else { self.u32().map(u64::from) }
    }

    /// One record and its children; `None` at a null record (the end of a list).
    fn record(&mut self, depth: usize) -> Result<Option<Node>, String> {
        if depth > MAX_DEPTH {
            return Err(format!("records nest deeper than {MAX_DEPTH} levels"));
        }
        if self.at >= self.bytes.len() {
            return Ok(None); // a file without the final null record
        }
        let end = self.offset()?;
        let value_count = self.offset()?;
        let _values_len = self.offset()?;
        let name_len = usize::from(self.take(1)?[0]);
        if end == 0 {
            return Ok(None);
        }
        let end = usize::try_from(end).ok().filter(|&e| e <= self.bytes.len() && e > self.at);
        let end = end.ok_or_else(|| format!("a record at byte {} ends outside the file", self.at))?;
        let name = String::from_utf8_lossy(self.take(name_len)?).into_owned();
        // Every value takes at least two bytes: a count larger than the record is a lie.
        if value_count > (end - self.at) as u64 {
            return Err(format!("record '{name}' claims {value_count} values in {} bytes", end - self.at));
        }
        let mut node = Node { name, values: Vec::with_capacity(value_count as usize), children: Vec::new() };
        for _ in 0..value_count {
            node.values.push(self.value()?);
        }
        while self.at < end {
            match self.record(depth + 1)? {
                Some(child) => node.children.push(child),
                None => break,
            }
        }
        if self.at > end {
            return Err(format!("record '{}' overruns its end at byte {end}", node.name));
        }
        self.at = end;
        Ok(Some(node))
    }

    /// One value: a type code and its data.
    fn value(&mut self) -> Result<Value, String> {
        let code = self.take(1)?[0];
        Ok(match code {
            // `B` and `Z` are one-byte numbers some Maya exporters write.
            b'C' | b'B' | b'Z' => Value::Int(i64::from(self.take(1)?[0])),
            b'Y' => Value::Int(i64::from(self.array::<2>().map(i16::from_le_bytes)?)),
            b'I' => Value::Int(i64::from(self.array::<4>().map(i32::from_le_bytes)?)),
            b'L' => Value::Int(self.array::<8>().map(i64::from_le_bytes)?),
            b'F' => Value::Float(f64::from(self.array::<4>().map(f32::from_le_bytes)?)),
            b'D' => Value::Float(self.array::<8>().map(f64::from_le_bytes)?),
            b'S' => Value::String(String::from_utf8_lossy(self.blob()?).into_owned()),
            b'R' => Value::Raw(self.blob()?.to_vec()),
            b'f' => Value::Floats(self.numbers(4, |b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))?),
            b'd' => Value::Floats(self.numbers(8, |b| f64::from_le_bytes(eight(b)))?),
            b'i' => Value::Ints(self.numbers(4, |b| i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])))?),
            b'l' => Value::Ints(self.numbers(8, |b| i64::from_le_bytes(eight(b)))?),
            b'b' | b'c' => Value::Ints(self.numbers(1, |b| i64::from(b[0]))?),
            other => return Err(format!("unknown value type code {other:#04x} at byte {}", self.at - 1)),
        })
    }

    /// A length-prefixed string or raw blob.
    fn blob(&mut self) -> Result<&[u8], String> {
        let len = self.u32()? as usize;
        self.take(len)
    }

    /// An array of `size`-byte elements, raw or zlib-compressed, each decoded
    /// from little-endian bytes by `decode` (reversed first in big-endian files).
    fn numbers<T>(&mut self, size: usize, decode: impl Fn(&[u8]) -> T) -> Result<Vec<T>, String> {
        let big_endian = self.big_endian;
        let count = self.u32()? as usize;
        let encoding = self.u32()?;
        let stored_len = self.u32()? as usize;
        let stored = self.take(stored_len)?;
        let bytes = count.checked_mul(size).filter(|&b| b <= MAX_ARRAY_BYTES);
        let bytes = bytes.ok_or_else(|| format!("an array of {count} elements is larger than drape accepts"))?;
        let data = match encoding {
            0 if stored_len == bytes => std::borrow::Cow::Borrowed(stored),
            0 => return Err(format!("an array of {count} elements is stored in {stored_len} bytes")),
            1 => std::borrow::Cow::Owned(inflate(stored, bytes)?),
            other => return Err(format!("an array uses encoding {other}, which FBX does not define")),
        };
        let mut out = Vec::with_capacity(count);
        let mut swapped = [0u8; 8];
        for chunk in data.chunks_exact(size) {
            if big_endian {
                swapped[..size].copy_from_slice(chunk);
                swapped[..size].reverse();
                out.push(decode(&swapped[..size]));
            } else {
                out.push(decode(chunk));
            }
        }
        Ok(out)
    }
}

fn eight(b: &[u8]) -> [u8; 8] {
    [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]
}

/// Decompresses a zlib stream that must hold exactly `expected` bytes.
fn inflate(stored: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    if expected > stored.len().saturating_mul(MAX_EXPANSION) + 64 {
        return Err(format!("a compressed array claims {expected} bytes from {} stored", stored.len()));
    }
    let mut out = Vec::with_capacity(expected);
    let mut decoder = flate2::read::ZlibDecoder::new(stored).take(expected as u64 + 1);
    decoder.read_to_end(&mut out).map_err(|e| format!("a compressed array is damaged: {e}"))?;
    if out.len() != expected {
        return Err(format!("a compressed array holds {} bytes, not the {expected} it claims", out.len()));
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A binary FBX file of `version` holding `records` (each already encoded).
    pub(crate) fn file(version: u32, big_endian: bool, records: &[Vec<u8>]) -> Vec<u8> {
        let mut bytes = MAGIC.to_vec();
        bytes.extend([0x1a, u8::from(big_endian)]);
        bytes.extend(if big_endian { version.to_be_bytes() } else { version.to_le_bytes() });
        for r in records {
            bytes.extend(r);
        }
        bytes.extend(vec![0; if version >= 7500 { 25 } else { 13 }]);
        bytes
    }

    /// One record at byte `at` of the file: `name` with encoded `values`
    /// and encoded `children`, in the layout of `version`.
    pub(crate) fn record(at: usize, version: u32, name: &str, values: &[Vec<u8>], children: &[Vec<u8>]) -> Vec<u8> {
        let wide = version >= 7500;
        let word = |v: usize| if wide { (v as u64).to_le_bytes().to_vec() } else { (v as u32).to_le_bytes().to_vec() };
        let values_len: usize = values.iter().map(Vec::len).sum();
        let header_len = if wide { 25 } else { 13 } + name.len();
        let null = if children.is_empty() { 0 } else { header_len - name.len() };
        let end = at + header_len + values_len + children.iter().map(Vec::len).sum::<usize>() + null;
        let mut out = [word(end), word(values.len()), word(values_len)].concat();
        out.push(name.len() as u8);
        out.extend(name.as_bytes());
        values.iter().for_each(|v| out.extend(v));
        children.iter().for_each(|c| out.extend(c));
        out.extend(vec![0; null]);
        out
    }

    fn int(v: i32) -> Vec<u8> {
        [vec![b'I'], v.to_le_bytes().to_vec()].concat()
    }

    fn compressed_doubles(values: &[f64]) -> Vec<u8> {
        use std::io::Write;
        let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        encoder.write_all(&raw).unwrap();
        let packed = encoder.finish().unwrap();
        let mut out = vec![b'd'];
        for word in [values.len() as u32, 1, packed.len() as u32] {
            out.extend(word.to_le_bytes());
        }
        out.extend(packed);
        out
    }

    #[test]
    fn records_values_and_children_are_read_in_both_offset_widths() {
        for version in [7400, 7500] {
            let start = HEADER_LEN;
            let child_at = start + if version >= 7500 { 25 } else { 13 } + 4 + 5;
            let child = record(child_at, version, "Vertices", &[compressed_doubles(&[1.0, -2.5, 3.0])], &[]);
            let parent = record(start, version, "Geom", &[int(7)], &[child]);
            let root = parse(&file(version, false, &[parent])).unwrap();
            let geom = &root.children[0];
            assert_eq!((geom.name.as_str(), &geom.values), ("Geom", &vec![Value::Int(7)]));
            assert_eq!(geom.child_floats("Vertices").unwrap(), vec![1.0, -2.5, 3.0]);
        }
    }

    #[test]
    fn byte_arrays_and_names_that_are_not_utf8_are_read() {
        let mut chars = vec![b'c'];
        for word in [3u32, 0, 3] {
            chars.extend(word.to_le_bytes());
        }
        chars.extend([1, 0, 255]);
        let mut name = vec![b'S', 3, 0, 0, 0];
        name.extend([b'a', 0xff, b'b']);
        let node = record(HEADER_LEN, 7400, "X", &[chars, name], &[]);
        let root = parse(&file(7400, false, &[node])).unwrap();
        assert_eq!(root.children[0].values[0], Value::Ints(vec![1, 0, 255]));
        assert_eq!(root.children[0].values[1], Value::String("a\u{fffd}b".into()));
    }

    #[test]
    fn big_endian_files_are_read() {
        let mut value = vec![b'I'];
        value.extend((-5i32).to_be_bytes());
        let mut node = record(HEADER_LEN, 7400, "N", &[value], &[]);
        // The record's own offsets and counts are big-endian too.
        for word in node[..12].chunks_exact_mut(4) {
            word.reverse();
        }
        let bytes = file(7400, true, &[node]);
        assert_eq!(header(&bytes), Some(Header { version: 7400, big_endian: true }));
        assert_eq!(parse(&bytes).unwrap().children[0].values, vec![Value::Int(-5)]);
    }

    #[test]
    fn lies_about_sizes_are_errors_not_allocations() {
        let mut huge = vec![b'd'];
        for word in [u32::MAX, 1, 8] {
            huge.extend(word.to_le_bytes());
        }
        huge.extend([0; 8]);
        let node = record(HEADER_LEN, 7400, "V", &[huge], &[]);
        assert!(parse(&file(7400, false, &[node])).unwrap_err().contains("larger than drape accepts"));
        let mut inflated = vec![b'd'];
        for word in [1_000_000u32, 1, 8] {
            inflated.extend(word.to_le_bytes());
        }
        inflated.extend([0; 8]);
        let node = record(HEADER_LEN, 7400, "V", &[inflated], &[]);
        assert!(parse(&file(7400, false, &[node])).unwrap_err().contains("claims 8000000 bytes from 8"));
        let mut truncated = file(7400, false, &[record(HEADER_LEN, 7400, "V", &[int(1)], &[])]);
        truncated.truncate(HEADER_LEN + 15);
        assert!(parse(&truncated).unwrap_err().contains("ends"));
    }
}
