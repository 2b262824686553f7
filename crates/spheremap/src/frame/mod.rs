//! Layer 1, frames: the conventions (eye space, image rows against t, texel centres, presets for
//! other tools) and views (which world direction the eye looks along).

pub mod conventions;
pub mod view;
