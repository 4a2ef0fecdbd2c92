//! With the `mujoco` feature, binaries and tests find PyPI's libmujoco at
//! run time where they were linked against it (an rpath to
//! MUJOCO_DYNAMIC_LINK_DIR), so no LD_LIBRARY_PATH is needed.
fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    if std::env::var_os("CARGO_FEATURE_MUJOCO").is_some()
        && let Ok(dir) = std::env::var("MUJOCO_DYNAMIC_LINK_DIR")
    {
        println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
