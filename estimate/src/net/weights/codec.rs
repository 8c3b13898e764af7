//! The byte-level encoding of weight files: little-endian writers, a
//! bounds-checked reader that names what it was reading when bytes run
//! out, and the FNV-1a checksum. The layout itself is documented in the
//! parent module.

use super::{WeightsError, WeightsHeader, FORMAT_VERSION, MAGIC};

pub(super) fn to_u32(value: usize) -> u32 {
    // Widths and tensor dimensions are bounded by MAX_WIDTH and the input lists.
    u32::try_from(value).unwrap_or(u32::MAX)
}

pub(super) fn put_u32(out: &mut Vec<u8>, value: u32) {
    out.extend_from_slice(&value.to_le_bytes());
}

pub(super) fn put_str(out: &mut Vec<u8>, text: &str) {
    let len = u16::try_from(text.len()).unwrap_or(u16::MAX);
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&text.as_bytes()[..len as usize]);
}

/// 64-bit FNV-1a.
pub(super) fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, byte| {
        (hash ^ u64::from(*byte)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A cursor over a weight file's bytes that reports what it was reading
/// when the bytes run out.
pub(super) struct Reader<'a> {
    bytes: &'a [u8],
    origin: &'a str,
    offset: usize,
    /// Where the readable fields end: the whole file until the checksum
    /// is verified, then the start of the checksum.
    end: usize,
    tensors_read: usize,
}

pub(super) const CHECKSUM_LEN: usize = 8;

impl<'a> Reader<'a> {
    pub(super) fn new(bytes: &'a [u8], origin: &'a str) -> Self {
        Reader {
            bytes,
            origin,
            offset: 0,
            end: bytes.len(),
            tensors_read: 0,
        }
    }

    /// Magic, version, declared length, then the checksum over the body.
    pub(super) fn verify(&mut self) -> Result<(), WeightsError> {
        let magic = self.take(MAGIC.len(), "magic")?;
        if magic != MAGIC {
            return Err(WeightsError::NotWeights {
                origin: self.origin.to_string(),
            });
        }
        let version = self.u32("format version")?;
        if version != FORMAT_VERSION {
            return Err(WeightsError::Version {
                origin: self.origin.to_string(),
                found: version,
            });
        }
        let b = self.take(8, "file length")?;
        let mut length = [0u8; 8];
        length.copy_from_slice(b);
        let declared = usize::try_from(u64::from_le_bytes(length)).unwrap_or(usize::MAX);
        let len = self.bytes.len();
        if len < declared {
            return Err(WeightsError::Truncated {
                origin: self.origin.to_string(),
                what: "the whole file".to_string(),
                needed: declared,
                offset: 0,
                len,
            });
        }
        if len > declared {
            return Err(WeightsError::TrailingBytes {
                origin: self.origin.to_string(),
                extra: len - declared,
            });
        }
        let Some(body_len) = len
            .checked_sub(CHECKSUM_LEN)
            .filter(|body| *body >= self.offset)
        else {
            return Err(self.truncated("checksum", CHECKSUM_LEN));
        };
        let (body, stored) = self.bytes.split_at(body_len);
        let mut stored_bytes = [0u8; CHECKSUM_LEN];
        stored_bytes.copy_from_slice(stored);
        let found = u64::from_le_bytes(stored_bytes);
        let computed = fnv1a(body);
        if found != computed {
            return Err(WeightsError::Checksum {
                origin: self.origin.to_string(),
                found,
                computed,
            });
        }
        self.end = body_len;
        Ok(())
    }

    pub(super) fn header(&mut self) -> Result<WeightsHeader, WeightsError> {
        let architecture = self.u32("architecture")?;
        let kind = self.string("network name")?;
        let width = self.u32("width")? as usize;
        let track = self.u32("track")? as usize;
        let input_count = self.u32("input count")? as usize;
        let mut inputs = Vec::new();
        for i in 0..input_count {
            inputs.push(self.string(&format!("input name {i}"))?);
        }
        let fused_outputs = self.u32("fused output count")? as usize;
        let per_view_outputs = self.u32("per-view output count")? as usize;
        Ok(WeightsHeader {
            architecture,
            kind,
            width,
            track,
            inputs,
            fused_outputs,
            per_view_outputs,
        })
    }

    /// The next tensor, which must be `name` with `dims` and finite values.
    pub(super) fn tensor(&mut self, name: &str, dims: &[usize]) -> Result<Vec<f32>, WeightsError> {
        let index = self.tensors_read;
        let problem = |problem: String| WeightsError::Tensor {
            origin: self.origin.to_string(),
            index,
            name: name.to_string(),
            problem,
        };
        let found_name = self.string(&format!("name of tensor {index}"))?;
        if found_name != name {
            return Err(problem(format!("the file has {found_name:?} here")));
        }
        let rank = self.take(1, &format!("rank of {name}"))?[0] as usize;
        let mut found_dims = Vec::with_capacity(rank);
        for _ in 0..rank {
            found_dims.push(self.u32(&format!("shape of {name}"))? as usize);
        }
        if found_dims != dims {
            return Err(problem(format!(
                "shape {found_dims:?}, expected {dims:?} for this width and input list"
            )));
        }
        let count: usize = dims.iter().product();
        let raw = self.take(count * 4, &format!("values of {name}"))?;
        let values: Vec<f32> = raw
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(problem(format!("value {bad} is {}", values[bad])));
        }
        self.tensors_read += 1;
        Ok(values)
    }

    pub(super) fn remaining_before_checksum(&self) -> usize {
        self.end.saturating_sub(self.offset)
    }

    fn take(&mut self, len: usize, what: &str) -> Result<&'a [u8], WeightsError> {
        let end = self.offset.checked_add(len).filter(|end| *end <= self.end);
        let Some(end) = end else {
            return Err(self.truncated(what, len));
        };
        let slice = &self.bytes[self.offset..end];
        self.offset = end;
        Ok(slice)
    }

    fn truncated(&self, what: &str, needed: usize) -> WeightsError {
        WeightsError::Truncated {
            origin: self.origin.to_string(),
            what: what.to_string(),
            needed,
            offset: self.offset,
            len: self.bytes.len(),
        }
    }

    pub(super) fn u32(&mut self, what: &str) -> Result<u32, WeightsError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn string(&mut self, what: &str) -> Result<String, WeightsError> {
        let b = self.take(2, what)?;
        let len = u16::from_le_bytes([b[0], b[1]]) as usize;
        let text = self.take(len, what)?;
        Ok(String::from_utf8_lossy(text).into_owned())
    }
}
