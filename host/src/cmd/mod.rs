//! Subcommands (one file each) and the option groups and progress display they share.

pub mod bench;
pub mod bench_accuracy;
pub mod bench_frame;
pub mod bench_link;
pub mod bench_link_faults;
pub mod bench_rays;
pub mod bench_skip;
pub mod bench_splat;
pub mod common;
pub mod completions;
pub mod config;
pub mod device;
pub mod flash;
pub mod monitor;
pub mod output;
pub mod plot;
pub mod ports;
pub mod progress;
pub mod render;
mod render_points;
pub mod scenes;
