//! What spheremap records in the maps it writes: the mapping and its conventions, as a short
//! text note, so that `spheremap info` can say what a file is instead of guessing, and
//! `spheremap convert` can read it without `--from`.
//!
//! The note is `mapping=NAME preset=PRESET`, then ` layout=LAYOUT` for a cube map in one image
//! or ` face=px` (nx, py, …) for one face file of six — the names `spheremap conventions`
//! prints — and, for a map made for a turned view, ` look=X,Y,Z up=X,Y,Z` (world vectors, as
//! `--look`/`--up` take them; [`crate::frame::view`]).  Each format keeps it where its readers expect metadata and others skip it:
//!
//! | format | where | other readers |
//! |---|---|---|
//! | OpenEXR | a string attribute `spheremap` in the header | listed as an extra attribute |
//! | PNG | a `tEXt` chunk, keyword `spheremap`, right after `IHDR` | ignored (ancillary chunk) |
//! | JPEG | a `COM` (comment) segment after `SOI` (and the JFIF `APP0`) | ignored |
//! | Radiance HDR | a header line `SPHEREMAP=…` before the blank line | unknown variables skipped |
//! | PFM | none (the format has no place for it) | – |
//! | KTX2 | a key/value entry `spheremap` | unknown keys skipped |
//! | DDS | none; a cube file reads as `mapping=cube preset=gl layout=vstrip` | – |
//!
//! A note is a record of how spheremap wrote the file, not a proof of what the pixels show: an
//! image edited elsewhere and saved keeps whatever its editor keeps.

use crate::base::error::{Error, Result};
use crate::images::cube_layout::Layout;
use crate::images::format::Format;
use crate::mappings::cube::FACE_NAMES;
use crate::mappings::mapping::Mapping;

/// The key the note is stored under (EXR attribute name, PNG `tEXt` keyword).
pub const KEY: &str = "spheremap";

/// The mapping a file records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapNote {
    pub mapping: Mapping,
    /// For a cube map in one image.
    pub layout: Option<Layout>,
    /// For one face file of six: its index in GL order (+X, −X, +Y, −Y, +Z, −Z).
    pub face: Option<usize>,
    /// For a map made for a turned view: the world `look` and `up` vectors of that view
    /// ([`crate::frame::view`]); `None` for the identity view.
    pub view: Option<([f64; 3], [f64; 3])>,
}

/// What a map written from memory is, as its writer is told (Python's `write_image(...,
/// mapping=…, preset=…, layout=…, look=…, up=…)`): read from these fields, checked, and
/// turned into the note recorded in the file.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoteRequest {
    pub mapping: Option<String>,
    pub preset: Option<String>,
    /// The cube layout of a cube map written as one image (a cube map's needs one).
    pub layout: Option<String>,
    /// The view it was made for: world directions of its eye's −Z and +Y.
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
}

impl NoteRequest {
    /// The note, checked (errors name the field); `None` when no mapping is named.
    pub fn resolve(&self) -> Result<Option<MapNote>> {
        let Some(name) = &self.mapping else {
            if self.preset.is_some()
                || self.layout.is_some()
                || self.look.is_some()
                || self.up.is_some()
            {
                return Err(Error::param(
                    "mapping",
                    "preset, layout, look and up describe a mapping; name it",
                ));
            }
            return Ok(None);
        };
        let mapping = Mapping::parse(name, self.preset.as_deref())
            .map_err(|e| crate::mappings::mapping::name_fields(e, "mapping", "preset"))?;
        let layout = self.layout.as_deref().map(Layout::parse).transpose()?;
        if layout.is_some() != matches!(mapping, Mapping::Cube(_)) {
            return Err(Error::param(
                "layout",
                "a cube map written as one image needs its layout, and only a cube map has one",
            ));
        }
        let view = match self.look {
            Some(l) => {
                let v = crate::frame::view::look_up(l, self.up.unwrap_or([0.0, 1.0, 0.0]))?;
                crate::frame::view::as_look_up(&v)
            }
            None if self.up.is_some() => return Err(Error::param("up", "needs look")),
            None => None,
        };
        Ok(Some(MapNote {
            mapping,
            layout,
            face: None,
            view,
        }))
    }
}

impl MapNote {
    /// The note's text.
    pub fn text(&self) -> String {
        let mut t = format!(
            "mapping={} preset={}",
            self.mapping.name(),
            self.mapping.preset_name()
        );
        if let Some(l) = self.layout {
            t += &format!(" layout={}", l.name());
        }
        if let Some(f) = self.face {
            t += &format!(" face={}", FACE_NAMES[f]);
        }
        if let Some((l, u)) = self.view {
            // Shortest round-trip decimals: the view reads back to the bit.
            t += &format!(
                " look={},{},{} up={},{},{}",
                l[0], l[1], l[2], u[0], u[1], u[2]
            );
        }
        t
    }

