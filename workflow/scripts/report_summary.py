"""Rule report_summary: the tables of the report's landing page (scorecard counts per seed section,
headline rows, discrepancy verdicts, package versions) and the scorecard as one HTML page."""
import csv
import html
import re
import sys
from collections import Counter

STATUSES = ("pass", "deviates", "fail")
#: Scorecard rows the landing page puts first: Table 6.2 (all variants) and the discrepancy checks;
#: a Table 6.2 quantity reads "NLST-STD mu mean (thesis Table 6.2, unit-free residuals)".
HEADLINE = re.compile(r"^thesis Table 6\.2|^discrepancy:")
VARIANT = re.compile(r"^(?P<result>.*?) \(thesis Table 6\.2(?:, (?P<variant>[^)]*))?\)$")
#: Columns of the discrepancy benchmark summary shown on the landing page, with their headings.
VERDICT_COLUMNS = {"case": "case", "truth": "hidden effect", "magnitude": "magnitude", "verdict": "named effect",
                   "ambiguous_with": "ambiguous with", "correct": "correct", "mu_mean_before": "mu mean before",
                   "mu_mean_after": "mu mean after"}


def read_rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def section(source):
    """The seed section of a scorecard row from its source: "thesis Table 6.2" is "thesis ch. 6"."""
    seed = (source.split() or [""])[0].lower()
    if seed == "thesis":
        number = re.search(r"(\d+)\.\d", source)  # Table 6.2, eq. (6.1), sec. 7.3: the chapter leads
        return f"thesis ch. {number.group(1)}" if number else "thesis"
    return "paper" if seed == "paper" else "uqdrive (past the seeds)"


def _order(name):
    number = re.search(r"\d+", name)
    return (not name.startswith("thesis"), name.startswith("uqdrive"), int(number.group()) if number else 0, name)


def count_rows(rows):
    """One row per seed section (thesis chapters, paper, uqdrive) and a total: rows per status."""
    statuses = list(STATUSES) + sorted({r["status"] for r in rows} - set(STATUSES))  # an unknown status stays visible
    groups = {}
    for row in rows:
        groups.setdefault(section(row["source"]), Counter())[row["status"]] += 1
    groups["all"] = sum(groups.values(), Counter())
    return [{"seed section": name, **{s: groups[name][s] for s in statuses}, "rows": sum(groups[name].values())}
            for name in sorted(groups, key=lambda n: (n == "all", _order(n)))]


def _variant(quantity):
    """(result, variant) of a headline quantity: the Table 6.2 variant split off its name."""
    match = VARIANT.match(quantity)
    if not match:
        return quantity, "uqdrive check"
    return match["result"], match["variant"] or "as printed (SI residuals)"


def headline_rows(rows):
    """Table 6.2 and the discrepancy checks, the published value beside uqdrive's."""
    picked = [r for r in rows if HEADLINE.search(r["source"]) or HEADLINE.search(r["quantity"])]
    return [dict(zip(("result", "variant"), _variant(r["quantity"])), published=r["published"], uqdrive=r["reproduced"],
                 tolerance=r["tolerance"], status=r["status"]) for r in picked] or [{"result": "(no Table 6.2 or discrepancy rows in this run)"}]


def _short(value):
    """A long float as three decimals (the benchmark writes repr floats); anything else as is."""
    try:
        return f"{float(value):.3f}" if "." in value and len(value) > 8 else value
    except ValueError:
        return value


def verdict_rows(rows):
    return [{heading: _short(row.get(column, "")) for column, heading in VERDICT_COLUMNS.items()} for row in rows]


def environment_rows(versions, scorecard):
    """The package versions of the run, then what its numbers trace to (from the scorecard)."""
    first = scorecard[0] if scorecard else {}
    trace = {key: first[key] for key in ("config", "config_hash", "seed") if key in first}
    return [{"name": name, "version": version} for name, version in {**versions, **trace}.items()]


#: What the scorecard page shows of each row; the provenance columns are the same in every row
#: and head the page once.
CARD_COLUMNS = ("quantity", "source", "published", "reproduced", "tolerance", "status", "reason", "evidence")
STYLE = ("body{font:13px sans-serif;margin:1em}table{border-collapse:collapse;margin:.5em 0 1.5em}"
         "th,td{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top}th{background:#eee}"
         ".pass{background:#d9f2d9}.deviates{background:#fff2cc}.fail{background:#f8d0d0}"
         "td:first-child{min-width:14em}td:nth-child(2){min-width:9em}td:nth-child(7){min-width:22em}"
         "td:nth-child(8){min-width:14em;overflow-wrap:anywhere}")  # evidence: long paths


def _row(row, columns, status=None):
    """One HTML table row, coloured by its ``status`` column if given."""
    cells = "".join(f"<td>{html.escape(str(row.get(c, '')))}</td>" for c in columns)
    return f'<tr class="{html.escape(row[status])}">{cells}</tr>' if status else f"<tr>{cells}</tr>"


def _table(rows, columns, status=None):
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(_row(r, columns, status) for r in rows)}</tbody></table>"


def scorecard_page(rows):
    """The scorecard as one HTML page: counts first, then one table per seed section."""
    counts = count_rows(rows)
    trace = ", ".join(f"{k} {rows[0][k]}" for k in ("config", "config_hash", "seed", "uqdrive_version") if rows and k in rows[0])
    parts = [f"<h1>Scorecard</h1><p>{html.escape(trace)}</p>", _table(counts, list(counts[0]))]
    for name in [c["seed section"] for c in counts[:-1]]:
        parts += [f"<h2>{html.escape(name)}</h2>", _table([r for r in rows if section(r["source"]) == name], CARD_COLUMNS, "status")]
    return f"<!doctype html><html><head><meta charset='utf-8'><style>{STYLE}</style></head><body>{''.join(parts)}</body></html>"


def main(smk):
    from uqdrive.io import write_csv_rows

    scorecard = read_rows(smk.input.scorecard)
    write_csv_rows(count_rows(scorecard), smk.output.counts)
    write_csv_rows(headline_rows(scorecard), smk.output.headline)
    write_csv_rows(verdict_rows(read_rows(smk.input.verdicts)), smk.output.verdicts)
    write_csv_rows(environment_rows(smk.params.versions, scorecard), smk.output.environment)
    with open(smk.output.page, "w") as fh:
        fh.write(scorecard_page(scorecard))


if __name__ == "__main__":
    sys.stderr = open(snakemake.log[0], "w")  # noqa: F821
    main(snakemake)  # noqa: F821
