//! `spheremap.view`: the viewer's server (spheremap-view) on background threads, as a Python
//! object (translation only).

use crate::to_py;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use spheremap::jobs::source::EnvRequest;

/// A running viewer: its address, and `close()` to stop it.
#[pyclass(module = "spheremap._spheremap")]
pub struct ViewServer {
    server: Option<spheremap_view::Server>,
    url: String,
}

#[pymethods]
impl ViewServer {
    /// Loads the data and starts serving. `request` is an `EnvRequest` as a dict; `port` 0 to
    /// 65535 (0: a free one), `max_upload` a positive number of bytes.
    #[new]
    #[pyo3(signature = (mesh, env, matcap, request, host, port, max_upload))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        mesh: Option<&Bound<'_, PyAny>>,
        env: Option<&Bound<'_, PyAny>>,
        matcap: Option<&Bound<'_, PyAny>>,
        request: &Bound<'_, PyAny>,
        host: String,
        port: &Bound<'_, PyAny>,
        max_upload: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let req: EnvRequest = super::request_of(request)?;
        let port = super::args::nonnegative(port, "port")
            .ok()
            .and_then(|p| u16::try_from(p).ok())
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "port: expected an integer from 0 to 65535, got {}",
                    port.repr().map(|r| r.to_string()).unwrap_or_default()
                ))
            })?;
        let max_upload = super::args::positive(max_upload, "max_upload")? as u64;
        if host.is_empty() {
            return Err(PyValueError::new_err("host: expected an address, got ''"));
        }
        use super::args::path_arg;
        let (mesh, matcap) = (path_arg(mesh, "mesh")?, path_arg(matcap, "matcap")?);
        let env = path_arg(env, "env")?.map(|e| e.to_string_lossy().into_owned());
        let server = py
            .detach(|| {
                let data = spheremap::view::ViewData::load(
                    mesh.as_deref(),
                    env.as_deref(),
                    &req,
                    matcap.as_deref(),
                )?;
                spheremap_view::Server::start(
                    data,
                    spheremap_view::ServeOptions {
                        host,
                        port,
                        max_upload,
                        env_request: req,
                    },
                )
            })
            .map_err(to_py)?;
        crate::emit_warnings(py)?;
        Ok(ViewServer {
            url: server.url().to_string(),
            server: Some(server),
        })
    }

    /// The page's address.
    #[getter]
    fn url(&self) -> &str {
        &self.url
    }

    /// Whether it is still serving.
    #[getter]
    fn running(&self) -> bool {
        self.server.is_some()
    }

    /// The data's version: 1, and one more for each file dropped on the page and accepted.
    #[getter]
    fn version(&self) -> u64 {
        self.server.as_ref().map_or(0, |s| s.version())
    }

    /// Stops serving (waits for the request threads); closing twice does nothing.
    fn close(&mut self, py: Python<'_>) {
        if let Some(mut s) = self.server.take() {
            py.detach(move || s.close());
        }
    }
}
