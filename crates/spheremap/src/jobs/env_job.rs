//! The run of a request that reads one environment and writes one output name: the trait
//! the MatCap bake and the prefilter share, so that the CLI, Python and the batch runner call
//! them alike.

/// A request that reads one environment (an image or six face files) and writes one output
/// name (a file, or a pattern of them): the MatCap bake and the prefilter.  The batch runner
/// reads the input once for all of a recipe's outputs and hands each its `read`.
pub trait EnvJob {
    /// What `--json` prints.
    type Report;

    /// Reads the environment `input` with `read`, runs, and writes `output` with `write`
    /// (refusing to overwrite the input unless `force`).  Returns the report and the notice
    /// the source's rules gave.
    fn run_files_with(
        &self,
        input: &str,
        output: &str,
        write: &crate::images::codec::WriteOptions,
        force: bool,
        progress: Option<&crate::resample::Progress>,
        read: &mut crate::images::envmap::EnvReader<'_>,
    ) -> crate::base::error::Result<(Self::Report, Option<String>)>;

    /// [`EnvJob::run_files_with`], the environment read from its files.
    fn run_files(
        &self,
        input: &str,
        output: &str,
        write: &crate::images::codec::WriteOptions,
        force: bool,
        progress: Option<&crate::resample::Progress>,
    ) -> crate::base::error::Result<(Self::Report, Option<String>)> {
        let read = &mut crate::images::envmap::read_env_layout;
        self.run_files_with(input, output, write, force, progress, read)
    }
}
