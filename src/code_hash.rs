// The hash of the source code that computes each stage kind, taken at build time by
// build.rs (which `include!`s this file) and embedded as LAYDOWN_CODE_HASH_<KIND>.
// Also compiled into the library (`crate::code_hash`) so that its rules are tested.
//
// A kind's code is its own module and the modules it uses for its results (`STAGE_CODE`);
// the files are hashed in sorted order by path relative to the crate root and content
// (line endings normalised). Test files (`tests.rs`, `*_tests.rs`, `*/tests/*`) are left
// out: changing a test does not change results.

/// Paths (files or directories, relative to the crate root) whose code computes each kind.
pub const STAGE_CODE: &[(&str, &[&str])] = &[
    ("laydown", &["src/stages/laydown", "src/rod", "src/geometry.rs", "src/archive/gather.rs"]),
    ("laid_web", &["src/stages/laid_web", "src/stages/laydown", "src/rod", "src/geometry.rs", "src/archive/gather.rs"]),
    ("spectra", &["src/stages/spectra", "src/geometry.rs"]),
    ("web", &["src/stages/web", "src/stages/spectra", "src/geometry.rs"]),
    ("grid", &["src/stages/grid", "src/stages/web", "src/stages/spectra", "src/geometry.rs", "src/uniformity.rs", "src/archive/gather.rs"]),
    ("image", &["src/stages/image", "src/uniformity.rs", "src/archive/gather.rs"]),
    ("accuracy", &["src/stages/accuracy.rs"]),
];

/// Shared by every kind: the stage interface, the random streams, parameter tables and
/// values, and how outputs are built and written.
pub const COMMON_CODE: &[&str] = &["src/stages/mod.rs", "src/rng.rs", "src/params.rs", "src/archive/data.rs", "src/archive/hdf.rs"];

/// Every `.rs` file under `path` (or `path` itself), sorted, without test files.
pub fn code_files(root: &std::path::Path, path: &str) -> Vec<String> {
    fn walk(root: &std::path::Path, rel: &str, out: &mut Vec<String>) {
        let full = root.join(rel);
        if full.is_dir() {
            let mut entries: Vec<String> = std::fs::read_dir(&full)
                .map(|d| d.filter_map(|e| e.ok()).map(|e| format!("{rel}/{}", e.file_name().to_string_lossy())).collect())
                .unwrap_or_default();
            entries.sort();
            for e in entries {
                if !e.ends_with("/tests") {
                    walk(root, &e, out);
                }
            }
        } else if rel.ends_with(".rs") && !rel.ends_with("/tests.rs") && !rel.ends_with("_tests.rs") {
            out.push(rel.to_string());
        }
    }
    let mut out = vec![];
    walk(root, path, &mut out);
    out
}

/// 64-bit FNV-1a, twice with different offsets (128 bits): stable across Rust versions,
/// needs no crate in the build script, and is ample for telling code versions apart.
pub fn code_hash(root: &std::path::Path, paths: &[&str]) -> String {
    let mut files: Vec<String> = paths.iter().flat_map(|p| code_files(root, p)).collect();
    files.sort();
    files.dedup();
    let (mut a, mut b): (u64, u64) = (0xcbf2_9ce4_8422_2325, 0x6c62_272e_07bb_0142);
    let mut feed = |bytes: &[u8]| {
        for &x in bytes {
            a = (a ^ x as u64).wrapping_mul(0x0000_0100_0000_01b3);
            b = (b ^ x as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for f in &files {
        feed(f.as_bytes());
        feed(&[0]);
        let text = std::fs::read_to_string(root.join(f)).unwrap_or_default().replace("\r\n", "\n");
        feed(text.as_bytes());
        feed(&[0]);
    }
    format!("{a:016x}{b:016x}")
}
