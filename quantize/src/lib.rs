//! Point quantization before insertion: the dense voxel-key quantization pre-pass
//! (Kwon & Yoon, "Point-Cloud Data Quantization for OctoMap Update in Real-Time").
//!
//! [`quantize_endpoints`] reduces a frame's end points to one voxel centre per end-point key
//! before the rays are cast, which gives exactly OctoMap's `insertPointCloud(.., discretize =
//! true)`; [`QuantizeOptions`] bounds the dense bit grid it uses and [`QuantizeStats`] reports
//! what it did.
#![deny(missing_docs)]
// One audited exception: the call into the AVX2 key pass after the run-time check that the CPU
// has AVX2 (`voxel_keys::avx2::pack`). Everything else is safe.
#![deny(unsafe_code)]

mod voxel_keys;
pub use voxel_keys::{quantize_endpoints, QuantizeOptions, QuantizeStats};
