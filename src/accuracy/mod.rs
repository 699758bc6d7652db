//! Accuracy sweep (`linkgi error`): the link solver's error against the
//! Monte Carlo reference ([`crate::reference`]) as a function of rays per
//! vertex, bounces and smoothing, with the run time of each setting; the
//! same reference path tracer at a ladder of samples per vertex beside it,
//! at equal run time ([`path`]); and the light-move preview against the
//! full result after the move ([`preview`]).
//!
//! Links depend only on the rays per vertex, so they are built once per ray
//! count; the gather and the smoothing are redone per setting. Run time of
//! a setting (ms) = kd build + links + light links (of its ray count) +
//! gather + smoothing: the time to a first complete solution.
//!
//! Errors ([`metrics`]) are of per-vertex irradiance (W/m^2) against the
//! reference, for `E_i` (smoothed where smoothing is on), `E_d` and the
//! total `E_d + E_i`: relative RMSE (RMSE over vertices and channels
//! divided by the reference mean), the same with the reference's own noise
//! removed (`sqrt(max(0, MSE - mean stderr^2))`, for `E_i` and total),
//! relative bias of the mean, and the 95th percentile of per-vertex
//! relative error (channel mean; the denominator is floored at 1% of the
//! reference mean so unlit vertices do not divide by zero).

pub mod csv;
pub mod metrics;
pub mod path;
#[cfg(feature = "cli")]
pub mod plot;
pub mod preview;
pub mod sweep;

pub use metrics::ErrorStats;
pub use sweep::{sweep, SweepParams, SweepRow};
