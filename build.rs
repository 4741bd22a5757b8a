//! Embeds the git commit, its dirty flag, the repository, the rustc version and the hash
//! of Cargo.lock (the exact dependency versions) at build time, for provenance.
use std::process::Command;

mod code {
    include!("src/code_hash.rs");
}

fn run(cmd: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(cmd).args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    Some(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = run("git", &["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = match run("git", &["status", "--porcelain", "--untracked-files=no"]) {
        Some(s) => (!s.is_empty()).to_string(),
        None => "unknown".into(),
    };
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let rustc_version = run(&rustc, &["--version"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=LAYDOWN_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=LAYDOWN_GIT_DIRTY={dirty}");
    println!("cargo:rustc-env=LAYDOWN_RUSTC_VERSION={rustc_version}");
    let remote = run("git", &["config", "--get", "remote.origin.url"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=LAYDOWN_GIT_REMOTE={remote}");
    let manifest_dir = std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".into()));
    println!("cargo:rustc-env=LAYDOWN_CARGO_LOCK_HASH={}", code::code_hash(&manifest_dir, &["Cargo.lock"]));
    println!("cargo:rerun-if-changed=Cargo.lock");
    // Rerun when HEAD moves or the index changes (commit / dirty flag).
    for p in [".git/HEAD", ".git/index"] {
        if std::path::Path::new(p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    if let Some(r) = run("git", &["symbolic-ref", "-q", "HEAD"]) {
        let p = format!(".git/{r}");
        if std::path::Path::new(&p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
    // The hash of the code that computes each stage kind (part of its fingerprint).
    let root = std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".into()));
    println!("cargo:rerun-if-changed=src/code_hash.rs");
    for (kind, paths) in code::STAGE_CODE {
        let all: Vec<&str> = paths.iter().chain(code::COMMON_CODE).copied().collect();
        println!("cargo:rustc-env=LAYDOWN_CODE_HASH_{}={}", kind.to_uppercase(), code::code_hash(&root, &all));
        for p in all {
            println!("cargo:rerun-if-changed={p}");
        }
    }
}
