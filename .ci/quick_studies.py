"""Time every registered study's quick mode and check that it says it is quick.

Usage: ``python .ci/quick_studies.py OUT [NAME ...]`` (every study when no name is given).

Each study runs as ``gearuq study NAME --quick --out OUT/NAME`` in a process of its own; its
CPU seconds are those of that process and of every worker process it waited for
(``os.wait4``), so a study's worker pool is counted. Wall time is printed too but means little
on a shared machine. Per study the table says:

- figures marked: every PNG written carries the quick mark in its text chunks
  (``gearuq.plot.QUICK_MARK_KEY``),
- screen: the printed ``quick: ..., not a result; left out: ...`` line,
- status in words: every printed line that names a status code says what it means
  (``status 3: the importance weights ...``, ``status: all 40 samples ok``); "none printed"
  when the study prints no status.

Numba compiles a model's kernels on its first use from an empty cache; run once before
measuring (or measure twice) to time a warm cache, and say which it was.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from importlib.metadata import entry_points
from pathlib import Path

from PIL import Image

from gearuq.plot import QUICK_MARK_KEY

#: A status code followed by words (``status 3: the ...``, ``status: all 400 samples ok``).
STATUS_IN_WORDS = re.compile(r"status(?: -?\d+)?: [a-z]", re.IGNORECASE)
#: A status code printed bare (``status 3``, ``status=3``, ``status (3)``).
STATUS_CODE = re.compile(r"status\W{0,3}-?\d", re.IGNORECASE)


def measure(name: str, out: Path) -> dict[str, object]:
    """Run one study's quick mode; its CPU seconds and what its output says."""
    gearuq = Path(sys.executable).with_name("gearuq")
    folder = out / name
    log = out / f"{name}.log"
    start = time.perf_counter()
    with open(log, "w", encoding="utf-8") as screen:
        proc = subprocess.Popen([str(gearuq), "study", name, "--quick", "--out", str(folder)],
                                stdout=screen, stderr=subprocess.STDOUT,
                                env={**os.environ, "MPLBACKEND": "Agg"})
        _, code, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    text = log.read_text(encoding="utf-8", errors="replace")
    pngs = sorted(folder.glob("**/*.png")) if folder.exists() else []
    marked = [Image.open(p).text.get(QUICK_MARK_KEY, "").startswith("quick: ") for p in pngs]
    lines = text.splitlines()
    in_words = [line for line in lines if STATUS_IN_WORDS.search(line)]
    bare = [line for line in lines if STATUS_CODE.search(line) and line not in in_words]
    return {"name": name, "exit": os.waitstatus_to_exitcode(code),
            "cpu": usage.ru_utime + usage.ru_stime, "wall": wall,
            "figures": f"{sum(marked)}/{len(pngs)}",
            "screen": any(line.startswith("quick: ") and "; left out: " in line
                          for line in text.splitlines()),
            "status": ("NO: " + bare[0].strip() if bare else
                       f"yes ({len(in_words)} lines)" if in_words else "none printed")}


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    names = argv[1:] or sorted(ep.name for ep in entry_points(group="gearuq.studies"))
    print("| study | exit | CPU s | wall s | figures marked | screen says quick, left out "
          "| status in words |\n|---|---|---|---|---|---|---|", flush=True)
    for name in names:
        r = measure(name, out)
        print(f"| {r['name']} | {r['exit']} | {r['cpu']:.1f} | {r['wall']:.0f} | {r['figures']} "
              f"| {'yes' if r['screen'] else 'NO'} | {r['status']} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
