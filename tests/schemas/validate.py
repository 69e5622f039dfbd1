#!/usr/bin/python3
"""The JSON Schemas under schemas/ against what papertear reads and writes (docs/scenario-format.md,
docs/result-format.md).

- Every shipped scenario (scenarios/, tests/soak/, docs/, the fuzz corpus' good seeds) is valid.
- Every file of tests/data/bad/ that a schema can judge is refused; the others are listed below with the
  reason (geometry, order, duplicates, or not JSON at all), so a new bad file needs a decision.
- Documents one edit away from a valid scenario are judged alike by the schema and by `papertear check`
  (refused: exit 2; accepted: exit 0), on the edges of the ranges and enums.
- result.json of a few short runs and batch.json of a short batch are valid; edits of them that drop a
  key, add one or break a format are refused.

Usage: validate.py SOURCE_DIR PAPERTEAR_BINARY. Exit 0 when all holds, 1 otherwise, 77 (skipped) when the
jsonschema module is missing (Debian: python3-jsonschema, scripts/install-deps.sh).
"""
import copy
import glob
import json
import math
import os
import subprocess
import sys
import tempfile

try:
    import jsonschema
except ImportError:
    print("validate.py: the jsonschema module is missing (apt install python3-jsonschema)")
    sys.exit(77)

# tests/data/bad/ files whose fault a JSON Schema cannot express: the engine refuses them (scenario_test,
# cli_test), the schema does not.
BEYOND_SCHEMA = {
    "clockwise.json": "outline orientation",
    "collinear.json": "outline geometry",
    "repeated_vertex.json": "outline geometry",
    "self_intersecting.json": "outline geometry",
    "finger_outside.json": "finger outside the outline",
    "duplicate_finger.json": "finger names must differ",
    "duplicate_key.json": "a key given twice in one object",
    "hand_unknown_finger.json": "a hand names a finger that does not exist",
    "keys_not_increasing.json": "key times must increase",
}
# Not JSON text (RFC 8259) at all: no schema applies.
NOT_JSON = {"empty.json", "whitespace_only.json", "malformed.json", "nan_literal.json", "number_overflow.json"}

failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def strict_json(text):
    """JSON as RFC 8259 has it: no NaN or Infinity, no number beyond a double's range."""

    def constant(name):
        raise ValueError("not JSON: " + name)

    def finite(s):
        v = float(s)
        if not math.isfinite(v):
            raise ValueError("number out of range: " + s)
        return v

    return json.loads(text, parse_constant=constant, parse_float=finite)


def load(path):
    with open(path, encoding="utf-8") as f:
        return strict_json(f.read())


def first_error(validator, doc):
    errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))
    return (errors[0].json_path + ": " + errors[0].message[:160]) if errors else None


def check_valid(validator, doc, what):
    error = first_error(validator, doc)
    if error:
        fail(what + " should be valid: " + error)


def check_refused(validator, doc, what):
    if first_error(validator, doc) is None:
        fail(what + " should be refused by the schema")


def with_edit(doc, path, value):
    """A copy of doc with the value at path (keys and indices) replaced, objects on the way created; value
    None deletes it."""
    out = copy.deepcopy(doc)
    node = out
    for key in path[:-1]:
        node = node.setdefault(key, {}) if isinstance(node, dict) else node[key]
    if value is None:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return out


def papertear_check(binary, doc, tmp):
    path = os.path.join(tmp, "edited.json")
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return subprocess.run([binary, "check", path], capture_output=True, text=True, timeout=60).returncode


