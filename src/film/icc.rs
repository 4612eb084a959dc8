//! A minimal ICC v4 display profile (ICC.1:2022) for the PNG's iCCP chunk:
//! viewers that do not read cICP (most image editors, older browsers) take
//! the colour space from it. A matrix/TRC profile: the primaries adapted
//! to the profile connection space's D50 by Bradford (with the `chad` tag
//! that says so) and the sRGB transfer curve as a parametric curve.

use glam::{DMat3, DVec3};

use super::colour::{bradford, rgb_to_xyz, xy_to_xyz, Chromaticities};

/// The ICC profile connection space's illuminant, D50 as ICC.1 fixes it.
const D50: DVec3 = DVec3::new(0.9642, 1.0, 0.8249);

/// The profile of an RGB display with `primaries` (and their white) and
/// the sRGB transfer curve, named `description`.
pub fn srgb_curve_profile(description: &str, primaries: Chromaticities) -> Vec<u8> {
    let white = xy_to_xyz(primaries.white);
    let chad = bradford(white, D50);
    let colorants = chad * rgb_to_xyz(primaries);
    let xyz_tag = |v: DVec3| tagged(b"XYZ ", &[v.x, v.y, v.z]);
    // The sRGB curve: Y = (aX + b)^g for X >= d, else cX.
    let mut curve = b"para\0\0\0\0".to_vec();
    curve.extend_from_slice(&3u16.to_be_bytes());
    curve.extend_from_slice(&[0, 0]);
    for v in [2.4, 1.0 / 1.055, 0.055 / 1.055, 1.0 / 12.92, 0.04045] {
        curve.extend_from_slice(&fixed(v));
    }
    let tags: Vec<([u8; 4], Vec<u8>)> = vec![
        (*b"desc", text(description)),
        (*b"cprt", text("No copyright, use freely")),
        (*b"wtpt", xyz_tag(D50)),
        (*b"chad", tagged(b"sf32", &row_major(chad))),
        (*b"rXYZ", xyz_tag(colorants.x_axis)),
        (*b"gXYZ", xyz_tag(colorants.y_axis)),
        (*b"bXYZ", xyz_tag(colorants.z_axis)),
        (*b"rTRC", curve.clone()),
        (*b"gTRC", curve.clone()),
        (*b"bTRC", curve),
    ];
    assemble(&tags)
}

/// Header, tag table and tag data, each tag's data 4-byte aligned.
fn assemble(tags: &[([u8; 4], Vec<u8>)]) -> Vec<u8> {
    let table_end = 128 + 4 + 12 * tags.len();
    let mut data = Vec::new();
    let mut table = (tags.len() as u32).to_be_bytes().to_vec();
    for (signature, bytes) in tags {
        while data.len() % 4 != 0 {
            data.push(0);
        }
        table.extend_from_slice(signature);
        table.extend_from_slice(&((table_end + data.len()) as u32).to_be_bytes());
        table.extend_from_slice(&(bytes.len() as u32).to_be_bytes());
        data.extend_from_slice(bytes);
    }
    while data.len() % 4 != 0 {
        data.push(0);
    }
    let size = table_end + data.len();
    let mut header = Vec::with_capacity(size);
    header.extend_from_slice(&(size as u32).to_be_bytes());
    header.extend_from_slice(&[0; 4]); // preferred CMM: none
    header.extend_from_slice(&[4, 0x30, 0, 0]); // version 4.3
    header.extend_from_slice(b"mntrRGB XYZ ");
    // Creation date: fixed, so the same image gives the same bytes.
    for v in [2026u16, 1, 1, 0, 0, 0] {
        header.extend_from_slice(&v.to_be_bytes());
    }
    header.extend_from_slice(b"acsp");
    header.extend_from_slice(&[0; 24]); // platform, flags, device, attributes
    header.extend_from_slice(&0u32.to_be_bytes()); // perceptual intent
    for v in [D50.x, D50.y, D50.z] {
        header.extend_from_slice(&fixed(v));
    }
    header.extend_from_slice(&[0; 4 + 16 + 28]); // creator, profile ID, reserved
    debug_assert_eq!(header.len(), 128);
    header.extend_from_slice(&table);
    header.extend_from_slice(&data);
    header
}

/// An s15Fixed16Number.
fn fixed(v: f64) -> [u8; 4] {
    ((v * 65536.0).round() as i32).to_be_bytes()
}

/// A tag of `kind` holding s15Fixed16Numbers.
fn tagged(kind: &[u8; 4], values: &[f64]) -> Vec<u8> {
    let mut out = kind.to_vec();
    out.extend_from_slice(&[0; 4]);
    for &v in values {
        out.extend_from_slice(&fixed(v));
    }
    out
}

/// A multiLocalizedUnicodeType with one en-US record.
fn text(s: &str) -> Vec<u8> {
    let utf16: Vec<u8> = s.encode_utf16().flat_map(|c| c.to_be_bytes()).collect();
    let mut out = b"mluc\0\0\0\0".to_vec();
    out.extend_from_slice(&1u32.to_be_bytes());
    out.extend_from_slice(&12u32.to_be_bytes());
    out.extend_from_slice(b"enUS");
    out.extend_from_slice(&(utf16.len() as u32).to_be_bytes());
    out.extend_from_slice(&28u32.to_be_bytes());
    out.extend_from_slice(&utf16);
    out
}

fn row_major(m: DMat3) -> [f64; 9] {
    m.transpose().to_cols_array()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::colour::ColourSpace;

    #[test]
    fn the_profile_is_well_formed() {
        let p = srgb_curve_profile("Display P3", ColourSpace::DisplayP3Linear.chromaticities());
        assert_eq!(
            u32::from_be_bytes(p[0..4].try_into().unwrap()) as usize,
            p.len()
        );
        assert_eq!(&p[36..40], b"acsp");
        assert_eq!(p.len() % 4, 0);
        let count = u32::from_be_bytes(p[128..132].try_into().unwrap()) as usize;
        assert_eq!(count, 10);
        for i in 0..count {
            let e = &p[132 + 12 * i..144 + 12 * i];
            let offset = u32::from_be_bytes(e[4..8].try_into().unwrap()) as usize;
            let size = u32::from_be_bytes(e[8..12].try_into().unwrap()) as usize;
            assert_eq!(offset % 4, 0);
            assert!(offset + size <= p.len());
        }
        // The colorants add up to the PCS white (D50), to the fixed point's
        // resolution.
        let read = |at: usize| {
            let v = |k: usize| {
                i32::from_be_bytes(p[at + 8 + 4 * k..at + 12 + 4 * k].try_into().unwrap()) as f64
                    / 65536.0
            };
            DVec3::new(v(0), v(1), v(2))
        };
        let offset_of = |sig: &[u8]| {
            (0..count)
                .map(|i| &p[132 + 12 * i..144 + 12 * i])
                .find(|e| &e[0..4] == sig)
                .map(|e| u32::from_be_bytes(e[4..8].try_into().unwrap()) as usize)
                .unwrap()
        };
        let sum = read(offset_of(b"rXYZ")) + read(offset_of(b"gXYZ")) + read(offset_of(b"bXYZ"));
        assert!((sum - D50).abs().max_element() < 1e-4, "{sum}");
    }
}
