//! Writing OpenEXR files (via the `exr` crate): one part, float32 channels
//! named `layer.channel` (the multi-layer naming that OpenEXR tools, Nuke,
//! Blender and OpenImageIO read as layers), and text attributes for the
//! metadata. Written to memory, then atomically to disk.
//!
//! The `exr` crate keeps a header's attributes in a hash map and writes
//! them in its (randomly seeded) iteration order, so the same image would
//! give different bytes on every run. [`canonical_attribute_order`] sorts
//! them by name in the written header (same attributes, same header size,
//! so the chunk offsets that follow stay valid): the same image gives the
//! same bytes.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::*;

use crate::error::{Error, Result};
use crate::io::atomic::write_atomic;

/// A wavelength as an EXR layer label: `540nm`, or `337p5nm` (no dot,
/// which would split the layer name).
pub fn wavelength_label(lambda_nm: f64) -> String {
    format!("{lambda_nm}nm").replace('.', "p")
}

/// A named float channel of `width × height` samples, row-major with row 0
/// the first row of the image.
pub struct Channel {
    pub name: String,
    pub samples: Vec<f32>,
}

/// Writes an EXR of `width × height` with the given channels and text
/// attributes (`key`, `value`).
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<Channel>,
    attributes: &[(String, String)],
) -> Result<()> {
    let fail = |message: String| Error::io(path, std::io::Error::other(message));
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|c| AnyChannel::new(c.name.as_str(), FlatSamples::F32(c.samples)))
        .collect();
    let mut layer_attributes = LayerAttributes::default();
    for (k, v) in attributes {
        layer_attributes
            .other
            .insert(Text::from(k.as_str()), AttributeValue::Text(Text::from(v.as_str())));
    }
    let layer = Layer::new(
        (width, height),
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    let mut bytes = Cursor::new(Vec::new());
    image.write().to_buffered(&mut bytes).map_err(|e| fail(e.to_string()))?;
    let mut bytes = bytes.into_inner();
    canonical_attribute_order(&mut bytes).map_err(|e| fail(format!("unexpected EXR header as written: {e}")))?;
    write_atomic(path, &bytes)
}

/// The magic number of an OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// Version flag of a multi-part file (a header per part).
const MULTIPART_FLAG: u32 = 0x1000;

/// Sorts the attributes of the single-part header of the OpenEXR file
/// `bytes` by name, in place. The header is the magic number, the version
/// field and then the attributes (name and type as null-terminated
/// strings, an i32 byte count, the value), closed by a null byte.
pub fn canonical_attribute_order(bytes: &mut [u8]) -> std::result::Result<(), String> {
    if bytes.len() < 8 || bytes[..4] != EXR_MAGIC {
        return Err("not an OpenEXR file".into());
    }
    let version = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    if version & MULTIPART_FLAG != 0 {
        return Err("a multi-part file".into());
    }
    let start = 8;
    let c_string_end = |at: usize| -> std::result::Result<usize, String> {
        bytes[at..]
            .iter()
            .position(|&b| b == 0)
            .map(|n| at + n)
            .ok_or_else(|| "unterminated attribute name or type".to_string())
    };
    // (name, start, end) of each attribute.
    let mut attributes: Vec<(Vec<u8>, usize, usize)> = Vec::new();
    let mut at = start;
    loop {
        if at >= bytes.len() {
            return Err("header without its closing null byte".into());
        }
        if bytes[at] == 0 {
            break;
        }
        let name_end = c_string_end(at)?;
        let type_end = c_string_end(name_end + 1)?;
        let size_at = type_end + 1;
        let size = bytes
            .get(size_at..size_at + 4)
            .map(|b| i32::from_le_bytes(b.try_into().expect("4 bytes")))
            .ok_or("truncated attribute size")?;
        let end = usize::try_from(size)
            .ok()
            .and_then(|n| (size_at + 4).checked_add(n))
            .filter(|&e| e <= bytes.len())
            .ok_or("attribute size out of range")?;
        attributes.push((bytes[at..name_end].to_vec(), at, end));
        at = end;
    }
    let mut sorted = attributes.clone();
    sorted.sort_by(|a, b| a.0.cmp(&b.0));
    let mut header = Vec::with_capacity(at - start);
    for (_, a, b) in &sorted {
        header.extend_from_slice(&bytes[*a..*b]);
    }
    bytes[start..at].copy_from_slice(&header);
    Ok(())
}

/// The largest ratio of decoded pixel bytes to file bytes of an EXR that
/// the exr crate reads: PXR24's, deflate's 1032:1 (RFC 1951: a 258-byte
/// match in about 2 bits) times 4/3 (32-bit floats stored in 24 bits).
/// ZIP reaches 1032:1, PIZ's Huffman run codes about 450:1, RLE 64:1, B44
/// about 11:1.
const MAX_EXPANSION: u128 = 1376;

/// What [`read_exr`] returns.
pub struct ExrContents {
    pub width: usize,
    pub height: usize,
    pub channels: Vec<Channel>,
    /// Text attributes (key, value).
    pub attributes: Vec<(String, String)>,
}

/// The text attributes of the first layer of the EXR at `path`, from its
/// header alone (no pixel is read); `None` if it is not a readable EXR.
pub fn read_exr_attributes(path: &Path) -> Option<Vec<(String, String)>> {
    let meta = MetaData::read_from_file(path, false).ok()?;
    let header = meta.headers.first()?;
    Some(text_attributes(&header.own_attributes.other))
}

