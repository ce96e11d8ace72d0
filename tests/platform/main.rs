//! The GPU layer and the shaders: the context, capabilities, dispatch checks, shader composition and validation, the WGSL library against its CPU twins, and the code rules tests/ checks by reading the tree.
//!
//! One test binary per area (`cargo test --test platform`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod gpu;
mod shader_lib;
mod shaders;
