//! Layer 8, batch: a library of maps turned into their assets by one recipe.
//!
//! * [`Recipe`]: the TOML recipe — a list of outputs, each one spheremap operation (`convert`,
//!   `bake-matcap`, `prefilter`, `irradiance`, and on photos `from-photo` and `from-fisheye`)
//!   with the same options as its CLI subcommand,
//!   spelled as the core's request fields, and an output name pattern.  [`Recipe::parse`]
//!   validates the whole recipe before any work: one line naming the recipe file, the key and
//!   the problem.
//! * [`plan`]: the inputs (files, folders, globs) expanded and sorted, each input's output
//!   names made from the patterns, collisions refused, and what a rerun may skip.
//! * [`run_task`]: one input through every output of the recipe.  Each file is written
//!   atomically (a temporary file renamed into place), so an interrupted or killed run leaves
//!   no partial output; an error is the input's alone and is recorded, not raised.
//! * [`Manifest`]: `DIR/manifest.jsonl`, one [`Record`] per input (the last line for an input
//!   wins; a torn last line is ignored), rewritten compactly at the start of each run.
//! * [`run_local`]: the tasks on a pool of local threads; the same [`run_task`] runs one input
//!   per Dask task from the Python package.

use crate::base::error::{Error, Result};
use crate::base::limits::check_map_size;
use crate::images::codec::{ReadOptions, WriteOptions};
use crate::images::compress::Encoding;
use crate::images::cube_layout::Layout;
use crate::images::envmap::{read_env_layout, EnvFiles, EnvReader};
use crate::images::format::Format;
use crate::images::Image;
use crate::jobs::bake_matcap::MatcapRequest;
use crate::jobs::convert::ConvertJob;
use crate::jobs::env_job::EnvJob;
use crate::jobs::irradiance::IrradianceRequest;
use crate::jobs::prefilter::PrefilterRequest;
use crate::mappings::mapping::Mapping;
use crate::resample::Progress;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// The operations a recipe's output may name, as `op = "…"`.
pub const OPS: &[&str] = &[
    "convert",
    "bake-matcap",
    "prefilter",
    "irradiance",
    #[cfg(feature = "photo")]
    "from-photo",
    #[cfg(feature = "photo")]
    "from-fisheye",
];
/// The placeholders of an output name, filled per input: the input's file name without its
/// extension, with it, the extension alone (no dot), and the input's position in the sorted
/// list of inputs (from 0).  `{face}` (cube faces as six files) and `{level}` (a prefiltered
/// chain as one file per level) pass through to the operation.
pub const PLACEHOLDERS: [&str; 4] = ["stem", "name", "ext", "index"];
/// The manifest's file name in the output folder.
pub const MANIFEST: &str = "manifest.jsonl";
/// Keys every output table takes besides its operation's own.
const COMMON_KEYS: [&str; 2] = ["op", "name"];
/// Output encoding keys every operation but `convert` takes (`convert` has them among its own).
const WRITE_KEYS: [&str; 5] = ["half", "clamp_half", "png16", "encode", "zstd"];

/// How the operations other than `convert` write their images.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WriteFlags {
    pub half: bool,
    pub clamp_half: bool,
    pub png16: bool,
    /// KTX2/DDS texel encoding ([`crate::images::compress`]).
    pub encode: Encoding,
    /// KTX2 Zstandard supercompression level.
    pub zstd: Option<i32>,
}

impl WriteFlags {
    fn options(&self) -> WriteOptions {
        WriteOptions {
            linear: false,
            png16: self.png16,
            half: self.half,
            clamp_half: self.clamp_half,
            encode: self.encode,
            zstd: self.zstd,
        }
    }
}

/// One output of a recipe: what to make and the name pattern of its file(s).
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    Convert(ConvertJob),
    BakeMatcap(MatcapRequest, WriteFlags),
    Prefilter(PrefilterRequest, WriteFlags),
    Irradiance(IrradianceRequest, WriteFlags),
    /// Each input a mirror-ball photo (its EXIF, or the recipe's `fov`, gives the camera).
    #[cfg(feature = "photo")]
    FromPhoto(crate::jobs::photo::BallRequest, WriteFlags),
    /// Each input a fisheye photo.
    #[cfg(feature = "photo")]
    FromFisheye(crate::jobs::photo::FisheyeRequest, WriteFlags),
}

