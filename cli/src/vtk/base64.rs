//! Base64 (RFC 4648, standard alphabet, `=` padding) for the binary arrays of VTK XML files,
//! through the `base64` crate: a streaming encoder over its slice encoder, and a decoder that
//! takes what VTK writers produce (line breaks and other ASCII whitespace, padding or none).

use std::io::Write;

use base64::alphabet::STANDARD as ALPHABET;
use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig, STANDARD};
use base64::engine::DecodePaddingMode;
use base64::Engine as _;

/// Raw bytes encoded per write: a multiple of 6, encoding to 1 MiB, which `BufWriter` passes
/// straight to the file.
const BASE64_CHUNK: usize = 3 << 18;

/// The decoder: the standard alphabet, padding optional, no stray bits after the last byte.
const LENIENT: GeneralPurpose = GeneralPurpose::new(
    &ALPHABET,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

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

    /// Encodes and writes all whole 3-byte groups (no padding arises), keeping the 0–2 bytes
    /// left over.
    #[inline(never)]
    fn drain<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        let whole = self.len / 3 * 3;
        let written = STANDARD
            .encode_slice(&self.raw[..whole], &mut self.encoded)
            .map_err(std::io::Error::other)?;
        w.write_all(&self.encoded[..written])?;
        self.raw.copy_within(whole..self.len, 0);
        self.len -= whole;
        Ok(())
    }

    pub(super) fn finish<W: Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.drain(w)?;
        // The last one or two bytes, with `=` padding.
        let mut tail = [0u8; 4];
        let written = STANDARD
            .encode_slice(&self.raw[..self.len], &mut tail)
            .map_err(std::io::Error::other)?;
        w.write_all(&tail[..written])?;
        self.len = 0;
        Ok(())
    }
}

/// Decodes base64 (standard alphabet, `=` padding optional, ASCII whitespace ignored) into
/// `out`, which it clears first. `None` for any other byte, a lone trailing symbol, or data after
/// padding.
pub(super) fn decode_base64(input: &[u8], out: &mut Vec<u8>) -> Option<()> {
    out.clear();
    let compact: Vec<u8>;
    let symbols = if input.iter().any(u8::is_ascii_whitespace) {
        compact = input.iter().copied().filter(|c| !c.is_ascii_whitespace()).collect();
        &compact[..]
    } else {
        input
    };
    LENIENT.decode_vec(symbols, out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode_all(bytes: &[u8]) -> String {
        let mut enc = Base64Writer::new();
        let mut out = Vec::new();
        enc.len = bytes.len();
        enc.raw[..bytes.len()].copy_from_slice(bytes);
        enc.finish(&mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn decoding_inverts_encoding_and_refuses_what_is_not_base64() {
        let mut out = Vec::new();
        for len in 0..40 {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 37 + 11) as u8).collect();
            assert_eq!(decode_base64(encode_all(&bytes).as_bytes(), &mut out), Some(()));
            assert_eq!(out, bytes, "{len} bytes");
            let unpadded = encode_all(&bytes).trim_end_matches('=').to_string();
            assert_eq!(decode_base64(unpadded.as_bytes(), &mut out), Some(()));
            assert_eq!(out, bytes, "{len} bytes without padding");
        }
        assert_eq!(decode_base64(b"Zm9v\nYmFy", &mut out), Some(()));
        assert_eq!(out, b"foobar");
        assert_eq!(decode_base64(b" Zm9v\r\n  YmE= \n", &mut out), Some(()));
        assert_eq!(out, b"fooba");
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
            assert_eq!(String::from_utf8(out).unwrap(), STANDARD.encode(&raw), "{words} words");
        }
    }
}
