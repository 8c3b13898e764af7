//! The EDID 1.3/1.4 base block (the first 128 bytes a display sends over
//! DDC): who made it, what it is called and its preferred timing. Used to
//! name the projector in logs and in the connector listing; the kernel has
//! already turned the EDID into the connector's mode list, so nothing here
//! decides the mode.
//!
//! Boundaries: bytes in, values out; extension blocks (CTA-861, DisplayID)
//! are counted but not read.

use crate::projector::kms::mode::Timing;

/// Length of the base block.
pub const BLOCK_LEN: usize = 128;
const HEADER: [u8; 8] = [0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00];
/// Descriptor tag of the display product name.
const TAG_PRODUCT_NAME: u8 = 0xfc;
/// The four 18-byte descriptors start here.
const DESCRIPTORS: usize = 54;

/// What was wrong with an EDID block.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EdidError {
    #[error("EDID is {len} bytes, expected at least the 128-byte base block")]
    TooShort { len: usize },
    #[error("EDID header is {found:02x?}, expected 00 ff ff ff ff ff ff 00")]
    BadHeader { found: [u8; 8] },
    #[error(
        "EDID checksum is wrong: the 128 bytes sum to {sum:#04x} modulo 256, expected 0 \
         (checksum byte {stored:#04x}; a bad cable or KVM corrupts DDC reads)"
    )]
    Checksum { sum: u8, stored: u8 },
    #[error("EDID version {version}.{revision}, expected 1.3 or 1.4")]
    Version { version: u8, revision: u8 },
    #[error("EDID manufacturer id {raw:#06x} is not three letters A..Z")]
    Manufacturer { raw: u16 },
}

/// The base block's identification and preferred timing.
#[derive(Debug, Clone, PartialEq)]
pub struct Edid {
    /// (version, revision), e.g. (1, 3).
    pub version: (u8, u8),
    /// The three-letter PNP id, e.g. `OTM` (Optoma), `EPS` (Epson).
    pub manufacturer: String,
    pub product_code: u16,
    /// 0 when the display does not number itself.
    pub serial: u32,
    /// Week (0 or 0xff: not given) and year of manufacture.
    pub week: u8,
    pub year: u16,
    /// The display product name descriptor (tag 0xFC), trimmed.
    pub name: Option<String>,
    /// The first detailed timing descriptor: the display's preferred mode
    /// (always in 1.4; in 1.3 when the feature byte says so, which every
    /// display in practice does).
    pub preferred: Option<Timing>,
    /// Extension blocks that follow the base block.
    pub extensions: u8,
}

impl Edid {
    /// Parses and checks the base block (`bytes` may hold extensions after
    /// it; they are not read).
    pub fn parse(bytes: &[u8]) -> Result<Edid, EdidError> {
        let block: &[u8; BLOCK_LEN] = bytes
            .get(..BLOCK_LEN)
            .and_then(|b| b.try_into().ok())
            .ok_or(EdidError::TooShort { len: bytes.len() })?;
        if block[..8] != HEADER {
            let mut found = [0u8; 8];
            found.copy_from_slice(&block[..8]);
            return Err(EdidError::BadHeader { found });
        }
        let sum = block.iter().fold(0u8, |s, &b| s.wrapping_add(b));
        if sum != 0 {
            return Err(EdidError::Checksum {
                sum,
                stored: block[127],
            });
        }
        let (version, revision) = (block[18], block[19]);
        if version != 1 || !(3..=4).contains(&revision) {
            return Err(EdidError::Version { version, revision });
        }
        let manufacturer = pnp_id(u16::from_be_bytes([block[8], block[9]]))?;
        let mut name = None;
        let mut preferred = None;
        for (k, d) in block[DESCRIPTORS..DESCRIPTORS + 4 * 18]
            .chunks_exact(18)
            .enumerate()
        {
            if d[0] != 0 || d[1] != 0 {
                // A detailed timing; only the first is the preferred one.
                if k == 0 {
                    preferred = detailed_timing(d);
                }
            } else if d[3] == TAG_PRODUCT_NAME && name.is_none() {
                name = Some(descriptor_text(&d[5..18]));
            }
        }
        Ok(Edid {
            version: (version, revision),
            manufacturer,
            product_code: u16::from_le_bytes([block[10], block[11]]),
            serial: u32::from_le_bytes([block[12], block[13], block[14], block[15]]),
            week: block[16],
            year: 1990 + block[17] as u16,
            name,
            preferred,
            extensions: block[126],
        })
    }

