#!/usr/bin/python3
"""The simulated shift of issue 30 over several seeds: for each seed a soilvol-server started here
(SQLite in a scratch directory) and `soilvol demo-shift` (20 trucks, 4-6 passes each, one body
scan per load at the exit). Prints one markdown row per seed: the registrations' struck capacity
against the truth (error and the reported 1-sigma), the loads whose body scan agrees with their
passes within the combined 2 sigma (target: 90%), the loads whose passes' sum lies within 2 of
its sigma of the truth, the mean error of the passes' sum and of the body scan (% of the truth),
and the refused scans.
Usage: bench/load/shift.py [--build build] [--seeds 1-10] [--trucks 20]
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests", "integration"))


def seeds_of(text):
    lo, _, hi = text.partition("-")
    return range(int(lo), int(hi or lo) + 1)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default="build")
    parser.add_argument("--seeds", default="1-10")
    parser.add_argument("--trucks", type=int, default=20)
    args = parser.parse_args()
    os.environ.setdefault("SOILVOL_SERVER_BIN", os.path.join(args.build, "server", "soilvol-server"))
    from harness import Server  # noqa: E402 (reads SOILVOL_SERVER_BIN)
    cli = os.path.join(args.build, "client", "soilvol")
    print("| seed | bucket struck err % (1-sigma %) | body struck err % (1-sigma %) | body agrees "
          "(2 sigma) | passes' sum within 2 sigma of truth | passes' sum err % | body err % | "
          "refused scans |")
    print("|---|---|---|---|---|---|---|---|")
    agree_total = reconciled_total = 0
    for seed in seeds_of(args.seeds):
        with tempfile.TemporaryDirectory() as data, Server(data_dir=data, args=["--workers", "2"]) as server:
            base = [cli, "--server", server.grpc_target, "demo-shift", "--trucks", str(args.trucks),
                    "--seed", str(seed), "--prefix", f"seed{seed}"]
            text = subprocess.run(base, capture_output=True, text=True, timeout=900)
            rows = json.loads(subprocess.run(
                [cli, "--server", server.grpc_target, "--json", *base[3:-1], f"seed{seed}j"],
                capture_output=True, text=True, timeout=900, check=True).stdout)
        struck = re.findall(r"struck ([\d.]+) \+- ([\d.]+) m\^3 \(true ([\d.]+) m\^3\)", text.stdout)
        cells = []
        for measured, sigma, true in struck[:2]:
            measured, sigma, true = float(measured), float(sigma), float(true)
            cells.append(f"{100 * (measured - true) / true:+.2f} ({100 * sigma / true:.2f})")
        refused = re.search(r"refused scans: (\d+)", text.stdout)
        reconciled = [r for r in rows if r["reconciled"]]
        agree = sum(r["withinTwoSigma"] for r in reconciled)
        covered = sum(abs(r["passesM3"] - r["trueM3"]) <= 2 * r["passesSigmaM3"] for r in rows)
        passes_err = statistics.mean(100 * (r["passesM3"] - r["trueM3"]) / r["trueM3"] for r in rows)
        body_err = statistics.mean(100 * (r["bodyM3"] - r["trueM3"]) / r["trueM3"] for r in reconciled)
        agree_total += agree
        reconciled_total += len(reconciled)
        print(f"| {seed} | {cells[0]} | {cells[1]} | {agree}/{len(reconciled)} | {covered}/{len(rows)} "
              f"| {passes_err:+.2f} | {body_err:+.2f} | {refused.group(1) if refused else '?'} |")
    print(f"\nbody scan within 2 sigma of the passes: {agree_total} of {reconciled_total} "
          f"reconciled loads ({100 * agree_total / max(1, reconciled_total):.0f}%)")


if __name__ == "__main__":
    main()
