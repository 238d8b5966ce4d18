"""Open a Snakemake report in headless Chromium: fail (exit 1, with a list) if the landing page, a
figure or a table does not render; write screenshots of the landing page and of every category."""
import argparse
import base64
import csv
import fcntl
import html
import io
import json
import os
import re
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

# Usage: python tools/check_report.py results/report.html [--screenshots results/report_screenshots]
#
# The report is a single-page app whose results are embedded as data URIs. The embedded data are
# read first (every PNG must be whole, every CSV table must appear as a table in its caption, no
# reStructuredText errors); then Chromium opens the report and is driven through the DevTools
# protocol on --remote-debugging-pipe (JSON messages on file descriptors 3 and 4, so the standard
# library suffices): a small script walks the app as a reader clicks (landing page, every category
# and subcategory, every figure, table and HTML page) and returns what it saw; screenshots are
# taken once a page is shown.

#: Chromium's flags: no sandbox (containers run it as root), nothing that reaches the network.
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--hide-scrollbars", "--mute-audio"]
PNG_START = b"\x89PNG\r\n\x1a\n"
WINDOW = {"width": 1600, "height": 1000}

#: Evaluated in the opened report: functions that walk the app (the globals ``app``, ``results``,
#: ``categories`` and ``getResultMimeType`` of the Snakemake 9 report) and say what they saw.
DRIVER = r"""
(() => {
  const sleep = ms => new Promise(r => setTimeout(r, ms));
  const settle = () => sleep(60);  // React renders a setView within a task or two
  const rows = el => el ? el.querySelectorAll("tbody tr").length : -1;
  const subcategories = cat => Object.keys(categories[cat]).sort((a, b) => a.localeCompare(b));
  // As a reader clicks: through the menu and the category, so that the app mounts a fresh result
  // list (a list kept mounted across subcategories would still show the previous one).
  async function showSub(cat, sub) {
    app.setView({navbarMode: "menu"});
    await settle();
    app.setView({navbarMode: "category", category: cat});
    await settle();
    app.setView({navbarMode: "subcategory", category: cat, subcategory: sub});
    await settle();
  }
  const listed = () => rows(document.querySelector("nav table.w-full"));
  const decode = uri => new TextDecoder().decode(Uint8Array.from(atob(uri.split(",")[1]), c => c.charCodeAt(0)));

  async function ready() {
    for (let i = 0; i < 600 && (typeof app === "undefined" || !document.querySelector("nav")); i++) await sleep(50);
  }
  async function landing() {
    app.setView({content: "rulegraph", navbarMode: "menu"});
    await settle();
    const desc = document.querySelector("#app .prose");
    return {found: !!desc, tables: desc ? [...desc.querySelectorAll("table")].map(rows) : [],
            system_messages: desc ? desc.querySelectorAll(".system-message").length : 0,
            chars: desc ? desc.innerText.length : 0, menu: document.querySelector("nav").innerText};
  }
  async function category(cat) {
    const out = {};
    for (const sub of subcategories(cat)) {
      await showSub(cat, sub);
      out[sub] = listed();
    }
    return out;
  }
  async function figure(path) {
    const uri = results[path].data_uri;
    app.setView({content: "img", contentPath: uri, resultPath: path});
    await settle();
    const img = [...document.querySelectorAll("#app img")].find(i => i.getAttribute("src") === uri);
    if (!img) return {error: "not shown"};
    try { await img.decode(); } catch (err) { return {error: "does not decode (" + err.name + ")"}; }
    const box = img.getBoundingClientRect(), pane = img.closest("div.grow").getBoundingClientRect();
    // The report centres a figure in its pane: what sticks out on the left or top is out of reach.
    const hidden = [Math.max(0, Math.round(pane.left - box.left)), Math.max(0, Math.round(pane.top - box.top))];
    return {width: img.naturalWidth, height: img.naturalHeight, shown: [Math.round(box.width), Math.round(box.height)], hidden};
  }
  async function caption(path) {
    app.showResultInfo(path);
    await settle();
    const text = document.querySelector("nav .prose");
    return {rows: rows(text && text.querySelector("table")), chars: text ? text.innerText.length : 0};
  }
  function page(path) {
    const doc = new DOMParser().parseFromString(decode(results[path].data_uri), "text/html");
    return {rows: [...doc.querySelectorAll("table")].reduce((n, t) => n + rows(t), 0), chars: doc.body.innerText.length};
  }
  window.uqdriveCheck = async () => {
    await ready();
    const out = {landing: await landing(), categories: {}, figures: {}, captions: {}, pages: {}};
    for (const cat of Object.keys(categories)) out.categories[cat] = await category(cat);
    for (const path of Object.keys(results)) {
      const mime = getResultMimeType(path);
      if (mime.startsWith("image/")) out.figures[path] = await figure(path);
      else if (mime === "text/html") out.pages[path] = page(path);
      out.captions[path] = await caption(path);
    }
    return out;
  };
  window.uqdriveLanding = async () => { await ready(); await landing(); };
  async function listedPaths(cat, sub) {  // the results in the order the list shows them
    await showSub(cat, sub);
    const rowCount = document.querySelectorAll("nav table.w-full tbody tr").length, paths = [];
    for (let i = 0; i < rowCount; i++) {
      if (i) await showSub(cat, sub);
      const buttons = document.querySelectorAll("nav table.w-full tbody tr")[i].querySelectorAll("a");
      buttons[buttons.length - 1].click();  // the info button: the app then holds the row's path
      await settle();
      paths.push(app.state.resultPath);
    }
    await showSub(cat, sub);
    return paths;
  }
  window.uqdriveShow = async cat => {  // the first subcategory, its first figure (or page, or caption)
    await ready();
    const sub = subcategories(cat)[0], paths = await listedPaths(cat, sub);
    const first = type => paths.find(p => getResultMimeType(p).startsWith(type));
    if (first("image/")) app.setView({content: "img", contentPath: results[first("image/")].data_uri, resultPath: first("image/")});
    else if (first("text/html")) app.setView({content: "html", contentPath: results[first("text/html")].data_uri, resultPath: first("text/html")});
    else app.showResultInfo(paths[0]);
    await sleep(400);  // an iframe or a large image paints
  };
})();
"""


