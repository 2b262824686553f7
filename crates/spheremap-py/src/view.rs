//! `spheremap.view`: the viewer's server (spheremap-view) on background threads, as a Python
//! object (translation only).

use crate::to_py;
use pyo3::prelude::*;
use spheremap::jobs::source::EnvRequest;
use std::path::Path;

/// A running viewer: its address, and `close()` to stop it.
#[pyclass(module = "spheremap._spheremap")]
pub struct ViewServer {
    server: Option<spheremap_view::Server>,
    url: String,
}

#[pymethods]
impl ViewServer {
    /// Loads the data and starts serving. `request` is an `EnvRequest` as a dict.
    #[new]
    #[pyo3(signature = (mesh, env, matcap, request, host, port, max_upload))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        mesh: Option<String>,
        env: Option<String>,
        matcap: Option<String>,
        request: &Bound<'_, PyAny>,
        host: String,
        port: u16,
        max_upload: u64,
    ) -> PyResult<Self> {
        let req: EnvRequest = super::request_of(request)?;
        let server = py
            .detach(|| {
                let data = spheremap::view::ViewData::load(
                    mesh.as_deref().map(Path::new),
                    env.as_deref(),
                    &req,
                    matcap.as_deref().map(Path::new),
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
