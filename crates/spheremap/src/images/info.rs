//! The report `spheremap info` prints and Python's `spheremap.info` returns: one struct, so the
//! two cannot disagree.

use super::codec::{inspect, ReadOptions};
use super::note::MapNote;
use crate::base::error::Result;
use crate::mappings::cube::FACE_NAMES;
use serde::Serialize;
use std::path::Path;

/// What a file is and holds.  Serialised as the JSON of `spheremap info --json` and as the dict
/// of Python's `spheremap.info`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InfoReport {
    /// The path as given.
    pub file: String,
    /// The format, recognised by the file's first bytes.
    pub format: &'static str,
    /// The other format the file's extension names, when it disagrees with the content.
    pub extension_names: Option<&'static str>,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    /// Per channel: min, max and mean over the finite values (None where there are none).
    pub stats: Vec<ChannelStats>,
    /// How many NaN, infinite and negative values the pixels hold.
    pub nan: usize,
    pub inf: usize,
    pub negative: usize,
    /// (x, y) of the first pixel holding a NaN or Inf.
    pub first_non_finite: Option<(usize, usize)>,
    /// A guess of the mapping from the shape, labelled as a guess.
    pub mapping_guess: MappingGuess,
    /// What spheremap noted in the file when it wrote it ([`super::note`]), if anything.
    pub recorded: Option<Recorded>,
    /// The note's text as the file holds it (for a DDS cube, which has no place for one, the
    /// face stack it reads as).
    pub note: Option<String>,
    /// For KTX2 and DDS: whether it is a cube texture and every level's size (a cube's faces).
    pub texture: Option<TextureInfo>,
}

/// What a KTX2 or DDS file holds beyond its level 0.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TextureInfo {
    pub cube: bool,
    /// (width, height) of each level, level 0 first.
    pub levels: Vec<(usize, usize)>,
}

/// One channel's statistics over its finite values.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelStats {
    pub channel: String,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub mean: Option<f64>,
}

/// The mapping an image's shape suggests, never read from the file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MappingGuess {
    pub name: &'static str,
    pub reason: &'static str,
    /// Always true: this is a guess.
    pub is_a_guess: bool,
}

/// A map note, spelled out.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recorded {
    pub mapping: &'static str,
    pub preset: &'static str,
    /// The cube layout of a cube map in one image.
    pub layout: Option<&'static str>,
    /// The face of one cube-face file of six (px, nx, py, ny, pz, nz).
    pub face: Option<&'static str>,
    /// The view's world look and up vectors (None for the identity view); sequences, so
    /// Python reads them as lists like every other vector it is given.
    pub look: Option<Vec<f64>>,
    pub up: Option<Vec<f64>>,
}

impl Recorded {
    pub fn of(note: &MapNote) -> Recorded {
        Recorded {
            mapping: note.mapping.name(),
            preset: note.mapping.preset_name(),
            layout: note.layout.map(|l| l.name()),
            face: note.face.map(|f| FACE_NAMES[f]),
            look: note.view.map(|v| v.0.to_vec()),
            up: note.view.map(|v| v.1.to_vec()),
        }
    }
}

/// Reads `path` and reports on it.
pub fn info(path: &Path, opts: &ReadOptions) -> Result<InfoReport> {
    let i = inspect(path, opts)?;
    let finite = |v: f64| v.is_finite().then_some(v);
    Ok(InfoReport {
        file: path.display().to_string(),
        format: i.format.name(),
        extension_names: i.extension_mismatch.map(|f| f.name()),
        width: i.width,
        height: i.height,
        channels: i.channels,
        stats: i
            .channel_names
            .iter()
            .zip(&i.stats)
            .map(|(n, s)| ChannelStats {
                channel: n.clone(),
                min: finite(s.0 as f64),
                max: finite(s.1 as f64),
                mean: finite(s.2),
            })
            .collect(),
        nan: i.nan_count,
        inf: i.inf_count,
        negative: i.negative_count,
        first_non_finite: i.first_non_finite,
        mapping_guess: MappingGuess {
            name: i.mapping_guess.0,
            reason: i.mapping_guess.1,
            is_a_guess: true,
        },
        recorded: i
            .note
            .as_deref()
            .and_then(MapNote::parse)
            .as_ref()
            .map(Recorded::of),
        note: i.note,
        texture: if i.format.is_container() {
            let t = super::codec::read_texture(path, opts)?;
            let (w, h) = t.size();
            Some(TextureInfo {
                cube: t.cube,
                levels: (0..t.levels.len())
                    .map(|k| super::container::Texture::level_size(w, h, k))
                    .collect(),
            })
        } else {
            None
        },
    })
}