def _above_9(fd):
    moved = fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
    os.close(fd)
    return moved


class DevTools:
    """Headless Chromium driven over ``--remote-debugging-pipe``: one page, commands and events."""

    def __init__(self, binary, timeout=600):
        self.profile = tempfile.TemporaryDirectory(prefix="chromium-profile-")
        self.timeout, self.next_id, self.buffer, self.events = timeout, 0, b"", []
        to_browser, self.commands = os.pipe()
        self.replies, from_browser = os.pipe()
        # Chromium reads commands on fd 3 and writes replies on fd 4: bash puts the pipes there,
        # from numbers above 9 so that neither is itself 3 or 4 (closed after the move; dash
        # takes single-digit descriptors only).
        to_browser, from_browser = (_above_9(fd) for fd in (to_browser, from_browser))
        shell = f'exec "$@" 3<&{to_browser} 4>&{from_browser} {to_browser}<&- {from_browser}>&-'
        self.proc = subprocess.Popen(["bash", "-c", shell, "bash", binary, *FLAGS, f"--user-data-dir={self.profile.name}",
                                      "--remote-debugging-pipe", "about:blank"],
                                     pass_fds=(to_browser, from_browser), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser)
        os.close(from_browser)
        target = next(t for t in self.call("Target.getTargets")["targetInfos"] if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=target["targetId"], flatten=True)["sessionId"]
        self.call("Page.enable", session=True)

    def _message(self, deadline):
        while b"\0" not in self.buffer:
            if not select.select([self.replies], [], [], max(0.0, deadline - time.monotonic()))[0]:
                raise TimeoutError("chromium did not answer in time")
            chunk = os.read(self.replies, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed the pipe")
            self.buffer += chunk
        message, _, self.buffer = self.buffer.partition(b"\0")
        return json.loads(message)

    def call(self, method, session=False, **params):
        """Send a command (to the page when ``session``) and return its result."""
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params}
        if session:
            message["sessionId"] = self.session
        os.write(self.commands, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            reply = self._message(deadline)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply.get("method"))

    def wait_for(self, event):
        deadline = time.monotonic() + self.timeout
        while event not in self.events:
            self.events.append(self._message(deadline).get("method"))
        self.events.clear()

    def evaluate(self, expression):
        """The value of a JavaScript expression in the page, promises awaited."""
        result = self.call("Runtime.evaluate", session=True, expression=expression, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            raise RuntimeError(details.get("exception", {}).get("description") or details.get("text"))
        return result["result"].get("value")

    def open(self, url, **window):
        self.call("Emulation.setDeviceMetricsOverride", session=True, deviceScaleFactor=1, mobile=False, **(window or WINDOW))
        self.call("Page.navigate", session=True, url=url)
        self.wait_for("Page.loadEventFired")
        self.evaluate(DRIVER)

    def screenshot(self, path, **window):
        self.call("Emulation.setDeviceMetricsOverride", session=True, deviceScaleFactor=1, mobile=False, **(window or WINDOW))
        data = self.call("Page.captureScreenshot", session=True, format="png")["data"]
        Path(path).write_bytes(base64.b64decode(data))

    def close(self):
        try:
            self.call("Browser.close")
        except (RuntimeError, TimeoutError, OSError):
            pass
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        os.close(self.commands)
        os.close(self.replies)
        self.profile.cleanup()


def embedded(text, name):
    """The JSON value the report's ``<script id=...>`` assigns to ``var name``."""
    tag = name.replace("_", "-")  # <script id="workflow-desc"> holds var workflow_desc
    match = re.search(rf'<script id="{tag}">\s*var {name} = (.*?);\s*</script>', text, re.DOTALL)
    if not match:
        raise ValueError(f"not a Snakemake report: no 'var {name}'")
    return json.loads(match.group(1))


def read_report(path):
    text = Path(path).read_text(encoding="utf-8")
    return {name: embedded(text, name) for name in ("workflow_desc", "results", "categories")}


def payload(entry):
    """The bytes of a result's data URI (the report embeds every result as base64)."""
    head, _, data = entry["data_uri"].partition(",")
    if not head.startswith("data:") or not head.endswith(";base64"):
        raise ValueError(f"not an embedded result ({head[:40]})")
    return base64.b64decode(data, validate=True)


def csv_rows(data):
    """Data rows of a CSV table (its header excluded)."""
    return len(list(csv.reader(io.StringIO(data.decode("utf-8"))))) - 1


def caption_rows(caption):
    """Body rows of the first table in a caption's HTML, or -1 without a table."""
    body = re.search(r"<tbody[^>]*>(.*?)</tbody>", caption, re.DOTALL)
    return body.group(1).count("<tr") if body else -1


def expected_rows(entries):
    """Rows of a subcategory's result list: one per result, halved where the app shows a label
    as a toggle (a label after the first with two values, each on half the results)."""
    labels = [e.get("labels") for e in entries]
    if not all(labels) or len(labels[0]) < 2:
        return len(entries)
    for name in list(labels[0])[1:]:
        values = [lab.get(name) for lab in labels]
        if len(set(values)) == 2 and all(values.count(v) * 2 == len(values) for v in set(values)):
            return len(entries) // 2
    return len(entries)


def png_problem(data):
    """Why a PNG would not show whole (None if it would): signature, chunk checksums, image data.
    Checked here because a browser draws a PNG with broken image data as a blank, without error."""
    if not data.startswith(PNG_START):
        return "not a PNG"
    pos, kinds, image = len(PNG_START), [], zlib.decompressobj()
    while pos < len(data) and kinds[-1:] != [b"IEND"]:
        if pos + 12 > len(data):
            return "not a whole PNG (cut short)"
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body, crc = data[pos + 8:pos + 8 + length], data[pos + 8 + length:pos + 12 + length]
        if len(crc) < 4 or zlib.crc32(kind + body) != struct.unpack(">I", crc)[0]:
            return f"not a whole PNG (chunk {kind.decode('latin-1')} cut short or failing its checksum)"
        if kind == b"IDAT":
            try:
                while body:  # in slices: a large figure need not be inflated at once
                    image.decompress(body, 1 << 22)
                    body = image.unconsumed_tail
            except zlib.error as err:
                return f"image data do not decompress ({err})"
        kinds.append(kind)
        pos += 12 + length
    if kinds[:1] != [b"IHDR"] or kinds[-1:] != [b"IEND"] or not image.eof:
        return "not a whole PNG (no header, no end or image data cut short)"
    return None


def result_problems(path, entry):
    """What is wrong with one embedded result, read without a browser."""
    try:
        data = payload(entry)
    except ValueError as err:
        return [f"{path}: {err}"]
    mime, problems = entry.get("mime_type") or "", []
    if not data:
        problems.append(f"{path}: empty")
    elif mime == "image/png" and png_problem(data):
        problems.append(f"{path}: {png_problem(data)}")
    elif mime == "image/svg+xml" and b"<svg" not in data:
        problems.append(f"{path}: not an SVG")
    elif path.endswith(".csv"):
        n = csv_rows(data)
        shown = caption_rows(entry.get("caption") or "")
        if n < 1:
            problems.append(f"{path}: a table without rows")
        elif shown != n:
            problems.append(f"{path}: table of {n} rows, its caption shows {'no table' if shown < 0 else f'{shown} rows'}")
    if not (entry.get("caption") or "").strip():
        problems.append(f"{path}: no caption")
    elif "system-message" in entry["caption"]:
        problems.append(f"{path}: reStructuredText errors in the caption (" + "; ".join(_system_messages(entry["caption"])) + ")")
    return problems


def static_problems(report):
    """Problems visible in the embedded data alone: results, categories, landing page."""
    results, problems = report["results"], []
    if not report["categories"]:
        problems.append("report: no categories")
    for cat, subs in report["categories"].items():
        for sub, paths in subs.items():
            problems += [f"category {cat!r}/{sub!r}: {p} is not among the results" for p in paths if p not in results]
    for path, entry in results.items():
        problems += result_problems(path, entry)
    desc = report["workflow_desc"]
    if "system-message" in desc:
        problems.append("landing page: reStructuredText errors (" + "; ".join(_system_messages(desc)) + ")")
    if "{{" in desc or "{%" in desc:
        problems.append("landing page: Jinja left unrendered")
    return problems


def _system_messages(text):
    """docutils' error boxes in rendered HTML, as one line each (repeats dropped)."""
    found = (re.sub(r"<[^>]+>|\s+", " ", m) for m in re.findall(r'<div class="system-message"[^>]*>(.*?)</div>', text, re.DOTALL))
    return list(dict.fromkeys(html.unescape(m).replace("backlink", "").strip()[:200] for m in found))


def browser_problems(report, seen):
    """Problems in what the driver saw in Chromium (``seen``: its JSON)."""
    if "error" in seen:
        return [f"driver: {seen['error']}"]
    results, problems = report["results"], []
    land = seen["landing"]
    if not land["found"] or land["chars"] < 1:
        problems.append("landing page: the description is not shown")
    problems += [f"landing page: table {i + 1} has no rows" for i, n in enumerate(land["tables"]) if n < 1]
    if report["workflow_desc"].count("<table") != len(land["tables"]):
        problems.append(f"landing page: {report['workflow_desc'].count('<table')} tables in the description, {len(land['tables'])} shown")
    problems += [f"menu: category {cat!r} missing" for cat in report["categories"] if cat not in land["menu"]]
    for cat, subs in report["categories"].items():
        for sub, paths in subs.items():
            shown, expected = seen["categories"].get(cat, {}).get(sub, -1), expected_rows([results[p] for p in paths])
            if shown != expected:
                problems.append(f"category {cat!r}/{sub!r}: {expected} results, {shown} listed")
    for path, entry in results.items():
        mime = entry.get("mime_type") or ""
        if mime.startswith("image/"):
            fig = seen["figures"].get(path, {"error": "not visited"})
            if fig.get("error") or not fig.get("width") or min(fig.get("shown", [0])) < 1:
                problems.append(f"{path}: figure does not render ({fig.get('error') or fig})")
        if mime == "text/html" and seen["pages"].get(path, {}).get("chars", 0) < 1:
            problems.append(f"{path}: HTML page is empty")
        if path.endswith(".csv"):  # a caption without the table is a problem found above
            n, shown = csv_rows(payload(entry)), seen["captions"].get(path, {}).get("rows", -1)
            if shown != n and caption_rows(entry.get("caption") or "") == n:
                problems.append(f"{path}: table of {n} rows, {shown} rows rendered in its description")
        if seen["captions"].get(path, {}).get("chars", 0) < 1:
            problems.append(f"{path}: description not shown")
    return problems


def clipped(seen):
    """Figures larger than the window's figure pane, whose left or top edge the reader cannot
    scroll to (Snakemake centres a figure): warnings, since the figure itself renders."""
    out = []
    for path, fig in seen.get("figures", {}).items():
        left, top = fig.get("hidden", (0, 0))
        if left or top:
            out.append(f"{path}: {fig['width']}x{fig['height']} px, {left} px on the left and {top} px at the top out of reach "
                       f"in a {WINDOW['width']}x{WINDOW['height']} window")
    return out


def chromium(explicit=None):
    found = explicit or next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)), None)
    if not found:
        raise FileNotFoundError("chromium not found: install Debian's chromium (apt-get install -y chromium)")
    return found


