//! Subcommands (one file each) and the option groups and progress display they share.

pub mod bench;
pub mod common;
pub mod completions;
pub mod config;
pub mod device;
pub mod flash;
pub mod monitor;
pub mod output;
pub mod ports;
pub mod progress;
pub mod render;
mod render_points;
mod render_stream;
pub mod scenes;