impl Op {
    pub fn name(&self) -> &'static str {
        match self {
            Op::Convert(_) => OPS[0],
            Op::BakeMatcap(..) => OPS[1],
            Op::Prefilter(..) => OPS[2],
            Op::Irradiance(..) => OPS[3],
            #[cfg(feature = "photo")]
            Op::FromPhoto(..) => OPS[4],
            #[cfg(feature = "photo")]
            Op::FromFisheye(..) => OPS[5],
        }
    }

    /// Whether the operation writes one map (a cube's may be six `{face}` files).
    fn writes_a_map(&self) -> bool {
        match self {
            Op::Convert(_) => true,
            #[cfg(feature = "photo")]
            Op::FromPhoto(..) | Op::FromFisheye(..) => true,
            _ => false,
        }
    }

    /// Every field with its default filled in, as JSON (the recipe's hash is made of these).
    fn canonical(&self) -> serde_json::Value {
        let (job, write) = match self {
            Op::Convert(j) => (serde_json::to_value(j), None),
            Op::BakeMatcap(j, w) => (serde_json::to_value(j), Some(w)),
            Op::Prefilter(j, w) => (serde_json::to_value(j), Some(w)),
            Op::Irradiance(j, w) => (serde_json::to_value(j), Some(w)),
            #[cfg(feature = "photo")]
            Op::FromPhoto(j, w) => (serde_json::to_value(j), Some(w)),
            #[cfg(feature = "photo")]
            Op::FromFisheye(j, w) => (serde_json::to_value(j), Some(w)),
        };
        serde_json::json!({
            "op": self.name(),
            "job": job.unwrap_or(serde_json::Value::Null),
            "write": write.map(|w| serde_json::to_value(w).unwrap_or_default()),
        })
    }
}

/// One `[[output]]` of a recipe.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The output name pattern, relative to the output folder.
    pub name: String,
    pub op: Op,
}

/// A validated recipe.
#[derive(Clone, Debug, PartialEq)]
pub struct Recipe {
    /// The recipe file, as named in errors.
    pub source: String,
    /// The recipe as written (`{"output": [{…}, …]}`): what Python hands to its Dask workers.
    pub table: toml::Table,
    pub steps: Vec<Step>,
    /// Hex digest of the steps with every default filled in and spheremap's version: a rerun
    /// with another recipe (or another spheremap) redoes its inputs.
    pub hash: String,
}

