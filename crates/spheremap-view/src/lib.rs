//! The viewer's local web server (`spheremap view`, Python `spheremap.view`): the bundled
//! WebGL2 page and the data the core prepared ([`spheremap::view::ViewData`]), by fixed routes.
//!
//! ## Routes (nothing else exists)
//!
//! | method | path | what |
//! |---|---|---|
//! | GET | `/`, `/index.html` | the page (query parameters: the page's URL parameters) |
//! | GET | `/viewer.js` | the page's script |
//! | GET | `/data/scene.json` | [`spheremap::view::SceneInfo`] |
//! | GET | `/data/mesh.bin`, `/data/env.bin`, `/data/matcap.bin` | the payloads (404 when absent) |
//! | POST | `/upload/mesh`, `/upload/env`, `/upload/matcap` (`?name=FILE`) | a dropped file |
//!
//! A request's path is only ever compared with this list: no part of it reaches the file
//! system. The page and its script are compiled into the binary. An upload must carry the
//! header `X-Spheremap-Upload: 1` (a header a cross-site form cannot send without a CORS
//! preflight, which this server never grants), declare a length up to the limit, and name a
//! file whose extension is one the viewer reads; its bytes go to a file the server names in a
//! directory it made for itself, are parsed by the CLI's readers with their limits, and the
//! file is deleted. A bad upload gets a one-line error (status 400 or 413) and changes nothing.
//! When the server listens on a loopback address it answers only requests whose `Host` is that
//! address or `localhost` (a DNS-rebinding page gets 403).

use spheremap::jobs::source::EnvRequest;
use spheremap::view::{ViewData, ENV_EXTENSIONS, MESH_EXTENSIONS};
use std::io::Read;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Duration;

/// The page.
pub const INDEX_HTML: &str = include_str!("../web/index.html");
/// The page's script.
pub const VIEWER_JS: &str = include_str!("../web/viewer.js");
/// Threads answering requests (so that a slow upload does not stall the page's reads).
pub const THREADS: usize = 4;
/// The header an upload must carry.
pub const UPLOAD_HEADER: &str = "X-Spheremap-Upload";

/// How to serve.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// The address to listen on (default 127.0.0.1).
    pub host: String,
    /// 0: a free port.
    pub port: u16,
    /// The largest upload, in bytes.
    pub max_upload: u64,
    /// How dropped environment maps are read (their mapping: the file's note, else lat-long).
    pub env_request: EnvRequest,
}

impl Default for ServeOptions {
    fn default() -> Self {
        ServeOptions {
            host: "127.0.0.1".into(),
            port: 0,
            max_upload: spheremap::base::limits::UPLOAD_BYTES,
            env_request: EnvRequest::default(),
        }
    }
}

/// Whether `host` is a loopback address (or `localhost`).
pub fn is_loopback(host: &str) -> bool {
    host == "localhost"
        || host
            .trim_matches(|c| c == '[' || c == ']')
            .parse::<std::net::IpAddr>()
            .is_ok_and(|a| a.is_loopback())
}

struct Shared {
    data: RwLock<ViewData>,
    opts: ServeOptions,
    addr: SocketAddr,
    upload_dir: PathBuf,
    uploads: AtomicU64,
}

/// A running server. Dropping it stops it.
pub struct Server {
    url: String,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
    shared: Arc<Shared>,
}

impl Server {
    /// Starts serving `data` on a background thread pool.
    pub fn start(data: ViewData, opts: ServeOptions) -> spheremap::Result<Server> {
        let want = format!("{}:{}", opts.host, opts.port);
        let server = tiny_http::Server::http(&want).map_err(|e| {
            spheremap::Error::param("host", format!("cannot listen on {want}: {e}"))
        })?;
        let addr = server.server_addr().to_ip().ok_or_else(|| {
            spheremap::Error::param("host", format!("{want} is not an IP address"))
        })?;
        let upload_dir = private_dir()?;
        let shared = Arc::new(Shared {
            data: RwLock::new(data),
            opts,
            addr,
            upload_dir,
            uploads: AtomicU64::new(0),
        });
        let server = Arc::new(server);
        let stop = Arc::new(AtomicBool::new(false));
        let threads = (0..THREADS)
            .map(|_| {
                let (server, stop, shared) = (server.clone(), stop.clone(), shared.clone());
                std::thread::spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        match server.recv_timeout(Duration::from_millis(100)) {
                            Ok(Some(rq)) => handle(&shared, rq),
                            Ok(None) => {}
                            Err(_) => break,
                        }
                    }
                })
            })
            .collect();
        let host = match addr {
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
            SocketAddr::V4(a) => a.ip().to_string(),
        };
        Ok(Server {
            url: format!("http://{host}:{}/", addr.port()),
            stop,
            threads,
            shared,
        })
    }

    /// The page's address.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The data's version (it grows with each accepted upload).
    pub fn version(&self) -> u64 {
        self.shared
            .data
            .read()
            .map(|d| d.scene.version)
            .unwrap_or(0)
    }

    /// Blocks until `stop` is set (Ctrl-C), then stops.
    pub fn wait_until(self, stop: &AtomicBool) {
        while !stop.load(Ordering::Relaxed) && !self.stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Stops serving and waits for the threads.
    pub fn close(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        let _ = std::fs::remove_dir_all(&self.shared.upload_dir);
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.close();
    }
}

