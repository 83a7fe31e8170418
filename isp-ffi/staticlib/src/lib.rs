//! `libcamsim_isp.a`: the C API ([`isp_ffi`]) as a static library. The header is
//! `isp-ffi/include/camsim_isp.h`; `isp-ffi/examples/develop.c` shows the calls.
#![warn(missing_docs)]

pub use isp_ffi::*;
