//! schemas/pipeline.schema.json is generated from the stages' parameter tables; keep
//! the committed file equal to what the code generates (regenerate with
//! `laydown schema > schemas/pipeline.schema.json`).
mod common;
use common::*;

#[test]
fn committed_schema_matches_the_code() {
    let out = run_in(&repo_root(), &["schema"]);
    assert_eq!(out.status.code(), Some(0));
    let generated = String::from_utf8(out.stdout).unwrap();
    let committed = std::fs::read_to_string(repo_root().join("schemas/pipeline.schema.json")).unwrap();
    assert_eq!(
        generated.trim(),
        committed.trim(),
        "schemas/pipeline.schema.json is stale: run `laydown schema > schemas/pipeline.schema.json`"
    );
}

#[test]
fn every_shipped_pipeline_validates() {
    let mut files = vec![];
    let mut stack = vec![repo_root().join("pipelines")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "yaml") {
                files.push(p);
            }
        }
    }
    assert!(!files.is_empty());
    let kinds = laydown::stages::kinds();
    for f in files {
        // `# requires kinds: a, b` marks an example written ahead of stages on other
        // branches; it is validated as soon as those kinds are registered.
        let text_of = std::fs::read_to_string(&f).unwrap();
        let missing: Vec<&str> = text_of
            .lines()
            .find_map(|l| l.strip_prefix("# requires kinds:"))
            .map(|l| l.split(',').map(str::trim).filter(|k| !kinds.contains(k)).collect())
            .unwrap_or_default();
        if !missing.is_empty() {
            eprintln!("{}: not validated, kinds not registered yet: {}", f.display(), missing.join(", "));
            continue;
        }
        let out = run_in(&repo_root(), &["validate", f.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(0), "{}: {:?}", f.display(), text(&out));
    }
}