    /// Parses a note; `None` for text that is not one (a note from a newer version with keys
    /// this one does not know still parses: unknown keys are skipped).
    pub fn parse(text: &str) -> Option<MapNote> {
        let (mut mapping, mut preset, mut layout, mut face) = (None, None, None, None);
        let (mut look, mut up) = (None, None);
        let vec3 = |v: &str| -> Option<[f64; 3]> {
            let p: Vec<f64> = v
                .split(',')
                .map(|x| x.parse().ok())
                .collect::<Option<_>>()?;
            let v: [f64; 3] = p.try_into().ok()?;
            v.iter().all(|x| x.is_finite()).then_some(v)
        };
        for kv in text.split_whitespace() {
            let (k, v) = kv.split_once('=')?;
            match k {
                "mapping" => mapping = Some(v),
                "preset" => preset = Some(v),
                "layout" => layout = Some(Layout::parse(v).ok()?),
                "face" => face = Some(FACE_NAMES.iter().position(|f| *f == v)?),
                "look" => look = Some(vec3(v)?),
                "up" => up = Some(vec3(v)?),
                _ => {}
            }
        }
        let view = match (look, up) {
            (Some(l), Some(u)) => {
                crate::frame::view::look_up(l, u).ok()?; // a degenerate pair is no view
                Some((l, u))
            }
            (None, None) => None,
            _ => return None,
        };
        Some(MapNote {
            mapping: Mapping::parse(mapping?, preset).ok()?,
            layout,
            face,
            view,
        })
    }
}

/// Adds the note to an encoded PNG, JPEG or HDR file (EXR writes it as it encodes; PFM has no
/// place for it and is returned unchanged).
pub fn insert(format: Format, mut bytes: Vec<u8>, text: &str) -> Vec<u8> {
    match format {
        Format::Png => {
            // Signature (8) + IHDR (4 length + 4 type + 13 data + 4 CRC) = 33 bytes; IHDR must
            // come first, and a tEXt chunk may go anywhere after it.
            if bytes.len() < 33 {
                return bytes;
            }
            let mut data = KEY.as_bytes().to_vec();
            data.push(0);
            data.extend(text.bytes().filter(|b| (0x20..0x7f).contains(b)));
            let mut chunk = (data.len() as u32).to_be_bytes().to_vec();
            let mut body = b"tEXt".to_vec();
            body.extend(&data);
            let crc = crc32fast::hash(&body);
            chunk.extend(&body);
            chunk.extend(crc.to_be_bytes());
            bytes.splice(33..33, chunk);
            bytes
        }
        Format::Jpeg => {
            // A COM segment: FF FE, a 2-byte length that counts itself, the text.  It goes
            // after SOI (FF D8) and after the JFIF APP0 segment when there is one, which JFIF
            // wants right after SOI.
            let body = format!("{KEY}: {text}");
            let mut seg = vec![0xff, 0xfe];
            seg.extend(((body.len() + 2) as u16).to_be_bytes());
            seg.extend(body.bytes());
            let at = match bytes.get(2..6) {
                Some([0xff, 0xe0, hi, lo]) => 4 + u16::from_be_bytes([*hi, *lo]) as usize,
                _ => 2,
            };
            if at > bytes.len() {
                return bytes;
            }
            bytes.splice(at..at, seg);
            bytes
        }
        Format::Hdr => {
            // After the first line (#?RADIANCE), among the header's variables.
            let Some(nl) = bytes.iter().position(|&b| b == b'\n') else {
                return bytes;
            };
            let line = format!("SPHEREMAP={text}\n");
            bytes.splice(nl + 1..nl + 1, line.bytes());
            bytes
        }
        Format::Exr | Format::Pfm | Format::Webp | Format::Ktx2 | Format::Dds => bytes,
    }
}

/// The note a file's bytes hold, if any (OpenEXR, PNG, JPEG, Radiance HDR or KTX2; a cube
/// texture's face stack for KTX2 and DDS without one).
pub fn read(bytes: &[u8]) -> Option<String> {
    match Format::sniff(bytes)? {
        Format::Png => read_png(bytes),
        Format::Jpeg => read_jpeg(bytes),
        Format::Hdr => read_hdr(bytes),
        Format::Exr => read_exr(bytes),
        Format::Ktx2 | Format::Dds => read_container(bytes),
        Format::Pfm | Format::Webp => None,
    }
}

