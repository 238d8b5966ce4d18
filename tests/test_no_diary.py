"""No tracked text file names a development session, day or helper: the product speaks of itself,
and its history lives in `git log`."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# The words session(s), day and helper followed by a number (the test below spells out examples).
# A process "session" (os.setsid, start_new_session) has no number after it and stays allowed.
DIARY = re.compile(r"\bsessions? \d|\bsession-\d|\bday \d|\bhelper-\d", re.IGNORECASE)


def tracked_text_files():
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    for name in out.decode().split("\0"):
        path = ROOT / name
        if not name or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data[:8192]:  # binary: figures, netCDF
            continue
        yield name, data.decode("utf-8", errors="replace")


def test_the_pattern_finds_diary_words_and_spares_process_sessions():
    # written as word + number, so that this file does not itself hold a diary line
    for word, number in (("seen in session", " 9"), ("Sessions", " 8-9 ran"), ("session", "-11 notes"),
                         ("on day", " 3"), ("helper", "-2 found")):
        assert DIARY.search(word + number), word + number
    for fine in ("start_new_session=True", "a job is a background session; its id", "os.setsid()", "today's config"):
        assert not DIARY.search(fine), fine


def test_no_tracked_file_names_a_development_session():
    hits = [f"{name}:{n}: {line.strip()}" for name, text in tracked_text_files()
            for n, line in enumerate(text.splitlines(), 1) if DIARY.search(line)]
    assert not hits, "development diary in tracked files (history belongs in git log):\n" + "\n".join(hits)