fn hex_hash(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// The content hash the manifest records for a file (BLAKE3, hex).
pub fn file_hash(path: &Path) -> Result<String> {
    let mut h = blake3::Hasher::new();
    h.update_mmap(path).map_err(|e| Error::io(path, e))?;
    Ok(h.finalize().to_hex().to_string())
}

/// The first line of a TOML error's message.
fn toml_message(e: &toml::de::Error) -> String {
    e.message()
        .lines()
        .next()
        .unwrap_or("invalid")
        .trim()
        .to_string()
}

impl Recipe {
    /// Reads and validates a recipe file.
    pub fn read(path: &Path) -> Result<Recipe> {
        let bytes = crate::base::files::read_file(path)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::data(path, "the recipe is not UTF-8 text"))?;
        Recipe::parse(&text, &path.display().to_string())
    }

    /// Validates a recipe's TOML text; `source` names it in errors ("R.toml: output 2: key:
    /// problem").
    pub fn parse(text: &str, source: &str) -> Result<Recipe> {
        let table: toml::Table = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
            match line {
                Some(l) => Error::data(source, format!("line {l}: {}", toml_message(&e))),
                None => Error::data(source, toml_message(&e)),
            }
        })?;
        Self::from_table(&table, source)
    }

    /// The same recipe as JSON data (`{"output": [{…}, …]}`: Python passes a dict so).
    pub fn from_json(value: &serde_json::Value, source: &str) -> Result<Recipe> {
        let table = <toml::Table as serde::Deserialize>::deserialize(value)
            .map_err(|e| Error::data(source, format!("not a recipe: {e}")))?;
        Self::from_table(&table, source)
    }

    fn from_table(table: &toml::Table, source: &str) -> Result<Recipe> {
        let bad = |what: String| Error::data(source, what);
        let mut steps = Vec::new();
        for (key, value) in table {
            if key != "output" {
                return Err(bad(format!(
                    "{key}: unknown key (a recipe is a list of [[output]] tables)"
                )));
            }
            let list = value.as_array().ok_or_else(|| {
                bad("output: expected a list of tables, written [[output]]".into())
            })?;
            for (i, item) in list.iter().enumerate() {
                let at = format!("output {}", i + 1);
                let t = item
                    .as_table()
                    .ok_or_else(|| bad(format!("{at}: expected a table")))?;
                steps.push(Self::step(t, &at).map_err(|e| match e {
                    Error::InvalidParameter { name, reason } => {
                        bad(format!("{at}: {name}: {reason}"))
                    }
                    other => bad(format!("{at}: {other}")),
                })?);
            }
        }
        if steps.is_empty() {
            return Err(bad("no [[output]]: the recipe makes nothing".into()));
        }
        for (i, a) in steps.iter().enumerate() {
            for (j, b) in steps.iter().enumerate().skip(i + 1) {
                if a.name == b.name {
                    return Err(bad(format!(
                        "output {}: name: {:?} is also output {}'s: their files would collide",
                        j + 1,
                        b.name,
                        i + 1
                    )));
                }
            }
        }
        let canonical: Vec<serde_json::Value> = steps
            .iter()
            .map(|s| serde_json::json!({"name": s.name, "op": s.op.canonical()}))
            .collect();
        let hash = hex_hash(
            serde_json::json!({"spheremap": env!("CARGO_PKG_VERSION"), "steps": canonical})
                .to_string()
                .as_bytes(),
        );
        Ok(Recipe {
            source: source.to_string(),
            table: table.clone(),
            steps,
            hash,
        })
    }

    fn step(t: &toml::Table, _at: &str) -> Result<Step> {
        let op = match t.get("op") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(v) => return Err(Error::param("op", format!("expected a name, got {v}"))),
            None => {
                return Err(Error::param(
                    "op",
                    format!("missing: one of {}", OPS.join(", ")),
                ))
            }
        };
        let name = match t.get("name") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(v) => return Err(Error::param("name", format!("expected a string, got {v}"))),
            None => {
                return Err(Error::param(
                    "name",
                    "missing: the output's file name pattern, e.g. \"{stem}_sphere.exr\"",
                ))
            }
        };
        let mut rest = t.clone();
        for k in COMMON_KEYS {
            rest.remove(k);
        }
        let mut write = toml::Table::new();
        if op != "convert" {
            for k in WRITE_KEYS {
                if let Some(v) = rest.remove(k) {
                    write.insert(k.into(), v);
                }
            }
        }
        /// The table as `T`, errors naming the key at fault (`jobs::fields`); `also`: the
        /// other keys the operation takes.
        fn de<T: serde::de::DeserializeOwned + Serialize + Default>(
            t: toml::Table,
            also: &[&str],
        ) -> Result<T> {
            let v = serde_json::to_value(&t).map_err(|e| Error::param("output", e.to_string()))?;
            crate::jobs::fields::read(&v, also)
        }
        let op = match op.as_str() {
            "convert" => Op::Convert(de(rest, &[])?),
            "bake-matcap" => Op::BakeMatcap(de(rest, &WRITE_KEYS)?, de(write, &[])?),
            "prefilter" => Op::Prefilter(de(rest, &WRITE_KEYS)?, de(write, &[])?),
            "irradiance" => Op::Irradiance(de(rest, &WRITE_KEYS)?, de(write, &[])?),
            #[cfg(feature = "photo")]
            "from-photo" => Op::FromPhoto(de(rest, &WRITE_KEYS)?, de(write, &[])?),
            #[cfg(feature = "photo")]
            "from-fisheye" => Op::FromFisheye(de(rest, &WRITE_KEYS)?, de(write, &[])?),
            other => {
                return Err(Error::param(
                    "op",
                    format!(
                        "unknown operation {other:?}; expected one of {}",
                        OPS.join(", ")
                    ),
                ))
            }
        };
        check_pattern(&name, &op)?;
        check_values(&op)?;
        Ok(Step { name, op })
    }
}