def slug(name):
    return re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_").lower()


def screenshots(browser, categories, folder):
    """The landing page (tall: it is long) and the first subcategory of every category."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.png"):
        old.unlink()
    browser.evaluate("uqdriveLanding()")
    written = [folder / "00_landing.png"]
    browser.screenshot(written[0], width=1600, height=2600)
    for i, cat in enumerate(sorted(categories, key=str.lower), 1):
        browser.evaluate(f"uqdriveShow({json.dumps(cat)})")
        written.append(folder / f"{i:02d}_{slug(cat)}.png")
        browser.screenshot(written[-1])
    return written


def browse(binary, report_path, shots=None):
    """What the driver saw in Chromium; screenshots into ``shots`` if given."""
    browser = DevTools(binary)
    try:
        browser.open(Path(report_path).resolve().as_uri())
        seen = browser.evaluate("uqdriveCheck()")
        if shots:
            print(f"{len(screenshots(browser, seen['categories'], shots))} screenshots in {shots}")
        return seen
    finally:
        browser.close()


def main(argv=None):
    parser = argparse.ArgumentParser(description=" ".join(__doc__.split()))
    parser.add_argument("report", help="the report, e.g. results/report.html")
    parser.add_argument("--screenshots", metavar="DIR", help="write the landing page and one page per category here as PNG")
    parser.add_argument("--chromium", metavar="PATH", help="the browser (default: chromium on PATH)")
    parser.add_argument("--no-browser", action="store_true", help="check the embedded data only")
    args = parser.parse_args(argv)

    report = read_report(args.report)
    problems = static_problems(report)
    if not args.no_browser:
        try:
            binary = chromium(args.chromium)
        except FileNotFoundError as err:
            print(err, file=sys.stderr)
            return 2
        seen = browse(binary, args.report, args.screenshots)
        problems += browser_problems(report, seen)
        warnings = clipped(seen)
        if warnings:
            print(f"{len(warnings)} figure(s) larger than the window:", *warnings, sep="\n  ")
    results = report["results"].values()
    n_fig = sum((e.get("mime_type") or "").startswith("image/") for e in results)
    n_tab = sum(e["filename"].endswith((".csv", ".html")) for e in results)
    print(f"{args.report}: {len(report['categories'])} categories, {n_fig} figures, {n_tab} tables, "
          f"{report['workflow_desc'].count('<table')} tables on the landing page")
    if problems:
        print(f"{len(problems)} problem(s):", *problems, sep="\n  ")
        return 1
    print("every figure and table renders" + ("" if args.no_browser else " in Chromium"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
