//! The devices' dictionaries and behaviour, one module per product.

pub mod ap10t;
pub mod comm;
pub mod sgh10;
pub mod sgh50;
pub mod wv5800m;
pub mod wv58mr;
