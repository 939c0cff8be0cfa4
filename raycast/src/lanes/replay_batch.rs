//! The batch the head replay moves at once ([`super::replay::replay_rays`]): its size and the
//! per-axis arrays its lanes load and store, shared by the dispatcher and the AVX2 and AVX-512
//! kernels.

/// Rays moved at once by [`super::replay::replay_rays`].
pub(crate) const REPLAY_RAYS: usize = 16;

/// The per-axis values of [`REPLAY_RAYS`] rays, one array per axis.
pub(crate) type Axes = [[f64; REPLAY_RAYS]; 3];