/// A name pattern: relative, inside the output folder, with known placeholders, and an
/// extension its operation can write.
fn check_pattern(name: &str, op: &Op) -> Result<()> {
    let p = Path::new(name);
    if name.is_empty()
        || p.is_absolute()
        || p.components()
            .any(|c| !matches!(c, std::path::Component::Normal(_)))
    {
        return Err(Error::param(
            "name",
            format!("{name:?} must be a relative path inside the output folder (no .., no /)"),
        ));
    }
    let mut rest = name;
    while let Some(open) = rest.find('{') {
        let close = rest[open..]
            .find('}')
            .ok_or_else(|| Error::param("name", format!("{name:?}: an unclosed {{")))?
            + open;
        let key = &rest[open + 1..close];
        let allowed = PLACEHOLDERS.contains(&key)
            || (key == "face" && op.writes_a_map())
            || (key == "level" && matches!(op, Op::Prefilter(..)));
        if !allowed {
            return Err(Error::param(
                "name",
                format!(
                    "{name:?}: unknown placeholder {{{key}}}; expected {}{}",
                    PLACEHOLDERS.map(|k| format!("{{{k}}}")).join(", "),
                    match op {
                        _ if op.writes_a_map() => ", {face}",
                        Op::Prefilter(..) => ", {level}",
                        _ => "",
                    }
                ),
            ));
        }
        rest = &rest[close + 1..];
    }
    if name == MANIFEST {
        return Err(Error::param(
            "name",
            format!("{MANIFEST} is the manifest's name"),
        ));
    }
    // A name whose extension is the input's ({name}, {ext}) is checked by the operation.
    let ext_from_input = name.ends_with("{name}") || name.ends_with("{ext}");
    let ext_ok = ext_from_input
        || match op {
            Op::Irradiance(..) => {
                name.ends_with(".json")
                    || name.ends_with(".txt")
                    || Format::from_extension(p).is_some()
            }
            Op::Prefilter(..) => Format::from_extension(p).is_some(),
            _ => {
                Format::from_extension(p).is_some_and(|f| !matches!(f, Format::Ktx2 | Format::Dds))
            }
        };
    if !ext_ok {
        return Err(Error::param(
            "name",
            format!(
                "{name:?}: {} cannot write this file type{}",
                op.name(),
                match op {
                    Op::Irradiance(..) => {
                        " (.json: the report; .txt: Filament's sh.txt; an image: the irradiance map)"
                    }
                    _ => "",
                }
            ),
        ));
    }
    Ok(())
}

/// Checks every value that does not depend on the input: the operation resolved against a
/// lat-long stand-in for the input (the source mapping is the input's own, known only when it
/// is read).
fn check_values(op: &Op) -> Result<()> {
    use crate::images::note::MapNote;
    let latlong = crate::mappings::mapping::Mapping::parse("latlong", None)?;
    let note = MapNote {
        mapping: latlong,
        layout: None,
        face: None,
        view: None,
    };
    match op {
        Op::Convert(j) => {
            j.resolve(Some(&note), "input")?;
            if let Some(n) = j.size {
                check_map_size("size", n)?;
            }
        }
        Op::BakeMatcap(j, _) => {
            j.resolve(Some(&note), "input")?;
        }
        Op::Prefilter(j, _) => {
            j.resolve(Some(&note), "input")?;
        }
        Op::Irradiance(j, _) => {
            j.resolve(Some(&note), "input")?;
        }
        #[cfg(feature = "photo")]
        Op::FromPhoto(j, _) => {
            j.resolve()?;
        }
        #[cfg(feature = "photo")]
        Op::FromFisheye(j, _) => {
            j.resolve()?;
        }
    }
    Ok(())
}

/// One input's outputs as the plan names them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Task {
    /// Position in the sorted inputs (the `{index}` placeholder).
    pub index: usize,
    /// The input as found (a path).
    pub input: String,
    /// Each step's output name, relative to the output folder (`{face}`/`{level}` kept).
    pub outputs: Vec<String>,
}

/// What a batch will do: every input's task, and which a rerun skips.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Plan {
    pub out_dir: String,
    pub recipe_hash: String,
    pub tasks: Vec<Task>,
    /// Per task: done before with this input and recipe, every output present.
    pub skip: Vec<bool>,
}

