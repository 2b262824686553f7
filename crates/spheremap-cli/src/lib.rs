//! The `spheremap` command line: argument parsing (clap) and translation to the core, nothing
//! else.  Used by the `spheremap` binary and by the Python package's console script, so both
//! run one CLI definition.
//!
//! Exit codes: 0 success, 1 "ran fine, found a problem" (`info --check`), 2 bad input or
//! failure (one line on stderr naming the file or argument and the cause), clap's own codes for
//! usage errors (2) and `--help` (0).

mod camera_args;
mod cmd_analyze;
pub mod cmd_batch;
mod cmd_conventions;
mod cmd_convert;
mod cmd_demo;
mod cmd_generate;
mod cmd_info;
mod cmd_lighting;
mod cmd_limits;
mod cmd_photo;
mod cmd_preview;
mod cmd_render;
mod cmd_shader;
mod cmd_texgen;
mod cmd_view;
mod job;
mod names;
pub mod progress;
mod sampling_args;
mod scene_args;
mod source_args;
mod view_args;

use clap::{Parser, Subcommand};
use std::ffi::OsString;

#[derive(Parser, Debug)]
#[command(
    name = "spheremap",
    version = spheremap::VERSION,
    about = "Exact, documented and fast sphere maps: GL_SPHERE_MAP texgen, mirror balls, MatCaps",
    long_about = None
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// GL_SPHERE_MAP texture coordinates for a mesh, exactly as OpenGL computes them.
    Texgen(cmd_texgen::Args),
    /// Run the built-in demo (no input files needed).
    Demo(cmd_demo::Args),
    /// Print the conventions and the named presets, with where each puts ±X, ±Y, ±Z.
    Conventions(cmd_conventions::Args),
    /// Convert an environment map between mappings (sphere, latlong, cube, angular,
    /// paraboloid, octahedral), footprint-filtered, for any view.
    Convert(Box<cmd_convert::Args>),
    /// Make a sphere map (or any mapping) by firing rays: ray-trace a scene (OBJ/glTF) from a
    /// point, or look up an environment map (six cube faces around the point).
    Generate(Box<cmd_generate::Args>),
    /// A sphere map (or any mapping) from one or two photos of a mirror ball: the ball found
    /// to a fraction of a pixel, orthographic or perspective camera, the camera removed with
    /// a second shot; with a confidence mask.
    FromPhoto(Box<cmd_photo::PhotoArgs>),
    /// A sphere map (or any mapping) from a fisheye photo (equidistant, equisolid,
    /// stereographic, orthographic or polynomial lens), with a coverage mask.
    FromFisheye(Box<cmd_photo::FisheyeArgs>),
    /// Render a photo of a scene (or an environment map) through a perspective or fisheye
    /// camera with the ray tracer.
    Preview(Box<cmd_preview::Args>),
    /// Draw a mesh with a sphere map (per-vertex exactly as OpenGL's GL_SPHERE_MAP, or
    /// per-pixel), a MatCap, its normals, or the per-vertex interpolation error.
    Render(Box<cmd_render::Args>),
    /// Sampling analytics of a mapping (texel solid angle, anisotropy, angular resolution) and
    /// a mesh's per-vertex interpolation error with tessellation advice.
    Analyze(Box<cmd_analyze::Args>),
    /// Print a shader snippet (GLSL, WGSL, HLSL) for per-vertex texgen, per-pixel sphere-map
    /// lookup or MatCap, in spheremap's conventions; compiled and executed by the tests.
    Shader(cmd_shader::Args),
    /// Bake a physically exact MatCap from an environment map: the lit sphere of a Lambert or
    /// GGX material seen by an orthographic viewer (usable by render --mode matcap and three.js
    /// MeshMatcapMaterial).
    BakeMatcap(Box<cmd_lighting::BakeArgs>),
    /// Order-2 spherical harmonics of an environment map and the irradiance they imply, in
    /// three.js and Filament conventions; optionally the full irradiance map.
    Irradiance(Box<cmd_lighting::IrradianceArgs>),
    /// The split-sum DFG lookup table (Karis 2013) of spheremap's GGX.
    Dfg(Box<cmd_lighting::DfgArgs>),
    /// Prefilter an environment for engines: the GGX radiance mip chain (each level the map
    /// convolved with the GGX lobe of that level's roughness), or with --irradiance the
    /// cosine-convolved map; a cube as one KTX2/DDS file with every face and level.
    Prefilter(Box<cmd_lighting::PrefilterArgs>),
    /// An interactive WebGL2 viewer in the browser: orbit a mesh lit by a sphere map
    /// regenerated for the camera every frame (or frozen), per-vertex GL texgen against
    /// per-pixel lookup and their error, MatCaps; served locally.
    View(Box<cmd_view::Args>),
    /// Run a recipe (TOML) over a library of maps: every input's outputs made on local cores
    /// or a Dask cluster, recorded in a manifest so a rerun resumes; a bad input fails alone.
    Batch(Box<cmd_batch::Args>),
    /// Describe an image: format (by content), size, channels, range, NaN/Inf, a mapping guess.
    Info(cmd_info::Args),
    /// Print every limit the commands enforce (sizes, samples, memory, uploads), from the one
    /// table in the core; --json for programs.
    Limits(cmd_limits::Args),
    /// Print a completion script for a shell (bash, zsh, fish, powershell, elvish) to stdout.
    Completions(CompletionsArgs),
}

#[derive(clap::Args, Debug)]
struct CompletionsArgs {
    /// The shell to complete for.
    shell: clap_complete::Shell,
}

