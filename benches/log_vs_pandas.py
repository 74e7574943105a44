"""bikeproc's log reader against pandas' read_csv on the same file, side by side (issue 33).

Writes an Euler log of two sensors in the lab's format (`../shared/formats/imu-log.md`: `//`
header, tab-separated, a packet counter with dropped packets, a few corrupt rows), then reads it
alternately with `bikeproc.read_log` (which also places every row on the sample grid by its
counter) and with pandas' `read_csv` (C engine, which does not), each in a fresh process so that
its peak memory can be taken (the peak resident size, VmHWM, after the read less before it: the
interpreter and the imports excluded). Prints each reader's median throughput (MB/s) and peak
memory over the file's size; then `bikeproc period FILE --segment 5:400 --sensor 00300417`
(the command-line program, `--bin`, default `target/release/bikeproc`) under
`/usr/bin/time`, its peak resident memory over the file's size beside pandas' (issue 77: at
most 1.5 times).

Run from the checkout with the Python package installed (`pip install ./python pandas`):

    python benches/log_vs_pandas.py                # 6,000,000 rows (about 230 MB), 3 rounds
    python benches/log_vs_pandas.py --rows 1000000 --rounds 5
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time


def write_log(path, rows, seed=1):
    """An Euler log of two sensors: 0.35 % of packets dropped (in bursts of 1-3), 0.05 % of rows
    corrupt (NaN, or cut short at a separator: pandas then reads every column as numbers),
    values with the receiver's precision."""
    import numpy as np

    rng = np.random.default_rng(seed)
    keep = np.ones(rows, dtype=bool)
    starts = rng.choice(rows, size=int(rows * 0.0035 / 2), replace=False)
    for s in starts:
        keep[s : s + rng.integers(1, 4)] = False
    counter = (51234 + np.arange(rows)) % 65536
    t = np.abs(np.arange(rows) * 0.01 + rng.normal(0, 0.0005, rows))
    # Roll and yaw wander and wrap at ±180°; pitch stays inside ±90°.
    angles = (np.cumsum(rng.normal(0, 0.05, (rows, 6)), axis=0) + 180.0) % 360.0 - 180.0
    angles[:, [1, 4]] = 60.0 * np.sin(np.radians(angles[:, [1, 4]]))
    header = (
        "// Receiver: Xbus Master, 2 sensors, Bluetooth\n"
        "// Sample rate: 100 Hz\n"
        "// Output mode: Euler\n"
        "// Sensor 00300417: frame\n"
        "// Sensor 00300418: handlebar\n"
        "// Start: 2009-03-12 11:42:07\n"
        "Counter\tTime\t00300417_Roll\t00300417_Pitch\t00300417_Yaw\t"
        "00300418_Roll\t00300418_Pitch\t00300418_Yaw\n"
    )
    corrupt = set(rng.choice(rows, size=max(1, rows // 2000), replace=False).tolist())
    with open(path, "w") as f:
        f.write(header)
        chunk = []
        for i in np.flatnonzero(keep):
            a = angles[i]
            line = (
                f"{counter[i]}\t{t[i]:.2f}\t{a[0]:.3f}\t{a[1]:.3f}\t{a[2]:.3f}\t"
                f"{a[3]:.3f}\t{a[4]:.3f}\t{a[5]:.3f}\n"
            )
            if i in corrupt:
                # Cut short after its fourth field, or a NaN: both kinds pandas reads as NaN.
                fields = line.split("\t")
                line = (
                    "\t".join(fields[:4]) + "\n"
                    if i % 2
                    else "\t".join(fields[:3] + ["NaN"] + fields[4:])
                )
            chunk.append(line)
            if len(chunk) >= 100_000:
                f.write("".join(chunk))
                chunk.clear()
        f.write("".join(chunk))


def measure(which, path):
    """In this (fresh) process: read `path` with `which`; print seconds and peak growth (bytes)."""
    if which == "bikeproc":
        # NumPy, whose arrays hold the columns, imported here as pandas imports it below: its
        # import (about 50 ms) is not reading, and was timed inside bikeproc's first call.
        import numpy  # noqa: F401

        import bikeproc

        read = lambda: bikeproc.read_log(path)
    else:
        import pandas as pd

        read = lambda: pd.read_csv(
            path, sep="\t", skiprows=6, na_values=["NaN"], engine="c", on_bad_lines="skip"
        )
    before = peak_rss_bytes()
    start = time.perf_counter()
    out = read()
    seconds = time.perf_counter() - start
    peak = peak_rss_bytes()
    del out
    print(seconds, peak - before)


def peak_rss_bytes():
    """This process's peak resident memory (VmHWM, bytes). Not `ru_maxrss`: on Linux a child
    starts with its parent's high-water mark, which here (the parent wrote the file) hid the
    readers' own peaks."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmHWM in /proc/self/status")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=6_000_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--bin", default="target/release/bikeproc", help="the bikeproc program")
    ap.add_argument("--measure", choices=["bikeproc", "pandas"], help=argparse.SUPPRESS)
    ap.add_argument("--file", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.measure:
        measure(a.measure, a.file)
        return
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "euler.log")
        write_log(path, a.rows)
        size = os.path.getsize(path)
        print(f"{a.rows:,} rows, {size / 1e6:.1f} MB")
        runs = {"bikeproc": [], "pandas": []}
        for _ in range(a.rounds):
            for which in runs:
                out = subprocess.run(
                    [sys.executable, __file__, "--measure", which, "--file", path],
                    check=True,
                    stdout=subprocess.PIPE,
                    text=True,
                ).stdout.split()
                runs[which].append((float(out[0]), float(out[1])))
        for which, r in runs.items():
            s = statistics.median(x[0] for x in r)
            m = max(x[1] for x in r)
            print(
                f"{which:9} {size / 1e6 / s:7.1f} MB/s (median of {len(r)}: {s:.2f} s), "
                f"peak memory {m / 1e6:.0f} MB = {m / size:.2f} × the file"
            )
        period(a.bin, path, size, a.rounds)


def period(program, path, size, rounds):
    """`bikeproc period` on the log's first sensor, a segment of it: wall time and peak resident
    memory (the whole process, as /usr/bin/time reports it) over the file's size."""
    if not (os.path.exists(program) and os.path.exists("/usr/bin/time")):
        print(f"period    skipped: no {program} or no /usr/bin/time")
        return
    runs = []
    for _ in range(rounds):
        cmd = ["/usr/bin/time", "-f", "%e %M", program, "period", path]
        cmd += ["--segment", "5:400", "--sensor", "00300417"]
        # Its output read and dropped: bikeproc refuses a standard output that is /dev/null
        # opened read-write, as subprocess.DEVNULL opens it.
        done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        seconds, kib = done.stderr.strip().splitlines()[-1].split()
        runs.append((float(seconds), int(kib) * 1024))
    s = statistics.median(x[0] for x in runs)
    m = max(x[1] for x in runs)
    print(
        f"period    {s:.2f} s (median of {len(runs)}), peak memory {m / 1e6:.0f} MB = "
        f"{m / size:.2f} × the file (`bikeproc period --segment 5:400 --sensor 00300417`)"
    )


if __name__ == "__main__":
    main()