/// The inputs named by files, folders (the image files directly in them) and glob patterns,
/// sorted and without duplicates.  A name that matches nothing is an error.
pub fn expand_inputs(names: &[String]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for n in names {
        let p = Path::new(n);
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| Error::io(p, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.is_file() && Format::from_extension(f).is_some())
                .filter(|f| {
                    !f.file_name()
                        .is_some_and(|s| s.to_string_lossy().starts_with('.'))
                })
                .collect();
            if found.is_empty() {
                return Err(Error::data(p, "no image files in this folder"));
            }
            found.sort();
            out.extend(found);
        } else if p.exists() {
            out.push(p.to_path_buf());
        } else if n.contains(['*', '?', '[']) {
            let matches: Vec<PathBuf> = glob::glob(n)
                .map_err(|e| Error::param("inputs", format!("{n:?}: {e}")))?
                .filter_map(|m| m.ok())
                .filter(|f| f.is_file())
                .collect();
            if matches.is_empty() {
                return Err(Error::data(p, "the pattern matches no file"));
            }
            out.extend(matches);
        } else {
            return Err(Error::data(p, "no such file or folder"));
        }
    }
    out.sort();
    out.dedup();
    if out.is_empty() {
        return Err(Error::param("inputs", "no inputs"));
    }
    Ok(out)
}

/// Fills a name pattern for one input.
pub fn output_name(pattern: &str, input: &Path, index: usize) -> String {
    let name = input
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = input
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    pattern
        .replace("{stem}", &stem)
        .replace("{name}", &name)
        .replace("{ext}", &ext)
        .replace("{index}", &index.to_string())
}

/// The files an output name stands for (six for a `{face}` pattern).
fn name_files(name: &str) -> Vec<String> {
    EnvFiles::parse(name).paths()
}

/// Plans a batch: inputs expanded, output names filled and checked for collisions (between
/// inputs, and with an input), the manifest read to see what a rerun may skip (unless
/// `force`).
pub fn plan(inputs: &[String], recipe: &Recipe, out_dir: &Path, force: bool) -> Result<Plan> {
    let manifest = Manifest::read(out_dir)?;
    // Files an earlier run made (an output folder inside an input folder) are not inputs.
    let made: std::collections::HashSet<PathBuf> = manifest
        .records
        .values()
        .flat_map(|r| r.outputs.iter())
        .filter_map(|o| std::fs::canonicalize(out_dir.join(&o.path)).ok())
        .collect();
    let files: Vec<PathBuf> = expand_inputs(inputs)?
        .into_iter()
        .filter(|f| std::fs::canonicalize(f).map_or(true, |c| !made.contains(&c)))
        .collect();
    if files.is_empty() {
        return Err(Error::param(
            "inputs",
            "every input is an output of an earlier run in this folder",
        ));
    }
    let mut tasks = Vec::with_capacity(files.len());
    let mut owner: HashMap<String, usize> = HashMap::new();
    let canon_inputs: Vec<PathBuf> = files
        .iter()
        .filter_map(|f| std::fs::canonicalize(f).ok())
        .collect();
    let out_canon = std::fs::canonicalize(out_dir).ok();
    for (index, f) in files.iter().enumerate() {
        let outputs: Vec<String> = recipe
            .steps
            .iter()
            .map(|s| output_name(&s.name, f, index))
            .collect();
        for o in &outputs {
            if let Some(&other) = owner.get(o) {
                return Err(Error::data(
                    &recipe.source,
                    format!(
                        "output {o:?} would be made from both {} and {}: add {{name}} or \
                         {{index}} to the name",
                        files[other].display(),
                        f.display()
                    ),
                ));
            }
            owner.insert(o.clone(), index);
            if let Some(dir) = &out_canon {
                for file in name_files(o) {
                    let target = dir.join(&file);
                    if canon_inputs.iter().any(|i| i == &target) {
                        return Err(Error::data(
                            &target,
                            "an output of the recipe would overwrite this input",
                        ));
                    }
                }
            }
        }
        tasks.push(Task {
            index,
            input: f.display().to_string(),
            outputs,
        });
    }
    let skip = tasks
        .iter()
        .map(|t| !force && manifest.is_done(t, &recipe.hash, out_dir))
        .collect();
    Ok(Plan {
        out_dir: out_dir.display().to_string(),
        recipe_hash: recipe.hash.clone(),
        tasks,
        skip,
    })
}

