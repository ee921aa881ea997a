//! Base64 (RFC 4648, standard alphabet, `=` padding) for the binary arrays of VTK XML files:
//! a streaming encoder.

use std::io::Write;

const BASE64_ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Raw bytes encoded per write: a multiple of 6, encoding to 1 MiB, which `BufWriter` passes
/// straight to the file.
const BASE64_CHUNK: usize = 3 << 18;

/// The base64 digits of every 12-bit value: two symbols per lookup.
static BASE64_PAIRS: [[u8; 2]; 4096] = {
    let mut table = [[0u8; 2]; 4096];
    let mut i = 0;
    while i < 4096 {
        table[i] = [BASE64_ALPHABET[i >> 6], BASE64_ALPHABET[i & 63]];
        i += 1;
    }
    table
};

/// A streaming base64 encoder for one array at a time: `begin` (writes the UInt64 header),
/// `push` (8 bytes at a time), `finish` (pads and writes the rest). Keeps its buffers between
/// arrays.
pub(super) struct Base64Writer {
    /// `BASE64_CHUNK + 8` bytes, of which `len` are pending.
    raw: Vec<u8>,
    len: usize,
    /// `BASE64_CHUNK / 3 * 4` bytes.
    encoded: Vec<u8>,
}

impl Base64Writer {
    pub(super) fn new() -> Self {
        Base64Writer {
            raw: vec![0; BASE64_CHUNK + 8],
            len: 0,
            encoded: vec![0; BASE64_CHUNK / 3 * 4],
        }
    }

    pub(super) fn begin<W: Write>(&mut self, w: &mut W, data_bytes: u64) -> std::io::Result<()> {
        self.len = 0;
        self.push(w, data_bytes.to_le_bytes())
    }

    #[inline(always)]
    pub(super) fn push<W: Write>(&mut self, w: &mut W, bytes: [u8; 8]) -> std::io::Result<()> {
        self.raw[self.len..self.len + 8].copy_from_slice(&bytes);
        self.len += 8;
        if self.len >= BASE64_CHUNK {
            self.drain(w)?;
        }
        Ok(())
    }

    /// Encodes and writes all whole 3-byte groups, keeping the 0–2 bytes left over.
    #[inline(never)]
    fn drain<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        let whole = self.len / 3 * 3;
        let encoded = &mut self.encoded[..whole / 3 * 4];
        encode_base64(&self.raw[..whole], encoded);
        w.write_all(encoded)?;
        self.raw.copy_within(whole..self.len, 0);
        self.len -= whole;
        Ok(())
    }

    pub(super) fn finish<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.drain(w)?;
        if self.len > 0 {
            w.write_all(&encode_base64_tail(&self.raw[..self.len]))?;
        }
        self.len = 0;
        Ok(())
    }
}

/// Encodes `input` (a multiple of 3 bytes) into `out` (`input.len() / 3 * 4` bytes).
pub(super) fn encode_base64(input: &[u8], out: &mut [u8]) {
    debug_assert!(input.len().is_multiple_of(3) && out.len() == input.len() / 3 * 4);
    let pair = |n: u64| BASE64_PAIRS[(n & 0xfff) as usize];
    // Six bytes (48 bits, four 12-bit pairs) at a time, then a last group of three.
    let mut src = input.chunks_exact(6);
    let mut dst = out.chunks_exact_mut(8);
    for (s, d) in (&mut src).zip(&mut dst) {
        let n = u64::from_be_bytes([0, 0, s[0], s[1], s[2], s[3], s[4], s[5]]);
        let (a, b, c, e) = (pair(n >> 36), pair(n >> 24), pair(n >> 12), pair(n));
        d.copy_from_slice(&[a[0], a[1], b[0], b[1], c[0], c[1], e[0], e[1]]);
    }
    if let [x, y, z] = *src.remainder() {
        let n = u64::from_be_bytes([0, 0, 0, 0, 0, x, y, z]);
        let (a, b) = (pair(n >> 12), pair(n));
        dst.into_remainder().copy_from_slice(&[a[0], a[1], b[0], b[1]]);
    }
}