/// The whole command-line definition (the reference in `docs/cli.md`, the man page and the
/// completion scripts are made from it).
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}

fn completions(a: CompletionsArgs) -> anyhow::Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(a.shell, &mut command(), "spheremap", &mut script);
    out(&String::from_utf8_lossy(&script));
    Ok(())
}

/// Prints to stdout; a closed pipe (`spheremap conventions | head`) is not an error.
pub(crate) fn out(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

/// A core report as one line of JSON on stdout (`--json`).
pub(crate) fn out_json<T: serde::Serialize>(report: &T) {
    match serde_json::to_string(report) {
        Ok(s) => out(&format!("{s}\n")),
        Err(e) => eprintln!("spheremap: the report could not be written as JSON: {e}"),
    }
}

/// Where a command's report goes without `--json`.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Words {
    /// On stdout: the report is what the command is for (`info`).
    Stdout,
    /// On stderr, unless quiet: the report accompanies the files the command wrote.
    Stderr { quiet: bool },
}

/// The end of every command that reports: its core report as one line of JSON on stdout with
/// `json`, else in words ([`spheremap::jobs::Report::lines`]).
pub(crate) fn print_report<R: spheremap::jobs::Report>(report: &R, json: bool, words: Words) {
    if json {
        return out_json(report);
    }
    match words {
        Words::Stdout => out(&report
            .lines()
            .iter()
            .map(|l| format!("{l}\n"))
            .collect::<String>()),
        Words::Stderr { quiet: false } => report.lines().iter().for_each(|l| eprintln!("{l}")),
        Words::Stderr { quiet: true } => {}
    }
}

/// Runs the CLI on `args` (the first item is the program name) and returns the exit code.
pub fn main_with_args<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) if e.kind() == clap::error::ErrorKind::ValueValidation => {
            // A bad value the core refused (a name, by `names::core`): its one-line error.
            let msg = e.to_string();
            let msg = msg
                .trim_start_matches("error: ")
                .lines()
                .next()
                .unwrap_or("");
            eprintln!("spheremap: {msg}");
            return 2;
        }
        Err(e) => {
            let _ = e.print();
            return e.exit_code();
        }
    };
    // A panic is a bug: report it in one line (the hook), never as a backtrace.
    let previous_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|info| {
        if spheremap::base::error::panic_is_guarded() {
            return; // a parser's panic the core turns into an error
        }
        eprintln!(
            "spheremap: internal error (a bug; please report it with the command line): {info}"
        );
    }));
    // Warnings go to stderr while the command runs, even inside a host (the Python module's
    // console script) that collects them otherwise.
    let previous_sink = spheremap::base::error::set_warning_sink(None);
    let result = std::panic::catch_unwind(|| match cli.command {
        Command::Texgen(a) => cmd_texgen::run(a),
        Command::Demo(a) => cmd_demo::run(a),
        Command::Conventions(a) => cmd_conventions::run(a),
        Command::Info(a) => cmd_info::run(a),
        Command::Limits(a) => cmd_limits::run(a),
        Command::Convert(a) => cmd_convert::run(*a),
        Command::Generate(a) => cmd_generate::run(*a),
        Command::FromPhoto(a) => cmd_photo::run_photo(*a),
        Command::FromFisheye(a) => cmd_photo::run_fisheye(*a),
        Command::Preview(a) => cmd_preview::run(*a),
        Command::Render(a) => cmd_render::run(*a),
        Command::Analyze(a) => cmd_analyze::run(*a),
        Command::Shader(a) => cmd_shader::run(a),
        Command::BakeMatcap(a) => cmd_lighting::run_bake(*a),
        Command::Irradiance(a) => cmd_lighting::run_irradiance(*a),
        Command::Dfg(a) => cmd_lighting::run_dfg(*a),
        Command::Prefilter(a) => cmd_lighting::run_prefilter(*a),
        Command::View(a) => cmd_view::run(*a),
        Command::Batch(a) => cmd_batch::run(*a),
        Command::Completions(a) => completions(a),
    });
    std::panic::set_hook(previous_hook);
    spheremap::base::error::set_warning_sink(previous_sink);
    match result {
        Ok(Ok(())) => 0,
        Ok(Err(e)) if e.downcast_ref::<FoundProblem>().is_some() => {
            eprintln!("spheremap: {e}");
            1
        }
        Ok(Err(e)) => {
            eprintln!("spheremap: {}", one_line(&e));
            2
        }
        Err(_) => 2,
    }
}

/// The error and its causes on one line, without repeating a cause the message already
/// quotes (the core's I/O errors include their OS error).
fn one_line(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let t = cause.to_string();
        if !msg.contains(&t) {
            msg.push_str(": ");
            msg.push_str(&t);
        }
    }
    msg.replace('\n', " ")
}

/// A core error whose parameter is a request's field (`max_samples`, `src_preset`), named as
/// the flag that sets it (`--max-samples`, `--from-preset`).
pub(crate) fn flag_error(e: spheremap::Error) -> anyhow::Error {
    match e {
        spheremap::Error::InvalidParameter { name, reason } if !name.starts_with('-') => {
            let flag = source_args::SourceArgs::flag(&name)
                .unwrap_or_else(|| format!("--{}", name.replace('_', "-")));
            anyhow::anyhow!("{flag}: {reason}")
        }
        other => other.into(),
    }
}

/// "Ran fine, found a problem" (`info --check`): exit code 1, not 2.
#[derive(Debug)]
pub(crate) struct FoundProblem(pub String);

impl std::fmt::Display for FoundProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FoundProblem {}