/// The note in the file at `path`, read from its first 4 MiB (every format keeps it in its
/// header), if it records one.  A file that cannot be read is an error naming it (missing,
/// not a regular file, empty): the first thing a command learns of its input is why it
/// cannot have it.
pub fn read_file(path: &std::path::Path) -> crate::base::error::Result<Option<String>> {
    use crate::base::error::Error;
    use std::io::Read;
    crate::base::files::check_input(path)?;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(4 << 20).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    Ok(read(&head))
}

/// The note a KTX2 file keeps under [`KEY`]; else, for a cube texture (KTX2 or DDS), the face
/// stack it reads as.
fn read_container(bytes: &[u8]) -> Option<String> {
    use crate::images::container;
    if let Some(v) = container::ktx2_value(bytes, KEY) {
        return Some(String::from_utf8_lossy(&v).into_owned());
    }
    container::is_cube(bytes).then(|| {
        MapNote {
            mapping: Mapping::parse("cube", Some("gl")).expect("the gl cube"),
            layout: Some(Layout::VStrip),
            face: None,
            view: None,
        }
        .text()
    })
}

fn read_png(bytes: &[u8]) -> Option<String> {
    let mut at = 8;
    while at + 12 <= bytes.len() {
        let len = u32::from_be_bytes(bytes[at..at + 4].try_into().ok()?) as usize;
        let kind = &bytes[at + 4..at + 8];
        let data = bytes.get(at + 8..(at + 8).checked_add(len)?)?;
        if kind == b"IDAT" || kind == b"IEND" {
            return None;
        }
        if kind == b"tEXt" {
            if let Some(text) = data
                .strip_prefix(KEY.as_bytes())
                .and_then(|d| d.strip_prefix(&[0]))
            {
                return Some(String::from_utf8_lossy(text).into_owned());
            }
        }
        at += 12 + len;
    }
    None
}

fn read_jpeg(bytes: &[u8]) -> Option<String> {
    let mut at = 2;
    let prefix = format!("{KEY}: ");
    while at + 4 <= bytes.len() && bytes[at] == 0xff {
        let marker = bytes[at + 1];
        // Start of scan: the entropy-coded data follows; no more header segments.
        if marker == 0xda {
            return None;
        }
        let len = u16::from_be_bytes([bytes[at + 2], bytes[at + 3]]) as usize;
        let body = bytes.get(at + 4..(at + 2).checked_add(len)?)?;
        if marker == 0xfe {
            if let Some(text) = body.strip_prefix(prefix.as_bytes()) {
                return Some(String::from_utf8_lossy(text).into_owned());
            }
        }
        at += 2 + len;
    }
    None
}

fn read_hdr(bytes: &[u8]) -> Option<String> {
    // The header: lines up to the first empty one (at most a few KiB).
    let head = &bytes[..bytes.len().min(1 << 16)];
    for line in head.split(|&b| b == b'\n').skip(1) {
        if line.is_empty() {
            break;
        }
        if let Some(text) = line.strip_prefix(b"SPHEREMAP=") {
            return Some(String::from_utf8_lossy(text).trim_end().to_string());
        }
    }
    None
}

fn read_exr(bytes: &[u8]) -> Option<String> {
    use exr::meta::attribute::AttributeValue;
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).ok()?;
    let h = meta.headers.first()?;
    let v = h
        .own_attributes
        .other
        .iter()
        .chain(h.shared_attributes.other.iter())
        .find(|(k, _)| *k == KEY)?
        .1;
    match v {
        AttributeValue::Text(t) => Some(t.to_string()),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_note_request_is_checked_field_by_field() {
        let r = |json: &str| serde_json::from_str::<NoteRequest>(json).unwrap().resolve();
        assert_eq!(r("{}").unwrap(), None);
        let n = r(r#"{"mapping": "cube", "layout": "hcross", "look": [1, 0, 0]}"#)
            .unwrap()
            .unwrap();
        assert!(n.text().contains("layout=hcross"), "{}", n.text());
        for (json, field) in [
            (r#"{"preset": "gl"}"#, "mapping"),
            (r#"{"mapping": "globe"}"#, "mapping"),
            (r#"{"mapping": "sphere", "preset": "nope"}"#, "preset"),
            (r#"{"mapping": "cube"}"#, "layout"),
            (r#"{"mapping": "sphere", "layout": "hcross"}"#, "layout"),
            (r#"{"mapping": "sphere", "up": [0, 1, 0]}"#, "up"),
            (r#"{"mapping": "sphere", "look": [0, 0, 0]}"#, "look"),
        ] {
            let e = r(json).unwrap_err().to_string();
            assert!(e.starts_with(&format!("{field}: ")), "{json}: {e}");
        }
    }
}
