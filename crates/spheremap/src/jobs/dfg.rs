//! The split-sum DFG table as one request: [`DfgRequest`] holds what `spheremap dfg` and
//! Python's `dfg_lut` take (the size), runs [`crate::lighting::dfg::table`] on a file or in
//! memory, and reports what it did ([`DfgReport`]).

use crate::base::error::Result;
use crate::images::codec::{write_image, WriteOptions};
use crate::images::Image;
use crate::lighting::dfg;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The DFG table as users ask for it.  `Default` gives the documented size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DfgRequest {
    /// Table size N (N×N): column i is n·v = (i+½)/N, row j (row 0 first) roughness (j+½)/N.
    pub size: usize,
}

impl Default for DfgRequest {
    fn default() -> Self {
        DfgRequest {
            size: dfg::DEFAULT_SIZE,
        }
    }
}

/// What `spheremap dfg --json` prints.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DfgReport {
    pub output: String,
    pub size: usize,
    pub seconds: f64,
}

impl DfgRequest {
    /// The table (N, N, 3): A, B, A + B.
    pub fn run_image(&self) -> Result<Image> {
        dfg::table(self.size)
    }

    /// Writes the table to `output` (`.exr`, `.pfm`, `.hdr`) with `write`.
    pub fn run_files(&self, output: &str, write: &WriteOptions) -> Result<DfgReport> {
        let t0 = std::time::Instant::now();
        let img = self.run_image()?;
        write_image(Path::new(output), &img, write)?;
        Ok(DfgReport {
            output: output.to_string(),
            size: self.size,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

impl crate::jobs::Report for DfgReport {
    fn lines(&self) -> Vec<String> {
        vec![format!(
            "-> {} ({n}x{n} split-sum DFG: A, B, A+B), {:.3} s",
            self.output,
            self.seconds,
            n = self.size,
        )]
    }
}
