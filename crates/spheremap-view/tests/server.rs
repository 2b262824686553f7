//! The viewer's server over real sockets: fixed routes only (no request path reaches the file
//! system), the Host check, upload limits and errors, concurrency, and that it keeps serving.

use spheremap::images::codec::{write_image, WriteOptions};
use spheremap::images::Image;
use spheremap::jobs::source::EnvRequest;
use spheremap::view::ViewData;
use spheremap_view::{ServeOptions, Server, UPLOAD_HEADER};
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::path::{Path, PathBuf};
use std::time::Duration;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("spheremap-view-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small lat-long of constant `v`.
fn small_env(dir: &Path, v: f32) -> PathBuf {
    let mut img = Image::new(32, 16, 3);
    img.data.fill(v);
    let p = dir.join("small.exr");
    write_image(&p, &img, &WriteOptions::default()).unwrap();
    p
}

fn server(name: &str, max_upload: u64) -> (Server, PathBuf) {
    let dir = tmp_dir(name);
    let env = small_env(&dir, 0.25);
    let data = ViewData::load(
        None,
        Some(env.to_str().unwrap()),
        &EnvRequest::default(),
        None,
    )
    .unwrap();
    let s = Server::start(
        data,
        ServeOptions {
            max_upload,
            ..ServeOptions::default()
        },
    )
    .unwrap();
    (s, dir)
}

fn addr(s: &Server) -> String {
    s.url()
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string()
}

struct Reply {
    status: u16,
    headers: String,
    body: Vec<u8>,
}

/// Sends `head` (and `body`), closes the writing half when `close_write`, reads the reply.
fn raw(s: &Server, head: &str, body: &[u8], close_write: bool) -> Reply {
    let mut c = TcpStream::connect(addr(s)).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    c.write_all(head.as_bytes()).unwrap();
    c.write_all(body).unwrap();
    if close_write {
        c.shutdown(Shutdown::Write).unwrap();
    }
    let mut buf = Vec::new();
    let _ = c.read_to_end(&mut buf);
    if buf.is_empty() {
        // The connection closed without a reply.
        return Reply {
            status: 0,
            headers: String::new(),
            body: Vec::new(),
        };
    }
    let split = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a reply with headers");
    let headers = String::from_utf8_lossy(&buf[..split]).to_string();
    let status = headers.split(' ').nth(1).unwrap().parse().unwrap();
    let mut body = buf[split + 4..].to_vec();
    // Chunked replies: keep the chunks' data only.
    if headers
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        let mut out = Vec::new();
        let mut rest = &body[..];
        loop {
            let nl = rest.windows(2).position(|w| w == b"\r\n").unwrap();
            let n = usize::from_str_radix(std::str::from_utf8(&rest[..nl]).unwrap().trim(), 16)
                .unwrap();
            if n == 0 {
                break;
            }
            out.extend_from_slice(&rest[nl + 2..nl + 2 + n]);
            rest = &rest[nl + 2 + n + 2..];
        }
        body = out;
    }
    Reply {
        status,
        headers,
        body,
    }
}

fn get(s: &Server, path: &str) -> Reply {
    let head = format!(
        "GET {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
        addr(s)
    );
    raw(s, &head, b"", false)
}

fn post(s: &Server, route: &str, name: &str, body: &[u8], upload_header: bool) -> Reply {
    let head = format!(
        "POST {route}?name={name} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\nContent-Length: {}\r\n{}\r\n",
        addr(s),
        body.len(),
        if upload_header {
            format!("{UPLOAD_HEADER}: 1\r\n")
        } else {
            String::new()
        }
    );
    raw(s, &head, body, false)
}

fn json(r: &Reply) -> serde_json::Value {
    serde_json::from_slice(&r.body).unwrap()
}

fn scene_version(s: &Server) -> u64 {
    json(&get(s, "/data/scene.json"))["version"]
        .as_u64()
        .unwrap()
}

