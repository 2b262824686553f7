//! The image file formats spheremap reads and writes, recognised by content or by name.

use std::path::Path;

/// File formats spheremap reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Exr,
    Hdr,
    Pfm,
    Png,
    Jpeg,
    Webp,
    /// Khronos KTX 2.0 (float or encoded textures, [`crate::images::container`]).
    Ktx2,
    /// DirectDraw Surface (float, BC6H or RGB9E5 textures, [`crate::images::container`]).
    Dds,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::Exr => "OpenEXR",
            Format::Hdr => "Radiance HDR",
            Format::Pfm => "PFM",
            Format::Png => "PNG",
            Format::Jpeg => "JPEG",
            Format::Webp => "WebP",
            Format::Ktx2 => "KTX2",
            Format::Dds => "DDS",
        }
    }
    /// The GPU texture containers (mip levels, cube faces).
    pub fn is_container(self) -> bool {
        matches!(self, Format::Ktx2 | Format::Dds)
    }
    /// Whether `path`'s extension names a texture container (`.ktx2`, `.dds`).
    pub fn names_container(path: &str) -> bool {
        Format::from_extension(Path::new(path)).is_some_and(|f| f.is_container())
    }
    /// Low dynamic range formats hold sRGB-encoded values.
    pub fn is_ldr(self) -> bool {
        matches!(self, Format::Png | Format::Jpeg | Format::Webp)
    }
    /// The format a file name's extension names, if any.
    pub fn from_extension(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "exr" => Format::Exr,
            "hdr" | "rgbe" | "pic" => Format::Hdr,
            "pfm" => Format::Pfm,
            "png" => Format::Png,
            "jpg" | "jpeg" => Format::Jpeg,
            "webp" => Format::Webp,
            "ktx2" => Format::Ktx2,
            "dds" => Format::Dds,
            _ => return None,
        })
    }
    /// The format the first bytes of a file identify.
    pub fn sniff(head: &[u8]) -> Option<Format> {
        if head.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
            Some(Format::Exr)
        } else if head.starts_with(b"\x89PNG\r\n\x1a\n") {
            Some(Format::Png)
        } else if head.starts_with(&[0xff, 0xd8, 0xff]) {
            Some(Format::Jpeg)
        } else if head.len() >= 12 && &head[..4] == b"RIFF" && &head[8..12] == b"WEBP" {
            Some(Format::Webp)
        } else if head.starts_with(b"#?RADIANCE") || head.starts_with(b"#?RGBE") {
            Some(Format::Hdr)
        } else if head.starts_with(&super::container::KTX2_MAGIC) {
            Some(Format::Ktx2)
        } else if head.starts_with(super::container::DDS_MAGIC) {
            Some(Format::Dds)
        } else if head.starts_with(b"PF") || head.starts_with(b"Pf") {
            Some(Format::Pfm)
        } else {
            None
        }
    }
}
