#!/usr/bin/env python3
"""Collects the @result lines of benchmark logs (bench/report.h) for scripts/bench.sh.

  bench_collect.py MODE OUT.json LOG...       -> OUT.json {date, revision, mode, machine, results}
  bench_collect.py --table OUT.json DOC.md    -> the table between the bench:results markers
  bench_collect.py --check OUT.json [BENCH...] -> exit 1 unless OUT.json holds well-formed results
                                                 (id, metric, numeric value, boolean met), at
                                                 least one from every BENCH named (ctest bench.runner)
"""
import datetime
import json
import os
import platform
import subprocess
import sys

BEGIN = "<!-- bench:results:begin -->"
END = "<!-- bench:results:end -->"


def collect(mode, out, logs):
    results = []
    for log in logs:
        bench = os.path.basename(log).removesuffix(".log")
        with open(log, encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("@result "):
                    r = json.loads(line[len("@result "):])
                    r["bench"] = bench
                    results.append(r)
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        rev = ""
    doc = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "revision": rev,
        "mode": mode,
        "machine": {"cpus": os.cpu_count(), "kernel": platform.release(),
                    "load_average": os.getloadavg()},
        "results": sorted(results, key=lambda r: (r["id"], r["metric"])),
    }
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    with open(out, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    missed = [r for r in results if not r.get("met", True)]
    print(f"bench: {len(results)} results in {out}; {len(missed)} miss their target")
    for r in missed:
        print(f"bench:   {r['id']} {r['metric']} = {r['value']:.4g} {r['unit']} (target {r['target']})")


def fmt(v):
    # Four significant digits, never an exponent: "1.998" must not print as "2" next to "=2".
    if not isinstance(v, float):
        return str(v)
    return f"{v:.0f}" if abs(v) >= 1000 else f"{v:.4g}"


def table(out, doc_path):
    with open(out, encoding="utf-8") as f:
        doc = json.load(f)
    rows = [f"Run {doc['date']} at {doc['revision']} ({doc['mode']}, load average "
            f"{doc['machine']['load_average'][0]:.2f}); raw numbers in `bench/results/latest.json`.",
            "",
            "| # | metric | value | unit | target | met | baseline (same run) | benchmark |",
            "|---|---|---|---|---|---|---|---|"]
    for r in doc["results"]:
        met = "—" if not r["target"] else ("yes" if r["met"] else "**no**")
        rows.append(f"| {r['id']} | {r['metric']} | {fmt(r['value'])} | {r['unit']} | {r['target'] or '—'} | "
                    f"{met} | {r['baseline']} | `{r['bench']}` |")
    with open(doc_path, encoding="utf-8") as f:
        text = f.read()
    block = BEGIN + "\n" + "\n".join(rows) + "\n" + END
    if BEGIN in text and END in text:
        text = text[:text.index(BEGIN)] + block + text[text.index(END) + len(END):]
    else:
        text = text.rstrip("\n") + "\n\n## Results of record (`scripts/bench.sh`)\n\n" + block + "\n"
    with open(doc_path, "w", encoding="utf-8") as f:
        f.write(text)
    print(f"bench: table in {doc_path}")


def check(out, benches):
    """The runner's own test: what scripts/bench.sh wrote must be usable by the table and by people."""
    problems = []
    try:
        with open(out, encoding="utf-8") as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        print(f"bench check: {out}: {e}")
        return 1
    for key in ("date", "revision", "mode", "machine", "results"):
        if key not in doc:
            problems.append(f"missing top-level key '{key}'")
    results = doc.get("results") or []
    if not results:
        problems.append("no results")
    for i, r in enumerate(results):
        for key in ("id", "metric", "value", "met", "target", "unit", "bench"):
            if key not in r:
                problems.append(f"results[{i}]: missing '{key}'")
        if not isinstance(r.get("value"), (int, float)) or isinstance(r.get("value"), bool):
            problems.append(f"results[{i}] {r.get('metric')}: value {r.get('value')!r} is not a number")
        if not isinstance(r.get("met"), bool):
            problems.append(f"results[{i}] {r.get('metric')}: met {r.get('met')!r} is not a boolean")
    seen = {r.get("bench") for r in results}
    for b in benches:
        if b not in seen:
            problems.append(f"benchmark {b}: no @result line")
    for p in problems:
        print(f"bench check: {out}: {p}")
    if not problems:
        print(f"bench check: {out}: {len(results)} results from {len(seen)} benchmarks, well-formed")
    return 1 if problems else 0


if __name__ == "__main__":
    if sys.argv[1] == "--check":
        sys.exit(check(sys.argv[2], sys.argv[3:]))
    if sys.argv[1] == "--table":
        table(sys.argv[2], sys.argv[3])
    else:
        collect(sys.argv[1], sys.argv[2], sys.argv[3:])