/// Encodes the last one or two bytes of a stream, with `=` padding.
fn encode_base64_tail(tail: &[u8]) -> [u8; 4] {
    let symbol = |v: u8| BASE64_ALPHABET[v as usize];
    match *tail {
        [a] => [symbol(a >> 2), symbol((a & 3) << 4), b'=', b'='],
        [a, b] => [
            symbol(a >> 2),
            symbol(((a & 3) << 4) | (b >> 4)),
            symbol((b & 15) << 2),
            b'=',
        ],
        _ => unreachable!("a base64 tail has one or two bytes"),
    }
}

/// Decodes base64 (standard alphabet, `=` padding optional, ASCII whitespace ignored) into
/// `out`, which it clears first. `None` for any other byte, a lone trailing symbol, or data after
/// padding.
pub(super) fn decode_base64(input: &[u8], out: &mut Vec<u8>) -> Option<()> {
    const INVALID: u8 = 0xff;
    static VALUES: [u8; 256] = {
        let mut table = [INVALID; 256];
        let mut i = 0;
        while i < 64 {
            table[BASE64_ALPHABET[i] as usize] = i as u8;
            i += 1;
        }
        table
    };
    out.clear();
    out.reserve(input.len() / 4 * 3);
    let (mut acc, mut bits, mut padded) = (0u32, 0u32, false);
    for &c in input {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            padded = true;
            continue;
        }
        let v = VALUES[c as usize];
        if v == INVALID || padded {
            return None;
        }
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    // 6 bits left over: a lone symbol, which encodes no whole byte.
    (bits < 6).then_some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode_all(bytes: &[u8]) -> String {
        let whole = bytes.len() / 3 * 3;
        let mut out = vec![0; whole / 3 * 4];
        encode_base64(&bytes[..whole], &mut out);
        if whole < bytes.len() {
            out.extend_from_slice(&encode_base64_tail(&bytes[whole..]));
        }
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn decoding_inverts_encoding_and_refuses_what_is_not_base64() {
        let mut out = Vec::new();
        for len in 0..40 {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 37 + 11) as u8).collect();
            assert_eq!(decode_base64(encode_all(&bytes).as_bytes(), &mut out), Some(()));
            assert_eq!(out, bytes, "{len} bytes");
        }
        assert_eq!(decode_base64(b"Zm9v\nYmFy", &mut out), Some(()));
        assert_eq!(out, b"foobar");
        assert_eq!(decode_base64(b"Zm9v!", &mut out), None);
        assert_eq!(decode_base64(b"Zg==Zg==", &mut out), None);
        assert_eq!(decode_base64(b"Zm9vY", &mut out), None);
    }

    #[test]
    fn base64_matches_the_rfc_4648_test_vectors() {
        let vectors = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
            ("foobarb", "Zm9vYmFyYg=="),
        ];
        for (plain, encoded) in vectors {
            assert_eq!(encode_all(plain.as_bytes()), encoded);
        }
    }

    #[test]
    fn the_streaming_encoder_matches_the_one_shot_encoding_across_chunk_boundaries() {
        for words in [
            0,
            1,
            2,
            3,
            BASE64_CHUNK / 8 - 1,
            BASE64_CHUNK / 8,
            2 * BASE64_CHUNK / 8 + 5,
        ] {
            let values: Vec<u64> = (0..words as u64)
                .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
                .collect();
            let mut enc = Base64Writer::new();
            let mut out = Vec::new();
            enc.begin(&mut out, 8 * words as u64).unwrap();
            for v in &values {
                enc.push(&mut out, v.to_le_bytes()).unwrap();
            }
            enc.finish(&mut out).unwrap();
            let mut raw = (8 * words as u64).to_le_bytes().to_vec();
            raw.extend(values.iter().flat_map(|v| v.to_le_bytes()));
            assert_eq!(
                String::from_utf8(out.clone()).unwrap(),
                encode_all(&raw),
                "{words} words"
            );
        }
    }
}
