//! Where the networks run: a CPU backend chosen explicitly ([`backend`]),
//! or a Vulkan GPU found and checked before burn touches it ([`gpu`]).

pub mod backend;
pub mod gpu;
