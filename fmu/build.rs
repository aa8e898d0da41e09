//! The FMU binary goes into every exported FMU: linked without debug information (the release
//! profile keeps it for the other crates' backtraces), it is about a tenth of the size.
fn main() {
    println!("cargo:rustc-cdylib-link-arg=-Wl,--strip-debug");
}
