//! `spheremap view`: the interactive WebGL2 viewer, served locally (thin layer over
//! `spheremap::view` and the `spheremap-view` server).

use anyhow::Context;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The mesh: OBJ or glTF/GLB (default: the bundled Utah teapot).
    mesh: Option<PathBuf>,
    /// The environment map (any mapping spheremap reads; default, when neither --env nor
    /// --matcap is given: the bundled HDRI).
    #[arg(long)]
    env: Option<String>,
    #[command(flatten)]
    env_flags: crate::source_args::SourceArgs,
    /// A MatCap image for the matcap mode (default: the live sphere map, the mirror's MatCap).
    #[arg(long)]
    matcap: Option<PathBuf>,
    /// The port (default 0: a free one).
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// The address to listen on. Anything but a loopback address lets other machines see the
    /// page and replace its data: asked for explicitly, with a warning.
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// Do not open a browser; print the address only.
    #[arg(long)]
    no_browser: bool,
    /// The largest file a user may drop on the page, in bytes (suffixes K, M, G: KiB, MiB, GiB).
    #[arg(long, default_value_t = spheremap::base::limits::UPLOAD_BYTES, value_parser = parse_bytes)]
    max_upload: u64,
    /// Instead of serving, write the page and its data into DIR as static files that any static
    /// web server serves (dropping files then needs the spheremap server).
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// NaN or Inf in the environment: error (default), zero, clamp.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::codec::NonFinite>())]
    nonfinite: spheremap::images::codec::NonFinite,
}

/// `512M`, `2G`, `1048576`, by the core's reading of sizes.
fn parse_bytes(s: &str) -> Result<u64, String> {
    spheremap::base::limits::parse_bytes(s)
        .filter(|&n| n > 0)
        .ok_or_else(|| format!("{s:?}: expected a positive size in bytes, e.g. 512M"))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let req = a.env_flags.env_request(a.nonfinite);
    let data = spheremap::view::ViewData::load(
        a.mesh.as_deref(),
        a.env.as_deref(),
        &req,
        a.matcap.as_deref(),
    )?;
    if let Some(env) = &data.scene.env {
        if let Some(n) = &env.notice {
            eprintln!("spheremap: {n}");
        }
        if env.clamped > 0 {
            eprintln!(
                "spheremap: warning: {} values of {} are over the half-float range and are shown clamped to 65504",
                env.clamped, env.name
            );
        }
    }
    if let Some(dir) = &a.export {
        let files = spheremap_view::export(&data, dir)
            .with_context(|| format!("cannot export to {}", dir.display()))?;
        eprintln!(
            "spheremap: wrote {} files to {}; serve that directory with any static web server",
            files.len(),
            dir.display()
        );
        return Ok(());
    }
    let server = spheremap_view::Server::start(
        data,
        spheremap_view::ServeOptions {
            host: a.host.clone(),
            port: a.port,
            max_upload: a.max_upload,
            env_request: req,
        },
    )?;
    if !spheremap_view::is_loopback(&a.host) {
        eprintln!(
            "spheremap: warning: listening on {}: anyone who can reach this machine can see the page and replace its data",
            a.host
        );
    }
    let url = server.url().to_string();
    crate::out(&format!("{url}\n"));
    eprintln!("spheremap: serving the viewer at {url} (Ctrl-C stops it)");
    if !a.no_browser {
        if let Err(e) = open_browser(&url) {
            eprintln!("spheremap: could not open a browser ({e}); open {url} yourself");
        }
    }
    server.wait_until(&crate::progress::INTERRUPTED);
    crate::progress::INTERRUPTED.store(false, Ordering::SeqCst);
    Ok(())
}

fn open_browser(url: &str) -> std::io::Result<()> {
    let mut cmd = if cfg!(target_os = "macos") {
        std::process::Command::new("open")
    } else if cfg!(windows) {
        let mut c = std::process::Command::new("cmd");
        c.args(["/C", "start", ""]);
        c
    } else {
        std::process::Command::new("xdg-open")
    };
    cmd.arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map(|_| ())
}