/// One output file as the manifest records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputRecord {
    /// Relative to the output folder.
    pub path: String,
    pub hash: String,
}

/// One manifest line: what became of one input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub input: String,
    /// BLAKE3 of the input's bytes (empty when it could not be read).
    pub input_hash: String,
    pub recipe_hash: String,
    pub outputs: Vec<OutputRecord>,
    pub seconds: f64,
    /// Who ran it: host, process and thread, or the Dask worker's address.
    pub worker: String,
    /// The one-line error when the input failed; its outputs are then not made.
    pub error: Option<String>,
}

impl Record {
    /// The record of `input` that failed with `error` before any output (a task that never
    /// ran to its end, on `worker`).
    pub fn failed(input: &str, recipe_hash: &str, worker: &str, error: &str) -> Record {
        Record {
            input: input.to_string(),
            input_hash: String::new(),
            recipe_hash: recipe_hash.to_string(),
            outputs: Vec::new(),
            seconds: 0.0,
            worker: worker.to_string(),
            error: Some(error.to_string()),
        }
    }
}

/// `DIR/manifest.jsonl`, read: the last record of each input.
#[derive(Clone, Debug, Default)]
pub struct Manifest {
    pub records: BTreeMap<String, Record>,
}

impl Manifest {
    pub fn path(out_dir: &Path) -> PathBuf {
        out_dir.join(MANIFEST)
    }

    /// Reads the manifest (none: empty).  Lines that do not parse — a line torn by a killed
    /// process — are ignored.
    pub fn read(out_dir: &Path) -> Result<Manifest> {
        let path = Self::path(out_dir);
        let text = match std::fs::read(&path) {
            Ok(b) => String::from_utf8_lossy(&b).into_owned(),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Manifest::default()),
            Err(e) => return Err(Error::io(&path, e)),
        };
        let mut records = BTreeMap::new();
        for line in text.lines() {
            if let Ok(r) = serde_json::from_str::<Record>(line) {
                records.insert(r.input.clone(), r);
            }
        }
        Ok(Manifest { records })
    }

    /// Whether `task` was made before from the same input bytes and recipe, and every file it
    /// made is still there.
    pub fn is_done(&self, task: &Task, recipe_hash: &str, out_dir: &Path) -> bool {
        let Some(r) = self.records.get(&task.input) else {
            return false;
        };
        r.error.is_none()
            && r.recipe_hash == recipe_hash
            && !r.outputs.is_empty()
            && r.outputs.iter().all(|o| out_dir.join(&o.path).is_file())
            && file_hash(Path::new(&task.input)).is_ok_and(|h| h == r.input_hash)
    }

    /// Rewrites the manifest with one line per input (atomically), dropping torn lines.
    pub fn compact(out_dir: &Path) -> Result<()> {
        let m = Self::read(out_dir)?;
        let path = Self::path(out_dir);
        if !path.exists() {
            return Ok(());
        }
        let mut text = String::new();
        for r in m.records.values() {
            text.push_str(
                &serde_json::to_string(r).map_err(|e| Error::data(&path, e.to_string()))?,
            );
            text.push('\n');
        }
        crate::base::files::write_text(&path, &text)
    }

    /// Appends one record as one line, synced: the manifest is consistent after each input.
    pub fn append(out_dir: &Path, record: &Record) -> Result<()> {
        let path = Self::path(out_dir);
        let mut line =
            serde_json::to_string(record).map_err(|e| Error::data(&path, e.to_string()))?;
        line.push('\n');
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        f.write_all(line.as_bytes())
            .map_err(|e| Error::io(&path, e))?;
        f.sync_data().map_err(|e| Error::io(&path, e))
    }
}

