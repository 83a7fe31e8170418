// Link the proof binary without the C runtime's start files: it brings its own `_start`.
// libc is linked (dynamically, so the loader resolves its ifuncs) only for memcpy/memset, which
// core's code calls and a hosted target does not provide otherwise. Scoped to the binary: build
// scripts link normally.
fn main() {
    println!("cargo:rustc-link-arg-bins=-nostartfiles");
    println!("cargo:rustc-link-lib=c");
}
