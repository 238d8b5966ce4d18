"""Write config/README.md from config/config.yaml (defaults and the comments that give units and
seed tables), the JSON schema (types and ranges) and the rules (which rule reads which key), and the
packaged default src/uqdrive/default_config.yaml: config/config.yaml searching every candidate at
every file's model_samples.

Run `python tools/config_docs.py` after changing the config, the schema or a rule's params;
tests/test_config_docs.py fails while a committed file differs from what this writes.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "config.yaml"
SCHEMA = ROOT / "src" / "uqdrive" / "config_schema.yaml"
RULES = ROOT / "workflow" / "rules"
TARGET = ROOT / "config" / "README.md"
PACKAGED = ROOT / "src" / "uqdrive" / "default_config.yaml"
#: The packaged default's two lines apart from config/config.yaml: the command line searches every
#: registered candidate, the workflow's reproduction its own list; the command line simulates
#: ``model_samples`` realisations whatever the file's runs, the reproduction sizes them to the runs.
PACKAGED_CANDIDATES = "  candidates: all             # every registered effect; one whose constants the car lacks (cg_height, ...) is reported untestable"
PACKAGED_MODEL_RATIO = "  model_ratio: 0             # linear-model realisations per measured run (at most model_samples, at least nonlinear_samples); 0: model_samples always"

_KEY = re.compile(r"^(?P<indent> *)(?P<key>[A-Za-z_][\w ]*?):(?P<value>[^#]*?)\s*(?:#\s*(?P<comment>.*))?$")


def commented_leaves(text: str) -> list[tuple[str, object, str, str]]:
    """(dotted key, default, its own comment, the nearest enclosing section's comment) per leaf."""
    stack: list[tuple[int, str, str]] = []  # (indent, key, comment)
    out = []
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        m = _KEY.match(line)
        if not m:
            continue
        indent, key, value, comment = len(m["indent"]), m["key"], m["value"].strip(), (m["comment"] or "").strip()
        while stack and stack[-1][0] >= indent:
            stack.pop()
        path = [s[1] for s in stack] + [key]
        section = next((s[2] for s in reversed(stack) if s[2]), "")
        if not value:
            stack.append((indent, key, comment))
            continue
        parsed = yaml.safe_load(value)
        if isinstance(parsed, dict):  # flow mapping: one row per entry, the line's comment for all
            for sub, v in parsed.items():
                out.append((".".join(path + [str(sub)]), v, comment, section))
        else:
            out.append((".".join(path), parsed, comment, section))
    return out


def schema_constraint(schema: dict, dotted: str) -> str:
    """Type and range of a dotted key from the schema (following $ref), e.g. "number > 0"."""
    node, defs = schema, schema.get("$defs", {})
    for part in dotted.split("."):
        node = node.get("properties", {}).get(part) or node.get("additionalProperties") or {}
        while "$ref" in node:
            node = defs[node["$ref"].rsplit("/", 1)[-1]]
    return _constraint(node)


def _constraint(node) -> str:
    """Type and range of one schema node; the alternatives of a ``oneOf`` joined by "or"."""
    if not isinstance(node, dict):
        return ""
    if "oneOf" in node:
        return " or ".join(f'"{alt["const"]}"' if "const" in alt else _constraint(alt) for alt in node["oneOf"])
    kind = node.get("type", "enum" if "enum" in node else "")
    if isinstance(kind, list):
        kind = " | ".join(kind)
    bits = [kind] if kind else []
    for word, sym in (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<="), ("exclusiveMaximum", "<")):
        if word in node:
            bits.append(f"{sym} {node[word]}")
    if "enum" in node:
        bits.append("one of " + ", ".join(map(str, node["enum"])))
    if node.get("type") == "array" and isinstance(node.get("items"), dict) and "type" in node["items"]:
        bits[0] = f"array of {node['items']['type']}"
    return " ".join(bits)


def _value(node: ast.AST, names: dict):
    """Value of a constant expression of the rules: strings, tuples and lists of them (with
    ``*`` and ``+``), dicts, and names assigned before; None for anything else."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.Name):
        return names.get(node.id)
    if isinstance(node, (ast.Tuple, ast.List)):
        out: list = []
        for elt in node.elts:
            value = _value(elt.value if isinstance(elt, ast.Starred) else elt, names)
            if isinstance(elt, ast.Starred):
                out += list(value or ())
            else:
                out.append(value)
        return tuple(out)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        left, right = _value(node.left, names), _value(node.right, names)
        return tuple(left or ()) + tuple(right or ()) if isinstance(left, tuple) or isinstance(right, tuple) else None
    if isinstance(node, ast.Dict):
        return {_value(k, names): _value(v, names) for k, v in zip(node.keys, node.values) if k is not None}
    return None


def _statements(text: str):
    """Top-level assignments (``NAME = ...``, ``A, B = ...``) of a rules file, parsed, each
    over as many lines as it takes."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if not re.match(r"^[A-Za-z_][\w, ]*=[^=]", line):
            continue
        for j in range(i + 1, min(i + 40, len(lines)) + 1):
            try:
                tree = ast.parse("\n".join(lines[i:j]))
            except SyntaxError:
                continue
            if tree.body and isinstance(tree.body[0], ast.Assign):
                yield tree.body[0]
            break


def _assign(stmt: ast.Assign, names: dict) -> None:
    for target in stmt.targets:
        if isinstance(target, ast.Name):
            names[target.id] = _value(stmt.value, names)
        elif isinstance(target, ast.Tuple) and isinstance(stmt.value, ast.Tuple):
            for t, v in zip(target.elts, stmt.value.elts):
                if isinstance(t, ast.Name):
                    names[t.id] = _value(v, names)


def _call_args(body: str, function: str):
    """The argument lists of every call ``function(...)`` in ``body``, each parsed as a call."""
    for m in re.finditer(rf"(?<![\w.]){function}\(", body):
        depth, k = 0, m.end() - 1
        for k in range(m.end() - 1, len(body)):
            depth += {"(": 1, ")": -1}.get(body[k], 0)
            if depth == 0:
                break
        try:
            yield ast.parse(" ".join(body[m.start():k + 1].split()), mode="eval").body
        except SyntaxError:
            continue


def _flat(value) -> list[str]:
    if isinstance(value, str):
        return [value]
    if isinstance(value, (tuple, list)):
        return [k for v in value for k in _flat(v)]
    if isinstance(value, dict):
        return [k for v in value.values() for k in _flat(v)]
    return []


def _call_keys(call: ast.Call, names: dict) -> list[str]:
    """Config keys a ``reads(...)`` or ``cfg(...)`` call names: its positional keys (``*ALIAS``
    expanded), the keys of ``per_job=(wildcard, {value: keys})`` and each ``name="key"``."""
    keys = []
    for arg in call.args:
        keys += _flat(_value(arg.value, names) if isinstance(arg, ast.Starred) else _value(arg, names))
    for kw in call.keywords:
        value = _value(kw.value, names)
        keys += _flat(value[1] if kw.arg == "per_job" and isinstance(value, tuple) and len(value) == 2 else value)
    return keys


def rule_readers(rules_dir: Path = RULES) -> dict[str, set[str]]:
    """Config key or section (dotted) -> the rules whose params read it.

    Read from the rules' ``params``: ``**reads(...)`` (and ``cfg(...)``) with their key aliases
    (top-level ``NAME = (...)`` assignments of the Snakefile and the rules files), hand-written
    triggers ``{"dotted.key": ...}`` and direct ``config["a"]["b"]`` reads."""
    readers: dict[str, set[str]] = {}
    names: dict = {}
    texts = [(ROOT / "workflow" / "Snakefile").read_text()] + [p.read_text() for p in sorted(rules_dir.glob("*.smk"))]
    for text in texts:
        for stmt in _statements(text):
            _assign(stmt, names)
    for text in texts:
        for m in re.finditer(r"^rule (\w+):\n((?:[ \t]+.*\n|[ \t]*\n)*)", text + "\n", flags=re.M):
            rule, body = m.group(1), m.group(2)
            keys = []
            for function in ("reads", "cfg"):
                for call in _call_args(body, function):
                    keys += _call_keys(call, names)
            keys += re.findall(r'\{"([A-Za-z_][\w]*(?:\.[\w]+)+)":', body)
            keys += [".".join(re.findall(r'\["(\w+)"\]', c)) for c in re.findall(r'config((?:\["\w+"\])+)', body)]
            for k in keys:
                readers.setdefault(k, set()).add(rule)
    return readers


def dag_keys(rules_dir: Path = RULES) -> set[str]:
    """Config keys the workflow reads outside the rules' bodies: they decide which jobs exist
    (``outdir``, the models and steerings, the noise levels, the GP training sizes)."""
    texts = [(ROOT / "workflow" / "Snakefile").read_text()] + [p.read_text() for p in sorted(rules_dir.glob("*.smk"))]
    outside = "\n".join(re.sub(r"^rule \w+:\n(?:[ \t]+.*\n|[ \t]*\n)*", "", t + "\n", flags=re.M) for t in texts)
    return {".".join(re.findall(r'\["(\w+)"\]', c)) for c in re.findall(r'config((?:\["\w+"\])+)', outside)}


def readers_of(dotted: str, readers: dict[str, set[str]]) -> list[str]:
    parts = dotted.split(".")
    found: set[str] = set()
    for i in range(1, len(parts) + 1):
        found |= readers.get(".".join(parts[:i]), set())
    return sorted(found)


def render() -> str:
    schema = yaml.safe_load(SCHEMA.read_text())
    readers = rule_readers()
    dag = {k: {"workflow"} for k in dag_keys()}
    lines = [
        "# Configuration keys",
        "",
        "Generated by `python tools/config_docs.py` from `config/config.yaml` (defaults and comments),",
        "`src/uqdrive/config_schema.yaml` (types and ranges) and `workflow/rules/*.smk` (readers); a test",
        "fails while this file is out of date. Units and seed tables come from the comments in",
        "`config/config.yaml`; a section's comment applies to its keys. Any key can be overridden with",
        "`--config key=value` or a `--configfile`, and swept (docs/workflow.md, \"Changing and sweeping config values\").",
        "",
        "| key | default | type / range | meaning, unit, source | read by rules |",
        "|---|---|---|---|---|",
    ]
    for key, value, comment, section in commented_leaves(CONFIG.read_text()):
        meaning = comment or ""
        if section and section not in meaning:
            meaning = f"{meaning} ({section})" if meaning else section
        shown = yaml.safe_dump(value, default_flow_style=True, width=1000).strip().removesuffix("...").strip()
        rules = ", ".join(readers_of(key, readers) + (["(which jobs exist)"] if readers_of(key, dag) else [])) or "CLI only"
        lines.append(f"| `{key}` | `{shown}` | {schema_constraint(schema, key)} | {meaning.replace('|', '/')} | {rules} |")
    present = {key for key, *_ in commented_leaves(CONFIG.read_text())}
    for key, description in optional_keys(schema):
        if key not in present:
            rules = ", ".join(readers_of(key, readers)) or "(applied when the config is loaded)"
            lines.append(f"| `{key}` | (absent) | {schema_constraint(schema, key)} | {description.replace('|', '/')} | {rules} |")
    return "\n".join(lines) + "\n"


def optional_keys(schema: dict, node: dict | None = None, prefix: str = "") -> list[tuple[str, str]]:
    """(dotted key, description) of each schema property that carries a description: the optional
    keys the default config leaves out (documented by the schema, not by a default)."""
    node, defs, out = schema if node is None else node, schema.get("$defs", {}), []
    for name, sub in node.get("properties", {}).items():
        key = f"{prefix}{name}"
        target = sub
        while "$ref" in target:
            target = defs[target["$ref"].rsplit("/", 1)[-1]]
        description = sub.get("description") or target.get("description")
        if description:
            out.append((key, description))
        elif target.get("type") == "object":
            out += optional_keys(schema, target, key + ".")
    return out


def packaged_default() -> str:
    """The text of the packaged default config: config/config.yaml with ``discrepancy.candidates``
    set to ``all`` and ``discrepancy.model_ratio`` to 0."""
    text = CONFIG.read_text()
    for key, line in (("candidates", PACKAGED_CANDIDATES), ("model_ratio", PACKAGED_MODEL_RATIO)):
        text, n = re.subn(rf"^  {key}: .*$", line, text, count=1, flags=re.M)
        if n != 1:
            raise SystemExit(f"{CONFIG}: no line '  {key}: ...' (discrepancy.{key}) to replace")
    return text


if __name__ == "__main__":
    TARGET.write_text(render())
    PACKAGED.write_text(packaged_default())
    print(f"wrote {TARGET} and {PACKAGED}", file=sys.stderr)