/// A directory only this server writes in: `spheremap-view-PID-N` in the system's temporary
/// directory, made anew (never an existing one).
fn private_dir() -> spheremap::Result<PathBuf> {
    static N: AtomicU64 = AtomicU64::new(0);
    let base = std::env::temp_dir();
    for _ in 0..1000 {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0);
        let p = base.join(format!(
            "spheremap-view-{}-{}-{nanos}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        match std::fs::create_dir(&p) {
            Ok(()) => return Ok(p),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(spheremap::Error::io(&p, e)),
        }
    }
    Err(spheremap::Error::param(
        "upload",
        "cannot make a private temporary directory",
    ))
}

type Resp = tiny_http::Response<std::io::Cursor<Vec<u8>>>;

fn header(name: &str, value: &str) -> tiny_http::Header {
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("a valid header")
}

fn reply(status: u16, content_type: &str, body: Vec<u8>) -> Resp {
    tiny_http::Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", content_type))
        .with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"))
        .with_header(header(
            "Content-Security-Policy",
            "default-src 'self'; img-src 'self' data: blob:; style-src 'self' 'unsafe-inline'",
        ))
}

fn error(status: u16, message: &str) -> Resp {
    let body = serde_json::json!({ "error": message }).to_string();
    reply(status, "application/json", body.into_bytes())
}

/// The page's routes, for a server (`uploads`) or an export.
pub fn scene_json(data: &ViewData, uploads: bool) -> Vec<u8> {
    let mut scene = data.scene.clone();
    scene.uploads = uploads;
    serde_json::to_vec(&scene).expect("the scene serializes")
}

fn host_allowed(shared: &Shared, rq: &tiny_http::Request) -> bool {
    if !shared.addr.ip().is_loopback() {
        return true;
    }
    let port = shared.addr.port();
    let Some(h) = rq.headers().iter().find(|h| h.field.equiv("Host")) else {
        return false;
    };
    let h = h.value.as_str();
    let ok = [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("[::1]:{port}"),
        format!("{}:{port}", shared.addr.ip()),
    ];
    ok.iter().any(|o| o.eq_ignore_ascii_case(h))
}

fn handle(shared: &Shared, mut rq: tiny_http::Request) {
    let resp = if host_allowed(shared, &rq) {
        route(shared, &mut rq)
    } else {
        error(
            403,
            "this server answers only requests addressed to its own host",
        )
    };
    let _ = rq.respond(resp);
}

fn route(shared: &Shared, rq: &mut tiny_http::Request) -> Resp {
    let url = rq.url().to_string();
    let (path, query) = url.split_once('?').unwrap_or((&url, ""));
    match (rq.method(), path) {
        (tiny_http::Method::Get | tiny_http::Method::Head, _) => get(shared, path),
        (tiny_http::Method::Post, "/upload/mesh" | "/upload/env" | "/upload/matcap") => {
            upload(shared, rq, &path["/upload/".len()..], query)
        }
        (tiny_http::Method::Post, _) => error(404, "no such upload route"),
        _ => error(405, "only GET and POST are served"),
    }
}

fn get(shared: &Shared, path: &str) -> Resp {
    let html = "text/html; charset=utf-8";
    match path {
        "/" | "/index.html" => reply(200, html, INDEX_HTML.as_bytes().to_vec()),
        "/viewer.js" => reply(
            200,
            "text/javascript; charset=utf-8",
            VIEWER_JS.as_bytes().to_vec(),
        ),
        "/favicon.ico" => reply(204, "image/x-icon", Vec::new()),
        "/data/scene.json" | "/data/mesh.bin" | "/data/env.bin" | "/data/matcap.bin" => {
            let Ok(d) = shared.data.read() else {
                return error(500, "the viewer's data is unavailable");
            };
            let bin = "application/octet-stream";
            match path {
                "/data/scene.json" => reply(200, "application/json", scene_json(&d, true)),
                "/data/mesh.bin" => reply(200, bin, d.mesh.clone()),
                "/data/env.bin" => match &d.env {
                    Some(b) => reply(200, bin, b.clone()),
                    None => error(404, "no environment map is loaded"),
                },
                _ => match &d.matcap {
                    Some(b) => reply(200, bin, b.clone()),
                    None => error(404, "no MatCap is loaded"),
                },
            }
        }
        _ => error(404, "not found"),
    }
}

