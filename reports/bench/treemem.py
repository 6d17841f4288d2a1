"""``python -m reports.bench.treemem COMMAND ...``: wall, CPU and peak memory of a process tree.

Runs COMMAND and samples it and all its descendants every ``INTERVAL_S`` with psutil: the
summed RSS (pages shared by forked pool workers counted once per process) and the summed PSS
(each shared page split between its sharers: the tree's real footprint), each process's
largest PSS/RSS by role (``parent`` = COMMAND, ``worker`` = its children and their children).
CPU is the user + system time of every finished descendant (``RUSAGE_CHILDREN``).  Prints
one summary line on stderr; exits with COMMAND's exit code.  How the README's run figures
were measured.
"""

from __future__ import annotations

import collections
import resource
import subprocess
import sys
import time

INTERVAL_S = 0.25


def measure(cmd: list[str]) -> tuple[int, dict[str, float]]:
    """(exit code, figures in s and MB) of running ``cmd`` to its end."""
    import psutil

    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd)
    root = psutil.Process(proc.pid)
    peak: collections.Counter = collections.Counter()
    while proc.poll() is None:
        try:
            tree = [root, *root.children(recursive=True)]
        except psutil.Error:
            break
        rss = pss = 0
        for p in tree:
            try:
                m = p.memory_full_info()
            except psutil.Error:
                continue  # ended between listing and reading
            rss, pss = rss + m.rss, pss + m.pss
            role = "parent" if p.pid == proc.pid else "worker"
            peak[f"{role}_pss"] = max(peak[f"{role}_pss"], m.pss)
            peak[f"{role}_rss"] = max(peak[f"{role}_rss"], m.rss)
        peak["tree_rss"], peak["tree_pss"] = max(peak["tree_rss"], rss), max(peak["tree_pss"], pss)
        time.sleep(INTERVAL_S)
    code = proc.wait()
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = {k: v / 2**20 for k, v in peak.items()}
    out.update(wall_s=time.perf_counter() - t0, cpu_s=ru.ru_utime + ru.ru_stime)
    return code, out


def main(argv: list[str]) -> int:
    if not argv:
        print("usage: python -m reports.bench.treemem COMMAND [ARG ...]", file=sys.stderr)
        return 2
    code, f = measure(argv)
    print(
        f"treemem: wall {f['wall_s']:.1f} s, CPU {f['cpu_s']:.1f} s, peak tree PSS "
        f"{f.get('tree_pss', 0):.0f} MB (RSS summed {f.get('tree_rss', 0):.0f} MB); largest "
        f"parent PSS {f.get('parent_pss', 0):.0f} MB, worker PSS {f.get('worker_pss', 0):.0f} MB "
        f"/ RSS {f.get('worker_rss', 0):.0f} MB; load average {' '.join(_load())}",
        file=sys.stderr,
    )
    return code


def _load() -> list[str]:
    import os

    return [f"{x:.1f}" for x in os.getloadavg()]


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
