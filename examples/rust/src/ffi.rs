// SPDX-License-Identifier: MIT
//! The part of include/pkss.h (1.0) this example uses, declared by hand.
//! pkss_result is versioned by struct_size: a host declares the fields it
//! knows, in order, and passes its own size to pkss_result_init. Here that
//! is the stable 1.0 part (PKSS_RESULT_MIN_SIZE, everything before the
//! EXPERIMENTAL block), so a later 1.x library, which only appends fields,
//! keeps working with this binary (docs/compatibility.md).
#![allow(dead_code)]
use std::os::raw::{c_char, c_uint};

/// pkss_status: 0 is PKSS_OK; the values are fixed (pkss.h).
pub type Status = i32;
pub const PKSS_OK: Status = 0;

/// Opaque pkss_context.
#[repr(C)]
pub struct Context {
    _private: [u8; 0],
}

#[repr(C)]
#[derive(Clone, Copy, Default)]
pub struct Counts {
    pub input: u64,
    pub nonfinite: u64,
    pub thinned: u64,
    pub after_mutual: u64,
    pub after_stat: u64,
    pub resampled: u64,
    pub features: u64,
    pub duplicates: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Default)]
pub struct Timings {
    pub validate: f64,
    pub preprocess: f64,
    pub search: f64,
    pub refine: f64,
    pub total: f64,
}

#[repr(C)]
pub struct PkssResult {
    pub struct_size: usize,
    pub t_target_source: [f64; 16],
    pub scale: f64,
    pub rotation: [f64; 9],
    pub translation: [f64; 3],
    pub score: f64,
    pub rms: f64,
    pub overlap: f64,
    pub fit: f64,
    pub winner: u32,
    pub n_candidates: u32,
    pub n_rotations: u32,
    pub n_offsets: u32,
    pub n_evaluations: u64,
    pub source_counts: Counts,
    pub target_counts: Counts,
    pub timings: Timings,
    pub backend: i32,
    pub flags: u32,
    pub device: [c_char; 128],
    pub note: [c_char; 256],
}

// offsetof(pkss_result, prepare_seconds) on LP64 for pkss 1.0: a field
// declared here in the wrong place or with the wrong type fails the build.
#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<PkssResult>() == 856);

extern "C" {
    pub fn pkss_version_number() -> c_uint;
    pub fn pkss_version_string() -> *const c_char;
    pub fn pkss_status_name(status: Status) -> *const c_char;
    pub fn pkss_context_create(out: *mut *mut Context) -> Status;
    pub fn pkss_context_destroy(ctx: *mut Context);
    pub fn pkss_context_last_error(ctx: *const Context) -> *const c_char;
    pub fn pkss_result_init(result: *mut PkssResult, struct_size: usize);
    pub fn pkss_register(
        ctx: *mut Context,
        source: *const f64,
        n_source: usize,
        target: *const f64,
        n_target: usize,
        result: *mut PkssResult,
    ) -> Status;
}
