#!/usr/bin/env python3
"""The editor's time left against the truth, from `probestudio-editor --time-jobs JOBS
--progress-log` output (lines `progress JOB SECONDS FRACTION`, then `editor JOB: T s`).

For each job, at 20 %, 30 %, ..., 90 % of its real wall time T, takes the time left the status
bar shows then (ui/MainWindow.cpp, onJobProgress: the bar's whole percent p, never lowered, and
elapsed * (100 - p) / p once p >= 3 and 2 s have passed; the last report at or before that
moment) and prints it with the true time left (T - t) and its relative error
(shown / true - 1; "-" while nothing is shown). Also prints the largest |error| from 20 % on.

Usage: scripts/time-left.py LOG [LOG...]   (or the log on stdin)
"""
import re
import sys


def jobs_of(lines):
    """Yields (job, [(seconds, fraction)], total seconds) per job of one log."""
    reports = []
    for line in lines:
        m = re.match(r"progress (\S+) ([\d.]+) ([\d.]+)", line)
        if m:
            reports.append((float(m.group(2)), float(m.group(3))))
            continue
        m = re.match(r"editor (\S+): ([\d.]+) s", line)
        if m:
            yield m.group(1), reports, float(m.group(2))
            reports = []


def shown_left(reports, at):
    """The time left the status bar shows at `at` seconds, or None."""
    percent, left = 0, None
    for t, f in reports:
        if t > at:
            break
        percent = max(percent, int(f * 100))
        left = t * (100 - percent) / percent if percent >= 3 and t >= 2.0 else None
    return left


def main():
    files = sys.argv[1:] or ["-"]
    for name in files:
        lines = sys.stdin if name == "-" else open(name)
        for job, reports, total in jobs_of(lines):
            print(f"{name}: {job}, {total:.2f} s")
            worst = 0.0
            for tenth in range(2, 10):
                at = total * tenth / 10
                left = shown_left(reports, at)
                truth = total - at
                if left is None:
                    print(f"  {tenth * 10:3d} %  true {truth:6.2f} s  shown      -")
                    worst = float("inf")
                    continue
                err = left / truth - 1
                worst = max(worst, abs(err))
                print(f"  {tenth * 10:3d} %  true {truth:6.2f} s  shown {left:6.2f} s  "
                      f"error {err * 100:+6.1f} %")
            print(f"  largest |error| from 20 %: {worst * 100:.1f} %")


if __name__ == "__main__":
    main()
