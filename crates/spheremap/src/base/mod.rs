//! Layer 0, the base: errors, enums of names (`named_enum!`), limits, the float type the maths
//! is generic over, quadrature, files in and out (the input check and atomic writes), small
//! textual inputs and large buffers.

pub mod buffer;
pub mod cpu;
pub mod error;
pub mod files;
pub mod limits;
pub mod named;
pub mod parse;
pub mod quadrature;
pub mod real;
pub mod vec;
