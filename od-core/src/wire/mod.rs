//! Wire formats: codecs only, one file per protocol, no state and no policy.
//!
//! Each format is a typed value (a `Repr`) with a `parse` that never panics on any input and an
//! `emit` that produces exactly the bytes the specification prints, in the style of smoltcp's
//! `wire` module. The services and nodes work on these values; the tests here check them byte
//! by byte against the manuals' example frames.

pub mod j1939;