/// Removes the temporary files a killed writer may have left beside `task`'s outputs
/// (`.NAME.PID.tmp`, [`crate::base::files::atomic_write`]).
pub fn remove_stale_temps(out_dir: &Path, task: &Task) {
    for o in &task.outputs {
        for file in name_files(o) {
            let p = out_dir.join(&file);
            let (Some(dir), Some(name)) = (p.parent(), p.file_name()) else {
                continue;
            };
            let prefix = format!(".{}.", name.to_string_lossy());
            if let Ok(entries) = std::fs::read_dir(dir) {
                for e in entries.flatten() {
                    let n = e.file_name().to_string_lossy().into_owned();
                    if n.starts_with(&prefix) && n.ends_with(".tmp") {
                        let _ = std::fs::remove_file(e.path());
                    }
                }
            }
        }
    }
}

/// A label for this process and thread, for the manifest's `worker`.
pub fn local_worker() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .ok()
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "localhost".into());
    let thread = rayon::current_thread_index()
        .map(|i| format!(":{i}"))
        .unwrap_or_default();
    format!("{host}:{}{thread}", std::process::id())
}

/// Runs one input through every step, writing into `out_dir`; never fails: an error is
/// recorded with the input's name, and the outputs made before it are removed.  `cancel`
/// is checked between steps and passed to each operation (a cancelled input is an error
/// that is not recorded as done).
pub fn run_task(
    task: &Task,
    recipe: &Recipe,
    out_dir: &Path,
    worker: &str,
    cancel: Option<&AtomicBool>,
) -> Record {
    let t0 = std::time::Instant::now();
    let mut record = Record {
        input: task.input.clone(),
        input_hash: String::new(),
        recipe_hash: recipe.hash.clone(),
        outputs: Vec::new(),
        seconds: 0.0,
        worker: worker.to_string(),
        error: None,
    };
    remove_stale_temps(out_dir, task);
    let result = (|| -> Result<Vec<OutputRecord>> {
        record.input_hash = file_hash(Path::new(&task.input))?;
        let mut made: Vec<String> = Vec::new();
        // The input is decoded once for all the steps that read it alike; each gets a copy.
        let mut cache: Vec<(String, (Image, Option<Layout>))> = Vec::new();
        let mut read = |files: &EnvFiles,
                        m: Mapping,
                        l: Option<Layout>,
                        o: &ReadOptions|
         -> Result<(Image, Option<Layout>)> {
            let key = format!("{:?}|{m:?}|{l:?}|{}", files.paths(), o.linear);
            if let Some((_, v)) = cache.iter().find(|(k, _)| *k == key) {
                return Ok(v.clone());
            }
            let v = read_env_layout(files, m, l, o)?;
            cache.push((key, v.clone()));
            Ok(v)
        };
        let run = (|| -> Result<()> {
            for (step, name) in recipe.steps.iter().zip(&task.outputs) {
                let progress = Progress::default();
                if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                    return Err(Error::Cancelled {
                        what: task.input.clone(),
                    });
                }
                let out = out_dir.join(name);
                if let Some(d) = out.parent() {
                    std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
                }
                let files = run_step(
                    &step.op,
                    &task.input,
                    &out.display().to_string(),
                    &progress,
                    &mut read,
                )?;
                made.extend(files);
            }
            Ok(())
        })();
        if let Err(e) = run {
            for f in &made {
                let _ = std::fs::remove_file(f);
            }
            return Err(e);
        }
        made.iter()
            .map(|f| {
                let p = Path::new(f);
                Ok(OutputRecord {
                    path: p.strip_prefix(out_dir).unwrap_or(p).display().to_string(),
                    hash: file_hash(p)?,
                })
            })
            .collect()
    })();
    match result {
        Ok(outputs) => record.outputs = outputs,
        Err(e) => {
            let msg = e.to_string();
            let line = msg.lines().next().unwrap_or("failed").to_string();
            // Errors name their file; one that does not gets the input's name.
            record.error = Some(if line.contains(&task.input) {
                line
            } else {
                format!("{}: {line}", task.input)
            });
        }
    }
    record.seconds = t0.elapsed().as_secs_f64();
    record
}

