//! The GLB container (glTF 2.0 binary): a 12-byte header, a JSON chunk and an
//! optional BIN chunk.

use thiserror::Error;

const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum GlbError {
    #[error("not a GLB file (magic is {0:?}, expected \"glTF\")")]
    BadMagic([u8; 4]),
    #[error("GLB version {0}; only version 2 is supported")]
    Version(u32),
    #[error("GLB truncated: header says {declared} bytes, file has {actual}")]
    Truncated { declared: usize, actual: usize },
    #[error("GLB chunk {index} at byte {offset}: length {length} runs past the end of the file ({file_len} bytes)")]
    BadChunkLength {
        index: usize,
        offset: usize,
        length: usize,
        file_len: usize,
    },
    #[error("GLB: the first chunk must be JSON")]
    NoJson,
}

/// The chunks of a GLB file: JSON, BIN, and any others (extensions'
/// chunks: kept as read and written back after BIN).
#[derive(Debug, Clone)]
pub struct Glb<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
    /// Every other chunk, in file order: its type and data.
    pub others: Vec<(u32, &'a [u8])>,
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    b.get(at..at + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// Splits a GLB file into its chunks, checking every length.
pub fn parse(bytes: &[u8]) -> Result<Glb<'_>, GlbError> {
    if bytes.len() < 12 {
        return Err(GlbError::Truncated {
            declared: 12,
            actual: bytes.len(),
        });
    }
    let magic = [bytes[0], bytes[1], bytes[2], bytes[3]];
    if &magic != MAGIC {
        return Err(GlbError::BadMagic(magic));
    }
    let version = u32_at(bytes, 4).unwrap_or(0);
    if version != 2 {
        return Err(GlbError::Version(version));
    }
    let declared = u32_at(bytes, 8).unwrap_or(0) as usize;
    if declared > bytes.len() {
        return Err(GlbError::Truncated {
            declared,
            actual: bytes.len(),
        });
    }
    let body = &bytes[..declared];
    let mut offset = 12;
    let mut chunks = Vec::new();
    while offset + 8 <= body.len() {
        let length = u32_at(body, offset).unwrap_or(0) as usize;
        let kind = u32_at(body, offset + 4).unwrap_or(0);
        let start = offset + 8;
        if start + length > body.len() {
            return Err(GlbError::BadChunkLength {
                index: chunks.len(),
                offset,
                length,
                file_len: body.len(),
            });
        }
        chunks.push((kind, &body[start..start + length]));
        offset = start + length;
    }
    let json = match chunks.first() {
        Some((CHUNK_JSON, data)) => *data,
        _ => return Err(GlbError::NoJson),
    };
    let bin_at = chunks.iter().skip(1).position(|(k, _)| *k == CHUNK_BIN).map(|k| k + 1);
    let bin = bin_at.map(|k| chunks[k].1);
    let others = chunks
        .iter()
        .enumerate()
        .skip(1)
        .filter(|(k, _)| Some(*k) != bin_at)
        .map(|(_, c)| *c)
        .collect();
    Ok(Glb { json, bin, others })
}

/// Builds a GLB file: JSON chunk padded with spaces, BIN chunk with zeros.
pub fn build(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    build_with(json, bin, &[])
}

/// [`build`], then `others` (type, data), each padded with zeros.
pub fn build_with(json: &[u8], bin: Option<&[u8]>, others: &[(u32, Vec<u8>)]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.map(|b| b.len() + pad(b.len()));
    let others_len: usize = others.iter().map(|(_, d)| 8 + d.len() + pad(d.len())).sum();
    let total = 12 + 8 + json_len + bin_len.map_or(0, |l| 8 + l) + others_len;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(json);
    out.resize(out.len() + pad(json.len()), b' ');
    if let (Some(b), Some(l)) = (bin, bin_len) {
        out.extend_from_slice(&(l as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(b);
        out.resize(out.len() + pad(b.len()), 0);
    }
    for (kind, data) in others {
        out.extend_from_slice(&((data.len() + pad(data.len())) as u32).to_le_bytes());
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(data);
        out.resize(out.len() + pad(data.len()), 0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_corruption() {
        let file = build(br#"{"asset":{"version":"2.0"}}"#, Some(&[1, 2, 3]));
        assert_eq!(file.len() % 4, 0);
        let g = parse(&file).unwrap();
        assert!(g.json.starts_with(br#"{"asset""#));
        assert_eq!(&g.bin.unwrap()[..3], &[1, 2, 3]);
        assert!(matches!(
            parse(&file[..file.len() - 4]),
            Err(GlbError::Truncated { .. })
        ));
        let mut bad = file.clone();
        bad[12] = 0xFF; // JSON chunk length far too large
        assert!(matches!(parse(&bad), Err(GlbError::BadChunkLength { index: 0, .. })));
        assert!(matches!(parse(b"glTF"), Err(GlbError::Truncated { .. })));
    }

    #[test]
    fn other_chunks_are_kept_in_order() {
        let others = vec![(0x1234_5678, vec![9u8; 5]), (0x0000_0042, vec![7u8; 8])];
        let file = build_with(b"{}", Some(&[1, 2, 3, 4]), &others);
        let g = parse(&file).unwrap();
        assert_eq!(g.bin.unwrap(), &[1, 2, 3, 4]);
        assert_eq!(g.others.len(), 2);
        assert_eq!((g.others[0].0, &g.others[0].1[..5]), (0x1234_5678, &[9u8; 5][..]));
        assert_eq!(g.others[1], (0x42, &[7u8; 8][..]));
    }
}
