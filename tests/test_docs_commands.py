"""Every `uqdrive` command the documentation shows exists with the flags it is shown with, and the
tables the docs build generates from the code name what the code defines."""

import re
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^\s*```")
COMMAND = re.compile(r"^\s*(?:\$\s+)?uqdrive\s+(.*)$")


def shown_commands(pages=None):
    """(page, line number, argv after `uqdrive`) of every command line in a fenced block of
    ``pages`` (default: the docs and the README), continuation lines joined."""
    pages = pages or sorted(p for p in (ROOT / "docs").rglob("*.md") if "generated" not in p.parts) + [ROOT / "README.md"]
    for page in pages:
        inside, pending, start = False, "", 0
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            if FENCE.match(line):
                inside = not inside
                continue
            if not inside:
                continue
            if pending:
                line, pending = pending + " " + line.strip(), ""
            elif COMMAND.match(line):
                start = n
            else:
                continue
            if line.rstrip().endswith("\\"):
                pending = line.rstrip()[:-1]
                continue
            m = COMMAND.match(line)
            if m:
                text = m.group(1).split(" #")[0]
                try:
                    yield page.name, start, shlex.split(text)
                except ValueError:  # an unbalanced quote in prose-like output: not a command
                    continue


def subcommands():
    from uqdrive.cli.main import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if getattr(a, "choices", None) and isinstance(a.choices, dict))
    return {name: {s for a in sub._actions for s in a.option_strings} for name, sub in action.choices.items()}


def problems(commands, known):
    """A line per shown command or flag that the command line does not have."""
    bad = []
    for page, n, argv in commands:
        if not argv or argv[0].startswith("-"):
            continue  # `uqdrive --help`, `uqdrive --version`
        if argv[0] not in known:
            bad.append(f"{page}:{n}: unknown command 'uqdrive {argv[0]}'")
            continue
        for token in argv[1:]:
            flag = token.split("=", 1)[0]
            if flag.startswith("--") and flag not in known[argv[0]]:
                bad.append(f"{page}:{n}: 'uqdrive {argv[0]}' has no flag {flag}")
    return bad


def test_every_documented_command_and_flag_exists():
    commands = list(shown_commands())
    assert len(commands) > 20  # the walk finds the guides' commands
    bad = problems(commands, subcommands())
    assert not bad, "documented commands that do not exist:\n" + "\n".join(bad)


def test_the_check_finds_a_wrong_flag_and_command(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("text uqdrive identify --outside-a-block\n```console\n$ uqdrive identify runs.nc --no-such-flag \\\n"
                    "    --out x\nuqdrive frobnicate x.nc\nuqdrive discover runs.nc --out gap/   # --not-a-flag in a comment\n```\n")
    bad = problems(list(shown_commands([page])), subcommands())
    assert len(bad) == 2 and "--no-such-flag" in bad[0] and "frobnicate" in bad[1], bad


def test_the_generated_candidate_table_names_every_registered_effect():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import generated_tables
    finally:
        sys.path.pop(0)
    from uqdrive.vehicle.effects import EFFECTS, FAMILIES

    table = generated_tables.candidates_table()
    members = {m for ms in FAMILIES.values() for m in ms}
    names = [n for n in EFFECTS if n not in members] + [f"{f}_<channel>" for f in FAMILIES]
    assert all(f"`{n}`" in table for n in names)
    assert table.count("\n| `") == len(names)  # one row each, nothing else


QUOTE = re.compile(r'\*"(.+?)"\*', re.DOTALL)


def missing_fragments(page: Path, source: str) -> list[str]:
    """The parts of each message the page quotes (*"..."*, "..." standing for what varies) that
    no source file holds."""
    out = []
    for quote in QUOTE.findall(page.read_text(encoding="utf-8")):
        for part in re.split(r"\s*\.\.\.\s*", " ".join(quote.split())):
            if len(part) >= 6 and part not in source:
                out.append(f"{part!r} (of *\"{' '.join(quote.split())}\"*)")
    return out


def _source() -> str:
    """Every product source file's text, its string pieces joined as Python joins them."""
    text = "\n".join(p.read_text(encoding="utf-8") for p in sorted((ROOT / "src" / "uqdrive").rglob("*.py")))
    return re.sub(r'"\s*\n\s*f?"', "", text)  # implicit concatenation across lines


def test_every_message_the_troubleshooting_page_quotes_is_one_the_code_prints(tmp_path):
    source = _source()
    assert len(QUOTE.findall((ROOT / "docs" / "faq.md").read_text(encoding="utf-8"))) > 20  # the page's quotes are found
    bad = missing_fragments(ROOT / "docs" / "faq.md", source)
    assert not bad, "quoted in docs/faq.md but printed nowhere (the message changed: update the page):\n" + "\n".join(bad)
    page = tmp_path / "faq.md"
    page.write_text('*"the misfit is ... times the noise"* and *"a message nobody prints"*')
    assert missing_fragments(page, source) == ["'a message nobody prints' (of *\"a message nobody prints\"*)"]
