"""Alternate two criterion bench binaries and compare them job by job.

On a shared, noisy host (BENCHMARKS.md: the same binary moves +-25 % between minutes) two
builds can only be compared run against run, in the same minutes.  This runs binary A, then
B, then A, ... for ROUNDS rounds and prints, per job, every round's criterion median and the
ratio of the lowest medians (B / A).

Build the two binaries first, e.g. for the conversion jobs (the base in a worktree sharing the
target directory; copy each binary right away, as both builds write the same file name):

    git worktree add /tmp/base <REV>
    (cd /tmp/base && CARGO_TARGET_DIR=$PWD/../main/target \\
        cargo bench -p spheremap --bench resample --no-run)   # prints the binary's path
    cp target/release/deps/resample-<hash> /tmp/bench_a
    touch crates/spheremap/src/lib.rs && cargo bench -p spheremap --bench resample --no-run
    cp target/release/deps/resample-<hash> /tmp/bench_b
    python bench/ab.py /tmp/bench_a /tmp/bench_b --filter 'J1|J2|J3|RT' --rounds 3

(`touch` makes cargo relink the current tree's binary: its fingerprint does not see that the
worktree's build overwrote the file.)
"""

import argparse
import re
import subprocess
import sys

TIME = re.compile(r"time:\s+\[\s*([\d.]+)\s+(\S+)\s+([\d.]+)\s+(\S+)\s+([\d.]+)\s+(\S+)\s*\]")
UNIT = {"ns": 1e-6, "µs": 1e-3, "us": 1e-3, "ms": 1.0, "s": 1e3}


def run(binary, filt):
    """{job: median in ms} from one criterion run of `binary`."""
    out = subprocess.run(
        [binary, "--bench", filt], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    res, last = {}, None
    for line in out:
        m = TIME.search(line)
        if m:
            # "name   time: [...]" on one line, or the name alone on the line before.
            name = line[: line.index("time:")].strip() or last
            if name:
                res[name] = float(m.group(3)) * UNIT[m.group(4)]
            continue
        if line and not line[0].isspace() and not line.startswith(("Benchmarking", "Found", "Warning")):
            last = line.strip()
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", help="criterion bench binary A (the base)")
    ap.add_argument("b", help="criterion bench binary B (the change)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--filter", default="", help="criterion's job filter (a regex)")
    args = ap.parse_args()
    runs = {"a": [], "b": []}
    for r in range(args.rounds):
        for k in ("a", "b"):
            runs[k].append(run(getattr(args, k), args.filter))
            print(f"round {r + 1} {k.upper()} done", file=sys.stderr)
    jobs = sorted(set().union(*runs["a"], *runs["b"]))
    print(f"{'job':45} {'A medians (ms)':>28} {'B medians (ms)':>28}  B/A (lowest)")
    for j in jobs:
        a = [x[j] for x in runs["a"] if j in x]
        b = [x[j] for x in runs["b"] if j in x]
        if not a or not b:
            continue
        fa = " ".join(f"{v:.3f}" for v in a)
        fb = " ".join(f"{v:.3f}" for v in b)
        print(f"{j:45} {fa:>28} {fb:>28}  {min(b) / min(a):.3f}")


if __name__ == "__main__":
    main()