#[test]
fn serves_its_fixed_routes() {
    let (s, _d) = server("routes", 1 << 20);
    let r = get(&s, "/");
    assert_eq!(r.status, 200);
    assert!(r.headers.contains("text/html"));
    assert!(String::from_utf8_lossy(&r.body).contains("id=\"view\""));
    assert_eq!(get(&s, "/index.html").body, r.body);
    let js = get(&s, "/viewer.js");
    assert_eq!(js.status, 200);
    assert!(js.headers.contains("text/javascript"));
    let scene = json(&get(&s, "/data/scene.json"));
    assert_eq!(scene["version"], 1);
    assert_eq!(scene["env"]["name"], "small.exr");
    assert_eq!(scene["uploads"], true);
    // The mesh: its vertex count × 6 floats (position, normal), then the triangles.
    let mesh = get(&s, "/data/mesh.bin");
    assert_eq!(mesh.status, 200);
    let m = &scene["mesh"];
    let (nv, nt) = (
        m["vertices"].as_u64().unwrap(),
        m["triangles"].as_u64().unwrap(),
    );
    assert_eq!(mesh.body.len() as u64, nv * 24 + nt * 12);
    assert_eq!(get(&s, "/data/env.bin").status, 200);
    let no = get(&s, "/data/matcap.bin");
    assert_eq!(no.status, 404);
    assert!(json(&no)["error"].as_str().unwrap().contains("MatCap"));
    assert!(r.headers.contains("Content-Security-Policy"));
    assert!(r.headers.contains("nosniff"));
}

#[test]
fn no_request_path_reaches_the_file_system() {
    let (s, dir) = server("paths", 1 << 20);
    let secret = dir.join("secret.txt");
    std::fs::write(&secret, "SECRET-CONTENT").unwrap();
    let abs = secret.to_string_lossy().to_string();
    let paths = [
        "/../Cargo.toml".to_string(),
        "/../../../../../../etc/passwd".into(),
        "/%2e%2e/%2e%2e/%2e%2e/etc/passwd".into(),
        "/%2E%2E%2F%2E%2E%2Fetc%2Fpasswd".into(),
        "/data/../../../../etc/passwd".into(),
        "/data/..%2f..%2f..%2fetc%2fpasswd".into(),
        "/data/%2e%2e/scene.json".into(),
        "//etc/passwd".into(),
        abs.clone(),
        format!("/{abs}"),
        format!("http://{}/../../etc/passwd", addr(&s)),
        "/index.html/../../secret.txt".into(),
        "/viewer.js%00.txt".into(),
        "/data/scene.json%2f..".into(),
        "/.\\..\\..\\etc\\passwd".into(),
        "/Cargo.toml".into(),
        "/data/".into(),
        "/data".into(),
    ];
    for p in &paths {
        let r = get(&s, p);
        assert!(matches!(r.status, 400 | 404), "{p}: status {}", r.status);
        let body = String::from_utf8_lossy(&r.body);
        assert!(
            !body.contains("SECRET") && !body.contains("root:"),
            "{p}: {body}"
        );
    }
    // Other methods are refused.
    let head = format!(
        "DELETE /data/scene.json HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
        addr(&s)
    );
    assert_eq!(raw(&s, &head, b"", false).status, 405);
    // And it still serves.
    assert_eq!(get(&s, "/data/scene.json").status, 200);
}