/// The `name` query parameter, percent-decoded.
fn name_param(query: &str) -> Option<String> {
    let v = query.split('&').find_map(|kv| kv.strip_prefix("name="))?;
    let b = v.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' if i + 2 < b.len() => {
                let hex = std::str::from_utf8(&b[i + 1..i + 3]).ok()?;
                out.push(u8::from_str_radix(hex, 16).ok()?);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// The extension the viewer reads a file `name` of `kind` by, lower case.
pub fn upload_extension(kind: &str, name: &str) -> Result<String, String> {
    let ext = Path::new(name)
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let allowed: &[&str] = if kind == "mesh" {
        &MESH_EXTENSIONS
    } else {
        &ENV_EXTENSIONS
    };
    if allowed.contains(&ext.as_str()) {
        Ok(ext)
    } else {
        Err(format!(
            "{name}: not a {} file the viewer reads (expected .{})",
            if kind == "mesh" { "mesh" } else { "image" },
            allowed.join(", .")
        ))
    }
}

fn upload(shared: &Shared, rq: &mut tiny_http::Request, kind: &str, query: &str) -> Resp {
    if !rq
        .headers()
        .iter()
        .any(|h| h.field.equiv(UPLOAD_HEADER) && h.value.as_str() == "1")
    {
        return error(
            403,
            &format!("an upload must carry the header {UPLOAD_HEADER}: 1"),
        );
    }
    let Some(name) = name_param(query).filter(|n| !n.is_empty()) else {
        return error(400, "an upload needs ?name=FILE");
    };
    // Only the file name is shown; nothing of it is used to reach the file system.
    let name = spheremap::view::display_name(Path::new(&name));
    let ext = match upload_extension(kind, &name) {
        Ok(e) => e,
        Err(m) => return error(400, &m),
    };
    let max = shared.opts.max_upload;
    let Some(len) = rq.body_length() else {
        return error(411, &format!("{name}: an upload must declare its length"));
    };
    if len as u64 > max {
        return error(
            413,
            &format!("{name}: {len} bytes is over the upload limit of {max} bytes (--max-upload)"),
        );
    }
    let mut bytes = Vec::with_capacity(len);
    if let Err(e) = rq.as_reader().take(max + 1).read_to_end(&mut bytes) {
        return error(400, &format!("{name}: the upload was cut short ({e})"));
    }
    if bytes.len() != len {
        return error(
            400,
            &format!(
                "{name}: the upload was cut short ({} of {len} bytes)",
                bytes.len()
            ),
        );
    }
    let n = shared.uploads.fetch_add(1, Ordering::Relaxed);
    let tmp = shared.upload_dir.join(format!("upload-{n}.{ext}"));
    let result = std::fs::write(&tmp, &bytes)
        .map_err(|e| spheremap::Error::io(&tmp, e))
        .and_then(|()| {
            // Parse into a copy: a bad file changes nothing.
            let mut next = shared.data.read().map(|d| d.clone()).map_err(|_| {
                spheremap::Error::param("upload", "the viewer's data is unavailable")
            })?;
            match kind {
                "mesh" => next.set_mesh_file(&tmp, &name)?,
                "env" => {
                    next.set_env_file(&tmp.to_string_lossy(), &name, &shared.opts.env_request)?
                }
                _ => next.set_matcap_file(&tmp, &name)?,
            }
            Ok(next)
        });
    let _ = std::fs::remove_file(&tmp);
    match result {
        Ok(next) => {
            let Ok(mut d) = shared.data.write() else {
                return error(500, "the viewer's data is unavailable");
            };
            let version = d.scene.version + 1;
            *d = next;
            d.scene.version = version;
            let body = serde_json::json!({ "ok": true, "version": version, "name": name });
            reply(200, "application/json", body.to_string().into_bytes())
        }
        Err(e) => {
            let line = e
                .to_string()
                .replace(&*tmp.to_string_lossy(), &name)
                .replace('\n', " ");
            error(400, &line)
        }
    }
}

/// Writes the page and its data into `dir` as static files (`index.html`, `viewer.js`,
/// `data/…`) that any static web server serves; dropped files are then refused by the page.
/// Every file is written atomically, all of them or none.
pub fn export(data: &ViewData, dir: &Path) -> spheremap::Result<Vec<PathBuf>> {
    let d = dir.join("data");
    std::fs::create_dir_all(&d).map_err(|e| spheremap::Error::io(&d, e))?;
    let scene = scene_json(data, false);
    let mut files: Vec<(PathBuf, &[u8])> = vec![
        (dir.join("index.html"), INDEX_HTML.as_bytes()),
        (dir.join("viewer.js"), VIEWER_JS.as_bytes()),
        (d.join("scene.json"), &scene),
        (d.join("mesh.bin"), &data.mesh),
    ];
    if let Some(b) = &data.env {
        files.push((d.join("env.bin"), b));
    }
    if let Some(b) = &data.matcap {
        files.push((d.join("matcap.bin"), b));
    }
    let refs: Vec<(&Path, &[u8])> = files.iter().map(|(p, b)| (p.as_path(), *b)).collect();
    spheremap::base::files::atomic_write_all(&refs)?;
    Ok(files.into_iter().map(|(p, _)| p).collect())
}
