//! Writing OpenEXR files (via the `exr` crate): one part, float32 channels
//! named `layer.channel` (the multi-layer naming that OpenEXR tools, Nuke,
//! Blender and OpenImageIO read as layers), and text attributes for the
//! metadata. Written to memory, then atomically to disk.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::*;

use crate::error::{Error, Result};
use crate::output::write_atomic;

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
    let fail = |message: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(message),
    };
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
    write_atomic(path, bytes.get_ref())
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

/// Reads back the channels and text attributes of an EXR written by
/// [`write_exr`]: for tests and tools.
pub fn read_exr(path: &Path) -> Result<ExrContents> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
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
    let attributes = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
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
}
