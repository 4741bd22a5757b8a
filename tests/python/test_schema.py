"""The JSON schema and the Rust checker agree: every shipped pipeline passes both, and
every bad pipeline that a schema can judge is rejected by both."""
import json
import pathlib
import subprocess

import jsonschema
import pytest
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCHEMA = json.loads((ROOT / "schemas" / "pipeline.schema.json").read_text())


def load(path):
    return yaml.safe_load(path.read_text())


GOOD = sorted((ROOT / "pipelines").rglob("*.yaml"))
BAD = sorted((ROOT / "tests" / "bad_pipelines").glob("*.yaml"))


def test_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)


@pytest.mark.parametrize("path", GOOD, ids=lambda p: p.name)
def test_shipped_pipelines_pass_schema_and_rust(path, laydown_bin):
    jsonschema.validate(load(path), SCHEMA)
    assert subprocess.run([laydown_bin, "validate", str(path)], capture_output=True).returncode == 0


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.name)
def test_bad_pipelines_rejected_by_both(path, laydown_bin):
    # `# args: --max-memory 16GiB (why)`: extra arguments, the words before the parenthesis
    args = next((l[len("# args: "):].split(" (")[0].split() for l in path.read_text().splitlines() if l.startswith("# args: ")), [])
    rust = subprocess.run([laydown_bin, "validate", str(path), *args], capture_output=True)
    assert rust.returncode == 2
    if "# schema: semantic" in path.read_text():
        pytest.skip("a check a JSON schema cannot express (Rust only)")
    try:
        doc = load(path)
    except yaml.YAMLError:
        return  # not YAML at all: nothing for a schema to accept
    errors = list(jsonschema.Draft202012Validator(SCHEMA).iter_errors(doc))
    assert errors, f"{path.name} passes the schema but Rust rejects it: {rust.stderr.decode()}"