def main():
    source, binary = sys.argv[1], sys.argv[2]
    schemas = {}
    for name in ("scenario", "result", "batch"):
        schema = load(os.path.join(source, "schemas", name + ".schema.json"))
        jsonschema.Draft202012Validator.check_schema(schema)
        schemas[name] = jsonschema.Draft202012Validator(schema)
    scenario = schemas["scenario"]

    # Shipped scenarios.
    shipped = sorted(glob.glob(os.path.join(source, "scenarios", "*.json")))
    shipped += sorted(glob.glob(os.path.join(source, "tests", "soak", "*.json")))
    shipped += [os.path.join(source, "docs", "memory-a4.json")]
    shipped += sorted(p for p in glob.glob(os.path.join(source, "tests", "fuzz", "corpus", "fuzz_scenario", "*.json"))
                      if not os.path.basename(p).startswith("bad-"))
    if len(shipped) < 20:
        fail("found only %d shipped scenarios" % len(shipped))
    for path in shipped:
        check_valid(scenario, load(path), os.path.relpath(path, source))

    # Bad inputs of the engine's tests.
    bad = sorted(glob.glob(os.path.join(source, "tests", "data", "bad", "*.json")))
    refused = 0
    for path in bad:
        name = os.path.basename(path)
        if name in NOT_JSON:
            try:
                load(path)
                fail("tests/data/bad/" + name + " parses as JSON; move it out of NOT_JSON")
            except ValueError:
                pass
            continue
        doc = load(path)
        if name in BEYOND_SCHEMA:
            continue
        check_refused(scenario, doc, "tests/data/bad/" + name)
        refused += 1
    for name in list(BEYOND_SCHEMA) + list(NOT_JSON):
        if not os.path.exists(os.path.join(source, "tests", "data", "bad", name)):
            fail("tests/data/bad/" + name + " is listed here but does not exist")

    # One edit away from a valid scenario: the schema and `papertear check` agree.
    base = load(os.path.join(source, "scenarios", "start-inward.json"))
    refused_edits = [
        (["sim", "relaxation"], "patch", ["sim", "solver"], "projective"),
        (["sim", "solver"], "projective", None, None),
        (["tearing", "snap"], 0.46, None, None),
        (["tearing", "direction"], "sideways", None, None),
        (["tearing", "radius"], 0, None, None),
        (["detail", "texture"], [0, 512], None, None),
        (["detail", "texture"], [512, 16385], None, None),
        (["name"], "..", None, None),
        (["name"], "a/b", None, None),
        (["name"], "tab\there", None, None),
        (["version"], 2, None, None),
        (["material", "fracture_c"], 9.9, None, None),
        (["material", "poisson"], 0.5, None, None),
        (["material", "membrane_scale"], 0, None, None),
        (["material", "fiber_seed"], -1, None, None),
        (["sim", "fps"], 100001, None, None),
        (["sim", "iterations"], 1001, None, None),
        (["sim", "gravity"], [0, 0, -10001], None, None),
        (["sim", "frames"], 2.5, None, None),
        (["fingers", 0, "grip"], 10001, None, None),
        (["fingers", 0, "pad"], 0.051, None, None),
        (["fingers", 0, "pad"], -0.001, None, None),
        (["fingers", 0, "release"], 0, None, None),
        (["fingers", 0, "attach"], -1, None, None),
        (["fingers", 0, "name"], "", None, None),
        (["fingers", 0, "at"], [1001, 0], None, None),
        (["fingers", 0, "keys"], [[-1, [0, 0, 0]]], None, None),
        (["fingers", 0, "keys"], [[0, [0, 0, 0], 1]], None, None),
        (["fingers", 0, "nail"], 1, None, None),
        (["sheet", "outlines"], 1, None, None),
        (["material", "stiffness"], 1, None, None),
        (["detail", "noise"], 1, None, None),
        (["sim", "fpss"], 1, None, None),
        (["tearing", "speed"], 1, None, None),
        (["hands"], [{"name": "h", "fingers": []}], None, None),
        (["hands"], [{"name": "h", "fingers": ["A", "A"]}], None, None),
        (["hands"], [{"name": "h", "fingers": ["A"], "keys": [[0, {"axis": [0, 0, 0]}]]}], None, None),
        (["hands"], [{"fingers": ["A"]}], None, None),
        (["sheet", "preset"], "A4", None, None),
        (["sheet", "triangles"], 1, None, None),
        (["sheet"], {"preset": "Letter"}, None, None),
        (["sheet", "mesh_seed"], 0.5, None, None),
    ]
    accepted_edits = [
        (["sim", "relaxation"], "patch", None, None),
        (["sim", "relaxation"], "patch", ["sim", "solver"], "implicit"),
        (["tearing", "direction"], "bisector", None, None),
        (["tearing", "snap"], 0.45, None, None),
        (["detail", "texture"], [512, 16384], None, None),
        (["detail", "texture"], [0, 0], None, None),
        (["version"], 1, None, None),
        (["version"], 1.0, None, None),
        (["sim", "frames"], 2.0, None, None),
        (["material", "fracture_c"], 10, None, None),
        (["material", "membrane_scale"], 1, None, None),
        (["material", "bending_scale"], 0, None, None),
        (["material", "fiber_seed"], 18446744073709551615, None, None),
        (["fingers", 0, "release"], 1e-3, None, None),
        (["fingers", 0, "grip"], 10000, None, None),
        (["fingers", 0, "pad"], 0.05, None, None),
        (["sheet"], {"preset": "A3"}, None, None),
        (["hands"], [{"name": "h", "fingers": ["A"], "keys": [[0, {"axis": [0, 0, -2]}]]}], None, None),
    ]
    if base["fingers"][0]["name"] != "A":
        fail("start-inward.json's first finger is no longer A; the hand edits below name it")
    with tempfile.TemporaryDirectory() as tmp:
        for edits, expect_refused in ((refused_edits, True), (accepted_edits, False)):
            for path, value, path2, value2 in edits:
                doc = with_edit(base, path, value)
                if path2:
                    doc = with_edit(doc, path2, value2)
                what = "start-inward.json with %s = %s%s" % (
                    ".".join(map(str, path)), json.dumps(value), " and %s = %s" % (".".join(map(str, path2)), json.dumps(value2)) if path2 else "")
                by_schema = first_error(scenario, doc) is not None
                status = papertear_check(binary, doc, tmp)
                if by_schema != expect_refused:
                    fail(what + (": the schema accepts it" if expect_refused else ": the schema refuses it: " + first_error(scenario, doc)))
                if status != (2 if expect_refused else 0):
                    fail(what + ": papertear check exits %d" % status)

        # Results of short runs (--set sim.frames keeps them short; torn-in-two runs whole: two pieces).
        runs = [("start-inward.json", ["--set", "sim.frames=3"]),
                ("fig14-straight.json", ["--set", "sim.frames=3", "--threads", "1"]),
                ("torn-in-two.json", [])]
        results = []
        for name, options in runs:
            out = os.path.join(tmp, name)
            run = subprocess.run([binary, "run", os.path.join(source, "scenarios", name), "--out", out] + options,
                                 capture_output=True, text=True, timeout=120)
            if run.returncode != 0:
                fail("papertear run %s exited %d: %s" % (name, run.returncode, run.stderr.strip()))
                continue
            doc = load(os.path.join(out, "result.json"))
            check_valid(schemas["result"], doc, name + " result.json")
            results.append(doc)
        if len(results) == len(runs):
            torn = results[-1]
            if torn["mesh"]["pieces"] < 2 or not torn["tears"] or not torn["tears"][0]["detail"]:
                fail("torn-in-two.json no longer tears in two; the result schema's tears and pieces go unchecked")
            result = schemas["result"]
            for key in torn:
                check_refused(result, with_edit(torn, [key], None), "result.json without " + key)
            for path in (["mesh"], ["tears", 0], ["tears", 0, "start"], ["fingers", 0], ["timings_ms"],
                         ["timings_ms", "frame"], ["systems_ms"], ["regions_summary"], ["regions_summary", "last"],
                         ["pieces", 0], ["solver"], ["solver_ms"]):
                check_refused(result, with_edit(torn, path + ["surprise"], 1),
                              "result.json with an unknown key in " + ".".join(map(str, path)))
            check_refused(result, with_edit(torn, ["hash"], torn["hash"][:8]), "result.json with a short hash")
            check_refused(result, with_edit(torn, ["hash"], torn["hash"].upper()), "result.json with an upper-case hash")
            check_refused(result, with_edit(torn, ["surprise"], 1), "result.json with an unknown key")
            check_refused(result, with_edit(torn, ["status"], "error"), "result.json with status error and no error")
            check_refused(result, with_edit(torn, ["error"], "why"), "result.json with status ok and an error")
            check_valid(result, with_edit(with_edit(torn, ["status"], "error"), ["error"], "why"),
                        "result.json with status error and its error")
            check_refused(result, with_edit(torn, ["tears", 0, "start", "kind"], "corner"), "result.json with an unknown start kind")
            check_refused(result, with_edit(torn, ["fingers", 0, "let_go"], None), "result.json without let_go")
            check_refused(result, with_edit(torn, ["pieces", 0, "centroid"], [0, 0]), "result.json with a 2D centroid")

        # A short batch: batch.json.
        out = os.path.join(tmp, "batch")
        run = subprocess.run([binary, "batch", os.path.join(source, "scenarios", "start-inward.json"), "--sheets", "2",
                              "--set", "sim.frames=3", "--vary", "material.fracture_c=2e4:3e4", "--out", out],
                             capture_output=True, text=True, timeout=120)
        if run.returncode != 0:
            fail("papertear batch exited %d: %s" % (run.returncode, run.stderr.strip()))
        else:
            doc = load(os.path.join(out, "batch.json"))
            check_valid(schemas["batch"], doc, "batch.json")
            check_refused(schemas["batch"], with_edit(doc, ["hashes"], None), "batch.json without hashes")
            check_refused(schemas["batch"], with_edit(doc, ["outcomes", 0, "status"], "fine"), "batch.json with a bad status")

    print("validate.py: %d shipped scenarios valid, %d bad files refused (%d beyond a schema, %d not JSON), "
          "%d + %d edits judged like papertear check, %d result.json and a batch.json checked; %d failures"
          % (len(shipped), refused, len(BEYOND_SCHEMA), len(NOT_JSON), len(refused_edits), len(accepted_edits),
             len(runs), len(failures)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
