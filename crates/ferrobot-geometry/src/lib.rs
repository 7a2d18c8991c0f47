//! The one geometry vocabulary of ferrobot.
//!
//! Every crate that describes a solid (URDF links in `ferrobot-model`,
//! obstacles in `ferrobot-collision`, rigid objects in `ferrobot-sim`, the
//! spherizer, the Python bindings) uses [`Shape`]. Its convention is parry's:
//! boxes by **half** extents, cylinders and capsules along **z** by radius and
//! **half** height (a capsule's half height is that of its cylindrical part).
//! Full sizes (URDF `size`/`length`, the Python API) are converted once, at
//! the boundary, with [`Shape::cuboid_from_size`],
//! [`Shape::cylinder_from_length`] and [`Shape::capsule_from_length`].
//!
//! Meshes, hulls and clouds are shared ([`std::sync::Arc`]) and carry the
//! query structures (parry BVH, kd-tree) built once, so cloning a shape or
//! passing it from the simulator to the collision world never copies or
//! rebuilds them.

pub mod cache;
pub mod cloud;
pub mod decomposition;
pub mod error;
pub mod mesh;
pub mod mesh_file;
pub mod shape;
pub mod trimesh;

pub use cloud::PointCloud;
pub use decomposition::DecompositionParams;
pub use error::{GeometryError, Result};
pub use mesh::{Hull, Mesh, MeshSource};
pub use mesh_file::{MAX_EXTENT, MAX_TRIANGLES, check_object_mesh, load_object_mesh};
pub use shape::{MeshAs, Shape, box_sdf, cylinder_sdf};
pub use trimesh::{BOX_TRIANGLES, TriMesh};
