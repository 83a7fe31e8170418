//! One module per command. Each imports the libraries and the command line's shared helpers
//! (`cli_args`, `progress`), never another command.

pub mod bench;
pub mod calibrate;
pub mod dataset;
pub mod demo;
pub mod demosaic;
pub mod dof;
pub mod isp;
pub mod lens;
pub mod render;
pub mod tune;