/// The text-valued attributes of a map, as (key, value).
fn text_attributes(map: &std::collections::HashMap<Text, AttributeValue>) -> Vec<(String, String)> {
    map.iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect()
}

/// Reads back the channels and text attributes of an EXR written by
/// [`write_exr`]: for tests and tools.
pub fn read_exr(path: &Path) -> Result<ExrContents> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_exr_bytes(&bytes, &path.display().to_string())
}

/// Reads the channels and text attributes of the first layer of an EXR
/// held in memory; `name` names it in errors. Every way the bytes can be
/// wrong is a [`Error::Data`] naming the file.
pub fn read_exr_bytes(bytes: &[u8], name: &str) -> Result<ExrContents> {
    let bad = |message: &str| Error::data(name, format!("not a readable OpenEXR file: {message}"));
    // The exr crate allocates every channel of a layer before it reads a
    // block, at the size the header states: refuse sizes the bytes cannot
    // hold (a damaged header of a 1 kB file can state 2¹⁶ × 2¹⁶ pixels).
    let meta = MetaData::read_from_buffered(bytes, false).map_err(|e| bad(&e.to_string()))?;
    for header in meta.headers.iter() {
        let (width, height) = (header.layer_size.0 as u128, header.layer_size.1 as u128);
        let pixel_bytes: u128 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u128)
            .sum();
        if width * height * pixel_bytes.max(1) > MAX_EXPANSION * bytes.len() as u128 {
            return Err(bad(&format!(
                "a layer of {width} × {height} pixels and {} channels cannot be held in {} bytes",
                header.channels.list.len(),
                bytes.len()
            )));
        }
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        // The images read back are small; the parallel reader would start a
        // thread pool for each.
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| bad(&e.to_string()))?;
    let layer = image.layer_data;
    let size = layer.size;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| Channel {
            name: c.name.to_string(),
            samples: c.sample_data.values_as_f32().collect(),
        })
        .collect();
    let attributes = text_attributes(&layer.attributes.other);
    Ok(ExrContents {
        width: size.0,
        height: size.1,
        channels,
        attributes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_and_attributes_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.exr");
        let a: Vec<f32> = (0..6).map(|i| i as f32 * 0.5).collect();
        write_exr(
            &p,
            3,
            2,
            vec![
                Channel {
                    name: "540nm.T".into(),
                    samples: a.clone(),
                },
                Channel {
                    name: "blocked".into(),
                    samples: vec![0.0; 6],
                },
            ],
            &[("units".into(), "1".into())],
        )
        .unwrap();
        let exr = read_exr(&p).unwrap();
        assert_eq!((exr.width, exr.height), (3, 2));
        let t = exr.channels.iter().find(|c| c.name == "540nm.T").unwrap();
        assert_eq!(t.samples, a);
        assert!(exr.attributes.contains(&("units".to_string(), "1".to_string())));
    }

    #[test]
    fn the_same_image_gives_the_same_bytes_with_attributes_in_name_order() {
        let dir = tempfile::tempdir().unwrap();
        // Enough attributes that a hash map's order differs between maps.
        let attributes: Vec<(String, String)> = (0..24)
            .map(|k| (format!("key{:02}", (k * 7) % 24), format!("value {k}")))
            .collect();
        let write = |name: &str| {
            let p = dir.path().join(name);
            let channel = Channel {
                name: "550nm_a000.I".into(),
                samples: (0..12).map(|i| i as f32).collect(),
            };
            write_exr(&p, 4, 3, vec![channel], &attributes).unwrap();
            std::fs::read(p).unwrap()
        };
        let first = write("a.exr");
        for k in 0..4 {
            assert_eq!(write(&format!("{k}.exr")), first, "run {k}");
        }
        // The attributes are in name order in the header.
        let text = String::from_utf8_lossy(&first);
        let positions: Vec<usize> = (0..24).map(|k| text.find(&format!("key{k:02}\0")).unwrap()).collect();
        assert!(positions.windows(2).all(|w| w[0] < w[1]), "{positions:?}");
        // And the file still reads, whole and from its header alone.
        let exr = read_exr(&dir.path().join("a.exr")).unwrap();
        assert_eq!(exr.attributes.iter().filter(|(k, _)| k.starts_with("key")).count(), 24);
        let mut header = read_exr_attributes(&dir.path().join("a.exr")).unwrap();
        let mut whole = exr.attributes;
        header.sort();
        whole.sort();
        assert_eq!(header, whole);
    }

    #[test]
    fn canonical_order_refuses_what_is_not_a_single_part_exr() {
        assert!(canonical_attribute_order(&mut b"not an exr".to_vec()).is_err());
        let mut truncated = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, b'a', 0, b'i', b'n', b't', 0, 4, 0];
        assert!(canonical_attribute_order(&mut truncated).is_err());
        let mut multipart = vec![0x76, 0x2f, 0x31, 0x01, 2, 0x10, 0, 0, 0];
        assert!(canonical_attribute_order(&mut multipart).is_err());
        let mut empty = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, 0];
        assert!(canonical_attribute_order(&mut empty).is_ok());
    }
}
