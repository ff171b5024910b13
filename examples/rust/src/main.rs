// SPDX-License-Identifier: MIT
//! pkss-example: registers a PLY pair through the pkss C API from Rust and
//! checks the result against a ground-truth 4x4 (rotation error < 2 deg,
//! scale within 1 %), like tests/package/consumer.c.
//!
//!   cargo run --offline -- [SOURCE.ply TARGET.ply GT_4x4.txt]
//! Without arguments: the bundled pair in tests/data. Exit 0 pass, 1 beyond
//! the tolerances, 2 unreadable input, 3 registration failure.
mod ffi;

use std::ffi::CStr;
use std::fs;
use std::os::raw::c_char;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn c_text(p: *const c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    // SAFETY: pkss returns NUL-terminated strings in static or context storage.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// Owns a pkss_context; destroyed on drop.
struct Context(*mut ffi::Context);

impl Context {
    fn new() -> Result<Context, String> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: `raw` is a valid out-pointer.
        let st = unsafe { ffi::pkss_context_create(&mut raw) };
        if st != ffi::PKSS_OK {
            return Err(format!("pkss_context_create: {}", status_name(st)));
        }
        Ok(Context(raw))
    }

    /// pkss_register on two n x 3 row-major point arrays.
    fn register(&mut self, src: &[[f64; 3]], tgt: &[[f64; 3]]) -> Result<ffi::PkssResult, String> {
        let mut res = std::mem::MaybeUninit::<ffi::PkssResult>::uninit();
        let size = std::mem::size_of::<ffi::PkssResult>();
        // SAFETY: pkss_result_init zeroes and fills `size` bytes, all of
        // them ours; [[f64; 3]] is contiguous n x 3 doubles.
        let st = unsafe {
            ffi::pkss_result_init(res.as_mut_ptr(), size);
            ffi::pkss_register(
                self.0,
                src.as_ptr().cast(),
                src.len(),
                tgt.as_ptr().cast(),
                tgt.len(),
                res.as_mut_ptr(),
            )
        };
        if st != ffi::PKSS_OK {
            // SAFETY: the context outlives this call.
            let detail = c_text(unsafe { ffi::pkss_context_last_error(self.0) });
            return Err(format!("{}: {}", status_name(st), detail));
        }
        // SAFETY: initialised by pkss_result_init and filled on success.
        Ok(unsafe { res.assume_init() })
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: created by pkss_context_create, destroyed once.
        unsafe { ffi::pkss_context_destroy(self.0) }
    }
}

fn status_name(st: ffi::Status) -> String {
    // SAFETY: static storage, never NULL.
    c_text(unsafe { ffi::pkss_status_name(st) })
}

/// x y z of the vertex element of an ascii or binary little-endian PLY
/// whose vertex properties are scalars (float or double coordinates).
fn read_ply(path: &Path) -> Result<Vec<[f64; 3]>, String> {
    let bytes = fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let bad = |what: &str| format!("{}: {what}", path.display());
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .ok_or_else(|| bad("no end_header"))?
        + 11;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let (mut ascii, mut n, mut in_vertex) = (None, 0usize, false);
    let mut props: Vec<(String, usize)> = Vec::new(); // (name, size)
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, ..] => ascii = Some(*f == "ascii"),
            ["element", name, count] => {
                in_vertex = *name == "vertex";
                if in_vertex {
                    n = count.parse().map_err(|_| bad("bad vertex count"))?;
                }
            }
            ["property", ty, name] if in_vertex => {
                let size = match *ty {
                    "char" | "uchar" | "int8" | "uint8" => 1,
                    "short" | "ushort" | "int16" | "uint16" => 2,
                    "int" | "uint" | "int32" | "uint32" | "float" | "float32" => 4,
                    "double" | "float64" => 8,
                    _ => return Err(bad("unsupported property type")),
                };
                props.push((name.to_string(), size));
            }
            _ => {}
        }
    }
    let col = |c: &str| props.iter().position(|(p, _)| p == c);
    let (ix, iy, iz) = match (col("x"), col("y"), col("z")) {
        (Some(x), Some(y), Some(z)) => (x, y, z),
        _ => return Err(bad("no x y z vertex properties")),
    };
    let mut pts = Vec::with_capacity(n);
    if ascii == Some(true) {
        let text = String::from_utf8_lossy(&bytes[end..]);
        let mut it = text.split_whitespace();
        for _ in 0..n {
            let row: Vec<f64> = (0..props.len())
                .map(|_| it.next().and_then(|v| v.parse().ok()))
                .collect::<Option<_>>()
                .ok_or_else(|| bad("truncated"))?;
            pts.push([row[ix], row[iy], row[iz]]);
        }
    } else {
        if !header.contains("format binary_little_endian") {
            return Err(bad("only ascii and binary_little_endian PLY are read"));
        }
        let offsets: Vec<usize> = props
            .iter()
            .scan(0, |o, (_, s)| {
                let at = *o;
                *o += s;
                Some(at)
            })
            .collect();
        let stride: usize = props.iter().map(|(_, s)| s).sum();
        let value = |rec: &[u8], i: usize| -> f64 {
            let b = &rec[offsets[i]..offsets[i] + props[i].1];
            match props[i].1 {
                4 => f32::from_le_bytes(b.try_into().unwrap()) as f64,
                8 => f64::from_le_bytes(b.try_into().unwrap()),
                _ => f64::NAN, // integer coordinates: not needed here
            }
        };
        let body = &bytes[end..];
        if body.len() < n * stride {
            return Err(bad("truncated"));
        }
        for rec in body.chunks_exact(stride).take(n) {
            pts.push([value(rec, ix), value(rec, iy), value(rec, iz)]);
        }
    }
    Ok(pts)
}