#[test]
fn answers_only_its_own_host() {
    let (s, _d) = server("host", 1 << 20);
    for host in ["evil.example", "evil.example:80", "127.0.0.1:1"] {
        let head =
            format!("GET /data/scene.json HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
        assert_eq!(raw(&s, &head, b"", false).status, 403, "{host}");
    }
    let port = addr(&s).rsplit(':').next().unwrap().to_string();
    let head = format!(
        "GET /data/scene.json HTTP/1.1\r\nHost: localhost:{port}\r\nConnection: close\r\n\r\n"
    );
    assert_eq!(raw(&s, &head, b"", false).status, 200);
}

#[test]
fn uploads_are_checked_and_the_server_goes_on() {
    let dir = tmp_dir("uploads-src");
    let good = std::fs::read(small_env(&dir, 2.0)).unwrap();
    let (s, _d) = server("uploads", good.len() as u64 + 100);
    // Without the header: refused (a form on another site cannot send it).
    assert_eq!(post(&s, "/upload/env", "a.exr", &good, false).status, 403);
    // No name, a name the viewer does not read, an unknown route.
    assert_eq!(post(&s, "/upload/env", "", &good, true).status, 400);
    let r = post(&s, "/upload/env", "notes.txt", b"hi", true);
    assert_eq!(r.status, 400);
    assert!(json(&r)["error"].as_str().unwrap().starts_with("notes.txt"));
    assert_eq!(post(&s, "/upload/shader", "a.exr", &good, true).status, 404);
    // Over the limit: 413, and nothing read.
    let big = vec![0u8; good.len() + 101];
    let r = post(&s, "/upload/env", "big.exr", &big, true);
    assert_eq!(r.status, 413);
    assert!(json(&r)["error"].as_str().unwrap().contains("big.exr"));
    // Garbage: one line naming the file as the user named it (not the temporary path).
    let r = post(&s, "/upload/env", "broken.exr", b"not an exr at all", true);
    assert_eq!(r.status, 400);
    let e = json(&r)["error"].as_str().unwrap().to_string();
    assert!(
        e.starts_with("broken.exr") && !e.contains('\n') && !e.contains("upload-"),
        "{e}"
    );
    // Truncated: the body ends before its declared length.
    let head = format!(
        "POST /upload/env?name=cut.exr HTTP/1.1\r\nHost: {}\r\nConnection: close\r\nContent-Length: {}\r\n{UPLOAD_HEADER}: 1\r\n\r\n",
        addr(&s),
        good.len()
    );
    // The connection is dropped (its client has stopped sending; tiny_http closes it) or
    // answered 400; either way nothing is taken and the server goes on.
    let r = raw(&s, &head, &good[..good.len() / 2], true);
    assert!(matches!(r.status, 0 | 400), "{}", r.status);
    assert_eq!(get(&s, "/data/scene.json").status, 200);
    // A truncated EXR of the right declared length: a parse error.
    let half = &good[..good.len() / 2];
    let r = post(&s, "/upload/env", "half.exr", half, true);
    assert_eq!(r.status, 400, "{}", String::from_utf8_lossy(&r.body));
    // A mesh that indexes past its vertices.
    let r = post(
        &s,
        "/upload/mesh",
        "cut.obj",
        b"v 0 0 0\nv 1 0 0\nf 1 2 3\n",
        true,
    );
    assert_eq!(r.status, 400);
    // Nothing of that changed the data.
    assert_eq!(scene_version(&s), 1);
    assert_eq!(s.version(), 1);
    // A good file is taken, with a new version.
    let r = post(&s, "/upload/env", "bright.exr", &good, true);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(json(&r)["version"], 2);
    let scene = json(&get(&s, "/data/scene.json"));
    assert_eq!(scene["version"], 2);
    assert_eq!(scene["env"]["name"], "bright.exr");
    // A name with a path in it: only its last part is shown, nothing is written there.
    let r = post(&s, "/upload/env", "..%2F..%2Fetc%2Fevil.exr", &good, true);
    assert_eq!(r.status, 200);
    assert_eq!(json(&r)["name"], "evil.exr");
    assert!(!Path::new("/etc/evil.exr").exists());
}

#[test]
fn concurrent_requests_are_all_answered() {
    let (s, _d) = server("concurrent", 1 << 20);
    let want = get(&s, "/data/env.bin").body;
    let s = std::sync::Arc::new(s);
    let threads: Vec<_> = (0..12)
        .map(|i| {
            let s = s.clone();
            std::thread::spawn(move || {
                (0..8)
                    .map(|k| {
                        let p = if (i + k) % 2 == 0 {
                            "/data/env.bin"
                        } else {
                            "/viewer.js"
                        };
                        let r = get(&s, p);
                        (p, r.status, r.body)
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    for t in threads {
        for (p, status, body) in t.join().unwrap() {
            assert_eq!(status, 200, "{p}");
            if p == "/data/env.bin" {
                assert_eq!(body, want);
            }
        }
    }
}

#[test]
fn close_stops_serving() {
    let (mut s, _d) = server("close", 1 << 20);
    let a = addr(&s);
    assert_eq!(get(&s, "/").status, 200);
    s.close();
    let refused = match TcpStream::connect(&a) {
        Err(_) => true,
        Ok(mut c) => {
            c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let _ = c.write_all(format!("GET / HTTP/1.1\r\nHost: {a}\r\n\r\n").as_bytes());
            let mut buf = [0u8; 16];
            !matches!(c.read(&mut buf), Ok(n) if n > 0)
        }
    };
    assert!(refused);
}
