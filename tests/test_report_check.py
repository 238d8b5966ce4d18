"""tools/check_report.py: what it reads from a report without a browser, and (when Chromium is
installed) that it fails on a figure that does not decode in a real Snakemake report."""

import base64
import importlib.util
import json
import shutil
import struct
import subprocess
import sys
import textwrap
import zlib

import pytest

from conftest import REPO

SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def check():
    spec = importlib.util.spec_from_file_location("check_report", REPO / "tools" / "check_report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def png(width=4, height=3, idat=None):
    """A red PNG, or one whose image data are ``idat`` (chunks and checksums still valid)."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    pixels = zlib.compress(b"".join(b"\0" + b"\xff\0\0" * width for _ in range(height)))
    return SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) + chunk(b"IDAT", pixels if idat is None else idat) + chunk(b"IEND", b"")


def uri(mime, data):
    return f"data:{mime};base64,{base64.b64encode(data).decode()}"


def fake_report(path, results, desc="<p>landing</p>"):
    """The three embedded variables of a Snakemake 9 report, in its own <script> tags."""
    categories = {"Figures": {"Other": list(results)}}
    path.write_text("<html><body><script>var results = new Array(3);</script>"
                    + "".join(f'<script id="{tag}">\nvar {name} = {json.dumps(value)};\n</script>'
                              for tag, name, value in [("workflow-desc", "workflow_desc", desc), ("results", "results", results),
                                                       ("categories", "categories", categories)]) + "</body></html>")
    return path


def entry(name, mime, data, caption="<p>A caption.</p>"):
    return {"name": name, "filename": name, "labels": None, "caption": caption, "mime_type": mime, "data_uri": uri(mime, data)}


def test_a_sound_report_passes_without_a_browser(check, tmp_path, capsys):
    table = "<table><thead><tr><th>a</th></tr></thead><tbody><tr><td>1</td></tr><tr><td>2</td></tr></tbody></table>"
    report = fake_report(tmp_path / "r.html", {"f.png": entry("f.png", "image/png", png()), "t.csv": entry("t.csv", "text/csv", b"a\n1\n2\n", table)})
    assert check.main([str(report), "--no-browser"]) == 0
    assert "1 figures, 1 tables" in capsys.readouterr().out


def test_broken_figures_and_tables_are_listed(check, tmp_path, capsys):
    results = {
        "cut.png": entry("cut.png", "image/png", png()[:40]),
        "text.png": entry("text.png", "image/png", b"not an image"),
        "blank.png": entry("blank.png", "image/png", png(idat=b"not a zlib stream")),
        "bare.csv": entry("bare.csv", "text/csv", b"a,b\n1,2\n"),
        "short.csv": entry("short.csv", "text/csv", b"a\n1\n2\n", "<table><tbody><tr><td>1</td></tr></tbody></table>"),
        "silent.png": entry("silent.png", "image/png", png(), caption=""),
    }
    desc = '<div class="system-message"><p>System Message: ERROR/3</p>Unknown target name.</div>'
    report = fake_report(tmp_path / "r.html", results, desc)
    assert check.main([str(report), "--no-browser"]) == 1
    out = capsys.readouterr().out
    for expected in ["cut.png: not a whole PNG", "text.png: not a PNG", "blank.png: image data do not decompress",
                     "bare.csv: table of 1 rows, its caption shows no table",
                     "short.csv: table of 2 rows, its caption shows 1 rows", "silent.png: no caption", "landing page: reStructuredText errors"]:
        assert expected in out
    assert "7 problem(s)" in out


def test_expected_rows_follow_the_apps_toggles(check):
    """A second label with two values, each on half the results, becomes a toggle: half the rows."""
    toggled = [{"labels": {"A": a, "model": m}} for a in ("0.0", "0.05") for m in ("LST", "NLST")]
    assert check.expected_rows(toggled) == 2
    assert check.expected_rows([{"labels": {"figure": f}} for f in "abc"]) == 3
    assert check.expected_rows([{"labels": None}] * 4) == 4


def test_not_a_report_is_refused(check, tmp_path):
    page = tmp_path / "page.html"
    page.write_text("<html><script>var results = new Array(3);</script></html>")
    with pytest.raises(ValueError, match="not a Snakemake report"):
        check.read_report(page)


@pytest.mark.long(12)
@pytest.mark.skipif(not (shutil.which("chromium") or shutil.which("chromium-browser")), reason="needs Debian's chromium")
def test_chromium_finds_a_figure_that_does_not_decode(tmp_path):
    """A tiny real workflow and its Snakemake report: a JPEG of garbage (which only a browser
    decodes, so only the browser finds it broken); the sound figure and the table pass."""
    (tmp_path / "good.bin").write_bytes(png(60, 40))
    (tmp_path / "bad.bin").write_bytes(b"\xff\xd8\xff\xe0" + b"not a picture" * 20)
    (tmp_path / "table.bin").write_text("a,b\n1,2\n3,4\n")
    (tmp_path / "caption.rst").write_text("A figure.\n")
    (tmp_path / "table.rst").write_text("A table.\n\n.. csv-table::\n   :file: {{ snakemake.output[0] }}\n   :header-rows: 1\n")
    (tmp_path / "workflow.rst").write_text("A tiny workflow whose report holds one sound figure, one broken figure and a table.\n")
    (tmp_path / "Snakefile").write_text(textwrap.dedent("""
        report: "workflow.rst"

        rule all:
            input: "good.png", "bad.jpg", "table.csv"

        rule copy:
            input: "{name}.bin"
            output: report("{name}.{ext}", caption="caption.rst", category="Figures")
            shell: "cp {input} {output}"

        rule table:
            input: "table.bin"
            output: report("table.csv", caption="table.rst", category="Tables")
            shell: "cp {input} {output}"
    """))
    snakemake = [sys.executable, "-m", "snakemake", "--cores", "1", "--directory", str(tmp_path), "-s", str(tmp_path / "Snakefile")]
    for extra in ([], ["--report", str(tmp_path / "report.html")]):
        proc = subprocess.run(snakemake + extra, capture_output=True, text=True, check=False)
        assert proc.returncode == 0, proc.stderr[-2000:]
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "check_report.py"), str(tmp_path / "report.html"), "--screenshots", str(tmp_path / "shots")],
                          capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    problems = proc.stdout.split("problem(s):")[1]
    assert "bad.jpg: figure does not render" in problems
    assert "good.png" not in problems and "table.csv" not in problems
    assert sorted(p.name for p in (tmp_path / "shots").iterdir()) == ["00_landing.png", "01_figures.png", "02_tables.png"]
