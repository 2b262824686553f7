//! Layer 2, mappings: each way of laying the sphere of directions on an image (sphere map,
//! lat-long, cube, angular, paraboloid, octahedral, fisheye lenses), the [`mapping::Mapping`]
//! that names them, mesh texgen and MatCap lookups.

pub mod angular;
pub mod cube;
pub mod fisheye;
pub mod latlong;
pub mod mapping;
pub mod matcap;
pub mod octahedral;
pub mod paraboloid;
pub mod sphere;
pub mod texgen;
