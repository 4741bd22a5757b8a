// Writes a small archive for manual inspection: cargo run --example write_sample_archive -- PATH
#[path = "../tests/archive_format.rs"]
#[allow(dead_code, unused_imports)]
mod fmt;
fn main() {
    let path = std::path::PathBuf::from(std::env::args().nth(1).expect("path"));
    let a = laydown::archive::Archive::open_write(&path).unwrap();
    a.commit_version("t", "fibre", &fmt::sample_output(), &fmt::complete(), "h").unwrap();
    a.commit_version("t", "spectra", &fmt::sample_output(), &fmt::complete(), "h").unwrap();
}
