//! The bounce operator: the links' gather of radiosity and the radiosity
//! formula ([`operator`]), the bounce loop and its stopping rule on the
//! CPU kernel ([`gather`]; the GPU kernel in `crate::gpu::gather`
//! implements the same [`gather::BounceKernel`]), hidden vertices'
//! stand-ins as link targets ([`hidden`]) and the gradient-corrected
//! radiosity the links read ([`reconstruct`]).

pub mod gather;
pub mod hidden;
pub mod operator;
pub mod reconstruct;
