//! `laydown completions SHELL`: completion scripts from the command line's own definition.
mod common;
use common::*;

fn script(shell: &str) -> String {
    let out = laydown().args(["completions", shell]).output().unwrap();
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    o
}

#[test]
fn completion_scripts_name_the_subcommands_and_flags() {
    let bash = script("bash");
    assert!(bash.contains("_laydown()") && bash.contains("complete -F _laydown"), "{bash}");
    for word in ["run", "validate", "dag", "ls", "verify", "show", "table", "plot", "completions", "--dry-run", "--quiet", "--verbose", "--json"] {
        assert!(bash.contains(word), "bash completes `{word}`");
    }
    let zsh = script("zsh");
    assert!(zsh.starts_with("#compdef laydown") && zsh.contains("--max-memory"), "{zsh}");
    let fish = script("fish");
    assert!(fish.contains("complete -c laydown") && fish.contains("-l dry-run"), "{fish}");
}

#[test]
fn the_bash_script_is_valid_bash() {
    let bash = script("bash");
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("laydown.bash");
    std::fs::write(&path, bash).unwrap();
    let out = std::process::Command::new("bash").arg("-n").arg(&path).output().expect("bash is installed");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Sourced and asked to complete `laydown r`, it offers `run`.
    let probe = format!(
        "source {}; COMP_WORDS=(laydown r); COMP_CWORD=1; COMP_LINE='laydown r'; COMP_POINT=9; _laydown laydown r laydown; printf '%s\\n' \"${{COMPREPLY[@]}}\"",
        path.display()
    );
    let out = std::process::Command::new("bash").arg("-c").arg(&probe).output().unwrap();
    let words = String::from_utf8_lossy(&out.stdout);
    assert!(words.lines().any(|w| w == "run"), "{words:?} {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn an_unknown_shell_is_bad_input() {
    let out = laydown().args(["completions", "tcsh"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("possible values"), "{:?}", text(&out));
}

/// clap checks a command definition (clashing short flags, a global flag shadowing a
/// subcommand's) only in debug builds; the suite runs in release, so ask for it here.
#[test]
fn the_command_line_definition_is_consistent() {
    use clap::CommandFactory;
    laydown::cli::Cli::command().debug_assert();
}
