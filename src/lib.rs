//! sparse-mpm (placeholder docs, rewritten below)
#![deny(missing_docs)]

pub mod error;
pub mod grid;
pub mod io;
pub mod mass;
pub mod operators;
pub mod particles;
pub mod shape;

pub use error::{MpmError, Result};
pub use grid::{Grid, NodeOrder};
pub use operators::{Operator, Operators};
pub use particles::Particles;
pub use shape::{dshape, shape, ShapeFunction};
pub mod homework;
pub mod material;
pub mod step;
pub mod transfer;
