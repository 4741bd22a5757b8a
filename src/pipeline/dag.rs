//! The stage graph of a pipeline (`laydown dag`): as text, one stage per line in the
//! order stages run, or as Graphviz DOT (`laydown dag P --dot | dot -Tsvg > dag.svg`).
use super::Pipeline;

/// `3 points × 2 replicates` (`1 point × 1 replicate` without a sweep).
fn size(p: &Pipeline, stage: &str) -> String {
    let decl = p.stage(stage).expect("a stage of the pipeline");
    let points = decl.points().0.len();
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    format!("{} × {}", plural(points, "point"), plural(decl.replicates, "replicate"))
}

/// One line per stage in the order they run: name, kind, size and inputs
/// (`spectra  spectra  1 point × 1 replicate  <- fibre`), after a header line.
pub fn text(p: &Pipeline) -> String {
    let order = p.topological_order();
    let name_w = order.iter().map(|s| s.len()).max().unwrap_or(0);
    let kind_w = p.stages.iter().map(|s| s.kind.len()).max().unwrap_or(0);
    let sizes: Vec<String> = order.iter().map(|s| size(p, s)).collect();
    let size_w = sizes.iter().map(|s| s.chars().count()).max().unwrap_or(0);
    let mut out = format!("pipeline {}: {} stages, in the order they run\n", p.name, order.len());
    for (name, size) in order.iter().zip(&sizes) {
        let decl = p.stage(name).expect("a stage of the pipeline");
        let inputs = if decl.inputs.is_empty() { String::new() } else { format!("  <- {}", decl.inputs.join(", ")) };
        let pad = size_w - size.chars().count();
        let line = format!("{name:<name_w$}  {:<kind_w$}  {size}{}{inputs}", decl.kind, " ".repeat(pad));
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// Graphviz DOT: a box per stage (name, kind, size), an edge from each input to the
/// stage reading it.
pub fn dot(p: &Pipeline) -> String {
    let quote = |s: &str| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let mut out = format!("digraph {} {{\n  rankdir=LR;\n  node [shape=box, fontname=\"DejaVu Sans\"];\n", quote(&p.name));
    let order = p.topological_order();
    for name in &order {
        let decl = p.stage(name).expect("a stage of the pipeline");
        out.push_str(&format!("  {} [label={}];\n", quote(name), quote(&format!("{name}\n{}\n{}", decl.kind, size(p, name))).replace('\n', "\\n")));
    }
    for name in &order {
        for input in &p.stage(name).expect("a stage of the pipeline").inputs {
            out.push_str(&format!("  {} -> {};\n", quote(input), quote(name)));
        }
    }
    out.push_str("}\n");
    out
}

#[cfg(test)]
mod tests {
    fn pipeline() -> super::Pipeline {
        let yaml = "pipeline: d\narchive: d.h5\nstages:\n  - {name: fibre, kind: laydown, sweep: {diameter: [3.0e-05, 5.0e-05]}, replicates: 2}\n  - {name: spectra, kind: spectra, input: fibre}\n  - {name: ideal, kind: spectra}\n";
        crate::pipeline::parse(yaml, std::path::Path::new("d.yaml")).unwrap()
    }

    #[test]
    fn text_lists_stages_in_run_order_with_their_inputs() {
        assert_eq!(
            super::text(&pipeline()),
            "pipeline d: 3 stages, in the order they run\n\
             fibre    laydown  2 points × 2 replicates\n\
             spectra  spectra  1 point × 1 replicate    <- fibre\n\
             ideal    spectra  1 point × 1 replicate\n"
        );
    }

    #[test]
    fn dot_has_a_node_per_stage_and_an_edge_per_input() {
        let dot = super::dot(&pipeline());
        assert!(dot.starts_with("digraph \"d\" {\n"), "{dot}");
        assert!(dot.contains("  \"spectra\" [label=\"spectra\\nspectra\\n1 point × 1 replicate\"];\n"), "{dot}");
        assert!(dot.contains("  \"fibre\" -> \"spectra\";\n"), "{dot}");
        assert_eq!(dot.matches("->").count(), 1, "{dot}");
        assert!(dot.ends_with("}\n"));
    }
}
