//! `fusion-ros`.
fn main() {}