/// The first 16 numbers of a text file ('#' lines skipped), row-major.
fn read_matrix(path: &Path) -> Result<[f64; 16], String> {
    let text = fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let v: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| l.split_whitespace().map(str::to_string).collect::<Vec<_>>())
        .filter_map(|w| w.parse().ok())
        .take(16)
        .collect();
    v.try_into()
        .map_err(|_| format!("{}: fewer than 16 numbers", path.display()))
}

fn main() -> ExitCode {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let paths = match args.len() {
        0 => vec![
            data.join("airplane_0001_s.ply"),
            data.join("airplane_0001_t.ply"),
            data.join("gt_similarity_s_to_t.txt"),
        ],
        3 => args,
        _ => {
            eprintln!("usage: pkss-example [SOURCE.ply TARGET.ply GT_4x4.txt]");
            return ExitCode::from(2);
        }
    };
    // SAFETY: plain calls without arguments; static strings.
    let (number, version) = unsafe {
        (
            ffi::pkss_version_number(),
            c_text(ffi::pkss_version_string()),
        )
    };
    println!("pkss library {version} (from Rust, extern \"C\")");
    if number / 10000 != 1 {
        eprintln!("pkss-example: declared against pkss 1.x, loaded {version}");
        return ExitCode::from(2);
    }
    let inputs = (|| {
        Ok::<_, String>((
            read_ply(&paths[0])?,
            read_ply(&paths[1])?,
            read_matrix(&paths[2])?,
        ))
    })();
    let (src, tgt, g) = match inputs {
        Ok(v) => v,
        Err(e) => {
            eprintln!("pkss-example: {e}");
            return ExitCode::from(2);
        }
    };
    let res = match Context::new().and_then(|mut ctx| ctx.register(&src, &tgt)) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("pkss-example: {e}");
            return ExitCode::from(3);
        }
    };
    // s_gt = cbrt(det(s R)); rotation error = angle of R_gt^T R
    let det = g[0] * (g[5] * g[10] - g[6] * g[9]) - g[1] * (g[4] * g[10] - g[6] * g[8])
        + g[2] * (g[4] * g[9] - g[5] * g[8]);
    let s_gt = det.cbrt();
    let mut tr = 0.0;
    for r in 0..3 {
        for c in 0..3 {
            tr += g[4 * r + c] / s_gt * res.rotation[3 * r + c];
        }
    }
    let rot_deg = (0.5 * (tr - 1.0)).clamp(-1.0, 1.0).acos().to_degrees();
    let scale_err = (res.scale / s_gt - 1.0).abs();
    let device = c_text(res.device.as_ptr());
    println!(
        "registered {} onto {} points on {} in {:.3} s",
        src.len(),
        tgt.len(),
        device,
        res.timings.total
    );
    println!(
        "scale {:.6} (ground truth {:.6}): error {:.4} %; rotation error {:.4} deg",
        res.scale,
        s_gt,
        100.0 * scale_err,
        rot_deg
    );
    if rot_deg < 2.0 && scale_err < 0.01 {
        println!("PASS (rotation < 2 deg, scale within 1 %)");
        ExitCode::SUCCESS
    } else {
        println!("FAIL");
        ExitCode::from(1)
    }
}