/// One operation on one input; returns the files written.
fn run_step(
    op: &Op,
    input: &str,
    output: &str,
    progress: &Progress,
    read: &mut EnvReader<'_>,
) -> Result<Vec<String>> {
    match op {
        Op::Convert(job) => {
            let mut job = job.clone();
            job.force = true; // the plan refused outputs that are inputs
            let r = job.run_files_with(
                &[input.to_string(), output.to_string()],
                Some(progress),
                read,
            )?;
            Ok(r.output)
        }
        Op::BakeMatcap(job, w) => {
            let (r, _) =
                job.run_files_with(input, output, &w.options(), true, Some(progress), read)?;
            Ok(r.output)
        }
        Op::Prefilter(job, w) => {
            let (r, _) =
                job.run_files_with(input, output, &w.options(), true, Some(progress), read)?;
            Ok(r.output)
        }
        Op::Irradiance(job, w) => {
            let (r, _) =
                job.run_files_with(input, &[output.to_string()], &w.options(), true, read)?;
            Ok(r.output)
        }
        #[cfg(feature = "photo")]
        Op::FromPhoto(job, w) => {
            let p = Some(progress);
            Ok(job
                .run_files(input, None, output, None, &w.options(), true, p)?
                .output)
        }
        #[cfg(feature = "photo")]
        Op::FromFisheye(job, w) => {
            let p = Some(progress);
            Ok(job
                .run_files(input, output, None, &w.options(), true, p)?
                .output)
        }
    }
}

/// What a run did, for its summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    pub inputs: usize,
    pub done: usize,
    pub skipped: usize,
    pub failed: usize,
    /// Inputs not started because the run was interrupted.
    pub cancelled: usize,
    pub outputs: usize,
    pub seconds: f64,
    /// Inputs done per second of wall time.
    pub files_per_second: f64,
    pub manifest: String,
    pub workers: usize,
}

impl Summary {
    /// The summary of a plan run in `seconds`: `results` holds a record per input started
    /// (`None`: not started, interrupted).
    pub fn of(plan: &Plan, results: &[Option<Record>], seconds: f64, workers: usize) -> Summary {
        let mut s = Summary {
            inputs: plan.tasks.len(),
            skipped: plan.skip.iter().filter(|s| **s).count(),
            manifest: Manifest::path(Path::new(&plan.out_dir))
                .display()
                .to_string(),
            workers,
            seconds,
            ..Default::default()
        };
        for r in results {
            match r {
                None => s.cancelled += 1,
                Some(r) if r.error.is_some() => s.failed += 1,
                Some(r) => {
                    s.done += 1;
                    s.outputs += r.outputs.len();
                }
            }
        }
        s.files_per_second = if seconds > 0.0 {
            s.done as f64 / seconds
        } else {
            0.0
        };
        s
    }
}

/// Runs a plan on `workers` local threads (0: all cores): inputs in parallel, each
/// operation's own kernels sharing the same threads.  `on_record` hears each input as it
/// ends (for a progress bar).  Stops starting inputs when `cancel` is set.
pub fn run_local(
    plan: &Plan,
    recipe: &Recipe,
    workers: usize,
    cancel: &AtomicBool,
    on_record: &(dyn Fn(&Record) + Sync),
) -> Result<Summary> {
    let t0 = std::time::Instant::now();
    let out_dir = Path::new(&plan.out_dir);
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    Manifest::compact(out_dir)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .build()
        .map_err(|e| Error::param("workers", e.to_string()))?;
    let todo: Vec<&Task> = plan
        .tasks
        .iter()
        .zip(&plan.skip)
        .filter(|(_, s)| !**s)
        .map(|(t, _)| t)
        .collect();
    let manifest_lock = std::sync::Mutex::new(());
    let results: Vec<Option<Record>> = pool.install(|| {
        use rayon::prelude::*;
        todo.par_iter()
            .with_max_len(1)
            .map(|t| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let r = run_task(t, recipe, out_dir, &local_worker(), Some(cancel));
                if cancel.load(Ordering::Relaxed) && r.error.is_some() {
                    return None; // interrupted mid-input: not recorded, redone next time
                }
                let _g = manifest_lock.lock();
                let written = Manifest::append(out_dir, &r);
                on_record(&r);
                written.ok().map(|_| r)
            })
            .collect()
    });
    Ok(Summary::of(
        plan,
        &results,
        t0.elapsed().as_secs_f64(),
        pool.current_num_threads(),
    ))
}
