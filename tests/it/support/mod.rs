//! What several test modules share.

pub mod gpu;
pub mod server;
