//! The single LM1247 axis as a product: one Hall-sensed linear carriage
//! ([`crate::app::joints::Joints`] with N = 1) following joint-space jobs read from
//! G-code moves along X ([`product`]), operable over the host link ([`link`]).

pub mod link;
pub mod product;