    /// "Optoma XGA (OTM 0x0815)", or the id alone without a name.
    pub fn describe(&self) -> String {
        match &self.name {
            Some(n) => format!("{n} ({} {:#06x})", self.manufacturer, self.product_code),
            None => format!("{} {:#06x}", self.manufacturer, self.product_code),
        }
    }
}

/// Three 5-bit letters, 1 = 'A', big-endian, top bit 0.
fn pnp_id(raw: u16) -> Result<String, EdidError> {
    let letters = [(raw >> 10) & 0x1f, (raw >> 5) & 0x1f, raw & 0x1f];
    if raw & 0x8000 != 0 || letters.iter().any(|&l| !(1..=26).contains(&l)) {
        return Err(EdidError::Manufacturer { raw });
    }
    Ok(letters
        .iter()
        .map(|&l| (b'A' + l as u8 - 1) as char)
        .collect())
}

/// Descriptor text: ends at a line feed, padded with spaces.
fn descriptor_text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0x0a).unwrap_or(bytes.len());
    bytes[..end]
        .iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                b as char
            } else {
                '?'
            }
        })
        .collect::<String>()
        .trim()
        .to_string()
}

/// An 18-byte detailed timing descriptor as a mode; `None` for a zero
/// size. Interlaced timings are per field in the EDID and doubled here as
/// the kernel does, so the mode describes the whole frame.
fn detailed_timing(d: &[u8]) -> Option<Timing> {
    let clock_khz = u16::from_le_bytes([d[0], d[1]]) as u32 * 10;
    let hi4 = |b: u8| (b >> 4) as u16;
    let lo4 = |b: u8| (b & 0x0f) as u16;
    // Two high bits of a field, from byte 11 at bit `shift`.
    let hi2 = |shift: u8| ((d[11] >> shift) & 3) as u16;
    let hactive = d[2] as u16 | hi4(d[4]) << 8;
    let hblank = d[3] as u16 | lo4(d[4]) << 8;
    let vactive = d[5] as u16 | hi4(d[7]) << 8;
    let vblank = d[6] as u16 | lo4(d[7]) << 8;
    let hsync_offset = d[8] as u16 | hi2(6) << 8;
    let hsync_width = d[9] as u16 | hi2(4) << 8;
    let vsync_offset = hi4(d[10]) | hi2(2) << 4;
    let vsync_width = lo4(d[10]) | hi2(0) << 4;
    let flags = d[17];
    if hactive == 0 || vactive == 0 || clock_khz == 0 {
        return None;
    }
    let interlaced = flags & 0x80 != 0;
    let mut t = Timing {
        clock_khz,
        hdisplay: hactive,
        hsync_start: hactive + hsync_offset,
        hsync_end: hactive + hsync_offset + hsync_width,
        htotal: hactive + hblank,
        vdisplay: vactive,
        vsync_start: vactive + vsync_offset,
        vsync_end: vactive + vsync_offset + vsync_width,
        vtotal: vactive + vblank,
        // The kernel reads bits 1 and 2 as the polarities whatever the
        // sync type; so does this.
        hsync_positive: flags & 0x02 != 0,
        vsync_positive: flags & 0x04 != 0,
        interlaced,
    };
    if interlaced {
        t.vdisplay *= 2;
        t.vsync_start *= 2;
        t.vsync_end *= 2;
        t.vtotal = t.vtotal * 2 + 1;
    }
    Some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The base block of an Optoma XGA projector (linuxhw/EDID,
    /// Digital/Optoma/OTM0815); edid-decode reads: OTM, model 2069, week 43
    /// of 2013, EDID 1.3, DTD 1 1024x768 65 MHz (Hfront 24 Hsync 135
    /// Hback 161, Vfront 3 Vsync 6 Vback 29, both polarities negative),
    /// name 'Optoma XGA', one extension, checksum 0x3d.
    const OPTOMA_XGA: [u8; 128] = [
        0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00, 0x3e, 0x8d, 0x15, 0x08, 0x97, 0x0a, 0x00,
        0x00, 0x2b, 0x17, 0x01, 0x03, 0x80, 0x00, 0x00, 0x00, 0x2f, 0x00, 0x00, 0xa4, 0x50, 0x4f,
        0x8c, 0x23, 0x12, 0x48, 0x4f, 0xaf, 0xef, 0x80, 0x45, 0x7c, 0x61, 0x7c, 0x81, 0x00, 0x81,
        0x80, 0xb3, 0x00, 0x81, 0xc0, 0x81, 0xfc, 0xa9, 0x40, 0x64, 0x19, 0x00, 0x40, 0x41, 0x00,
        0x26, 0x30, 0x18, 0x87, 0x36, 0x00, 0xc4, 0x8e, 0x21, 0x00, 0x00, 0x18, 0x0e, 0x1f, 0x00,
        0xbc, 0x52, 0x00, 0x1e, 0x30, 0xb8, 0x28, 0x55, 0x40, 0xc4, 0x8e, 0x21, 0x00, 0x00, 0x1e,
        0x00, 0x00, 0x00, 0xfd, 0x00, 0x38, 0x78, 0x1e, 0x78, 0x11, 0x00, 0x0a, 0x20, 0x20, 0x20,
        0x20, 0x20, 0x20, 0x00, 0x00, 0x00, 0xfc, 0x00, 0x4f, 0x70, 0x74, 0x6f, 0x6d, 0x61, 0x20,
        0x58, 0x47, 0x41, 0x0a, 0x20, 0x20, 0x01, 0x3d,
    ];

    fn fix_checksum(block: &mut [u8; 128]) {
        let sum = block[..127].iter().fold(0u8, |s, &b| s.wrapping_add(b));
        block[127] = 0u8.wrapping_sub(sum);
    }

    #[test]
    fn real_projector_edid_gives_its_identity_and_preferred_timing() {
        let e = Edid::parse(&OPTOMA_XGA).expect("valid EDID");
        assert_eq!(e.version, (1, 3));
        assert_eq!(e.manufacturer, "OTM");
        assert_eq!(e.product_code, 2069);
        assert_eq!(e.serial, 0x0a97);
        assert_eq!((e.week, e.year), (43, 2013));
        assert_eq!(e.name.as_deref(), Some("Optoma XGA"));
        assert_eq!(e.extensions, 1);
        assert_eq!(e.describe(), "Optoma XGA (OTM 0x0815)");
        let t = e.preferred.expect("a preferred timing");
        assert_eq!(t.clock_khz, 65_000);
        assert_eq!((t.hdisplay, t.vdisplay), (1024, 768));
        // Hfront 24, Hsync 135, Hback 161.
        assert_eq!((t.hsync_start, t.hsync_end, t.htotal), (1048, 1183, 1344));
        // Vfront 3, Vsync 6, Vback 29.
        assert_eq!((t.vsync_start, t.vsync_end, t.vtotal), (771, 777, 806));
        assert!(!t.hsync_positive && !t.vsync_positive && !t.interlaced);
        assert!((t.refresh_hz() - 60.003840).abs() < 1e-5);
    }

    #[test]
    fn extension_blocks_after_the_base_block_are_ignored() {
        let mut two = OPTOMA_XGA.to_vec();
        two.extend_from_slice(&[0x02; 128]);
        assert_eq!(Edid::parse(&two), Edid::parse(&OPTOMA_XGA));
    }

    #[test]
    fn flipped_bit_fails_the_checksum_naming_the_sum() {
        let mut bad = OPTOMA_XGA;
        bad[60] ^= 0x01;
        let err = Edid::parse(&bad).unwrap_err();
        assert_eq!(
            err,
            EdidError::Checksum {
                sum: 0x01,
                stored: 0x3d
            }
        );
        assert!(err.to_string().contains("checksum"), "{err}");
    }

    #[test]
    fn wrong_header_is_reported_with_the_bytes_found() {
        let mut bad = OPTOMA_XGA;
        bad[0] = 0x20;
        let err = Edid::parse(&bad).unwrap_err();
        assert!(matches!(err, EdidError::BadHeader { found } if found[0] == 0x20));
        assert!(err.to_string().contains("00 ff ff ff ff ff ff 00"), "{err}");
    }

    #[test]
    fn truncated_edid_is_too_short() {
        assert_eq!(
            Edid::parse(&OPTOMA_XGA[..100]),
            Err(EdidError::TooShort { len: 100 })
        );
        assert_eq!(Edid::parse(&[]), Err(EdidError::TooShort { len: 0 }));
    }

    #[test]
    fn version_2_is_refused() {
        let mut bad = OPTOMA_XGA;
        bad[18] = 2;
        bad[19] = 0;
        fix_checksum(&mut bad);
        assert_eq!(
            Edid::parse(&bad),
            Err(EdidError::Version {
                version: 2,
                revision: 0
            })
        );
    }

    #[test]
    fn manufacturer_letter_zero_is_refused() {
        let mut bad = OPTOMA_XGA;
        bad[8] = 0x00;
        bad[9] = 0x21; // letters 0, 1, 1
        fix_checksum(&mut bad);
        assert_eq!(
            Edid::parse(&bad),
            Err(EdidError::Manufacturer { raw: 0x0021 })
        );
    }

    #[test]
    fn constructed_1280x800_edid_with_positive_sync_and_no_name() {
        // A 1.4 block for a WXGA projector: "EPS" 0x1234, DTD 1280x800
        // CVT-RB (71.00 MHz, 48/32/80, 3/6/14, +h -v), no name descriptor.
        let mut b = [0u8; 128];
        b[..8].copy_from_slice(&HEADER);
        b[8..10].copy_from_slice(&0x1613u16.to_be_bytes()); // E=5 P=16 S=19
        b[10..12].copy_from_slice(&0x1234u16.to_le_bytes());
        b[18] = 1;
        b[19] = 4;
        let d = &mut b[54..72];
        d[..2].copy_from_slice(&7100u16.to_le_bytes());
        d[2] = (1280 & 0xff) as u8;
        d[3] = 160;
        d[4] = ((1280 >> 8) << 4) as u8;
        d[5] = (800 & 0xff) as u8;
        d[6] = 23;
        d[7] = ((800 >> 8) << 4) as u8;
        d[8] = 48;
        d[9] = 32;
        d[10] = (3 << 4) | 6;
        d[11] = 0;
        d[17] = 0x18 | 0x02; // digital separate, +hsync, -vsync
        fix_checksum(&mut b);
        let e = Edid::parse(&b).expect("valid");
        assert_eq!(e.manufacturer, "EPS");
        assert_eq!(e.product_code, 0x1234);
        assert_eq!(e.name, None);
        let t = e.preferred.expect("timing");
        assert_eq!(t.clock_khz, 71_000);
        assert_eq!((t.hsync_start, t.hsync_end, t.htotal), (1328, 1360, 1440));
        assert_eq!((t.vsync_start, t.vsync_end, t.vtotal), (803, 809, 823));
        assert!(t.hsync_positive && !t.vsync_positive);
    }
}
