//! The view an output map is made for, the same two flags on every command that writes one
//! (`convert`, `generate`, `bake-matcap`, `prefilter`, `from-photo`, `from-fisheye`).

use crate::job::vec3;

#[derive(clap::Args, Debug, Clone, Default)]
pub struct ViewArgs {
    /// The output's view: the world direction of its eye's -Z (with --up; default 0 0 -1); a
    /// sphere map's or a MatCap's eye. For photos, in the camera's frame (it looks down -Z).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub look: Option<Vec<f64>>,
    /// The world direction of the output eye's +Y (with --look; default 0 1 0).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub up: Option<Vec<f64>>,
}

impl ViewArgs {
    /// (look, up) as the core's requests take them.
    pub fn get(&self) -> (Option<[f64; 3]>, Option<[f64; 3]>) {
        (vec3(&self.look), vec3(&self.up))
    }
}
