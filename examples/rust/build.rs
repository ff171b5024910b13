// SPDX-License-Identifier: MIT
//! Links the installed libpkss: the folder comes from $PKSS_LIB_DIR, else
//! from `pkg-config --variable=libdir pkss` (run directly, no crate). The
//! folder is also put in the binary's rpath so that `cargo run` works
//! without LD_LIBRARY_PATH.
use std::env;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-env-changed=PKSS_LIB_DIR");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
    let dir = env::var("PKSS_LIB_DIR")
        .ok()
        .filter(|d| !d.is_empty())
        .or_else(|| {
            let out = Command::new("pkg-config")
                .args(["--variable=libdir", "pkss"])
                .output()
                .ok()?;
            let d = String::from_utf8_lossy(&out.stdout).trim().to_string();
            (out.status.success() && !d.is_empty()).then_some(d)
        });
    match dir {
        Some(d) => {
            println!("cargo:rustc-link-search=native={d}");
            println!("cargo:rustc-link-arg-bins=-Wl,-rpath,{d}");
        }
        None => println!(
            "cargo:warning=pkss: neither PKSS_LIB_DIR nor pkg-config (pkss.pc) gave the \
             folder of libpkss.so; trying the default linker path"
        ),
    }
    println!("cargo:rustc-link-lib=dylib=pkss");
}
